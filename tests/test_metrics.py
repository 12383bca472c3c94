"""PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13) (fast kernel vs slow reference)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from vergence.metrics import (
    FLAT_VARIANCE,
    TIE_TOLERANCE,
    RegistrationError,
    dssim,
    psnr,
    registration_error,
    ssim,
)

# Two float64 computations of one quantity in different orders: a few ulps of the result.
FLOAT64_TOL = 1e-12
# float32 inputs (as_image) against float64 references: the float32 ulp of values in [0, 1].
FLOAT32_TOL = 1e-6


def _noise(shape, seed=0):
    return np.random.default_rng(seed).random(shape).astype(np.float32)


# --- PSNR --------------------------------------------------------------------------------------


def test_psnr_hand_values():
    assert psnr(np.full((2, 2), 0.5), np.zeros((2, 2))) == pytest.approx(10 * math.log10(4), abs=FLOAT64_TOL)
    # colour: one channel off by 0.5 on every pixel -> MSE = 0.25 / 3
    a = np.zeros((3, 3, 3))
    b = a.copy()
    b[..., 1] = 0.5
    assert psnr(a, b) == pytest.approx(10 * math.log10(12), abs=FLOAT64_TOL)


def test_psnr_mask_and_identical_images():
    a = np.zeros((4, 4))
    b = a.copy()
    b[0, 0] = 1.0
    assert psnr(a, a) == math.inf  # MSE = 0
    mask = np.ones((4, 4), bool)
    mask[0, 0] = False
    assert psnr(a, b, mask=mask) == math.inf
    only = ~mask
    assert psnr(a, b, mask=only) == pytest.approx(0.0, abs=FLOAT64_TOL)  # MSE = 1
    assert psnr(a, b) == pytest.approx(10 * math.log10(16), abs=FLOAT64_TOL)


def test_psnr_matches_scikit_image():
    a, b = _noise((9, 11, 3), 1), _noise((9, 11, 3), 2)
    ref = peak_signal_noise_ratio(b.astype(float), a.astype(float), data_range=1.0)
    assert psnr(a, b) == pytest.approx(ref, abs=FLOAT64_TOL)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"mask": np.ones((2, 2), int)}, TypeError, "mask must be a boolean array; got dtype int64"),
        (
            {"mask": np.ones((2, 3), bool)},
            ValueError,
            r"mask must have shape \(H, W\) matching image \(2, 2\); got \(2, 3\)",
        ),
        ({"mask": np.zeros((2, 2), bool)}, ValueError, "mask must select at least one pixel"),
    ],
)
def test_psnr_bad_masks(kwargs, error, message):
    with pytest.raises(error, match=message):
        psnr(np.zeros((2, 2)), np.zeros((2, 2)), **kwargs)


def test_shared_bad_input():
    for f in (psnr, ssim, dssim, registration_error):
        with pytest.raises(ValueError, match=r"reference must have the same shape as image \(8, 8\); got \(8, 9"):
            f(np.zeros((8, 8)), np.zeros((8, 9)))
        with pytest.raises(ValueError, match=r"image values must lie in \[0, 1\]"):
            f(np.full((8, 8), 1.5), np.zeros((8, 8)))
        with pytest.raises(ValueError, match="reference must be finite"):
            f(np.zeros((8, 8)), np.full((8, 8), np.nan))
        with pytest.raises(ValueError, match=r"no alpha"):
            f(np.zeros((8, 8, 4)), np.zeros((8, 8, 4)))


# --- SSIM / DSSIM ------------------------------------------------------------------------------


def test_ssim_identical_and_against_scikit_image():
    a, b = _noise((16, 20, 3), 3), _noise((16, 20, 3), 4)
    assert ssim(a, a) == pytest.approx(1.0, abs=FLOAT64_TOL)
    ref = structural_similarity(a.astype(float), b.astype(float), data_range=1.0, channel_axis=2)
    assert ssim(a, b) == pytest.approx(ref, abs=FLOAT64_TOL)
    assert dssim(a, b) == pytest.approx((1 - ref) / 2, abs=FLOAT64_TOL)
    assert dssim(a, a) == pytest.approx(0.0, abs=FLOAT64_TOL)


def test_ssim_mask_averages_the_map_inside_the_border():
    a, b = _noise((16, 16), 5), _noise((16, 16), 6)
    _, smap = structural_similarity(a.astype(float), b.astype(float), data_range=1.0, full=True)
    full = np.ones((16, 16), bool)
    assert ssim(a, b, mask=full) == pytest.approx(ssim(a, b), abs=FLOAT64_TOL)
    mask = np.zeros((16, 16), bool)
    mask[4:8, 5:12] = True
    assert ssim(a, b, mask=mask) == pytest.approx(smap[4:8, 5:12].mean(), abs=FLOAT64_TOL)
    assert dssim(a, b, mask=mask) == pytest.approx((1 - smap[4:8, 5:12].mean()) / 2, abs=FLOAT64_TOL)
    border = np.zeros((16, 16), bool)
    border[:3] = True
    with pytest.raises(ValueError, match="at least 3 pixels from the border; got none"):
        ssim(a, b, mask=border)


def test_ssim_win_size_validation():
    a = np.zeros((6, 10))
    with pytest.raises(ValueError, match="win_size must not exceed the image's smaller side 6; got 7"):
        ssim(a, a)
    with pytest.raises(ValueError, match="win_size must be an odd integer >= 3; got 4"):
        ssim(a, a, win_size=4)
    assert ssim(a, a, win_size=5) == pytest.approx(1.0, abs=FLOAT64_TOL)


# --- registration error: slow reference --------------------------------------------------------


def reference_registration_distance(image, reference, *, radius, patch_size, similarity="zncc", threshold=None):
    """Obviously-correct loops over pixels and candidates (S1 Eq. 11); same rules as the kernel."""
    a = np.asarray(image, np.float64)
    b = np.asarray(reference, np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    b = b[:, :, None] if b.ndim == 2 else b
    height, width = a.shape[:2]
    h = patch_size // 2
    a_pad = np.pad(a, ((h, h), (h, h), (0, 0)), mode="reflect")
    b_pad = np.pad(b, ((h, h), (h, h), (0, 0)), mode="reflect")
    r = int(math.floor(radius))
    candidates = sorted(
        (math.hypot(dy, dx), dy, dx)
        for dy in range(-r, r + 1)
        for dx in range(-r, r + 1)
        if dy * dy + dx * dx <= radius * radius
    )
    tau = (0.8 if similarity == "zncc" else -math.inf) if threshold is None else threshold
    out = np.empty((height, width))
    for y in range(height):
        for x in range(width):
            pa = a_pad[y : y + patch_size, x : x + patch_size]
            best, best_d = -math.inf, 0.0
            for dist, dy, dx in candidates:
                yb, xb = y + dy, x + dx
                if not (0 <= yb < height and 0 <= xb < width):
                    continue
                pb = b_pad[yb : yb + patch_size, xb : xb + patch_size]
                if similarity == "zncc":
                    da = pa - pa.mean(axis=(0, 1))
                    db = pb - pb.mean(axis=(0, 1))
                    va, vb = float((da**2).sum()), float((db**2).sum())
                    if va <= FLAT_VARIANCE and vb <= FLAT_VARIANCE:
                        s = 1.0
                    elif va <= FLAT_VARIANCE or vb <= FLAT_VARIANCE:
                        s = 0.0
                    else:
                        s = float((da * db).sum()) / math.sqrt(va * vb)
                else:
                    s = -float(((pa - pb) ** 2).mean())
                if s > best + TIE_TOLERANCE:
                    best, best_d = s, dist
            out[y, x] = radius if best < tau else best_d
    return out


def _pair_with_noise(shape, seed, shift=(0, 0), noise=0.05):
    rng = np.random.default_rng(seed)
    ref = rng.random(shape)
    moved = np.roll(ref, shift, axis=(0, 1)) + noise * rng.standard_normal(shape)
    return np.clip(moved, 0, 1).astype(np.float32), ref.astype(np.float32)


def _pair_with_varied_shifts(shape, seed):
    """Image = reference with a different shift in each quarter (0 to 2 px) plus mild noise."""
    rng = np.random.default_rng(seed)
    ref = rng.random(shape)
    image = ref.copy()
    hy, hx = shape[0] // 2, shape[1] // 2
    for (ys, xs), shift in zip(
        [(slice(0, hy), slice(0, hx)), (slice(0, hy), slice(hx, None)), (slice(hy, None), slice(0, hx)),
         (slice(hy, None), slice(hx, None))],
        [(0, 0), (0, 1), (1, 1), (-1, 2)],
        strict=True,
    ):
        image[ys, xs] = np.roll(ref, shift, axis=(0, 1))[ys, xs]
    image = np.clip(image + 0.03 * rng.standard_normal(shape), 0, 1)
    return image.astype(np.float32), ref.astype(np.float32)


@pytest.mark.parametrize(
    ("shape", "similarity", "threshold", "radius", "patch_size"),
    [
        ((12, 13), "zncc", None, 3, 3),
        ((11, 12, 3), "zncc", 0.5, 2.5, 5),
        ((12, 10), "ssd", None, 3, 3),
        ((10, 11, 3), "ssd", -0.02, 2, 3),
    ],
)
def test_kernel_matches_slow_reference(shape, similarity, threshold, radius, patch_size):
    image, ref = _pair_with_varied_shifts(shape, seed=len(shape) + patch_size)
    fast = registration_error(
        image, ref, radius=radius, patch_size=patch_size, similarity=similarity, threshold=threshold
    )
    slow = reference_registration_distance(
        image, ref, radius=radius, patch_size=patch_size, similarity=similarity, threshold=threshold
    )
    assert_array_equal(fast.distance, slow)
    assert len(np.unique(slow)) >= 4  # the case exercises several distances, not one constant


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31), st.integers(-2, 2), st.integers(-2, 2))
def test_kernel_matches_reference_property(seed, dy, dx):
    image, ref = _pair_with_noise((8, 9), seed, shift=(dy, dx), noise=0.1)
    fast = registration_error(image, ref, radius=2, patch_size=3)
    assert_array_equal(fast.distance, reference_registration_distance(image, ref, radius=2, patch_size=3))


def test_spec_example_two_one_misregistration_gives_sqrt5():
    ref = _noise((30, 32), 7)
    image = np.roll(ref, (-1, -2), axis=(0, 1))  # image(p) = ref(p + (1, 2)): a (2, 1)-px shift
    result = registration_error(image, ref)  # ZNCC 5 x 5, r = 10, tau = 0.8
    interior = result.distance[3:-4, 3:-5]  # patches and matches inside both images
    assert_allclose(interior, math.sqrt(5), rtol=0, atol=FLOAT64_TOL)


def test_identical_images_give_zero():
    for image in (_noise((15, 14, 3), 8), np.full((9, 9), 0.3, np.float32), np.zeros((9, 9))):
        result = registration_error(image, image, radius=3)
        assert_array_equal(result.distance, 0.0)
        assert result.rms == 0.0 and result.median == 0.0 and result.hausdorff == 0.0
        assert dict(result.ranked) == {0.8: 0.0, 0.95: 0.0, 1.0: 0.0}


def test_unrelated_images_fall_below_the_threshold():
    a, b = _noise((20, 20), 9), _noise((20, 20), 10)
    result = registration_error(a, b, radius=2, patch_size=5)  # ZNCC of 25 random pairs < 0.8
    assert_array_equal(result.distance, 2.0)
    lenient = registration_error(a, b, radius=2, patch_size=5, threshold=-1.0)
    assert lenient.distance.max() <= 2.0 and (lenient.distance < 2.0).any()


def test_flat_patches_score_one_together_and_zero_against_texture():
    flat = np.full((9, 9), 0.5, np.float32)
    textured = flat.copy()
    textured[:, 6:] = _noise((9, 3), 11)  # texture in columns 6..8 only
    result = registration_error(flat, textured, radius=4, patch_size=3)
    assert_array_equal(result.distance[:, :4], 0.0)  # flat patch, flat candidate at p itself
    # column 4's patch (columns 3..5) is flat; its own candidate patch (3..5) too: distance 0
    assert_array_equal(result.distance[:, 4], 0.0)
    # pixels in the textured strip of `flat` are flat patches; the nearest flat candidate in
    # `textured` has its patch ending at column 5 (centre column 4)
    assert_array_equal(result.distance[4, 6:], [2.0, 3.0, 4.0])


def test_summaries_and_nearest_rank():
    image, ref = _pair_with_noise((14, 15), 12, shift=(0, 1), noise=0.3)
    result = registration_error(image, ref, radius=3, patch_size=3, ranks=(0.5, 0.8, 1.0))
    d = np.sort(result.distance.ravel())
    n = d.size
    assert result.rms == pytest.approx(math.sqrt(np.mean(d**2)), abs=FLOAT64_TOL)
    assert result.median == np.median(d)
    assert result.ranked[0.5] == d[math.ceil(0.5 * n) - 1]
    assert result.ranked[0.8] == d[math.ceil(0.8 * n) - 1]
    assert result.ranked[1.0] == d[-1] == result.hausdorff  # Eq. (12)


def test_result_is_frozen_and_read_only():
    result = registration_error(_noise((8, 8), 13), _noise((8, 8), 14), radius=2, patch_size=3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.rms = 0.0
    with pytest.raises(ValueError, match="read-only"):
        result.distance[0, 0] = 1.0
    with pytest.raises(TypeError):
        result.ranked[0.5] = 1.0
    assert result.radius == 2.0 and result.patch_size == 3 and result.similarity == "zncc"
    assert result.threshold == 0.8
    with pytest.raises(ValueError, match="distance must be finite and >= 0"):
        RegistrationError(np.full((2, 2), -1.0), 0.0, 0.0, {1.0: 0.0}, 1.0, 3, "zncc", 0.8)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"radius": 0}, ValueError, "radius must be > 0; got 0"),
        ({"radius": math.nan}, ValueError, "radius must be finite"),
        ({"patch_size": 4}, ValueError, "patch_size must be an odd integer >= 3; got 4"),
        ({"patch_size": 1}, ValueError, "patch_size must be an odd integer >= 3; got 1"),
        ({"patch_size": 11}, ValueError, "patch_size must not exceed the image's smaller side 8; got 11"),
        ({"patch_size": 3.0}, TypeError, "patch_size must be an integer; got float"),
        ({"similarity": "sad"}, ValueError, "similarity must be one of ssd, zncc; got 'sad'"),
        ({"threshold": 1.5}, ValueError, r"threshold must lie in \[-1, 1\]; got 1.5"),
        ({"threshold": math.inf, "similarity": "ssd"}, ValueError, "threshold must be finite"),
        ({"ranks": (0.0, 1.0)}, ValueError, r"ranks must lie in \(0, 1\]; got 0"),
        ({"ranks": (1.2,)}, ValueError, r"ranks must lie in \[0, 1\]; got 1.2"),
        ({"ranks": ()}, TypeError, "ranks must be a non-empty sequence"),
        ({"ranks": 0.5}, TypeError, "ranks must be a non-empty sequence"),
    ],
)
def test_registration_error_bad_parameters(kwargs, error, message):
    with pytest.raises(error, match=message):
        registration_error(np.zeros((8, 8)), np.zeros((8, 8)), **kwargs)
