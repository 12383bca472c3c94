"""The truth of a retargeted clip: convert_clip's right view against a direct render with the retargeted rig."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.metrics import psnr
from vergence.render import builtin_scene
from vergence.synthesis import synthesize_stereo
from vergence.video import (
    CLIP_SHOTS,
    ClipShot,
    convert_clip,
    open_depth_clip,
    open_frames,
    open_stereo,
    render_retargeted,
    retargeted_rig,
)
from vergence.viewing import Display, LinearMapping


DISPLAY = Display.preset("tv-55")
# The rig's parallax against psi(-q) of the truth depth: float32 maps of about +-3.5 px (measured
# 7e-6 px); a wrong baseline or convergence is off by a tenth of a pixel or more.
PARALLAX_ATOL_PX = 1e-4
# Converted right view vs the direct render, PSNR per shot (mean over frames): measured 23.4 dB
# (tabletop) and 26.2 dB (stadium) on the session's clips (160x90, H.264 crf 12), 1 dB below.
MIN_PSNR_DB = {"tabletop": 22.4, "stadium": 25.2}
# The input's right view (unretargeted) scores 19.2 and 16.6 dB there: the retargeted one must gain.
MIN_GAIN_DB = 3.0
# synthesize_stereo of the same left view with the rig's true parallax: the conversion's depth
# (8-bit, H.264) and its stabilisation cost 0.03 (tabletop) and 0.26 dB (stadium), measured.
IDEAL_TOLERANCE_DB = 0.5
IDENTITY = LinearMapping(0.0, 1.0, 0.0, 1.0)  # psi(p) = p


def _q8(image):
    return np.rint(image * 255.0) / 255.0  # the direct render as 8 bits, as the clips store views


def _mean_psnr(images, truths):
    return float(np.mean([psnr(np.clip(a, 0.0, 1.0), b) for a, b in zip(images, truths)]))


@pytest.fixture(scope="module")
def rgbd_left(clips, tmp_path_factory):
    """The 2D + depth clip converted with origin left as PNG frames, and per shot its rig and direct render."""
    out = tmp_path_factory.mktemp("retarget") / "rgbd_LRF_Full_SBS"
    conversion = convert_clip(open_depth_clip(clips.rgbd), out, DISPLAY, origin="left")
    frames = np.stack(list(open_frames(out).frames()))
    with np.load(clips.truth) as data:
        near, far = data["near"], data["far"]
    shots = []
    for s, (shot, conv) in enumerate(zip(CLIP_SHOTS, conversion.shots)):
        focal = builtin_scene(shot.scene, width=clips.width, height=clips.height).camera.build().focal_px
        rig = retargeted_rig(shot, conv.mapping, focal_px=focal, kind="inverse", near=near[s], far=far[s])
        views = render_retargeted(shot, rig, frames_per_shot=clips.cuts[0], width=clips.width, height=clips.height)
        shots.append((shot, conv, rig, views))
    return frames, shots


def test_the_rig_gives_the_parallax_psi_maps_the_truth_to(rgbd_left, truth):
    _, shots = rgbd_left
    for s, (shot, conv, rig, views) in enumerate(shots):
        z = truth["depth"][conv.start:conv.end].astype(np.float64)
        q = (1.0 / z - 1.0 / truth["far"][s]) / (1.0 / truth["near"][s] - 1.0 / truth["far"][s])  # the RGBD value
        assert_allclose(views.parallax_px, conv.mapping(-q), rtol=0, atol=PARALLAX_ATOL_PX)
        assert views.left.shape == (conv.end - conv.start, *truth["depth"].shape[1:], 3)
        # a psi over the stereo clip's disparity x_l - x_r (its truth): the rig's parallax is psi(-D)
        focal = builtin_scene(shot.scene, width=z.shape[2], height=z.shape[1]).camera.build().focal_px
        d = truth["disparity"][conv.start:conv.end]
        psi = LinearMapping(float(-d.max()), float(-d.min()), -3.0, 3.0)
        rig = retargeted_rig(shot, psi, focal_px=focal, kind="disparity")
        assert_allclose(focal * rig.baseline * (1.0 / rig.convergence - 1.0 / z), psi(-d.astype(np.float64)),
                        rtol=0, atol=PARALLAX_ATOL_PX)  # fmt: skip


def test_converted_right_view_is_the_direct_render_up_to_the_synthesis(rgbd_left, clips):
    frames, shots = rgbd_left
    inputs = np.stack(list(open_stereo(clips.stereo).pairs()))  # (n, 2, H, W, 3): the unretargeted views
    w = clips.width
    for shot, conv, _, views in shots:
        a, b = conv.start, conv.end
        truth = _q8(views.right)
        converted = _mean_psnr(frames[a:b, :, w:], truth)
        assert converted >= MIN_PSNR_DB[shot.scene], (shot.scene, converted)
        assert converted >= _mean_psnr(inputs[a:b, 1], truth) + MIN_GAIN_DB, shot.scene
        ideal = [synthesize_stereo(image, -p, kind="disparity", mapping=IDENTITY, origin="left").right
                 for image, p in zip(frames[a:b, :, :w], views.parallax_px)]  # fmt: skip
        assert converted >= _mean_psnr(ideal, truth) - IDEAL_TOLERANCE_DB, shot.scene
        assert views.visible.mean() > 0.9  # the disoccluded share of a small parallax change


def test_retargeted_rig_refuses_bad_input():
    shot = CLIP_SHOTS[0]
    psi = LinearMapping(-1.0, -0.25, -4.0, 4.0)
    with pytest.raises(TypeError, match="mapping must be a LinearMapping"):
        retargeted_rig(shot, lambda p: p, focal_px=100.0, kind="metric")
    with pytest.raises(TypeError, match="shot must be a ClipShot"):
        retargeted_rig("tabletop", psi, focal_px=100.0, kind="metric")
    with pytest.raises(ValueError, match="kind must be one of"):
        retargeted_rig(shot, psi, focal_px=100.0, kind="depth")
    with pytest.raises(ValueError, match="focal_px must be > 0"):
        retargeted_rig(shot, psi, focal_px=0.0, kind="metric")
    with pytest.raises(ValueError, match="kind='inverse' needs near and far"):
        retargeted_rig(shot, psi, focal_px=100.0, kind="inverse", near=1.0)
    with pytest.raises(ValueError, match="near must be < far; got near 2, far 1"):
        retargeted_rig(shot, psi, focal_px=100.0, kind="inverse", near=2.0, far=1.0)
    with pytest.raises(ValueError, match="near and far are for kind='inverse' only"):
        retargeted_rig(shot, psi, focal_px=100.0, kind="metric", far=3.0)
    # every nearness in front of the zero-parallax plane: P(infinity) = psi(0) = -4 px < 0
    with pytest.raises(ValueError, match="zero-parallax plane at or beyond infinity"):
        retargeted_rig(shot, LinearMapping(-1.0, 0.0, -8.0, -4.0), focal_px=100.0, kind="metric")
    with pytest.raises(ValueError, match="rig must have the shot's scene and travel"):
        render_retargeted(shot, dataclasses.replace(CLIP_SHOTS[1]), frames_per_shot=2, width=16, height=10)
    with pytest.raises(TypeError, match="rig must be a ClipShot"):
        render_retargeted(shot, (0.1, 1.2), frames_per_shot=2, width=16, height=10)
    with pytest.raises(ValueError, match="frames_per_shot must be an integer >= 2"):
        render_retargeted(shot, shot, frames_per_shot=1, width=16, height=10)


def test_the_same_rig_renders_the_clip_again():
    shot = ClipShot(scene="tabletop", baseline=0.1, convergence=1.2, travel=0.3)
    views = render_retargeted(shot, shot, frames_per_shot=2, width=32, height=18)
    focal = builtin_scene("tabletop", width=32, height=18).camera.build().focal_px
    # the metric psi of the shot's own rig, P = f b (1/H - 1/z), gives the rig back
    psi = LinearMapping(-1.0, 0.0, -focal * 0.1 * (1.0 - 1.0 / 1.2), focal * 0.1 / 1.2)
    rig = retargeted_rig(shot, psi, focal_px=focal, kind="metric")
    assert_allclose((rig.baseline, rig.convergence), (0.1, 1.2), rtol=1e-12)
    assert views.visible.dtype == bool and views.parallax_px.dtype == np.float32


def _seen_by_left_loop(depth_left, depth_right, focal, baseline, convergence):
    """Slow reference of the visibility rule, pixel by pixel."""
    from vergence.video.clips import VISIBLE_RTOL

    h, w = depth_right.shape
    seen = np.zeros((h, w), bool)
    for y in range(h):
        for x in range(w):
            z = float(depth_right[y, x])
            if not np.isfinite(z):
                continue
            x_l = x - focal * baseline * (1.0 / convergence - 1.0 / z)
            if not -0.5 <= x_l <= w - 0.5:
                continue
            a = depth_left[y, min(max(int(np.floor(x_l)), 0), w - 1)]
            b = depth_left[y, min(max(int(np.ceil(x_l)), 0), w - 1)]
            seen[y, x] = min(a, b) * (1 - VISIBLE_RTOL) <= z <= max(a, b) * (1 + VISIBLE_RTOL)
    return seen


def test_visibility_matches_the_rule_pixel_by_pixel():
    from vergence.video.clips import _seen_by_left

    # a wall at 4 m seen with P = 100 * 0.1 * (1/3 - 1/4) = 0.83 px: only the right view's first column
    # shows what the left view does not (x_l = 0 - 0.83 < -0.5)
    wall = np.full((2, 12), 4.0)
    expected = np.ones((2, 12), bool)
    expected[:, 0] = False
    assert np.array_equal(_seen_by_left(wall, wall, 100.0, 0.1, 3.0), expected)
    rng = np.random.default_rng(7)
    left = rng.choice([2.0, 4.0], size=(6, 40)) * (1.0 + 0.004 * rng.standard_normal((6, 40)))
    right = rng.choice([2.0, 4.0], size=(6, 40)) * (1.0 + 0.004 * rng.standard_normal((6, 40)))
    right[0, 3] = np.nan
    got = _seen_by_left(left, right, 100.0, 0.1, 3.0)
    want = _seen_by_left_loop(left, right, 100.0, 0.1, 3.0)
    assert np.array_equal(got, want) and 0.1 < got.mean() < 0.9
