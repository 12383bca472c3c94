"""Rivalry (S3 §3.2): push-pull filling of missing matches and the 7 x 7 SSD of L*, against references."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import vergence.specular.rivalry_map as riv_module
from vergence.specular import (
    RIVALRY_WINDOW,
    LayerDisparity,
    PerceivedLightness,
    Rivalry,
    fill_matches,
    layer_disparity,
    perceived_lightness,
    rivalry,
)
from vergence.viewing import Display

# float64 means of 49 squares of L* differences (<= 100^2) from float32 inputs: 1e-9 relative is ample.
RTOL = 1e-9


def lightness_pair(left, right) -> PerceivedLightness:
    return PerceivedLightness(left=np.asarray(left, np.float32), right=np.asarray(right, np.float32),
                              exposure=1.0, pixels_per_degree=30.0)  # fmt: skip


def matches_of(disparity) -> LayerDisparity:
    disparity = np.asarray(disparity, np.float32)
    dist = np.where(np.isnan(disparity[..., 0]), np.nan, 0.0).astype(np.float32)
    return LayerDisparity(disparity_px=disparity, distance=dist, epsilon=1.0, window=(81, 9))


def reference_rivalry(left, right, disparity, half=3):  # S3: 7 x 7
    """Pixel by pixel: the mean squared difference of the 7 x 7 patches, the border pixel repeated outside."""
    n_layers, h, w = left.shape
    out = np.full((n_layers, h, w), np.nan)
    point = np.full((n_layers, h, w), np.nan)
    u = np.arange(-half, half + 1)
    for n in range(n_layers):
        for y in range(h):
            for x in range(w):
                dx, dy = disparity[n, y, x]
                if np.isnan(dx):
                    continue
                my, mx = y - int(dy), x - int(dx)
                a = left[n][np.ix_(np.clip(y + u, 0, h - 1), np.clip(x + u, 0, w - 1))].astype(np.float64)
                b = right[n][np.ix_(np.clip(my + u, 0, h - 1), np.clip(mx + u, 0, w - 1))].astype(np.float64)
                out[n, y, x] = ((a - b) ** 2).mean()
                centre = right[n, np.clip(my, 0, h - 1), np.clip(mx, 0, w - 1)]
                point[n, y, x] = abs(float(left[n, y, x]) - float(centre))
    return out, point


def shifted_pair(rng, h, w, shift):
    """A textured right image and the left eye's view of it, shifted by ``shift`` pixels to the right."""
    right = rng.uniform(20, 80, (1, h, w))
    left = np.roll(right, shift, axis=2)
    return left, right


# --- filling ----------------------------------------------------------------------------------------


def test_fill_keeps_matches_and_fills_holes_from_neighbours():
    d = np.full((2, 6, 9, 2), np.nan)
    d[0, :, :4] = (3.0, 0.0)
    d[0, :, 6:] = (7.0, 1.0)
    out = fill_matches(d)
    assert_array_equal(out[0, :, :4], d[0, :, :4])
    assert_array_equal(out[0, :, 6:], d[0, :, 6:])
    assert np.isfinite(out[0]).all()
    assert ((out[0, ..., 0] >= 3) & (out[0, ..., 0] <= 7)).all()  # within the range of the matches
    assert_array_equal(out[0], np.round(out[0]))  # whole pixels
    assert np.isnan(out[1]).all()  # a layer with no match at all stays empty


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 17), st.integers(1, 17), st.floats(-20, 20))
def test_fill_of_a_constant_field_is_the_constant(seed, h, w, value):
    rng = np.random.default_rng(seed)
    d = np.zeros((1, h, w, 2))
    d[..., 0] = np.round(value)
    d[..., 1] = -2.0
    holes = rng.random((1, h, w)) < 0.7
    holes.flat[rng.integers(h * w)] = False  # at least one match
    d[holes] = np.nan
    out = fill_matches(d)
    assert_array_equal(out[..., 0], np.round(value))
    assert_array_equal(out[..., 1], -2.0)


def test_fill_prefers_the_nearest_matches():
    d = np.full((1, 1, 16, 2), np.nan)
    d[0, 0, 0] = (1.0, 0.0)
    d[0, 0, 15] = (9.0, 0.0)
    out = fill_matches(d)[0, 0, :, 0]
    assert_array_equal(out[:8], 1.0)  # the left half's block holds only the left match
    assert_array_equal(out[8:], 9.0)


# --- rivalry ----------------------------------------------------------------------------------------


def test_rivalry_equals_reference():
    rng = np.random.default_rng(7)
    shape = (2, 8, 10)
    left, right = rng.uniform(0, 100, shape), rng.uniform(0, 100, shape)
    d = np.zeros((*shape, 2))
    d[..., 0] = rng.integers(-4, 5, shape)
    d[..., 1] = rng.integers(-2, 3, shape)
    d[rng.random(shape) < 0.3] = np.nan
    out = rivalry(lightness_pair(left, right), matches_of(d))
    assert isinstance(out, Rivalry)
    filled = fill_matches(d)
    assert_array_equal(out.disparity_px, filled)
    assert_array_equal(out.filled, np.isnan(d[..., 0]))
    ref, point = reference_rivalry(np.float32(left), np.float32(right), filled)
    assert_allclose(out.rivalry, ref, rtol=1e-6)  # float32 output
    assert_allclose(out.point_difference, point, rtol=1e-6, atol=1e-5)


def test_constant_shift_has_no_rivalry_where_matched():
    rng = np.random.default_rng(8)
    left, right = shifted_pair(rng, 20, 30, 3)
    d = np.zeros((1, 20, 30, 2))
    d[..., 0] = 3.0  # left x matches right x - 3
    d[:, :, :3] = np.nan  # the left border column has no match (occluded in the right eye)
    out = rivalry(lightness_pair(left, right), matches_of(d))
    assert_allclose(out.rivalry[0, 3:-3, 6:-3], 0.0, atol=1e-9)  # patches fully inside the matched region
    assert_array_equal(out.point_difference[0, :, 3:], 0.0)
    assert np.isfinite(out.rivalry).all()  # the holes were filled, then compared
    wrong = rivalry(lightness_pair(left, right), matches_of(np.zeros((1, 20, 30, 2))))
    assert (wrong.rivalry[0, 3:-3, 6:-3] > 100).all()  # the same images read without the shift: rivalry


def test_swapped_patch_gives_high_rivalry_there_only():
    rng = np.random.default_rng(9)
    left, right = shifted_pair(rng, 30, 30, 0)
    right = right.copy()
    left = left.copy()
    left[0, 10:16, 10:16] = rng.uniform(20, 80, (6, 6))  # one eye sees another pattern there
    out = rivalry(lightness_pair(left, right), matches_of(np.zeros((1, 30, 30, 2))))
    assert (out.rivalry[0, 11:15, 11:15] > 200).all()  # uniform(20, 80) differences: mean square ~600
    assert_array_equal(out.rivalry[0, 22:, 22:], 0.0)


def test_rivalry_bad_input():
    pair = lightness_pair(np.zeros((1, 4, 5)), np.zeros((1, 4, 5)))
    with pytest.raises(TypeError, match="PerceivedLightness"):
        rivalry(np.zeros((1, 4, 5)), matches_of(np.zeros((1, 4, 5, 2))))
    with pytest.raises(TypeError, match="LayerDisparity"):
        rivalry(pair, np.zeros((1, 4, 5, 2)))
    with pytest.raises(ValueError, match="layers"):
        rivalry(pair, matches_of(np.zeros((1, 4, 6, 2))))
    with pytest.raises(ValueError, match=r"\(N, H, W, 2\)"):
        fill_matches(np.zeros((4, 5, 2)))
    with pytest.raises(ValueError, match="inf"):
        fill_matches(np.full((1, 4, 5, 2), np.inf))
    assert RIVALRY_WINDOW == 7  # S3 §3.2


def test_rivalry_on_glasses():
    render = pytest.importorskip("vergence.render")
    scene = render.open_scene("glasses", width=40, height=30)
    left, right = render.render_stereo(scene, baseline=0.065, convergence=scene.stereo.convergence, max_depth=2,
                                       samples=1)  # fmt: skip
    pair = perceived_lightness(left.radiance, right.radiance, left.position, right.position,
                               Display.preset("samsung-2233rz"))  # fmt: skip
    m = layer_disparity(left.position, right.position)
    out = rivalry(pair, m)
    ref, _ = reference_rivalry(pair.left[:2], pair.right[:2], out.disparity_px[:2])
    assert_allclose(out.rivalry[:2], ref, rtol=1e-6, atol=1e-6)
    # The diffuse first hit is the same surface seen from two points: the matched centres mostly agree.
    # (Whole 7 x 7 patches often do not at 40 x 30 px: one sample per pixel of textured walls, and
    # matches up to epsilon = 10 cm apart, read different texels in the two eyes.)
    assert np.median(out.point_difference[0][m.matched[0]]) < 1.0  # ΔL*: below one JND
    assert np.isfinite(out.rivalry[m.matched.any(axis=(1, 2))]).all()


def test_docstring_examples():
    assert doctest.testmod(riv_module, optionflags=doctest.ELLIPSIS).failed == 0
