"""Stereo video (pipelines layer): clips as frame streams, layouts, shot cuts, comfort analysis, retargeting.

Reading and writing video needs PyAV, the ``video`` extra (``pip install 'vergence[video]'``; why PyAV:
:mod:`vergence.video._av`); image folders and single images work without it. Clips are streamed
frame by frame, never held whole in memory.
"""

from vergence.video.analysis import (
    HISTOGRAM_STEP_PX,
    PERCENTILES,
    VERTICAL_MAX_WIDTH,
    WINDOW_BAND,
    WINDOW_MIN_PX,
    WINDOW_SHARE,
    ClipAnalysis,
    FrameStats,
    ShotStats,
    analyze_clip,
)
from vergence.video.conversion import Conversion, ShotConversion
from vergence.video.convert import CONVERT_ORIGINS, SPLIT_FRAMES, convert_clip
from vergence.video.outputs import VIDEO_SUFFIXES, check_new_output, converted_path
from vergence.video.clips import (
    CLIP_SHOTS,
    VISIBLE_RTOL,
    ClipShot,
    RetargetedViews,
    TestClips,
    make_test_clips,
    render_retargeted,
    retargeted_rig,
)
from vergence.video.cuts import CUT_BINS, CUT_SAMPLE_SIDE, CUT_THRESHOLD, MIN_SHOT_FRAMES, ShotCuts, detect_cuts, histogram_change
from vergence.video.layout import LAYOUT_TAGS, STEREO_LAYOUTS, VIDEO_LAYOUTS, guess_layout, layout_video_name, split_frame
from vergence.video.reader import DEFAULT_FOLDER_FPS, FRAME_SUFFIXES, FrameReader, VideoInfo, open_frames
from vergence.video.stability import STABILIZE_ALPHA, STATIC_THRESHOLD, Flicker, FlickerMeter, disparity_flicker, stabilize_disparity
from vergence.video.sources import DepthClip, StereoClip, open_depth_clip, open_stereo
from vergence.video.writer import DEFAULT_CRF, DEFAULT_PIXEL_FORMAT, DEFAULT_PRESET, PIXEL_FORMATS, X264_PRESETS, VideoWriter

__all__ = [
    "CLIP_SHOTS",
    "CONVERT_ORIGINS",
    "CUT_BINS",
    "CUT_SAMPLE_SIDE",
    "CUT_THRESHOLD",
    "ClipAnalysis",
    "ClipShot",
    "Conversion",
    "DEFAULT_CRF",
    "DEFAULT_FOLDER_FPS",
    "DEFAULT_PIXEL_FORMAT",
    "DEFAULT_PRESET",
    "DepthClip",
    "FRAME_SUFFIXES",
    "Flicker",
    "FlickerMeter",
    "FrameReader",
    "FrameStats",
    "HISTOGRAM_STEP_PX",
    "LAYOUT_TAGS",
    "MIN_SHOT_FRAMES",
    "PERCENTILES",
    "PIXEL_FORMATS",
    "RetargetedViews",
    "SPLIT_FRAMES",
    "STABILIZE_ALPHA",
    "STATIC_THRESHOLD",
    "STEREO_LAYOUTS",
    "ShotConversion",
    "ShotCuts",
    "ShotStats",
    "StereoClip",
    "TestClips",
    "VERTICAL_MAX_WIDTH",
    "VIDEO_LAYOUTS",
    "VIDEO_SUFFIXES",
    "VISIBLE_RTOL",
    "VideoInfo",
    "VideoWriter",
    "WINDOW_BAND",
    "WINDOW_MIN_PX",
    "WINDOW_SHARE",
    "X264_PRESETS",
    "analyze_clip",
    "check_new_output",
    "convert_clip",
    "converted_path",
    "detect_cuts",
    "disparity_flicker",
    "guess_layout",
    "histogram_change",
    "layout_video_name",
    "make_test_clips",
    "open_depth_clip",
    "open_frames",
    "open_stereo",
    "render_retargeted",
    "retargeted_rig",
    "split_frame",
    "stabilize_disparity",
]
