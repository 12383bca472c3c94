"""DIBR pipelines: view interpolation (analytic scene and Middlebury Dolls), 2D + depth to stereo."""

from __future__ import annotations

import re

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import look_at
from vergence.metrics import psnr
from vergence.synthesis import (
    MAX_SYNTHESIS_BYTES,
    MOSTLY_HOLES_FRACTION,
    holes_warnings,
    interpolate_view,
    synthesize_stereo,
    synthesize_view,
    synthesize_views,
)
from vergence.viewing.geometry import Display

# Layered scene (fronto-parallel layers with smooth textures, exact disparities): linear resampling
# of textures of period >= 30 px is accurate to ~1e-3 (measured 59.1 / inf / 60.0 dB at T = 0.3 /
# 0.5 / 0.7). With the default contour handling the 1-px band grown around the foreground takes
# background colour on these perfectly sharp edges (measured 40.5-42.5 dB); real photographs gain
# from it instead (benchmarks/dolls.py).
LAYERED_MIN_PSNR_DB = 50.0
LAYERED_DEFAULT_MIN_PSNR_DB = 38.0
# Middlebury Dolls, view3 from view1 + view5 at T = 0.5 (benchmarks/dolls.py measures 37.11 dB;
# the baselines score 31.2 and 33.3 dB). Regression floor, a little under the measurement.
DOLLS_MIN_PSNR_DB = 36.5


def _layered_view(t: float, h: int = 24, w: int = 80):
    """View at position t of a background (d = 2) and a foreground rectangle (d = 10).

    Pixel x of view t sees the point at u = x + t d of each layer (left view coordinates); the
    nearer layer whose support holds u wins.
    """
    xs = np.arange(w, dtype=np.float64)[None, :].repeat(h, axis=0)
    ys = np.arange(h, dtype=np.float64)[:, None].repeat(w, axis=1)
    u_bg, u_fg = xs + 2.0 * t, xs + 10.0 * t
    bg = np.stack([0.5 + 0.3 * np.sin(u_bg / 5.0), 0.5 + 0.3 * np.cos(u_bg / 7.0 + ys / 9.0), 0.4 + 0.0 * u_bg], axis=-1)
    fg = np.stack([0.8 + 0.15 * np.cos(u_fg / 6.0), 0.2 + 0.0 * u_fg, 0.3 + 0.2 * np.sin(ys / 4.0 + u_fg / 8.0)], axis=-1)
    inside = (u_fg >= 30.0) & (u_fg < 50.0) & (ys >= 6) & (ys < 18)
    img = np.where(inside[..., None], fg, bg).astype(np.float32)
    disp = np.where(inside, 10.0, 2.0).astype(np.float32)
    return img, disp


@pytest.mark.parametrize("t", [0.3, 0.5, 0.7])
def test_interpolation_of_a_layered_scene_matches_the_true_view(t):
    left, dl = _layered_view(0.0)
    right, dr = _layered_view(1.0)
    truth, _ = _layered_view(t)
    exact = interpolate_view(left, dl, right, dr, t, edge_dilation=0)
    assert psnr(exact.image, truth) > LAYERED_MIN_PSNR_DB
    assert not exact.holes.any()  # the two references see everything between them
    default = interpolate_view(left, dl, right, dr, t)
    assert psnr(default.image, truth) > LAYERED_DEFAULT_MIN_PSNR_DB


def test_interpolation_at_the_ends_reproduces_the_references():
    rng = np.random.default_rng(0)
    left = rng.random((6, 20, 3), dtype=np.float32)
    right = rng.random((6, 20, 3), dtype=np.float32)
    dl = rng.choice([1.0, 2.0, 6.0], size=(6, 20))
    dr = rng.choice([1.0, 2.0, 6.0], size=(6, 20))
    dl[rng.random((6, 20)) < 0.2] = np.nan
    # T = 0: the left view exactly (unknown disparities are filled from the background, so every
    # pixel of a row with one known value is valid); T = 1: the right view.
    assert_array_equal(interpolate_view(left, dl, right, dr, 0.0).image, left)
    assert_array_equal(interpolate_view(left, dl, right, dr, 1.0).image, right)


def test_interpolation_is_symmetric_in_its_references():
    # Swapping the references mirrors the scene: flip both views left-right and swap them. (At T
    # where a shift lands on a half pixel, e.g. 0.25 * 2, nearest-pixel ties break toward +x in
    # both runs, which mirroring turns into -x: T = 0.3 and 0.6 keep every position off the ties.)
    left, dl = _layered_view(0.0)
    right, dr = _layered_view(1.0)
    for t in (0.3, 0.6):
        a = interpolate_view(left, dl, right, dr, t).image
        b = interpolate_view(right[:, ::-1], dr[:, ::-1], left[:, ::-1], dl[:, ::-1], 1.0 - t).image
        assert_allclose(a, b[:, ::-1], atol=1e-6)


def test_interpolation_input_types():
    rng = np.random.default_rng(1)
    u8 = rng.integers(0, 256, (5, 12), dtype=np.uint8)
    d = np.full((5, 12), 2.0)
    grey = interpolate_view(u8, d, u8, d, 0.5).image
    assert grey.shape == (5, 12) and grey.dtype == np.float32
    assert_allclose(interpolate_view(u8.astype(np.uint16) * 257, d, u8.astype(np.uint16) * 257, d, 0.5).image, grey, atol=1e-6)
    colour = interpolate_view(np.repeat(u8[..., None], 3, axis=2), d, np.repeat(u8[..., None], 3, axis=2), d, 0.5).image
    assert_allclose(colour[..., 1], grey, atol=1e-6)


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 6)), np.ones((4, 6)), 0.5), {}, ValueError, r"right must have shape \(4, 5\) like left; got \(4, 6\)"),
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 5, 3)), np.ones((4, 5)), 0.5), {}, ValueError, r"right must have shape \(4, 5\) like left; got \(4, 5, 3\)"),
        ((np.zeros((4, 5)), np.ones((4, 6)), np.zeros((4, 5)), np.ones((4, 5)), 0.5), {}, ValueError, r"left_disparity must have shape \(H, W\) matching left"),
        ((np.zeros((4, 5)), np.full((4, 5), np.nan), np.zeros((4, 5)), np.ones((4, 5)), 0.5), {}, ValueError, "left_disparity must have at least one known value"),
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 5)), np.full((4, 5), -np.inf), 0.5), {}, ValueError, "right_disparity must not contain inf"),
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 5)), np.ones((4, 5)), 1.5), {}, ValueError, r"position must lie in \[0, 1\]; got 1.5"),
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 5)), np.ones((4, 5)), -0.1), {}, ValueError, r"position must lie in \[0, 1\]; got -0.1"),
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 5)), np.ones((4, 5)), 0.5), {"fill": "blur"}, ValueError, "fill must be one of background, inpaint, mirror; got 'blur'"),
        ((np.zeros((4, 5)), np.ones((4, 5)), np.zeros((4, 5)), np.ones((4, 5)), 0.5), {"edge_dilation": -1}, ValueError, r"edge_dilation must lie in \[0, 64\] pixels"),
    ],
)
def test_interpolation_bad_input(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        interpolate_view(*args, **kwargs)


def test_dolls_view3_from_view1_and_view5(shared_data):
    # Middlebury 2005 Dolls (Scharstein & Pal 2007), half size: see shared/data/SOURCES.md.
    from vergence.io import read_disparity, read_image

    folder = shared_data / "multiview" / "dolls"
    v1, v3, v5 = (read_image(folder / f"view{k}.png") for k in (1, 3, 5))
    d1 = read_disparity(folder / "disp1.png", scale=2.0)
    d5 = read_disparity(folder / "disp5.png", scale=2.0)
    res = interpolate_view(v1, d1, v5, d5, 0.5)
    assert psnr(res.image, v3) > DOLLS_MIN_PSNR_DB


# ------------------------------------------------------------------------- 2D + depth


def _square_scene():
    img = np.zeros((10, 40), np.float32)
    img[3:7, 18:22] = 1.0  # a bright square, near
    depth = np.full((10, 40), 4.0)
    depth[3:7, 18:22] = 1.0
    return img, depth


def test_stereo_pair_moves_near_objects_apart_as_planned():
    img, depth = _square_scene()
    res = synthesize_stereo(img, depth, budget_px=6.0)
    assert res.plan.range_px == (-6.0, 6.0)
    # Near square: P = -6 (crossed); x_l = x_c - P/2 = x_c + 3, x_r = x_c - 3; far: P = +6.
    cols_l = np.flatnonzero(res.left[5] > 0.5)
    cols_r = np.flatnonzero(res.right[5] > 0.5)
    assert cols_l.tolist() == list(range(21, 25))
    assert cols_r.tolist() == list(range(15, 19))
    assert res.offsets == (-0.5, 0.5)
    assert all(h.any() for h in res.holes)  # disocclusions beside the square, filled


def test_odd_view_count_keeps_the_original_in_the_middle():
    img, depth = _square_scene()
    res = synthesize_stereo(img, depth, budget_px=4.0, views=3)
    assert len(res.views) == 3
    assert_array_equal(res.views[1], img)


def test_synthesize_views_with_the_original_as_left_view():
    img, depth = _square_scene()
    parallax = np.where(depth < 2.0, -4.0, 0.0)
    (left, right), _ = synthesize_views(img, parallax, offsets=(0.0, 1.0))
    assert_array_equal(left, img)
    assert np.flatnonzero(right[5] > 0.5).tolist() == list(range(14, 18))


def test_synthesize_stereo_depth_controls_and_bad_input():
    img, depth = _square_scene()
    with pytest.raises(ValueError, match=r"depth must have shape \(H, W\) matching image \(10, 40\); got \(10, 41\)"):
        synthesize_stereo(img, np.ones((10, 41)), budget_px=3.0)
    with pytest.raises(ValueError, match=r"views must lie in \[2, 128\] \(MAX_VIEWS\); got 1"):
        synthesize_stereo(img, depth, budget_px=3.0, views=1)
    with pytest.raises(ValueError, match="depth must be > 0 metres"):
        synthesize_stereo(img, -depth, budget_px=3.0)
    res = synthesize_stereo(img, depth, focal_px=100.0, interaxial=0.06, convergence=4.0)
    assert res.plan.range_px[1] == pytest.approx(0.0, abs=1e-9)  # background on the screen plane


def test_synthesize_view_rectified_and_general_paths_agree():
    # A slightly turned target is not rectified with the source: the 3D path. A sideways one is:
    # the rectified path. On a fronto-parallel plane with a smooth texture both render the shift.
    src = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60.0, width=48, height=32)
    side = look_at([0.1, 0, 0], [0.1, 0, 1], [0, -1, 0], fov_deg=60.0, width=48, height=32)
    xs = np.arange(48, dtype=np.float32)
    img = np.tile(0.5 + 0.3 * np.sin(xs / 6.0), (32, 1)).astype(np.float32)
    depth = np.full((32, 48), 2.0)
    rect = synthesize_view(img, depth, src, side)
    d = src.focal_px * 0.1 / 2.0
    expected = 0.5 + 0.3 * np.sin((xs + d) / 6.0)  # target x sees source x + d
    ok = xs + d <= 47
    assert_allclose(rect.image[:, ok], np.broadcast_to(expected[ok], (32, ok.sum())), atol=2e-3)
    turned = look_at([0.1, 0, 0], [0.1 + 1e-3, 0, 1], [0, -1, 0], fov_deg=60.0, width=48, height=32)
    general = synthesize_view(img, depth, src, turned)
    inner = slice(2, 30), slice(2, 30)
    assert_allclose(general.image[inner], rect.image[inner], atol=0.05)


def test_contour_removal_takes_a_haloed_edge_from_the_other_reference():
    # The left view has a bright halo on the background pixel just right of the foreground (a
    # mixed pixel, S1 §IV.B.3). Both references see that background point at T = 0.5; with
    # contour removal the left one's copy is unreliable and the right one's clean copy is used.
    left, dl = _layered_view(0.0)
    right, dr = _layered_view(1.0)
    truth, _ = _layered_view(0.5)
    left[6:18, 50] = 1.0  # u = 50: first background column right of the square (u in [30, 50))
    plain = interpolate_view(left, dl, right, dr, 0.5, edge_dilation=0)
    cleaned = interpolate_view(left, dl, right, dr, 0.5, edge_dilation=0, contour_width=1)
    x = 50 - 1  # the background point u = 50 seen at x = u - T d = 49
    assert np.abs(plain.image[6:18, x] - truth[6:18, x]).max() > 0.1
    assert_allclose(cleaned.image[6:18, x], truth[6:18, x], atol=1e-5)
    # And a target at a reference position still reproduces it exactly.
    assert_array_equal(interpolate_view(left, dl, right, dr, 0.0, contour_width=1).image, left)


def test_synthesize_view_shift_sensor_pair_uses_the_principal_point():
    # Same centre, principal point 2 px to the left in the target: every pixel moves 2 px left,
    # d = f b / Z + cx_s - cx_t = 2 (rectified path, exact integer shift).
    src = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60.0, width=20, height=8)
    K = src.K.copy()
    K[0, 2] -= 2.0
    tgt = src.with_intrinsics(K)
    img = np.random.default_rng(9).random((8, 20), dtype=np.float32)
    res = synthesize_view(img, np.full((8, 20), 3.0), src, tgt)
    assert_array_equal(res.image[:, :18], img[:, 2:])
    assert res.holes[:, 18:].all()


@pytest.mark.parametrize("kind", ["metric", "disparity", "inverse"])
def test_pipelines_never_modify_their_inputs(kind):
    img, depth = _square_scene()
    depth = (1.0 / depth if kind == "inverse" else depth).astype(np.float32)  # inverse depth lies in [0, 1]
    img0, depth0 = img.copy(), depth.copy()
    synthesize_stereo(img, depth, kind=kind, budget_px=3.0, fill="inpaint")
    assert_array_equal(img, img0)
    assert_array_equal(depth, depth0)
    left, dl = _layered_view(0.0)
    right, dr = _layered_view(1.0)
    copies = [a.copy() for a in (left, dl, right, dr)]
    interpolate_view(left, dl, right, dr, 0.4, contour_width=1, fill="mirror")
    for a, b in zip((left, dl, right, dr), copies):
        assert_array_equal(a, b)


def _overhang_scene():
    """Background (depth 5, colours r, g <= 0.4) behind three objects whose colours have r or g >= 0.95:
    a near block (1 m), a narrower one to its right (1.5 m) and a bar over both (1.2 m)."""
    rng = np.random.default_rng(3)
    h, w = 32, 96
    img = np.stack([0.1 + 0.3 * rng.random((h, w)), 0.1 + 0.3 * rng.random((h, w)), 0.4 + 0.2 * rng.random((h, w))], -1)
    depth = np.full((h, w), 5.0)
    layers = [((slice(6, 8), slice(30, 70)), 1.2, (0.95, 0.0, 0.95)),
              ((slice(8, 24), slice(30, 44)), 1.0, (0.95, 0.95, 0.95)),
              ((slice(10, 22), slice(52, 56)), 1.5, (0.95, 0.95, 0.0))]
    for region, z, colour in layers:
        depth[region] = z
        img[region] = colour
    return img.astype(np.float32), depth, layers


# Overhang scene: background r, g <= 0.4, foreground 0.95. With edge dilation the background pixel
# next to an edge moves with the foreground and, resampled at a sub-pixel position, mixes with its
# foreground neighbour (measured up to 0.52 here); a hole between two such pixels can only take a
# mix. Copied foreground (0.95, or 0.76 from the inpainting) stays well above this bound.
BACKGROUND_OR_MIX_MAX = 0.6


@pytest.mark.parametrize("edge_dilation", [0, 1, 2])
@pytest.mark.parametrize("fill", ["background", "mirror", "inpaint"])
def test_hole_filling_never_smears_foreground_into_the_background(fill, edge_dilation):
    # Disocclusions beside the near block are bounded by it, by the narrower block (its right
    # neighbour in the left view) and by the bar above. No hole pixel whose true content is the
    # background may take a foreground colour, whatever the method: edge dilation makes background
    # pixels along the edges carry foreground disparity, which once let mirror filling copy the
    # narrow block and inpainting copy the bar into the hole.
    img, depth, layers = _overhang_scene()
    res = synthesize_stereo(img, depth, budget_px=8.0, fill=fill, edge_dilation=edge_dilation)
    h, w = depth.shape
    xs = np.arange(w)
    for view, holes, offset in zip(res.views, res.holes, res.offsets):
        behind = np.ones((h, w), bool)  # the true content is the background
        for (rows, cols), z, _ in layers:
            p = float(res.plan.parallax_px[rows.start, cols.start])
            src = np.floor(xs - offset * p + 0.5).astype(int)  # view pixel x shows source x - o P
            covered = (src >= cols.start) & (src < cols.stop)
            behind[rows, :] &= ~covered[None, :]
        background_holes = holes & behind
        assert background_holes.sum() > 20
        assert view[background_holes][:, :2].max() <= BACKGROUND_OR_MIX_MAX


def test_synthesize_view_reports_target_depth_on_both_paths():
    # A fronto-parallel plane 2 m away stays 2 m away for a sideways move (rectified path, depth
    # from Z = f b / d) and for a move along the optical axis (3D path), 2 - 0.1 = 1.9 m.
    h, w = 8, 16
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    side = look_at([0.05, 0, 0], [0.05, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    ahead = look_at([0, 0, 0.1], [0, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    img = np.random.default_rng(3).random((h, w)).astype(np.float32)
    depth = np.full((h, w), 2.0)
    rect = synthesize_view(img, depth, a, side)
    assert rect.nearness_unit == "px"
    assert_allclose(rect.depth, 2.0, rtol=1e-6)
    assert_allclose(rect.nearness, a.K[0, 0] * 0.05 / 2.0, rtol=1e-6)  # d = f b / Z
    general = synthesize_view(img, depth, a, ahead)
    assert general.nearness_unit == "1/m"
    assert_allclose(general.depth[~general.holes], 1.9, rtol=1e-6)


def test_synthesize_stereo_refuses_views_that_cannot_fit_the_image():
    # Issue 9: the outer views lie (views - 1) adjacent parallaxes apart; a whole image width (40 px
    # here) or more is refused before any view is rendered.
    img, depth = _square_scene()
    assert len(synthesize_stereo(img, depth, budget_px=2.0, views=20).views) == 20  # 19 x 2 = 38 px
    with pytest.raises(ValueError, match=r"views 21 at up to 2 px of parallax between neighbours span 40 px between the outer views, which must stay below 40 px"):
        synthesize_stereo(img, depth, budget_px=2.0, views=21)


def test_synthesize_stereo_warns_outside_the_comfort_zone_past_divergence_and_on_mostly_holes():
    # Issue 9: a result that leaves the comfort zone or passes divergence comes with a warning.
    # desktop-24: 1920 display px for 40 image px, 48 per image pixel; the divergence limit is
    # 0.065 m / 0.5313 m x 1920 = 234.9 display px = 4.89 image px; +-60 arcmin is about +-0.8 image px.
    img, depth = _square_scene()
    desk = Display.preset("desktop-24")
    assert synthesize_stereo(img, depth, budget_px=0.5, display=desk).warnings == ()
    assert synthesize_stereo(img, depth, budget_px=2.0).warnings == ()  # no display: nothing to check
    (comfort,) = synthesize_stereo(img, depth, budget_px=2.0, display=desk).warnings
    assert re.fullmatch(r"the parallax range -\d+\.?\d* \.\. \+\d+\.?\d* arcmin leaves the comfort zone -60 \.\. \+60 arcmin by \d+\.?\d* arcmin", comfort)
    found = synthesize_stereo(img, depth, budget_px=5.0, display=desk).warnings
    assert len(found) == 2
    assert found[0] == "the parallax reaches +240 display px behind the screen, past the divergence limit 234.9 px of this display (S0 Eq. 8): the eyes would diverge"
    res = synthesize_stereo(img, depth, budget_px=39.0, origin="left")  # view 1 moves by P: up to 39 px
    shares = [float(h.mean()) for h in res.holes]
    assert res.warnings == tuple(
        f"view {k} is {100 * s:.1f} % filled-in holes (more than MOSTLY_HOLES_FRACTION 50 %): most of it was not seen; lower the parallax"
        for k, s in enumerate(shares) if s > 0.5
    ) and res.warnings
    assert res.to_dict()["warnings"] == list(res.warnings)


def test_holes_warnings_threshold():
    half = np.zeros((2, 2), bool)
    half[0] = True
    assert MOSTLY_HOLES_FRACTION == 0.5
    assert holes_warnings([half]) == ()  # exactly half: not more than half
    half[1, 0] = True
    assert holes_warnings([half]) == ("the view is 75.0 % filled-in holes (more than MOSTLY_HOLES_FRACTION 50 %): most of it was not seen; lower the parallax",)
    with pytest.raises(TypeError, match="holes must be a sequence"):
        holes_warnings(half)


def test_interpolate_view_refuses_disparities_of_an_image_width():
    # Issue 9: disparities wider than the image gave an all-black view.
    img = np.random.default_rng(1).random((6, 20), dtype=np.float32)
    ok = np.full((6, 20), 19.5)
    assert interpolate_view(img, ok, img, ok, 0.5).image.shape == (6, 20)
    wide = np.full((6, 20), 20.0)
    with pytest.raises(ValueError, match=r"left_disparity must lie within \+-20 px, 1 image width \(MAX_PARALLAX_WIDTHS\).*got \|d\| up to 20"):
        interpolate_view(img, wide, img, ok, 0.5)
    with pytest.raises(ValueError, match=r"right_disparity must lie within \+-20 px.*got \|d\| up to 100"):
        interpolate_view(img, ok, img, -5 * wide, 0.5)


def test_synthesize_stereo_refuses_results_past_max_synthesis_bytes_before_any_work():
    # Issue 9 kin (render grew to 24 GB): 128 views of an 8000 x 10000 RGB image would need
    # 128 x (8e7 x 3 x 4 + 8e7) bytes = 124 GiB.
    # The check reads only the shapes: a broadcast image of that size costs no memory.
    assert MAX_SYNTHESIS_BYTES == 4 * 2**30
    img = np.broadcast_to(np.float32(0.5), (10000, 8000, 3))
    depth = np.broadcast_to(2.0, (10000, 8000))
    with pytest.raises(ValueError, match=r"views 128 of a 8000x10000 image would take 124 GiB, more than MAX_SYNTHESIS_BYTES 4 GiB"):
        synthesize_stereo(img, depth, budget_px=1.0, views=128)
