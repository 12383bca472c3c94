"""Stereo video (pipelines layer): clips as frame streams, layouts, shot cuts, comfort analysis.

Reading and writing video needs PyAV, the ``video`` extra (``pip install 'vergence[video]'``; why PyAV:
:mod:`vergence.video._av`); image folders work without it. Clips are streamed frame by frame, never
held whole in memory.
"""

from vergence.video.layout import LAYOUT_TAGS, STEREO_LAYOUTS, VIDEO_LAYOUTS, guess_layout, layout_video_name, split_frame
from vergence.video.reader import DEFAULT_FOLDER_FPS, FrameReader, VideoInfo, open_frames
from vergence.video.sources import DepthClip, StereoClip, open_depth_clip, open_stereo
from vergence.video.writer import DEFAULT_CRF, DEFAULT_PIXEL_FORMAT, PIXEL_FORMATS, VideoWriter

__all__ = [
    "DEFAULT_CRF",
    "DEFAULT_FOLDER_FPS",
    "DEFAULT_PIXEL_FORMAT",
    "DepthClip",
    "FrameReader",
    "LAYOUT_TAGS",
    "PIXEL_FORMATS",
    "STEREO_LAYOUTS",
    "StereoClip",
    "VIDEO_LAYOUTS",
    "VideoInfo",
    "VideoWriter",
    "guess_layout",
    "layout_video_name",
    "open_depth_clip",
    "open_frames",
    "open_stereo",
    "split_frame",
]
