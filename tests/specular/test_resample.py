"""Low-resolution solve and edge-aware up-sampling (S3 §3.4): the Numba kernels against slow loops,
identities (constants stay, guide edges hold, weight 0 does not count) and the errors."""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import vergence.specular.resample as resample_module
from vergence.specular import joint_bilateral_upsample, weighted_block_mean

# float64 sums of at most a few hundred float32 terms, rounded to float32 once: a few float32 ulps.
RTOL = 1e-6
ATOL = 1e-6


def block_mean_reference(values, weights, f):
    """Pixel by pixel: each block's usable pixels (weight > 0, no NaN channel), their weighted mean
    and the sum of their weights over the block's pixel count."""
    v = np.asarray(values, np.float64)
    w = np.asarray(weights, np.float64)
    channels = v.ndim > w.ndim
    lead = w.shape[:-2]
    big_h, big_w = w.shape[-2:]
    ho, wo = math.ceil(big_h / f), math.ceil(big_w / f)
    nc = v.shape[-1] if channels else 1
    mean = np.full((*lead, ho, wo, nc), np.nan)
    wmean = np.zeros((*lead, ho, wo))
    for idx in np.ndindex(*lead):
        for by in range(ho):
            for bx in range(wo):
                num, den, count = np.zeros(nc), 0.0, 0
                for r in range(by * f, min(by * f + f, big_h)):
                    for c in range(bx * f, min(bx * f + f, big_w)):
                        count += 1
                        px = v[idx + (r, c)] if channels else np.array([v[idx + (r, c)]])
                        wt = w[idx + (r, c)]
                        if np.isnan(px).any() or wt == 0:
                            continue
                        num += wt * px
                        den += wt
                if den > 0:
                    mean[idx + (by, bx)] = num / den
                wmean[idx + (by, bx)] = den / count
    return (mean if channels else mean[..., 0]), wmean


def jbu_reference(values, weights, guide_low, guide_high, sigma_space, sigma_range, radius, fill):
    """Kopf et al. 2007 Eq. (2) with importance weights, written out tap by tap (no underflow guard:
    the test data keep the exponents small)."""
    n, h, w = values.shape
    big_h, big_w = guide_high.shape[1:]
    out = np.empty((n, big_h, big_w))
    for i in range(n):
        for r in range(big_h):
            yl = (r + 0.5) * h / big_h - 0.5
            ny = min(max(int(np.floor(yl + 0.5)), 0), h - 1)
            for c in range(big_w):
                xl = (c + 0.5) * w / big_w - 0.5
                nx = min(max(int(np.floor(xl + 0.5)), 0), w - 1)
                gp = guide_high[i, r, c]
                num = den = 0.0
                for qy in range(max(0, ny - radius), min(h, ny + radius + 1)):
                    for qx in range(max(0, nx - radius), min(w, nx + radius + 1)):
                        vq, wq, gq = values[i, qy, qx], weights[i, qy, qx], guide_low[i, qy, qx]
                        if np.isnan(vq) or wq == 0:
                            continue
                        space = math.exp(-((yl - qy) ** 2 + (xl - qx) ** 2) / (2 * sigma_space**2))
                        rng = 1.0 if np.isnan(gp) or np.isnan(gq) else math.exp(-((gp - gq) ** 2) / (2 * sigma_range**2))
                        num += vq * wq * space * rng
                        den += wq * space * rng
                out[i, r, c] = num / den if den > 0 else fill
    return out


def _random(rng, shape, nan_fraction=0.15, zero_fraction=0.15, *, channels=False):
    """float32 values (NaN at random) and weights (0 at random) of ``shape`` (its last axis channels)."""
    values = rng.uniform(-2, 3, shape).astype(np.float32)
    values[rng.random(shape) < nan_fraction] = np.nan
    weights = rng.uniform(0, 1, shape[:-1] if channels else shape).astype(np.float32)
    weights[rng.random(weights.shape) < zero_fraction] = 0
    return values, weights


def test_docstring_examples():
    assert doctest.testmod(resample_module, extraglobs={"np": np}).failed == 0


# --- weighted_block_mean -------------------------------------------------------------------------


@pytest.mark.parametrize("f", [1, 2, 3, 4, 7])
@pytest.mark.parametrize("channels", [False, True])
def test_block_mean_matches_reference(f, channels):
    rng = np.random.default_rng(f + 10 * channels)
    shape = (2, 3, 11, 9, 2) if channels else (2, 3, 11, 9)
    values = rng.uniform(-2, 3, shape).astype(np.float32)
    values[rng.random(shape) < 0.2] = np.nan  # NaN in one channel only, often
    weights = rng.uniform(0, 1, shape[:4]).astype(np.float32)
    weights[rng.random(weights.shape) < 0.2] = 0
    mean, wmean = weighted_block_mean(values, weights, f)
    ref_mean, ref_wmean = block_mean_reference(values, weights, f)
    assert mean.dtype == np.float32 and wmean.dtype == np.float32
    assert mean.shape == ref_mean.shape and wmean.shape == ref_wmean.shape
    assert_allclose(mean, ref_mean, rtol=RTOL, atol=ATOL)
    assert_allclose(wmean, ref_wmean, rtol=RTOL, atol=ATOL)
    assert_array_equal(np.isnan(mean), np.isnan(ref_mean))


def test_block_mean_partial_blocks_by_hand():
    v = np.arange(15, dtype=np.float32).reshape(3, 5)
    w = np.ones((3, 5))
    mean, wmean = weighted_block_mean(v, w, 2)
    # blocks: rows {0,1} x cols {0,1}, {2,3}, {4}; row {2} x the same
    assert_array_equal(mean, [[3.0, 5.0, 6.5], [10.5, 12.5, 14.0]])
    assert_array_equal(wmean, np.ones((2, 3)))


def test_block_mean_nan_pixel_counts_with_weight_zero_in_the_weight_mean():
    v = np.array([[[1.0, np.nan], [2.0, 4.0]], [[1.0, 1.0], [1.0, 1.0]]])  # (H, W, C) = (2, 2, 2)
    w = np.ones((2, 2))
    mean, wmean = weighted_block_mean(v, w, 2)
    assert_allclose(mean[0, 0], [(2 + 1 + 1) / 3, (4 + 1 + 1) / 3], rtol=RTOL)  # pixel (0, 0) drops out
    assert wmean[0, 0] == pytest.approx(3 / 4)


def test_block_mean_all_unusable_block_is_nan():
    v = np.array([[np.nan, 1.0], [2.0, 3.0]])
    w = np.array([[1.0, 0.0], [0.0, 0.0]])
    mean, wmean = weighted_block_mean(v, w, 2)
    assert np.isnan(mean[0, 0]) and wmean[0, 0] == 0


def test_block_mean_factor_one_is_the_values_with_nan_at_weight_zero():
    rng = np.random.default_rng(3)
    values, weights = _random(rng, (3, 6, 5))
    weights = weights.astype(np.float64) * np.pi  # w v / w would not always round back to v
    mean, wmean = weighted_block_mean(values, weights, 1)
    expected = np.where(weights > 0, values, np.nan)
    assert_array_equal(mean, expected)
    assert_array_equal(wmean, np.where(np.isnan(values), 0, weights).astype(np.float32))


def test_block_mean_constant_stays_constant_and_weights_scale_out():
    rng = np.random.default_rng(4)
    w = rng.uniform(0.1, 1, (4, 10, 10))
    mean, _ = weighted_block_mean(np.full((4, 10, 10), 0.375), w, 3)
    assert_array_equal(mean, 0.375)
    values = rng.uniform(0, 1, (4, 10, 10))
    a, wa = weighted_block_mean(values, w, 3)
    b, wb = weighted_block_mean(values, 8 * w, 3)  # a power of two: exact
    assert_allclose(a, b, rtol=RTOL)
    assert_allclose(wb, 8 * wa, rtol=RTOL)


def test_block_mean_zero_weight_pixel_does_not_influence():
    rng = np.random.default_rng(5)
    values, weights = _random(rng, (5, 8), nan_fraction=0, zero_fraction=0)
    weights[2, 3] = 0
    a, _ = weighted_block_mean(values, weights, 4)
    values[2, 3] = 1e30
    b, _ = weighted_block_mean(values, weights, 4)
    assert_array_equal(a, b)


def test_block_mean_reads_float32_and_strided_input():
    rng = np.random.default_rng(6)
    values, weights = _random(rng, (2, 3, 12, 10, 2), channels=True)
    strided = np.asfortranarray(values)  # reshape has to copy: still float32, same answer
    a = weighted_block_mean(values, weights, 4)
    b = weighted_block_mean(strided, weights.astype(np.float64), 4)
    assert_allclose(a[0], b[0], rtol=RTOL, atol=ATOL)
    assert_allclose(a[1], b[1], rtol=RTOL, atol=ATOL)


@settings(max_examples=40, deadline=None)
@given(
    h=st.integers(1, 9),
    w=st.integers(1, 9),
    f=st.integers(1, 5),
    seed=st.integers(0, 2**32 - 1),
)
def test_block_mean_property_matches_reference(h, w, f, seed):
    rng = np.random.default_rng(seed)
    values, weights = _random(rng, (2, h, w, 3), channels=True)
    mean, wmean = weighted_block_mean(values, weights, f)
    ref_mean, ref_wmean = block_mean_reference(values, weights, f)
    assert_allclose(mean, ref_mean, rtol=RTOL, atol=ATOL)
    assert_allclose(wmean, ref_wmean, rtol=RTOL, atol=ATOL)
    # a block's mean is NaN (in every channel) exactly where its usable weight is 0
    assert_array_equal(np.isnan(mean), np.broadcast_to((wmean == 0)[..., None], mean.shape))


@pytest.mark.parametrize(
    ("values", "weights", "factor", "error", "match"),
    [
        (np.ones((4, 4)), np.ones((4, 4)), 0, ValueError, "factor must be >= 1"),
        (np.ones((4, 4)), np.ones((4, 4)), 2.0, TypeError, "factor must be an integer"),
        (np.ones((4, 4)), np.ones((4,)), 2, ValueError, r"weights must have shape \(\.\.\., H, W\)"),
        (np.ones((4, 5)), np.ones((4, 4)), 2, ValueError, "values must have shape"),
        (np.ones((2, 4, 4, 2, 1)), np.ones((2, 4, 4)), 2, ValueError, "values must have shape"),
        (np.ones((0, 4)), np.ones((0, 4)), 2, ValueError, "must not be empty"),
        (np.full((4, 4), np.inf), np.ones((4, 4)), 2, ValueError, "values must not contain inf"),
        (np.ones((4, 4)), -np.ones((4, 4)), 2, ValueError, "weights must be finite and >= 0"),
        (np.ones((4, 4)), np.full((4, 4), np.nan), 2, ValueError, "weights must be finite and >= 0"),
        (np.ones((4, 4)), np.full((4, 4), np.inf), 2, ValueError, "weights must be finite and >= 0"),
        (np.ones((4, 4), bool), np.ones((4, 4)), 2, TypeError, "values must hold real numbers"),
        (np.ones((4, 4)), np.ones((4, 4), complex), 2, TypeError, "weights must hold real numbers"),
    ],
)
def test_block_mean_errors(values, weights, factor, error, match):
    with pytest.raises(error, match=match):
        weighted_block_mean(values, weights, factor)


def test_block_mean_one_bad_weight_anywhere_is_found():
    w = np.ones((3, 9, 9), np.float32)
    w[2, 8, 8] = -1e-3  # in the last, partial block of the last image
    with pytest.raises(ValueError, match="weights must be finite"):
        weighted_block_mean(np.ones((3, 9, 9, 2), np.float32), w, 4)


# --- joint_bilateral_upsample --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("low", "high", "radius", "sigmas"),
    [
        ((5, 4), (5, 4), 1, (1.0, 0.5)),  # equal size: the joint bilateral filter
        ((4, 5), (8, 10), 2, (1.0, 0.5)),  # factor 2
        ((5, 3), (13, 7), 2, (0.8, 0.3)),  # non-integer factors 2.6, 2.33
        ((3, 4), (3, 11), 0, (1.5, 1.0)),  # radius 0: nearest pixel only
        ((6, 6), (17, 23), 3, (2.0, 2.0)),
    ],
)
def test_jbu_matches_reference(low, high, radius, sigmas):
    rng = np.random.default_rng(sum(high) + radius)
    n = 2
    values, weights = _random(rng, (n, *low), nan_fraction=0.15, zero_fraction=0.2)
    guide_low = rng.uniform(0, 1, (n, *low))
    guide_low[rng.random(guide_low.shape) < 0.1] = np.nan
    guide_high = rng.uniform(0, 1, (n, *high))
    guide_high[rng.random(guide_high.shape) < 0.1] = np.nan
    kw = dict(sigma_space=sigmas[0], sigma_range=sigmas[1], radius=radius, fill=0.75)
    out = joint_bilateral_upsample(values, weights, guide_low, guide_high, **kw)
    ref = jbu_reference(values.astype(np.float64), weights, guide_low, guide_high, *sigmas, radius, 0.75)
    assert out.dtype == np.float32 and out.shape == (n, *high)
    assert_allclose(out, ref, rtol=RTOL, atol=ATOL)


@settings(max_examples=30, deadline=None)
@given(
    h=st.integers(1, 5),
    w=st.integers(1, 5),
    up_h=st.integers(0, 7),
    up_w=st.integers(0, 7),
    radius=st.integers(0, 3),
    sigma_space=st.floats(0.3, 3.0),
    sigma_range=st.floats(0.2, 3.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_jbu_property_matches_reference_and_stays_in_range(h, w, up_h, up_w, radius, sigma_space, sigma_range, seed):
    rng = np.random.default_rng(seed)
    values, weights = _random(rng, (1, h, w), nan_fraction=0.2, zero_fraction=0.2)
    guide_low = rng.uniform(0, 1, (1, h, w))
    guide_high = rng.uniform(0, 1, (1, h + up_h, w + up_w))
    out = joint_bilateral_upsample(values, weights, guide_low, guide_high, sigma_space=sigma_space,
                                   sigma_range=sigma_range, radius=radius, fill=-5.0)  # fmt: skip
    ref = jbu_reference(values.astype(np.float64), weights, guide_low, guide_high, sigma_space, sigma_range, radius, -5.0)
    assert_allclose(out, ref, rtol=RTOL, atol=ATOL)
    usable = values[~np.isnan(values) & (weights > 0)]
    filled = out == -5.0
    if usable.size:  # a weighted mean stays within the usable values
        assert (out[~filled] >= usable.min() - ATOL).all() and (out[~filled] <= usable.max() + ATOL).all()


def test_jbu_constant_values_stay_constant():
    rng = np.random.default_rng(7)
    weights = rng.uniform(0.1, 1, (3, 6, 7))
    out = joint_bilateral_upsample(np.full((3, 6, 7), 0.625), weights, rng.uniform(0, 50, (3, 6, 7)),
                                   rng.uniform(0, 50, (3, 20, 19)), sigma_range=4.0)  # fmt: skip
    assert_allclose(out, 0.625, rtol=RTOL)


def test_jbu_guide_edge_is_preserved():
    # left half of the guide at 0, right half at 10; values 0.2 and 0.9 on the two sides
    low = np.zeros((1, 8, 8))
    low[..., 4:] = 10.0
    values = np.where(low > 5, 0.9, 0.2)
    high = np.zeros((1, 32, 32))
    high[..., 16:] = 10.0
    sharp = joint_bilateral_upsample(values, np.ones_like(values), low, high, sigma_space=2.0, sigma_range=0.5, radius=3)
    assert_allclose(sharp[..., :16], 0.2, atol=1e-12 + 1e-6)  # exp(-200) of mixing: nothing in float32
    assert_allclose(sharp[..., 16:], 0.9, atol=1e-6)
    # a large sigma_range blurs across the edge: the test above would fail without the range factor
    blurred = joint_bilateral_upsample(values, np.ones_like(values), low, high, sigma_space=2.0, sigma_range=1e3, radius=3)
    assert blurred[0, 0, 15] > 0.3 and blurred[0, 0, 16] < 0.8


def test_jbu_weight_zero_and_nan_pixels_do_not_influence():
    rng = np.random.default_rng(8)
    values = rng.uniform(0, 1, (2, 6, 6))
    weights = rng.uniform(0.2, 1, (2, 6, 6))
    guide_low = rng.uniform(0, 1, (2, 6, 6))
    guide_high = rng.uniform(0, 1, (2, 15, 15))
    weights[0, 2, 3] = 0
    values[1, 4, 1] = np.nan
    a = joint_bilateral_upsample(values, weights, guide_low, guide_high)
    changed = values.copy()
    changed[0, 2, 3] = 1e6
    weights_b = weights.copy()
    weights_b[1, 4, 1] = 1e6  # a NaN value with any weight adds nothing
    b = joint_bilateral_upsample(changed, weights_b, guide_low, guide_high)
    assert_array_equal(a, b)


def test_jbu_fill_where_no_usable_pixel_is_near():
    values = np.full((1, 6, 6), np.nan)
    values[0, 0, 0] = 0.25
    out = joint_bilateral_upsample(values, np.ones((1, 6, 6)), np.zeros((1, 6, 6)), np.zeros((1, 12, 12)),
                                   radius=1, fill=1.0)  # fmt: skip
    assert_allclose(out[0, :4, :4], 0.25)  # within one low pixel of (0, 0)
    assert (out[0, 4:, :] == 1.0).all() and (out[0, :, 4:] == 1.0).all()
    assert np.isnan(joint_bilateral_upsample(values, np.zeros((1, 6, 6)), values, values, fill=np.nan)).all()


def test_jbu_far_apart_guides_do_not_underflow_to_fill():
    # every tap is > 40 sigma_range from the fine guide: exp(-800) and below underflow to 0 in
    # float64, yet the ratio is decided by the nearest guide value, not by fill
    values = np.array([[[0.1, 0.2, 0.3]]])
    guide_low = np.array([[[100.0, 60.0, 100.0]]])
    out = joint_bilateral_upsample(values, np.ones((1, 1, 3)), guide_low, np.zeros((1, 1, 3)), sigma_range=1.0, radius=1)
    assert_allclose(out, 0.2, atol=1e-7)


def test_jbu_nan_guide_gives_spatial_weights_only():
    rng = np.random.default_rng(9)
    values = rng.uniform(0, 1, (1, 5, 5))
    weights = rng.uniform(0.1, 1, (1, 5, 5))
    nan_guide = joint_bilateral_upsample(values, weights, np.full((1, 5, 5), np.nan), rng.uniform(0, 9, (1, 10, 10)))
    flat_guide = joint_bilateral_upsample(values, weights, np.zeros((1, 5, 5)), np.zeros((1, 10, 10)))
    assert_allclose(nan_guide, flat_guide, rtol=RTOL)


def test_jbu_radius_zero_at_equal_size_is_the_identity_where_weighted():
    rng = np.random.default_rng(10)
    values, weights = _random(rng, (2, 5, 6))
    guide = rng.uniform(0, 1, (2, 5, 6))
    out = joint_bilateral_upsample(values, weights, guide, guide, radius=0, fill=-1.0)
    usable = ~np.isnan(values) & (weights > 0)
    assert_array_equal(out, np.where(usable, values, -1.0))


V = np.ones((1, 3, 3))


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        ((np.ones((3, 3)), V[0], V[0], V[0]), {}, ValueError, r"values must have shape \(N, H, W\)"),
        ((np.ones((1, 0, 3)),) * 4, {}, ValueError, r"values must have shape \(N, H, W\) with N, H, W >= 1"),
        ((V, np.ones((1, 3, 4)), V, V), {}, ValueError, "weights must have the shape of values"),
        ((V, V, np.ones((2, 3, 3)), V), {}, ValueError, "guide_low must have the shape of values"),
        ((V, V, V, np.ones((1, 2, 6))), {}, ValueError, "guide_high must have shape"),
        ((V, V, V, np.ones((2, 6, 6))), {}, ValueError, "guide_high must have shape"),
        ((V * np.inf, V, V, V), {}, ValueError, "values must not contain inf"),
        ((V, V * np.nan, V, V), {}, ValueError, "weights must be finite"),
        ((V, -V, V, V), {}, ValueError, "weights must be >= 0"),
        ((V, V, V * np.inf, V), {}, ValueError, "guide_low must not contain inf"),
        ((V, V, V, -V * np.inf), {}, ValueError, "guide_high must not contain inf"),
        ((V, V, V, V), {"sigma_space": 0.0}, ValueError, "sigma_space must be > 0"),
        ((V, V, V, V), {"sigma_range": np.inf}, ValueError, "sigma_range must be finite"),
        ((V, V, V, V), {"sigma_range": "6"}, TypeError, "sigma_range must be a real number"),
        ((V, V, V, V), {"radius": -1}, ValueError, "radius must be >= 0"),
        ((V, V, V, V), {"radius": 1.5}, TypeError, "radius must be an integer"),
        ((V, V, V, V), {"fill": np.inf}, ValueError, "fill must not be inf"),
        ((V, V, V, V), {"fill": None}, TypeError, "fill must be a real number"),
        ((V.astype(bool), V, V, V), {}, TypeError, "values must hold real numbers"),
    ],
)
def test_jbu_errors(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        joint_bilateral_upsample(*args, **kwargs)


def test_push_pull_fill_keeps_weighted_values_and_interpolates_the_rest():
    from vergence.specular import push_pull_fill

    rng = np.random.default_rng(3)
    v = rng.uniform(0, 1, (2, 9, 13))
    w = (rng.uniform(0, 1, (2, 9, 13)) > 0.7) * rng.uniform(0.1, 1, (2, 9, 13))
    out = push_pull_fill(v, w)
    assert out.shape == v.shape
    np.testing.assert_array_equal(out[w > 0], v[w > 0])
    assert out.min() >= v[w > 0].min() - 1e-12 and out.max() <= v[w > 0].max() + 1e-12  # a convex fill
    # one weighted pixel: its value everywhere; none: the fill value
    one = np.zeros((1, 5, 7))
    one[0, 2, 3] = 1.0
    np.testing.assert_allclose(push_pull_fill(np.full((1, 5, 7), 0.4), one), 0.4)
    np.testing.assert_array_equal(push_pull_fill(np.full((1, 5, 7), 0.4), np.zeros((1, 5, 7)), fill=1.0), 1.0)
    # a weighted ramp with a gap: the gap is filled between its sides, monotone
    ramp = np.linspace(0, 1, 16)[None, None, :].repeat(4, axis=1)
    gap = np.ones((1, 4, 16))
    gap[..., 5:11] = 0.0
    filled = push_pull_fill(np.where(gap > 0, ramp, 9.0), gap)[0, 0]
    assert np.all(np.diff(filled) >= -1e-12) and 0.3 < filled[8] < 0.7


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"weights": -np.ones((1, 2, 2))}, "weights must be >= 0"),
        ({"weights": np.ones((1, 2, 3))}, "shape of values"),
        ({"values": np.full((1, 2, 2), np.nan)}, "finite where the weight is positive"),
        ({"fill": np.inf}, "fill must be a finite number"),
    ],
)
def test_push_pull_fill_bad_input(kwargs, match):
    from vergence.specular import push_pull_fill

    args = {"values": np.zeros((1, 2, 2)), "weights": np.ones((1, 2, 2)), **kwargs}
    with pytest.raises(ValueError, match=match):
        push_pull_fill(args.pop("values"), args.pop("weights"), **args)
