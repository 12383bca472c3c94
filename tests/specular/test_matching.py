"""Per-layer disparity (S3 §3.2): both Numba searches against a slow exhaustive numpy reference."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import vergence.specular.matching as ld
from vergence.specular import (
    EPSILON_FRACTION,
    LAYER_MATCH_METHODS,
    MATCH_WINDOW,
    LayerDisparity,
    disparity_arcmin,
    layer_disparity,
    scene_diameter,
)
from vergence.viewing import Display, arcmin_from_pixels

METHODS = sorted(LAYER_MATCH_METHODS)


def reference(left: np.ndarray, right: np.ndarray, window: tuple[int, int], epsilon: float):
    """The definition, offset by offset: disparity (N, H, W, 2) and distance (N, H, W).

    For each offset (dy, dx) of the window, in raster order, every left pixel compares the right
    pixel (y + dy, x + dx) with its best so far (``d2 = (dx^2 + dy^2) + dz^2`` in float32, the
    documented form); a strict ``<`` keeps the first of equal candidates, i.e. the smallest right row,
    then column. Start at ``float32(epsilon)^2``: nothing at epsilon or beyond matches; NaN never wins.
    """
    left = np.asarray(left, np.float32)
    right = np.asarray(right, np.float32)
    n, h, w, _ = left.shape
    eps = np.float32(epsilon)
    best = np.full((n, h, w), eps * eps, np.float32)
    match_y = np.full((n, h, w), -1)
    match_x = np.full((n, h, w), -1)
    ys, xs = np.mgrid[0:h, 0:w]
    for dy in range(-(window[1] // 2), window[1] // 2 + 1):
        for dx in range(-(window[0] // 2), window[0] // 2 + 1):
            yy, xx = ys + dy, xs + dx
            inside = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
            cand = np.full_like(left, np.nan)
            cand[:, inside] = right[:, yy[inside], xx[inside]]
            d = cand - left
            d2 = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2]
            with np.errstate(invalid="ignore"):
                better = d2 < best
            best[better] = d2[better]
            match_y[better] = np.broadcast_to(yy, better.shape)[better]
            match_x[better] = np.broadcast_to(xx, better.shape)[better]
    found = match_x >= 0
    disp = np.full((n, h, w, 2), np.nan, np.float32)
    disp[..., 0][found] = (np.broadcast_to(xs, found.shape) - match_x)[found]
    disp[..., 1][found] = (np.broadcast_to(ys, found.shape) - match_y)[found]
    dist = np.where(found, np.sqrt(best), np.float32(np.nan)).astype(np.float32)
    return disp, dist


def surfaces(rng: np.random.Generator, n: int, h: int, w: int, *, shift: float = 3.0, holes: float = 0.2):
    """Two eyes' positions of smooth, bumpy surfaces seen with a horizontal and vertical shift, with holes."""
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    left, right = [], []
    for _ in range(n):
        a, b, c = rng.uniform(-1, 1, 3)
        depth = lambda u, v: 2.0 + 0.3 * np.sin(a * u / 3.0) + 0.2 * np.cos(b * v / 2.0) + 0.01 * c * u  # noqa: E731
        su, sv = rng.uniform(-shift, shift), rng.uniform(-1.0, 1.0)
        for eye, (u, v) in ((left, (xs, ys)), (right, (xs + su, ys + sv))):
            p = np.stack([0.01 * u, 0.01 * v, depth(u, v)], axis=-1)
            p += rng.normal(0.0, 0.002, p.shape)  # not exactly on a lattice: a unique nearest point
            p[rng.random((h, w)) < holes] = np.nan
            eye.append(p)
    return np.array(left, np.float32), np.array(right, np.float32)


def assert_same(out: LayerDisparity, ref: tuple[np.ndarray, np.ndarray]) -> None:
    assert_array_equal(out.disparity_px, ref[0])  # NaN equal NaN; whole numbers compared exactly
    assert_array_equal(out.distance, ref[1])  # bit for bit: the same float32 d2


# --- against the reference ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("window", [MATCH_WINDOW, (7, 3), (1, 1), (21, 5)])
def test_methods_equal_reference_on_surfaces(method, window):
    left, right = surfaces(np.random.default_rng(1), 3, 24, 56)
    eps = 0.02
    assert_same(layer_disparity(left, right, window=window, epsilon=eps, method=method),
                reference(left, right, window, eps))  # fmt: skip


@pytest.mark.parametrize("method", METHODS)
def test_methods_equal_reference_on_noise(method):
    """Unstructured positions: the branch and bound gets no help from smoothness."""
    rng = np.random.default_rng(2)
    left = rng.uniform(0.0, 1.0, (2, 17, 45, 3)).astype(np.float32)
    right = rng.uniform(0.0, 1.0, (2, 17, 45, 3)).astype(np.float32)
    right[0, 3:9, 10:30] = np.nan
    for eps in (0.05, 0.2, 2.0):
        assert_same(layer_disparity(left, right, window=(31, 5), epsilon=eps, method=method),
                    reference(left, right, (31, 5), eps))  # fmt: skip


@pytest.mark.parametrize("method", METHODS)
def test_ties_on_a_coarse_lattice(method):
    """Positions rounded to a coarse grid: many candidates at exactly the same distance."""
    rng = np.random.default_rng(3)
    left = rng.integers(0, 4, (2, 15, 40, 3)).astype(np.float32)
    right = rng.integers(0, 4, (2, 15, 40, 3)).astype(np.float32)
    right[1, ::3] = np.nan
    out = layer_disparity(left, right, window=(11, 5), epsilon=1.5, method=method)
    ref = reference(left, right, (11, 5), 1.5)
    assert_same(out, ref)
    assert out.matched.mean() > 0.5


@pytest.mark.parametrize("method", METHODS)
def test_tie_rule_smallest_row_then_column(method):
    left = np.full((1, 9, 20, 3), np.nan, np.float32)
    right = np.full_like(left, np.nan)
    left[0, 4, 10] = (1.0, 1.0, 1.0)
    twin = (1.0, 1.0, 1.01)  # the same distance 0.01 from three right pixels
    right[0, 5, 3] = right[0, 3, 14] = right[0, 3, 12] = twin
    out = layer_disparity(left, right, window=(21, 5), epsilon=0.1, method=method)
    assert_array_equal(out.disparity_px[0, 4, 10], [10 - 12, 4 - 3])  # row 3 before row 5, column 12 before 14
    right[0, 3, 12] = right[0, 3, 14] = np.nan
    out = layer_disparity(left, right, window=(21, 5), epsilon=0.1, method=method)
    assert_array_equal(out.disparity_px[0, 4, 10], [10 - 3, 4 - 5])


@pytest.mark.parametrize("method", METHODS)
def test_window_borders_and_image_borders(method):
    """A match at the window's edge is found; one pixel past it, not; nothing outside the image."""
    h, w = 11, 100
    left = np.full((1, h, w, 3), np.nan, np.float32)
    right = np.full_like(left, np.nan)
    left[0, 5, 50] = left[0, 0, 0] = left[0, 10, 99] = (0.0, 0.0, 0.0)
    right[0, 9, 10] = (0.0, 0.0, 0.001)  # dx = -40, dy = -4 from (50, 5): the corner of the 81 x 9 window
    right[0, 1, 99] = (0.0, 0.0, 0.002)  # 49 columns from (50, 5): outside; 9 rows from (99, 10): outside
    out = layer_disparity(left, right, epsilon=0.01, method=method)
    assert_array_equal(out.disparity_px[0, 5, 50], [40, -4])
    assert_allclose(out.distance[0, 5, 50], 0.001, rtol=1e-6)
    assert np.isnan(out.disparity_px[0, 0, 0]).all()  # (10, 9) is 10 columns but 9 rows away
    assert np.isnan(out.disparity_px[0, 10, 99]).all()
    right[0, 9, 10] = np.nan
    right[0, 9, 9] = (0.0, 0.0, 0.001)  # dx = -41: one past the window
    assert not layer_disparity(left, right, epsilon=0.01, method=method).matched[0, 5, 50]
    assert_array_equal(layer_disparity(left, right, window=(83, 9), epsilon=0.01, method=method)
                       .disparity_px[0, 5, 50], [41, -4])  # fmt: skip


@pytest.mark.parametrize("method", METHODS)
def test_epsilon_cutoff_is_strict(method):
    """No match at distance epsilon (S3: 'smaller than a threshold'), a match just below."""
    e = np.float32(0.25)
    left = np.zeros((1, 1, 3, 3), np.float32)
    right = np.zeros_like(left)
    right[0, 0, :, 0] = e  # every candidate exactly e away along x
    assert not layer_disparity(left, right, window=(3, 1), epsilon=float(e), method=method).matched.any()
    above = float(np.nextafter(e, np.float32(1.0)))
    out = layer_disparity(left, right, window=(3, 1), epsilon=above, method=method)
    assert out.matched.all()
    assert_array_equal(out.disparity_px[0, 0, :, 0], [0, 1, 1])  # ties: the window's first column in the image
    assert_array_equal(out.distance, np.full((1, 1, 3), e))


@pytest.mark.parametrize("method", METHODS)
def test_nan_pixels_never_match_and_are_never_matched(method):
    rng = np.random.default_rng(4)
    left, right = surfaces(rng, 3, 12, 30, holes=0.3)
    left[1] = np.nan  # a layer with no surface at all (paths that do not exist)
    right[2] = np.nan
    right[0, :, :, 1] = np.where(rng.random((12, 30)) < 0.5, np.nan, right[0, :, :, 1])  # one coordinate NaN
    out = layer_disparity(left, right, window=(15, 5), epsilon=0.05, method=method)
    assert_same(out, reference(left, right, (15, 5), 0.05))
    assert not out.matched[1].any() and not out.matched[2].any()
    assert not out.matched[0][np.isnan(left[0]).any(axis=-1)].any()
    ys, xs = np.nonzero(out.matched[0])
    hit = right[0, ys - out.disparity_px[0, ys, xs, 1].astype(int), xs - out.disparity_px[0, ys, xs, 0].astype(int)]
    assert np.isfinite(hit).all()


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), h=st.integers(1, 14), w=st.integers(1, 50),
       half=st.tuples(st.integers(0, 12), st.integers(0, 3)), eps=st.floats(0.005, 0.5))  # fmt: skip
def test_property_bounded_equals_reference(seed, h, w, half, eps):
    left, right = surfaces(np.random.default_rng(seed), 2, h, w, shift=6.0)
    window = (2 * half[0] + 1, 2 * half[1] + 1)
    assert_same(layer_disparity(left, right, window=window, epsilon=eps), reference(left, right, window, eps))


def test_known_shift_and_sign():
    """The right eye sees each point 3 columns left and 1 row up: x_left - x_right = 3, y_left - y_right = 1."""
    left, right = surfaces(np.random.default_rng(5), 1, 10, 30, shift=0.0, holes=0.0)
    right = np.full_like(left, np.nan)
    right[0, :-1, :-3] = left[0, 1:, 3:]
    out = layer_disparity(left, right, epsilon=0.001)
    assert_array_equal(out.disparity_px[0, 1:, 3:], np.broadcast_to([3.0, 1.0], (9, 27, 2)))
    assert_array_equal(out.distance[0, 1:, 3:], 0.0)
    assert not out.matched[0, 0].any() and not out.matched[0, :, :3].any()


def test_default_epsilon_is_a_hundredth_of_the_scene_diameter():
    left = np.full((2, 2, 3, 3), np.nan, np.float32)
    right = np.full_like(left, np.nan)
    left[0, 0, 0] = (-1.0, 0.0, 2.0)
    right[1, 1, 2] = (1.0, 2.0, 3.0)  # the box (-1, 0, 2)-(1, 2, 3) over both eyes: diagonal 3
    right[0, 1, 1] = (0.0, np.nan, 100.0)  # not finite on all axes: not part of the scene
    assert scene_diameter(left, right) == pytest.approx(3.0)
    out = layer_disparity(left, right)
    assert out.epsilon == pytest.approx(EPSILON_FRACTION * 3.0) and EPSILON_FRACTION == 0.01
    assert scene_diameter(np.full_like(left, np.nan), right[:, :, :, :] * np.nan) == 0.0
    empty = layer_disparity(np.full_like(left, np.nan), np.full_like(left, np.nan))
    assert empty.epsilon == 0.0 and not empty.matched.any()


def test_result_is_read_only_and_inputs_untouched():
    left, right = surfaces(np.random.default_rng(6), 2, 8, 16)
    before = left.copy(), right.copy()
    out = layer_disparity(left, right)
    assert_array_equal(left, before[0]) and assert_array_equal(right, before[1])
    assert out.disparity_px.dtype == np.float32 and out.distance.dtype == np.float32
    assert out.disparity_px.shape == (2, 8, 16, 2) and out.window == MATCH_WINDOW and out.n_layers == 2
    with pytest.raises(ValueError):
        out.distance[0, 0, 0] = 1.0
    # float64 input is rounded to float32 first: the same matches
    assert_same(layer_disparity(left.astype(np.float64), right.astype(np.float64)), (out.disparity_px, out.distance))


# --- on a rendered scene -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def glasses():
    render = pytest.importorskip("vergence.render")
    scene = render.open_scene("glasses", width=48, height=36)
    # A wide baseline (0.4 m) makes first-hit disparities of several pixels, to check sign and size.
    left, right = render.render_stereo(scene, baseline=0.4, convergence=scene.stereo.convergence, max_depth=2, samples=1)
    return left, right, render.screen_disparity(left, right)


def test_rendered_layers_equal_reference(glasses):
    left, right, _ = glasses
    eps = EPSILON_FRACTION * scene_diameter(left.position, right.position)
    ref = reference(left.position, right.position, MATCH_WINDOW, eps)
    for method in METHODS:
        out = layer_disparity(left.position, right.position, method=method)
        assert out.epsilon == pytest.approx(eps)
        assert_same(out, ref)
    specular = out.matched[1:].sum()
    assert specular > 0.05 * out.matched[0].size  # the glass and the mirror have matched layers


def test_first_layer_agrees_with_the_projected_truth(glasses):
    """Node 1 is plain geometry: its matches are the projection of the left points into the right
    camera (:func:`vergence.render.screen_disparity`) to the pixel, bar occlusion edges."""
    left, right, truth = glasses
    dx = layer_disparity(left.position, right.position).disparity_px[0, ..., 0]
    both = np.isfinite(dx) & np.isfinite(truth)
    err = np.abs(dx - truth)[both]
    assert both.mean() > 0.95 and np.nanmin(truth) < -2.0 and np.nanmax(truth) > 2.0  # both signs, a few px
    assert np.median(err) < 0.5 and np.mean(err <= 1.0) > 0.95
    assert np.corrcoef(dx[both], truth[both])[0, 1] > 0.95  # the same sign convention


# --- arcminutes --------------------------------------------------------------------------------------


def test_disparity_arcmin_reuses_the_display_conversion():
    display = Display(eye_separation=0.065, distance=0.6, width=0.5, resolution=1000)
    d = np.full((2, 3, 500, 2), np.nan)
    d[0, 1, 2] = (4.0, -2.0)
    d[1, 0, 0] = (-3.0, 0.0)
    out = disparity_arcmin(d, display)
    scale = 1000 / 500  # the 500 px image fills the 1000 px screen
    assert out.shape == d.shape
    assert_allclose(out[0, 1, 2, 0], arcmin_from_pixels(-4.0 * scale, display), rtol=1e-12)
    assert out[0, 1, 2, 0] < 0  # crossed: in front of the screen
    assert_allclose(out[0, 1, 2, 1], 2.0 * scale * 0.0005 / 0.6 * 180 * 60 / np.pi, rtol=1e-12)
    assert_allclose(out[1, 0, 0, 0], arcmin_from_pixels(3.0 * scale, display), rtol=1e-12)
    assert_allclose(disparity_arcmin(d, display, exact=False)[1, 0, 0, 0], 3.0 * scale * 0.0005 / 0.6 * 10800 / np.pi)
    assert np.isnan(out[0, 0, 0]).all() and np.isnan(out).sum() == d.size - 4
    assert np.isnan(disparity_arcmin(np.full((1, 2, 2), np.nan), display)).all()  # nothing matched: no error


def test_disparity_arcmin_of_a_layer_disparity():
    left, right = surfaces(np.random.default_rng(7), 2, 6, 20)
    out = layer_disparity(left, right)
    arc = disparity_arcmin(out.disparity_px, Display.preset("samsung-2233rz"))
    assert_array_equal(np.isnan(arc), np.isnan(out.disparity_px))


# --- bad input ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"left_position": np.zeros((2, 4, 3))}, ValueError, r"left_position must have shape \(N, H, W, 3\)"),
        ({"right_position": np.zeros((1, 2, 4, 2))}, ValueError, r"right_position must have shape \(N, H, W, 3\)"),
        ({"right_position": np.zeros((1, 2, 5, 3))}, ValueError, "must have the shape of left_position"),
        ({"left_position": np.zeros((0, 2, 4, 3))}, ValueError, "N, H, W >= 1"),
        ({"left_position": np.full((1, 2, 4, 3), "a")}, TypeError, "left_position must be a real numeric array"),
        ({"left_position": np.zeros((1, 2, 4, 3), bool)}, TypeError, "real numeric"),
        ({"right_position": np.full((1, 2, 4, 3), np.inf)}, ValueError, r"right_position must hold finite .* 24 inf"),
        ({"left_position": np.full((1, 2, 4, 3), 1e300)}, ValueError, "float32 range"),
        ({"window": (80, 9)}, ValueError, "window must be two odd integers"),
        ({"window": (81, 0)}, ValueError, "window must be two odd integers"),
        ({"window": 81}, TypeError, r"window must be two integers \(width, height\)"),
        ({"window": (81.0, 9)}, TypeError, "window must be two integers"),
        ({"epsilon": 0.0}, ValueError, r"epsilon must lie in \[1e-18, 1e\+18\]"),
        ({"epsilon": 1e-20}, ValueError, "epsilon must lie in"),
        ({"epsilon": float("nan")}, ValueError, "epsilon must be finite"),
        ({"epsilon": 1e30}, ValueError, "epsilon must lie in"),
        ({"left_position": np.full((1, 2, 4, 3), 1e37)}, ValueError, "scene diameter must be at most"),
        ({"epsilon": "1"}, TypeError, "epsilon must be a real number"),
        ({"method": "fast"}, ValueError, "unknown method 'fast'; valid methods: bounded, exhaustive"),
        ({"method": None}, TypeError, "method must be a string"),
    ],
)
def test_layer_disparity_bad_input(kwargs, error, match):
    args = {"left_position": np.zeros((1, 2, 4, 3)), "right_position": np.zeros((1, 2, 4, 3))} | kwargs
    with pytest.raises(error, match=match):
        layer_disparity(args.pop("left_position"), args.pop("right_position"), **args)


def test_disparity_arcmin_bad_input():
    display = Display.preset("samsung-2233rz")
    with pytest.raises(ValueError, match=r"disparity_px must have shape \(\.\.\., H, W, 2\)"):
        disparity_arcmin(np.zeros((4, 5)), display)
    with pytest.raises(ValueError, match="must not contain inf"):
        disparity_arcmin(np.full((2, 2, 2), np.inf), display)
    with pytest.raises(TypeError, match="display must be a vergence.viewing.Display"):
        disparity_arcmin(np.zeros((2, 2, 2)), "samsung")
    with pytest.raises(ValueError, match="resolution is unknown"):
        disparity_arcmin(np.zeros((2, 2, 2)), Display(eye_separation=0.065, distance=0.6, width=0.5))
    with pytest.raises(TypeError, match="exact must be a bool"):
        disparity_arcmin(np.zeros((2, 2, 2)), display, exact=1)
    with pytest.raises(TypeError, match="disparity_px must be numeric"):
        disparity_arcmin("x", display)


def test_docstring_examples():
    assert doctest.testmod(ld, raise_on_error=False).failed == 0
