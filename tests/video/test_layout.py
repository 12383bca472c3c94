"""Layouts guessed from iw3/Bino file-name tags, names that carry them, frames split into views."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.video import STEREO_LAYOUTS, VIDEO_LAYOUTS, guess_layout, layout_video_name, split_frame


@pytest.mark.parametrize("name, layout", [
    ("holiday_LRF_Full_SBS.mp4", "sbs"),     # iw3, full side by side (VR)
    ("holiday_LR.mp4", "half-sbs"),          # iw3, half side by side
    ("holiday_TB.mkv", "half-tb"),           # iw3, half top-bottom
    ("holiday_TBF.mkv", "tb"),
    ("holiday_Half_SBS.mp4", "half-sbs"),
    ("holiday_full_sbs.mp4", "sbs"),
    ("holiday.Full-TB.mp4", "tb"),
    ("holiday_HSBS.mp4", "half-sbs"),
    ("holiday [HOU].mkv", "half-tb"),
    ("movie-lr.mkv", "sbs"),                 # Bino, left-right
    ("movie-lrh.mkv", "half-sbs"),           # Bino, half width
    ("movie-tb.mkv", "tb"),
    ("movie-ab.mkv", "tb"),
    ("movie-tbh.mkv", "half-tb"),
    ("holiday_RGBD.mp4", "rgbd"),            # iw3, colour + depth
    ("frames_LRF_Full_SBS", "sbs"),          # a folder
])
def test_tags_of_iw3_and_bino_name_their_layout(name, layout):
    assert guess_layout(name) == layout


@pytest.mark.parametrize("name", ["clip.mp4", "movie-rl.mkv", "holiday_LRX.mp4", "calibration.mp4", "TBD_notes.mp4",
                                  "color_lrs.mp4"])
def test_names_without_a_tag_guess_nothing(name):
    assert guess_layout(name) is None


@pytest.mark.parametrize("layout", VIDEO_LAYOUTS)
def test_the_names_we_write_are_guessed_back(layout):
    name = layout_video_name("clip", layout)
    assert name.startswith("clip_") and name.endswith(".mp4")
    assert guess_layout(name) == layout


def test_split_frame_gives_full_resolution_views():
    left = np.zeros((4, 6, 3), np.float32)
    right = np.ones((4, 6, 3), np.float32)
    a, b = split_frame(np.concatenate([left, right], axis=1), "sbs")
    assert a.shape == b.shape == (4, 6, 3) and a.max() == 0 and b.min() == 1
    a, b = split_frame(np.concatenate([left, right], axis=0), "tb")
    assert a.shape == (4, 6, 3) and b.min() == 1
    # half layouts: each view squeezed into half the frame, stretched back to the whole frame
    a, b = split_frame(np.concatenate([left[:, :3], right[:, :3]], axis=1), "half-sbs")
    assert a.shape == b.shape == (4, 6, 3) and a.max() == 0 and b.min() == 1
    a, b = split_frame(np.concatenate([left[:2], right[:2]], axis=0), "half-tb")
    assert a.shape == b.shape == (4, 6, 3)


def test_a_ramp_squeezed_to_half_width_keeps_its_disparity_in_full_resolution_pixels():
    x = np.arange(64, dtype=np.float32)
    view = np.repeat(np.tile(x / 64.0, (4, 1))[:, :, None], 3, axis=2)
    squeezed = view[:, ::2]  # a half-SBS encoder keeps every other column
    left, _ = split_frame(np.concatenate([squeezed, squeezed], axis=1), "half-sbs")
    assert left.shape == (4, 64, 3)
    np.testing.assert_allclose(left[0, 2:-2:2, 0], view[0, 2:-2:2, 0], atol=1.0 / 64)


@pytest.mark.parametrize("layout", ["sbs", "half-sbs"])
def test_an_odd_width_cannot_be_split_side_by_side(layout):
    with pytest.raises(ValueError, match=f"layout {layout} \\(side by side\\) needs an even frame width; got 7x4"):
        split_frame(np.zeros((4, 7, 3), np.float32), layout)


def test_an_odd_height_cannot_be_split_top_bottom_and_unknown_layouts_are_listed():
    with pytest.raises(ValueError, match="needs an even frame height; got 6x5"):
        split_frame(np.zeros((5, 6, 3), np.float32), "half-tb")
    with pytest.raises(ValueError, match="layout must be one of sbs, half-sbs, tb, half-tb, rgbd; got 'lr'"):
        split_frame(np.zeros((4, 6, 3), np.float32), "lr")
    assert tuple(STEREO_LAYOUTS) == ("sbs", "half-sbs", "tb", "half-tb")
