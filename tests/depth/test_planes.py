"""Segment planes: the vectorised IRLS against a per-segment loop, recovery of slanted planes, filling, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vergence.depth import (
    MIN_INLIER_SHARE,
    PatchMatchParameters,
    SegmentPlanes,
    compute_disparity,
    fill_from_planes,
    fill_occlusions,
    fit_segment_planes,
    refine_disparity,
    segment_image,
)
from vergence.depth.planes import _HUBER_ITERATIONS, _MIN_SPREAD_PX, _TUKEY_ITERATIONS

# Fast and slow fits solve the same normal equations in another order of summation (float64).
FIT_RTOL, FIT_ATOL = 1e-7, 1e-7
# The brief's bar for a plane recovered from noisy pixels with gross outliers, pixels.
RECOVERY_PX = 0.05
# Filled pixels of a textureless slanted plane: the 1 px Middlebury bad-pixel threshold, halved.
FILL_PX = 0.5


def _slow_fit(d, labels, reliable, inlier_px=1.0, min_support=20):
    """Per-segment loop: the same IRLS (median start, Huber then Tukey weights) with numpy.linalg.lstsq."""
    n = int(labels.max()) + 1
    planes = np.full((n, 3), np.nan)
    share = np.zeros(n)
    support = np.zeros(n, np.int64)
    for s in range(n):
        ys, xs = np.nonzero((labels == s) & reliable)
        support[s] = xs.size
        if xs.size < min_support:
            continue
        v = d[ys, xs].astype(np.float64)
        u0, v0 = xs - xs.mean(), ys - ys.mean()
        cov = np.cov(np.stack([u0, v0]), bias=True)
        if np.linalg.eigvalsh(cov)[0] < _MIN_SPREAD_PX ** 2:
            continue
        a = np.column_stack([u0, v0, np.ones_like(u0)])
        p = np.array([0.0, 0.0, np.sort(v)[xs.size // 2]])
        for it in range(_HUBER_ITERATIONS + _TUKEY_ITERATIONS):
            r = np.abs(v - a @ p)
            if it < _HUBER_ITERATIONS:
                w = np.where(r <= inlier_px, 1.0, inlier_px / np.maximum(r, inlier_px))
            else:
                w = np.where(r < 3 * inlier_px, (1 - (r / (3 * inlier_px)) ** 2) ** 2, 0.0)
            sw = np.sqrt(w)
            p = np.linalg.lstsq(a * sw[:, None], v * sw, rcond=None)[0]
        share[s] = np.mean(np.abs(v - a @ p) <= inlier_px)
        planes[s] = [p[0], p[1], p[2] - p[0] * xs.mean() - p[1] * ys.mean()]
    return planes, support, share


def _noisy_planes(rng, h=60, w=80):
    """Four quadrant segments, each a slanted plane + 0.1 px noise, 20 % gross outliers, 30 % unknown."""
    labels = np.zeros((h, w), np.int64)
    labels[:, w // 2:] += 1
    labels[h // 2:] += 2
    truth = rng.uniform([-0.3, -0.3, 20.0], [0.3, 0.3, 40.0], size=(4, 3))
    ys, xs = np.mgrid[0:h, 0:w]
    exact = (truth[labels, 0] * xs + truth[labels, 1] * ys + truth[labels, 2])
    d = exact + rng.normal(0.0, 0.1, (h, w))
    outlier = rng.random((h, w)) < 0.2
    d[outlier] += rng.uniform(-15.0, 15.0, outlier.sum())
    d[rng.random((h, w)) < 0.3] = np.nan
    return d.astype(np.float32), labels, exact, truth


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_fit_matches_the_slow_loop_and_recovers_slanted_planes_through_outliers(seed):
    rng = np.random.default_rng(seed)
    d, labels, exact, _ = _noisy_planes(rng)
    fit = fit_segment_planes(d, labels)
    planes, support, share = _slow_fit(d, labels, np.isfinite(d))
    np.testing.assert_allclose(fit.planes, planes, rtol=FIT_RTOL, atol=FIT_ATOL)
    np.testing.assert_array_equal(fit.support, support)
    np.testing.assert_allclose(fit.inlier_share, share, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fit.disparity(labels), exact, rtol=0, atol=RECOVERY_PX)
    assert (fit.inlier_share > 0.75).all()  # 80 % inliers, 0.1 px noise: about all of them within 1 px


def test_fit_by_hand_support_share_and_segments_without_a_plane():
    labels = np.zeros((10, 30), np.int64)
    labels[:, 10:20] = 1
    labels[:, 20:] = 2
    ys, xs = np.mgrid[0:10, 0:30]
    d = (0.5 * xs - 0.25 * ys + 3.0).astype(np.float32)
    reliable = np.ones_like(labels, bool)
    reliable[:, 10:20] = False
    reliable[4, 10:20] = True  # segment 1: ten pixels on one row, no slant to measure
    d[0, :5] += 8.0  # segment 0: 5 of 100 pixels off the plane
    fit = fit_segment_planes(d, labels, reliable=reliable, min_support=5)
    assert isinstance(fit, SegmentPlanes)
    np.testing.assert_array_equal(fit.support, [100, 10, 100])
    np.testing.assert_allclose(fit.inlier_share, [0.95, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(fit.planes[[0, 2]], [[0.5, -0.25, 3.0]] * 2, atol=1e-6)
    assert np.isnan(fit.planes[1]).all() and np.isnan(fit.disparity(labels)[:, 10:20]).all()
    assert np.isnan(fit_segment_planes(d, labels, min_support=101).planes).all()  # too few pixels anywhere
    with pytest.raises(ValueError, match="read-only"):
        fit.planes[0, 0] = 1.0
    with pytest.raises(ValueError, match=r"labels must lie in \[0, 2\] \(one plane per segment\); got \[0, 3\]"):
        fit.disparity(labels + (labels == 2))
    with pytest.raises(ValueError, match="labels must be an \\(H, W\\) integer array"):
        fit.disparity(labels.astype(float))


def _hole_in_slanted_plane():
    """A uniform grey square (no texture) on a textured background, one slanted plane across both; the
    disparity is known on the background and on a 6 px rim inside the square, unknown within."""
    rng = np.random.default_rng(5)
    h, w = 80, 120
    guide = rng.random((h, w, 3)).astype(np.float32)
    guide[20:60, 30:90] = 0.5
    ys, xs = np.mgrid[0:h, 0:w]
    truth = (0.2 * xs + 0.1 * ys + 10.0).astype(np.float32)
    d = truth.copy()
    d[26:54, 36:84] = np.nan
    return d, guide, truth


def test_fill_from_planes_fills_a_textureless_slanted_hole_where_row_filling_fails():
    d, guide, truth = _hole_in_slanted_plane()
    hole = np.isnan(d)
    out = fill_from_planes(d, guide)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out[hole], truth[hole], rtol=0, atol=FILL_PX)
    np.testing.assert_array_equal(out[~hole], d[~hole])  # known pixels untouched
    assert (np.abs(fill_occlusions(d) - truth)[hole] > 1.0).mean() > 0.5  # the background fill misses the slant
    refined = refine_disparity(d, guide, planes=True, smoothing="none")
    np.testing.assert_allclose(refined.disparity[hole], truth[hole], rtol=0, atol=FILL_PX)
    assert not refined.matched[hole].any()  # filled, not matched
    kept = refine_disparity(d, guide, planes=True, keep_invalid=True).disparity
    assert np.isfinite(kept).all()  # plane pixels are estimates, kept with keep_invalid


def test_fill_from_planes_leaves_a_segment_whose_plane_explains_too_few_pixels():
    d, guide, _ = _hole_in_slanted_plane()
    guide[np.isfinite(d) & (guide[..., 0] != 0.5)] = 0.1  # two clean segments: the background and the square
    guide[:20], guide[60:], guide[:, :30], guide[:, 90:] = 0.1, 0.1, 0.1, 0.1
    rim = np.isfinite(d) & (guide[..., 0] == 0.5)
    noise = np.random.default_rng(1).uniform(-20.0, 20.0, d.shape).astype(np.float32)
    d2 = np.where(rim & (np.random.default_rng(2).random(d.shape) < 0.5), d + noise, d)
    labels = segment_image(guide, scale=200.0, min_size=100)
    share = fit_segment_planes(d2, labels).inlier_share[labels[40, 60]]  # the grey square's segment
    assert 0.4 < share < MIN_INLIER_SHARE
    assert np.isnan(fill_from_planes(d2, guide, scales=(200.0,))[np.isnan(d)]).all()
    assert np.isfinite(fill_from_planes(d2, guide, scales=(200.0,), min_inlier_share=0.4)[np.isnan(d)]).all()


def _flat_slanted_square():
    """A textured pair whose middle is a uniform square, all on the plane d = 0.05 x + 0.02 y + 8."""
    rng = np.random.default_rng(3)
    h, w = 120, 200
    left = cv2.GaussianBlur(rng.random((h, w + 40)).astype(np.float32), (3, 3), 0.7)[:, :w]
    left[30:90, 50:150] = 0.5
    a, b, c = 0.05, 0.02, 8.0  # the right pixel xr shows the left pixel (xr + b y + c) / (1 - a)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    right = cv2.remap(left, (xs + b * ys + c) / (1 - a), ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    inner = np.zeros((h, w), bool)
    inner[35:85, 55:145] = True
    return left, right, a * xs + b * ys + c, inner


def test_compute_disparity_with_planes_on_a_textureless_slanted_square():
    """End to end: SGBM leaves most of a flat square unmatched; the planes give its slanted disparity."""
    left, right, truth, inner = _flat_slanted_square()
    plain = compute_disparity(left, right, max_disparity=31, smoothing="none")
    planar = compute_disparity(left, right, max_disparity=31, smoothing="none", planes=True)
    assert plain.matched[inner].mean() < 0.5  # the flat square is mostly not matched
    bad_plain = np.abs(plain.disparity - truth) > 1.0
    bad_planar = np.abs(planar.disparity - truth) > 1.0
    assert bad_planar[inner].mean() < 0.1 < 0.5 < bad_plain[inner].mean()  # measured 4.2 % and 62 %
    assert bad_planar[inner & ~planar.matched].mean() < 0.01  # what is left: SGBM's wrong matches, kept
    np.testing.assert_array_equal(planar.matched, plain.matched)


def test_patchmatch_with_planes_fills_its_failed_pixels_from_the_segment_planes():
    left, right, truth, inner = _flat_slanted_square()
    prm = PatchMatchParameters(window=11, iterations=2)
    plain = compute_disparity(left, right, max_disparity=31, method="patchmatch", patchmatch=prm)
    planar = compute_disparity(left, right, max_disparity=31, method="patchmatch", patchmatch=prm, planes=True)
    np.testing.assert_array_equal(planar.matched, plain.matched)
    np.testing.assert_array_equal(planar.disparity[plain.matched], plain.disparity[plain.matched])
    changed = planar.disparity != plain.disparity
    assert changed.any() and not (changed & plain.matched).any()
    err = np.abs(planar.disparity - truth)[changed]
    assert (err > 1.0).mean() < (np.abs(plain.disparity - truth)[changed] > 1.0).mean()
    kept = compute_disparity(left, right, max_disparity=31, method="patchmatch", patchmatch=prm, planes=True,
                             keep_invalid=True).disparity
    np.testing.assert_array_equal(np.isfinite(kept), plain.matched | changed)  # planes kept, PMS's filling not


def test_segment_image_labels():
    img = np.zeros((20, 30, 3), np.float32)
    img[:, 15:] = 1.0
    labels = segment_image(img, scale=100.0, sigma=0.0, min_size=10)
    assert labels.shape == (20, 30) and labels.dtype == np.int64
    assert len(np.unique(labels[:, :15])) == 1 and len(np.unique(labels[:, 15:])) == 1
    assert labels[0, 0] != labels[0, 29]
    np.testing.assert_array_equal(np.unique(labels), np.arange(labels.max() + 1))


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"labels": np.zeros((4, 5), np.int64)}, ValueError, r"labels must have the shape of disparity \(5, 5\); got \(4, 5\)"),
        ({"labels": np.zeros((5, 5))}, TypeError, "labels must be an integer array; got dtype float64"),
        ({"labels": np.full((5, 5), -1)}, ValueError, "labels must be >= 0; got -1"),
        ({"reliable": np.ones((5, 5), np.uint8)}, TypeError, "reliable must be a boolean array; got dtype uint8"),
        ({"reliable": np.ones((5, 4), bool)}, ValueError, r"reliable must have the shape of disparity \(5, 5\)"),
        ({"min_support": 2}, ValueError, "min_support must be at least 3"),
        ({"inlier_px": 0.0}, ValueError, "inlier_px"),
        ({"disparity": np.zeros(5)}, ValueError, r"disparity must have shape \(H, W\); got \(5,\)"),
    ],
)
def test_fit_segment_planes_bad_input(kwargs, error, message):
    args = {"disparity": np.zeros((5, 5), np.float32), "labels": np.zeros((5, 5), np.int64), **kwargs}
    with pytest.raises(error, match=message):
        fit_segment_planes(args.pop("disparity"), args.pop("labels"), **args)


def test_fit_refuses_reliable_unknown_pixels():
    d = np.zeros((5, 5), np.float32)
    d[0, 0] = np.nan
    with pytest.raises(ValueError, match="disparity must be finite wherever reliable is set"):
        fit_segment_planes(d, np.zeros((5, 5), np.int64), reliable=np.ones((5, 5), bool))


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"guide": np.zeros((4, 5))}, ValueError, r"guide must have the \(H, W\) of disparity \(5, 5\); got \(4, 5\)"),
        ({"disparity": np.full((5, 5), np.nan)}, ValueError, "disparity has no finite value to fit planes to"),
        ({"scales": ()}, ValueError, "scales must be a non-empty tuple of positive numbers; got ()"),
        ({"scales": (100.0, -1.0)}, ValueError, "scales"),
        ({"min_inlier_share": 0.0}, ValueError, r"min_inlier_share must be a number in \(0, 1\]; got 0.0"),
        ({"min_inlier_share": 1.5}, ValueError, r"min_inlier_share must be a number in \(0, 1\]; got 1.5"),
        ({"inlier_px": 0.0}, ValueError, "inlier_px"),  # refused even with nothing to fill
        ({"min_support": 2}, ValueError, r"min_support must be at least 3 \(a plane has three parameters\); got 2"),
    ],
)
def test_fill_from_planes_bad_input(kwargs, error, message):
    args = {"disparity": np.zeros((5, 5), np.float32), "guide": np.zeros((5, 5)), **kwargs}
    with pytest.raises(error, match=message):
        fill_from_planes(args.pop("disparity"), args.pop("guide"), **args)


def test_planes_option_bad_input():
    rng = np.random.default_rng(0)
    right = rng.random((40, 80)).astype(np.float32)
    left = np.roll(right, 5, axis=1)
    with pytest.raises(TypeError, match="planes must be a bool; got str"):
        compute_disparity(left, right, max_disparity=15, planes="yes")
    with pytest.raises(TypeError, match="planes must be a bool; got int"):
        refine_disparity(np.zeros((4, 4), np.float32), np.zeros((4, 4)), planes=1)
    with pytest.raises(ValueError, match="sigma must be a finite number >= 0"):
        segment_image(np.zeros((4, 4)), sigma=-1.0)
    with pytest.raises(ValueError, match="scale"):
        segment_image(np.zeros((4, 4)), scale=0.0)


def test_a_large_guide_is_segmented_on_a_smaller_copy_with_the_same_fill(monkeypatch):
    from vergence.depth import planes

    d, guide, truth = _hole_in_slanted_plane()
    hole = np.isnan(d)
    full = fill_from_planes(d, guide)
    calls = []
    original = planes._pixel_graph

    def spy(image, sigma):
        calls.append(np.shape(image)[:2])
        return original(image, sigma)

    monkeypatch.setattr(planes, "_pixel_graph", spy)
    monkeypatch.setattr(planes, "_SEGMENT_MAX_PIXELS", d.size // 4)  # the guide is "large": halved each way
    small = fill_from_planes(d, guide)
    assert calls and all(h * w <= d.size // 4 + d.shape[0] + d.shape[1] for h, w in calls)
    np.testing.assert_allclose(small[hole], truth[hole], rtol=0, atol=FILL_PX)
    np.testing.assert_array_equal(small[~hole], d[~hole])
    np.testing.assert_allclose(small[hole], full[hole], rtol=0, atol=FILL_PX)
    assert len(calls) == 1  # one graph for every scale
    labels = next(planes._segments(guide, (200.0,)))
    assert labels.shape == d.shape and set(np.unique(labels)) == set(range(labels.max() + 1))
