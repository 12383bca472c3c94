"""Stereo video (pipelines layer): clips as frame streams, layouts, shot cuts, comfort analysis.

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
from vergence.video.clips import CLIP_SHOTS, ClipShot, TestClips, make_test_clips
from vergence.video.cuts import CUT_BINS, CUT_SAMPLE_SIDE, CUT_THRESHOLD, MIN_SHOT_FRAMES, ShotCuts, detect_cuts, histogram_change
from vergence.video.layout import LAYOUT_TAGS, STEREO_LAYOUTS, VIDEO_LAYOUTS, guess_layout, layout_video_name, split_frame
from vergence.video.reader import DEFAULT_FOLDER_FPS, FRAME_SUFFIXES, FrameReader, VideoInfo, open_frames
from vergence.video.sources import DepthClip, StereoClip, open_depth_clip, open_stereo
from vergence.video.writer import DEFAULT_CRF, DEFAULT_PIXEL_FORMAT, PIXEL_FORMATS, VideoWriter

__all__ = [
    "CLIP_SHOTS",
    "CUT_BINS",
    "CUT_SAMPLE_SIDE",
    "CUT_THRESHOLD",
    "ClipAnalysis",
    "ClipShot",
    "DEFAULT_CRF",
    "DEFAULT_FOLDER_FPS",
    "DEFAULT_PIXEL_FORMAT",
    "DepthClip",
    "FRAME_SUFFIXES",
    "FrameReader",
    "FrameStats",
    "HISTOGRAM_STEP_PX",
    "LAYOUT_TAGS",
    "MIN_SHOT_FRAMES",
    "PERCENTILES",
    "PIXEL_FORMATS",
    "STEREO_LAYOUTS",
    "ShotCuts",
    "ShotStats",
    "StereoClip",
    "TestClips",
    "VERTICAL_MAX_WIDTH",
    "VIDEO_LAYOUTS",
    "VideoInfo",
    "VideoWriter",
    "WINDOW_BAND",
    "WINDOW_MIN_PX",
    "WINDOW_SHARE",
    "analyze_clip",
    "detect_cuts",
    "guess_layout",
    "histogram_change",
    "layout_video_name",
    "make_test_clips",
    "open_depth_clip",
    "open_frames",
    "open_stereo",
    "split_frame",
]
