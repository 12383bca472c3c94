"""Blending with a depth test (S1 §IV.B.2) and background-only hole filling."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.synthesis import WarpedView, baseline_weights, blend_views, fill_disparity, fill_holes, forward_warp


@pytest.mark.parametrize(
    ("positions", "target", "expected"),
    [
        ([0.0, 1.0], 0.25, [0.75, 0.25]),  # S1 Sec. IV.B.2: w_L = |t - t_R| / |t_R - t_L|
        ([0.0, 1.0], 0.0, [1.0, 0.0]),
        ([0.0, 1.0], 1.0, [0.0, 1.0]),
        ([0.0, 1.0, 2.0], 1.5, [0.0, 0.5, 0.5]),  # only the neighbours on each side
        ([0.0, 1.0], 1.5, [0.0, 1.0]),  # outside the segment: the nearest alone
    ],
)
def test_baseline_weights(positions, target, expected):
    assert_allclose(baseline_weights(positions, target), expected)


def _view(image, nearness, reliability=None, depth=None, **payload):
    """A warped view from an image and its nearness (px), holes where the nearness is unknown."""
    near = np.asarray(nearness, np.float32)
    return WarpedView(
        image=np.asarray(image, np.float32), holes=np.isnan(near), nearness=near,
        depth=None if depth is None else np.asarray(depth, np.float32), reliability=reliability,
        payload={k: np.asarray(v, np.float32) for k, v in payload.items()},
    )


def test_blend_depth_test_nearest_wins_and_weights_apply():
    a = np.full((1, 3), 0.2, np.float32)
    b = np.full((1, 3), 0.6, np.float32)
    da = np.array([[5.0, 5.0, np.nan]])
    db = np.array([[5.5, 9.0, 2.0]])
    res = blend_views([_view(a, da), _view(b, db)], [0.75, 0.25])
    # Pixel 0: same surface (|5 - 5.5| <= 1) -> 0.75 * 0.2 + 0.25 * 0.6; pixel 1: b is nearer;
    # pixel 2: only b sees it.
    assert_allclose(res.image[0], [0.3, 0.6, 0.6], rtol=1e-6)
    assert_allclose(res.nearness[0], [0.75 * 5 + 0.25 * 5.5, 9.0, 2.0], rtol=1e-6)
    assert not res.holes.any() and res.depth is None and res.nearness_unit == "px"


def test_blend_zero_weight_only_fills_holes():
    a = np.full((1, 2), 0.2, np.float32)
    b = np.full((1, 2), 0.6, np.float32)
    res = blend_views([_view(a, [[1.0, np.nan]]), _view(b, [[9.0, 1.0]])], [1.0, 0.0])
    # b is nearer at pixel 0 but weighs nothing there: the reference at the target position is kept.
    assert_allclose(res.image[0], [0.2, 0.6])
    assert res.nearness[0].tolist() == [1.0, 1.0]


def test_blend_prefers_reliable_pixels_of_the_same_surface():
    a = np.full((1, 2), 0.2, np.float32)
    b = np.full((1, 2), 0.6, np.float32)
    d = np.array([[3.0, 3.0]])
    res = blend_views([_view(a, d, np.array([[False, True]])), _view(b, d, np.array([[True, True]]))], [0.5, 0.5])
    assert_allclose(res.image[0], [0.6, 0.4])
    assert res.reliability.tolist() == [[True, True]]


def test_blend_holes_where_no_reference_sees():
    a = np.zeros((1, 2, 3), np.float32)
    res = blend_views([_view(a, [[np.nan, 1.0]])] * 2, [0.5, 0.5])
    assert res.holes.tolist() == [[True, False]]
    assert np.isnan(res.nearness[0, 0]) and res.image.shape == (1, 2, 3)


def test_blend_per_pixel_weights():
    # Two sources on one surface; pixel 0 weighs a 3:1, pixel 1 weighs only b, pixel 2 only a.
    a, b = np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32)
    d = np.full((1, 3), 2.0)
    w = np.array([[[0.75, 0.0, 1.0]], [[0.25, 2.0, 0.0]]])
    res = blend_views([_view(a, d, fill_guide=[[4.0, 4.0, 4.0]]), _view(b, d, fill_guide=[[8.0, 8.0, 8.0]])], w)
    assert_allclose(res.image[0], [0.25, 1.0, 0.0])
    assert_allclose(res.payload["fill_guide"][0], [5.0, 8.0, 4.0])  # blended like the colours


def test_blend_metric_depth_test_is_relative():
    # With metric depth on every view, the depth test is relative: 10.0 m and 10.05 m are one surface
    # at depth_rtol = 0.01 (10.05 <= 10.1), 10.0 m and 10.5 m are not (the nearer wins).
    a, b = np.zeros((1, 2), np.float32), np.ones((1, 2), np.float32)
    za, zb = np.array([[10.0, 10.5]]), np.array([[10.05, 10.0]])
    views = [WarpedView(im, np.zeros((1, 2), bool), (1 / z).astype(np.float32), "1/m", z.astype(np.float32)) for im, z in ((a, za), (b, zb))]
    res = blend_views(views, [0.5, 0.5], depth_rtol=0.01)
    assert_allclose(res.image[0], [0.5, 1.0])
    assert_allclose(res.depth[0], [10.025, 10.0], rtol=1e-6)
    assert res.nearness_unit == "1/m"


def _blend_reference(views, weights, tol):
    """Slow reference of blend_views on rectified views: per pixel, plain loops."""
    n, (h, w) = len(views), views[0].holes.shape
    out = np.zeros((h, w)); near = np.full((h, w), np.nan); holes = np.ones((h, w), bool)
    for y in range(h):
        for x in range(w):
            known = [k for k in range(n) if not np.isnan(views[k].nearness[y, x])]
            weighted = [k for k in known if weights[k, y, x] > 0]
            active = weighted if weighted else known
            if not active:
                continue
            holes[y, x] = False
            best = max(views[k].nearness[y, x] for k in active)
            cand = [k for k in active if views[k].nearness[y, x] >= best - tol]
            ws = [weights[k, y, x] for k in cand]
            if sum(ws) == 0:
                ws = [1.0] * len(cand)
            out[y, x] = sum(wk * views[k].image[y, x] for wk, k in zip(ws, cand)) / sum(ws)
            near[y, x] = sum(wk * views[k].nearness[y, x] for wk, k in zip(ws, cand)) / sum(ws)
    return out, near, holes


def test_blend_matches_a_slow_reference():
    rng = np.random.default_rng(5)
    for _ in range(5):
        n, h, w = 3, 4, 7
        views = []
        for _ in range(n):
            d = rng.choice([1.0, 1.5, 4.0, np.nan], size=(h, w))
            views.append(_view(rng.random((h, w)), d))
        weights = rng.choice([0.0, 0.3, 1.0], size=(n, h, w))
        weights[0] += 0.1  # not all zero
        res = blend_views(views, weights, depth_tolerance=1.0)
        image, near, holes = _blend_reference(views, weights, 1.0)
        assert_array_equal(res.holes, holes)
        assert_allclose(res.image, image, rtol=1e-5, atol=1e-6)
        assert_allclose(res.nearness, near, rtol=1e-5)


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        (([], []), {}, ValueError, "views must be a non-empty sequence"),
        (([np.zeros((2, 2))], [1.0]), {}, TypeError, r"views\[0\] must be a WarpedView; got ndarray"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2))), _view(np.zeros((2, 3)), np.ones((2, 3)))], [1, 1]), {}, ValueError, r"views\[1\].image must have shape \(2, 2\)"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2)))], [-1.0]), {}, ValueError, "weights must be >= 0 and not all zero"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2)))], [[1.0, 2.0]]), {}, ValueError, r"weights must have shape \(1,\) or \(1, 2, 2\)"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2)))], [1.0]), {"depth_tolerance": 0.0}, ValueError, "depth_tolerance must be > 0"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2)))], [1.0]), {"depth_rtol": -1.0}, ValueError, "depth_rtol must be > 0"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2))), WarpedView(np.zeros((2, 2), np.float32), np.zeros((2, 2), bool), np.ones((2, 2), np.float32), "1/m")], [1, 1]),
         {}, ValueError, r"views\[1\].nearness_unit must be 'px'"),
        (([_view(np.zeros((2, 2)), np.ones((2, 2)), g=np.ones((2, 2))), _view(np.zeros((2, 2)), np.ones((2, 2)))], [1, 1]), {}, ValueError, r"views\[1\].payload must have the keys"),
    ],
)
def test_blend_bad_input(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        blend_views(*args, **kwargs)


# ---------------------------------------------------------------------------------- holes


def _disocclusion_scene():
    """A foreground square (d = 12, colour 1) on a textured background (d = 2, colours in [0, 0.5])."""
    rng = np.random.default_rng(5)
    h, w = 20, 60
    img = (0.5 * rng.random((h, w, 3))).astype(np.float32)
    d = np.full((h, w), 2.0)
    d[5:15, 25:40] = 12.0
    img[5:15, 25:40] = 1.0
    return img, d


@pytest.mark.parametrize("method", ["background", "mirror", "inpaint"])
def test_hole_filling_never_puts_foreground_colour_in_a_background_hole(method):
    # Warping with the foreground moving left opens a hole right of it, bounded by the foreground
    # (white, near) on its left and the background on its right. No method may paint white in it.
    img, d = _disocclusion_scene()
    warped = forward_warp(img, d)
    assert warped.holes[5:15, 28:38].all()
    known_d = np.where(warped.holes, 0.0, warped.nearness)
    filled, filled_d = fill_holes(warped.image, known_d, warped.holes, method=method)
    hole_pixels = filled[warped.holes & (np.arange(60) > 10)[None, :]]
    assert hole_pixels.max() <= 0.5 + 1e-6  # background colours only; the foreground is 1.0
    assert_allclose(filled_d[5:15, 28:38], 2.0)
    assert_array_equal(filled[~warped.holes], warped.image[~warped.holes])


def test_inpainting_under_an_overhang_takes_no_foreground():
    # A hole with background beside it and a wide foreground bar (white, d = 10) right above it:
    # Telea reads the rows above the hole, so the bar must be replaced by background first; it
    # spans the whole row, so a replacement along the row would only find more bar.
    rng = np.random.default_rng(8)
    img = (0.5 * rng.random((16, 40, 3))).astype(np.float32)
    d = np.full((16, 40), 2.0)
    img[2:6], d[2:6] = 1.0, 10.0
    holes = np.zeros((16, 40), bool)
    holes[6:10, 12:24] = True
    filled, _ = fill_holes(img, np.where(holes, 0.0, d), holes, method="inpaint")
    assert filled[holes].max() <= 0.5 + 1e-4  # background colours only (16-bit rounding)
    assert_array_equal(filled[~holes], img[~holes])


def test_background_fill_repeats_the_background_neighbour():
    img = np.array([[0.9, 0.0, 0.0, 0.2]], dtype=np.float32)
    out, d = fill_holes(img, np.array([[8.0, 0.0, 0.0, 1.0]]), np.array([[False, True, True, False]]))
    assert_allclose(out[0], [0.9, 0.2, 0.2, 0.2])
    assert d[0].tolist() == [8.0, 1.0, 1.0, 1.0]


def test_mirror_fill_reflects_the_background_scanline():
    img = np.array([[0.9, 0.0, 0.0, 0.1, 0.2, 0.3]], dtype=np.float32)
    d = np.array([[8.0, 0.0, 0.0, 1.0, 1.0, 1.0]])
    out, _ = fill_holes(img, d, np.array([[False, True, True, False, False, False]]), method="mirror")
    # Hole x = 1, 2, background side x_b = 3: x -> 2 * 3 - x = 5, 4.
    assert_allclose(out[0], [0.9, 0.3, 0.2, 0.1, 0.2, 0.3])


def test_border_runs_take_their_only_neighbour():
    img = np.array([[0.0, 0.4, 0.7, 0.0]], dtype=np.float32)
    out, _ = fill_holes(img, np.array([[0.0, 9.0, 1.0, 0.0]]), np.array([[True, False, False, True]]))
    assert_allclose(out[0], [0.4, 0.4, 0.7, 0.7])


def test_fill_disparity_takes_the_background():
    d = np.array([[5.0, np.nan, np.nan, 2.0], [np.nan, 3.0, np.nan, np.nan], [np.nan] * 4])
    out = fill_disparity(d)
    assert out[0].tolist() == [5.0, 2.0, 2.0, 2.0]
    assert out[1].tolist() == [3.0, 3.0, 3.0, 3.0]
    assert np.isnan(out[2]).all()


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        ((np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2))), {}, TypeError, "holes must be a boolean mask; got float64"),
        ((np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 3), bool)), {}, ValueError, r"holes must have shape \(H, W\) matching image \(2, 2\)"),
        ((np.zeros((2, 2)), np.full((2, 2), np.nan), np.zeros((2, 2), bool)), {}, ValueError, "disparity must be finite outside the holes"),
        ((np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2), bool)), {"method": "smear"}, ValueError, "method must be one of background, inpaint, mirror; got 'smear'"),
    ],
)
def test_fill_holes_bad_input(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        fill_holes(*args, **kwargs)


def test_fill_guide_kernel_matches_a_slow_reference():
    # Each view pixel looks up the original disparity of its source pixel, nearest to x + s d; a
    # pixel whose warped disparity exceeds that by more than the limit counts halfway between.
    from vergence.synthesis._stages import fill_guide as _fill_guide

    rng = np.random.default_rng(12)
    h, w, scale, limit = 6, 30, -0.6, 1.0
    original = rng.uniform(0.0, 10.0, (h, w)).astype(np.float32)
    prepared = (original + np.where(rng.random((h, w)) < 0.3, 5.0, 0.0)).astype(np.float32)
    warped = rng.uniform(-2.0, 14.0, (h, w)).astype(np.float32)
    warped[rng.random((h, w)) < 0.2] = np.nan
    expected = np.full((h, w), np.nan, np.float32)
    for y in range(h):
        for x in range(w):
            d = warped[y, x]
            if np.isnan(d):
                continue
            g = original[y, min(max(int(np.floor(x + scale * d + 0.5)), 0), w - 1)]
            expected[y, x] = (g + d) / 2 if d > g + limit else g
    assert_allclose(_fill_guide(warped, prepared, original, scale, limit), expected, rtol=1e-6)
    assert _fill_guide(warped, original, original, scale, limit) is warped  # no dilation: no guide


def test_blend_scalar_weights_are_their_broadcast():
    rng = np.random.default_rng(9)
    views = [_view(rng.random((3, 5, 3)), rng.choice([1.0, 2.5, np.nan], size=(3, 5))) for _ in range(3)]
    w = np.array([0.2, 0.0, 0.8])
    a = blend_views(views, w)
    b = blend_views(views, np.broadcast_to(w[:, None, None], (3, 3, 5)).copy())
    assert_array_equal(a.image, b.image)
    assert_array_equal(a.nearness, b.nearness)
    assert_array_equal(a.holes, b.holes)
