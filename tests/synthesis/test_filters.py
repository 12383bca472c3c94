"""Depth smoothing, foreground dilation, contour masks and median refinement (S1 §IV.B)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import ndimage

from vergence.synthesis import (
    contour_mask,
    dilate_foreground,
    forward_warp,
    median_refine,
    smooth_depth,
)
from vergence.synthesis import _kernels


def test_smooth_depth_keeps_constants_and_unknowns():
    d = np.full((6, 7), 3.0)
    d[2, 3] = np.nan
    out = smooth_depth(d, sigma=1.5)
    assert np.isnan(out[2, 3])
    assert_allclose(out[~np.isnan(d)], 3.0, rtol=1e-6)


def test_smooth_depth_matches_gaussian_filter_without_unknowns():
    d = np.random.default_rng(0).random((20, 30)) * 10
    assert_allclose(smooth_depth(d, sigma=2.0), ndimage.gaussian_filter(d, 2.0, mode="nearest"), rtol=1e-5)


def test_dilate_foreground_grows_only_across_jumps():
    d = np.array([[0.0, 0, 5, 5, 0, 0], [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]])
    out = dilate_foreground(d[:1], radius=1)
    assert out.tolist() == [[0.0, 5.0, 5.0, 5.0, 5.0, 0.0]]
    # A slope of 0.5 px per pixel is below the 1-px threshold: unchanged.
    assert_array_equal(dilate_foreground(d[1:], radius=1), d[1:])


def test_dilate_foreground_matches_a_maximum_filter_reference():
    rng = np.random.default_rng(1)
    d = rng.choice([1.0, 2.0, 8.0], size=(12, 15)).astype(np.float32)
    d[rng.random((12, 15)) < 0.1] = np.nan
    for r in (1, 2):
        m = ndimage.maximum_filter(np.where(np.isnan(d), -np.inf, d), size=2 * r + 1, mode="nearest")
        expected = np.where(~np.isnan(d) & (m - d > 1.0), m, d)
        assert_array_equal(dilate_foreground(d, radius=r), expected)


def test_contour_mask_sides():
    d = np.array([[0.0, 0, 0, 5, 5, 5]])
    assert contour_mask(d, side="far").astype(int).tolist() == [[0, 0, 1, 0, 0, 0]]
    assert contour_mask(d, side="near").astype(int).tolist() == [[0, 0, 0, 1, 0, 0]]
    assert contour_mask(d, width=2).astype(int).tolist() == [[0, 1, 1, 1, 1, 0]]


def slow_median3(z: np.ndarray, holes: np.ndarray, tol: float, min_count: int):
    """Reference of the median kernel: lower median of the known 3x3 neighbours."""
    h, w = z.shape
    med = np.full((h, w), np.nan, np.float32)
    changed = np.zeros((h, w), bool)
    for y in range(h):
        for x in range(w):
            win = z[max(y - 1, 0) : y + 2, max(x - 1, 0) : x + 2].ravel()
            win = np.sort(win[~np.isnan(win)])
            if win.size < min_count:
                continue
            med[y, x] = win[(win.size - 1) // 2]
            changed[y, x] = holes[y, x] or abs(med[y, x] - z[y, x]) > tol
    return med, changed


def test_median_kernel_matches_slow_reference():
    rng = np.random.default_rng(2)
    z = rng.choice([1.0, 1.25, 4.0, 9.0], size=(9, 11)).astype(np.float32)
    holes = rng.random((9, 11)) < 0.2
    z[holes] = np.nan
    med = np.empty_like(z)
    changed = np.empty(z.shape, bool)
    _kernels.median3_changes(z, holes, 0.5, 5, med, changed)
    ref_med, ref_changed = slow_median3(z, holes, 0.5, 5)
    assert_array_equal(changed, ref_changed)
    # Where nothing changed the kernel may keep the pixel's own value instead of sorting.
    both = changed | np.isnan(ref_med)
    assert_array_equal(med[both], ref_med[both])


def test_median_refine_closes_a_crack_with_the_right_colour():
    # A constant shift of 2 px with one unknown source disparity leaves a one-pixel crack; the
    # median (2 px) and inverse warping put the right source pixel in it.
    img = np.random.default_rng(3).random((5, 12, 3), dtype=np.float32)
    d = np.full((5, 12), 2.0)
    d[2, 6] = np.nan
    warped = forward_warp(img, d)
    assert warped.holes[2, 4]
    refined = median_refine(warped, img, np.full((5, 12), 2.0), scale=1.0)
    assert not refined.holes[2, 4]
    assert_allclose(refined.image[2, 4], img[2, 6])
    assert refined.nearness[2, 4] == 2.0


def test_median_refine_leaves_true_disocclusions():
    # Near on the left: the 10-px disocclusion is not a crack; the background reference disparity
    # does not agree with the median there, so it stays a hole.
    n = 60
    d = np.where(np.arange(n) < 30, 15.0, 5.0)[None, :].repeat(5, axis=0)
    img = np.random.default_rng(4).random((5, n), dtype=np.float32)
    warped = forward_warp(img, d)
    refined = median_refine(warped, img, d, scale=1.0)
    assert refined.holes[2, 15:25].all()


@pytest.mark.parametrize(
    ("fn", "kwargs", "error", "match"),
    [
        (smooth_depth, {"depth": np.ones((3, 3)), "sigma": 0.0}, ValueError, r"sigma must lie in \(0, 1024\] pixels \(MAX_SMOOTH_SIGMA\); got 0"),
        # Issue 9 kin: a huge sigma overflowed SciPy's kernel size (OverflowError).
        (smooth_depth, {"depth": np.ones((3, 3)), "sigma": 1e308}, ValueError, r"sigma must lie in \(0, 1024\] pixels"),
        (contour_mask, {"disparity": np.ones((3, 3)), "width": 10**9}, ValueError, r"width must lie in \[0, 64\] pixels \(MAX_FILTER_RADIUS\); got 1000000000"),
        (smooth_depth, {"depth": np.ones(3), "sigma": 1.0}, ValueError, r"depth must have shape \(H, W\); got \(3,\)"),
        (dilate_foreground, {"disparity": np.ones((3, 3)), "radius": -1}, ValueError, r"radius must lie in \[0, 64\] pixels \(MAX_FILTER_RADIUS\); got -1"),
        (dilate_foreground, {"disparity": np.ones((3, 3)), "radius": 1.5}, TypeError, "radius must be an integer; got float"),
        (dilate_foreground, {"disparity": np.full((3, 3), np.inf)}, ValueError, "disparity must not contain inf"),
        (contour_mask, {"disparity": np.ones((3, 3)), "side": "left"}, ValueError, "side must be one of both, near, far; got 'left'"),
        (contour_mask, {"disparity": np.full((3, 3), np.nan)}, ValueError, "at least one known value"),
    ],
)
def test_filters_bad_input(fn, kwargs, error, match):
    with pytest.raises(error, match=match):
        fn(**kwargs)


def test_median_refine_bad_input():
    img = np.zeros((4, 5), np.float32)
    warped = forward_warp(img, np.ones((4, 5)))
    with pytest.raises(TypeError, match="warped must be a WarpedView; got tuple"):
        median_refine((1, 2), img, np.ones((4, 5)), scale=1.0)
    with pytest.raises(ValueError, match="source_image must have the channels of the warped image"):
        median_refine(warped, np.zeros((4, 5, 3)), np.ones((4, 5)), scale=1.0)
    with pytest.raises(ValueError, match="tolerance must be > 0"):
        median_refine(warped, img, np.ones((4, 5)), scale=1.0, tolerance=0.0)


def test_contour_mask_refuses_a_negative_threshold():
    with pytest.raises(ValueError, match="threshold"):
        contour_mask(np.zeros((3, 3)), threshold=-1.0)
