"""PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13) (fast kernel vs slow reference)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from scipy import ndimage
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from vergence.metrics import (
    FLAT_VARIANCE,
    MIN_CONTRAST,
    REGISTRATION_PATCH,
    SSIM_WINDOW,
    TIE_TOLERANCE,
    RegistrationError,
    dssim,
    patch_contrast,
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
        with pytest.raises(ValueError, match=r"^image must have shape \(H, W\) or \(H, W, C\) with C in 1, 3, 4; got \(8,\)$"):
            f(np.zeros(8), np.zeros(8))
        with pytest.raises(ValueError, match=r"^image must not be empty; got shape \(0, 8\)$"):
            f(np.zeros((0, 8)), np.zeros((0, 8)))
        with pytest.raises(TypeError, match="^image must be a numeric image .*; got bool$"):
            f(np.zeros((8, 8), bool), np.zeros((8, 8)))
        with pytest.raises(TypeError, match="^reference must be float in \\[0, 1\\], uint8 or uint16; got int64$"):
            f(np.zeros((8, 8)), np.zeros((8, 8), np.int64))
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


def reference_registration_distance(
    image, reference, *, radius, patch_size, similarity="zncc", threshold=None, min_contrast=MIN_CONTRAST
):
    """Obviously-correct loops over pixels and candidates (S1 Eq. 11); same rules as the kernel.

    A pixel whose patch in ``image`` has an RMS deviation about its channel means (pooled over the
    channels) below ``min_contrast`` is NaN; ``min_contrast=0`` is the plain Eq. (11).
    """
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
            if math.sqrt(float(((pa - pa.mean(axis=(0, 1))) ** 2).mean())) < min_contrast:
                out[y, x] = math.nan
                continue
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


def _flat_noisy_with_textured_block(shape, seed, *, shift=(0, 0), noise=1 / 255):
    """Grey 0.5 with a textured block in its middle third; the image is the reference with the
    block's content shifted by ``shift`` (rows, columns); independent noise of ``noise`` RMS on each."""
    rng = np.random.default_rng(seed)
    clean = np.full(shape, 0.5)
    tex = ndimage.gaussian_filter(rng.random(shape), 1.0)
    block = (slice(shape[0] // 3, 2 * shape[0] // 3), slice(shape[1] // 3, 2 * shape[1] // 3))
    clean[block] = 0.2 + 0.6 * (tex[block] - tex.min()) / np.ptp(tex)
    ref = clean + noise * rng.standard_normal(shape)
    image = np.roll(clean, shift, axis=(0, 1)) + noise * rng.standard_normal(shape)
    return np.clip(image, 0, 1).astype(np.float32), np.clip(ref, 0, 1).astype(np.float32)


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


@pytest.mark.parametrize(("similarity", "min_contrast"), [("zncc", 0.0), ("zncc", 0.02), ("ssd", 0.02)])
def test_kernel_matches_slow_reference_with_contrast_gate(similarity, min_contrast):
    image, ref = _flat_noisy_with_textured_block((15, 18), 15, shift=(1, -1))
    fast = registration_error(image, ref, radius=3, patch_size=3, similarity=similarity, min_contrast=min_contrast)
    slow = reference_registration_distance(
        image, ref, radius=3, patch_size=3, similarity=similarity, min_contrast=min_contrast
    )
    assert_array_equal(fast.distance, slow)  # NaN at the same pixels
    skipped = np.isnan(slow).sum()
    assert (skipped == 0) if min_contrast == 0 else (0 < skipped < slow.size)
    assert fast.evaluated == slow.size - skipped
    assert fast.evaluated_fraction == pytest.approx(fast.evaluated / slow.size, abs=FLOAT64_TOL)


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



def test_registration_error_to_dict_is_json_of_the_summaries():
    import json

    ref = _noise((30, 32), 7)
    image = np.roll(ref, (-1, -2), axis=(0, 1))
    result = registration_error(image, ref)
    data = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert data["rms"] == result.rms and data["median"] == result.median and data["hausdorff"] == result.hausdorff
    assert data["ranked"] == {"0.8": result.ranked[0.8], "0.95": result.ranked[0.95], "1": result.ranked[1.0]}
    assert (data["radius"], data["patch_size"], data["similarity"], data["threshold"]) == (10.0, 5, "zncc", 0.8)
    ssd = registration_error(image, ref, similarity="ssd").to_dict()
    assert ssd["threshold"] is None  # SSD's default: no threshold (-inf has no JSON form)
    assert data["evaluated"] == result.evaluated and "distance" not in data

def test_identical_images_give_zero():
    # flat images have nothing above the default contrast: they need min_contrast=0
    for image, min_contrast in (
        (_noise((15, 14, 3), 8), MIN_CONTRAST),
        (np.full((9, 9), 0.3, np.float32), 0.0),
        (np.zeros((9, 9)), 0.0),
    ):
        result = registration_error(image, image, radius=3, min_contrast=min_contrast)
        assert_array_equal(result.distance, 0.0)
        assert result.rms == 0.0 and result.median == 0.0 and result.hausdorff == 0.0
        assert dict(result.ranked) == {0.8: 0.0, 0.95: 0.0, 1.0: 0.0}
        assert result.evaluated == image.shape[0] * image.shape[1] and result.evaluated_fraction == 1.0


def test_flat_noisy_region_no_longer_saturates_but_misregistration_is_measured():
    # A (2, 1)-px misregistration of a textured block on a flat grey with independent 1/255 noise.
    image, ref = _flat_noisy_with_textured_block((36, 48), 21, shift=(1, 2))
    plain = registration_error(image, ref, min_contrast=0.0)
    # flat and noisy: the ZNCC of two noise patches is random, mostly < 0.8, so d = r there
    assert plain.median == 10.0 and plain.ranked[0.8] == 10.0 and plain.ranked[0.95] == 10.0
    gated = registration_error(image, ref)  # default MIN_CONTRAST = 3/255, the noise is 1/255
    assert np.isnan(gated.distance[:8]).all()  # the flat band above the block is not evaluated
    assert_allclose(gated.distance[14:22, 18:30], math.sqrt(5), rtol=0, atol=FLOAT64_TOL)  # block interior
    assert gated.median == pytest.approx(math.sqrt(5), abs=FLOAT64_TOL)
    assert gated.ranked[0.95] == pytest.approx(math.sqrt(5), abs=FLOAT64_TOL)
    assert 0.1 < gated.evaluated_fraction < 0.4  # the block (1/9 of the image) and its edges


def test_min_contrast_zero_is_the_plain_eq11_on_every_pixel():
    image, ref = _flat_noisy_with_textured_block((15, 18), 16, shift=(0, 1))
    result = registration_error(image, ref, radius=3, patch_size=3, min_contrast=0)
    assert not np.isnan(result.distance).any() and result.evaluated == 15 * 18
    d = np.sort(result.distance.ravel())
    assert result.rms == pytest.approx(math.sqrt(np.mean(d**2)), abs=FLOAT64_TOL)
    assert result.median == np.median(d) and result.ranked[0.8] == d[math.ceil(0.8 * d.size) - 1]


def test_summaries_skip_unevaluated_pixels():
    image, ref = _flat_noisy_with_textured_block((15, 18), 17, shift=(1, 0))
    result = registration_error(image, ref, radius=3, patch_size=3, min_contrast=0.02, ranks=(0.5, 1.0))
    d = np.sort(result.distance[~np.isnan(result.distance)])
    assert 0 < d.size < result.distance.size
    assert result.rms == pytest.approx(math.sqrt(np.mean(d**2)), abs=FLOAT64_TOL)
    assert result.median == np.median(d)
    assert result.ranked[0.5] == d[math.ceil(0.5 * d.size) - 1]
    assert result.ranked[1.0] == d[-1] == result.hausdorff


def test_no_pixel_above_min_contrast_is_an_error():
    flat = np.full((9, 9), 0.25)
    with pytest.raises(ValueError, match=r"min_contrast must be at most the largest patch contrast of image \(0\)"):
        registration_error(flat, flat)
    ramp = np.tile(np.linspace(0.0, 1.0, 9), (9, 1))  # 3 x 3 patches: contrast (1/8) sqrt(2/3) inside
    with pytest.raises(ValueError, match=r"contrast of image \(0\.102\) to leave a pixel; got 0\.2"):
        registration_error(ramp, ramp, patch_size=3, min_contrast=0.2)


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
    result = registration_error(flat, textured, radius=4, patch_size=3, min_contrast=0)
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
    with pytest.raises(TypeError, match="does not support item assignment"):
        result.ranked[0.5] = 1.0
    assert result.radius == 2.0 and result.patch_size == 3 and result.similarity == "zncc"
    assert result.threshold == 0.8 and result.min_contrast == MIN_CONTRAST
    with pytest.raises(ValueError, match="distance must be finite and >= 0 where evaluated"):
        RegistrationError(np.full((2, 2), -1.0), 0.0, 0.0, {1.0: 0.0}, 1.0, 3, "zncc", 0.8, 0.0)
    with pytest.raises(ValueError, match="distance must hold at least one evaluated"):
        RegistrationError(np.full((2, 2), np.nan), 0.0, 0.0, {1.0: 0.0}, 1.0, 3, "zncc", 0.8, 0.0)
    with pytest.raises(ValueError, match=r"^distance must be a non-empty \(H, W\) array; got shape \(4,\)$"):
        RegistrationError(np.zeros(4), 0.0, 0.0, {1.0: 0.0}, 1.0, 3, "zncc", 0.8, 0.0)
    with pytest.raises(ValueError, match="^similarity must be one of ssd, zncc; got 'sad'$"):
        RegistrationError(np.zeros((2, 2)), 0.0, 0.0, {1.0: 0.0}, 1.0, 3, "sad", 0.8, 0.0)


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
        ({"min_contrast": -0.01}, ValueError, r"min_contrast must lie in \[0, 0.5\]; got -0.01"),
        ({"min_contrast": 0.6}, ValueError, r"min_contrast must lie in \[0, 0.5\]; got 0.6"),
        ({"min_contrast": math.nan}, ValueError, "min_contrast must be finite"),
    ],
)
def test_registration_error_bad_parameters(kwargs, error, message):
    with pytest.raises(error, match=message):
        registration_error(np.zeros((8, 8)), np.zeros((8, 8)), **kwargs)


def _checkerboard(shape, centre, amplitude, dtype=np.float64):
    yy, xx = np.indices(shape)
    return (centre + amplitude * np.where((yy + xx) % 2 == 0, 1, -1)).astype(dtype)


def test_default_min_contrast_is_three_8_bit_levels():
    # A 5 x 5 checkerboard of +-a has RMS deviation a sqrt(1 - 1/25^2) ~ 0.9992 a about its mean:
    # +-3.5 levels lies above MIN_CONTRAST = 3/255 (evaluated), +-2.5 levels below it (not evaluated).
    above = _checkerboard((12, 12), 0.5, 3.5 / 255.0)
    below = _checkerboard((12, 12), 0.5, 2.5 / 255.0)
    assert registration_error(above, above, radius=2.0).evaluated_fraction == 1.0
    with pytest.raises(ValueError, match=r"^min_contrast must be at most the largest patch contrast of image \(0.0098\)"):
        registration_error(below, below, radius=2.0)


def test_one_16_bit_level_of_texture_is_not_flat():
    # +-1 level of 16 bits: a 5 x 5 patch has 25 (1/65535)^2 ~ 5.8e-9 of squared deviation, far above
    # FLAT_VARIANCE = 1e-12, so against a flat reference it scores ZNCC 0 (< 0.8): d = r everywhere.
    texture = _checkerboard((12, 12), 32768, 1, np.uint16)
    flat = np.full((12, 12), 32768, np.uint16)
    result = registration_error(texture, flat, radius=2.0, min_contrast=0.0)
    assert_array_equal(result.distance, 2.0)
    assert_array_equal(registration_error(flat, flat, radius=2.0, min_contrast=0.0).distance, 0.0)


def test_ranked_distances_use_the_nearest_rank():
    from vergence._summaries import distance_summaries

    # N = 5: k = 0.3 -> ceil(1.5) = 2nd smallest, k = 0.5 -> ceil(2.5) = 3rd, k = 1 -> the largest.
    rms, median, ranked = distance_summaries(np.array([5.0, 1.0, 4.0, 2.0, 3.0]), (0.3, 0.5, 1.0))
    assert ranked == {0.3: 2.0, 0.5: 3.0, 1.0: 5.0}
    assert median == 3.0 and rms == pytest.approx(math.sqrt(11.0), rel=FLOAT64_TOL)


def test_a_better_match_farther_away_beats_a_near_one_unless_tied():
    # Columns alternate in sign (period 2) with a random amplitude per row, plus 1 % noise: the
    # reference is the image shifted by 2 columns, so ZNCC is 1 at offset (0, 2) and about
    # 1 - 1e-4 at offset (0, 0) (the noise differs). The gap is far above TIE_TOLERANCE = 1e-9, so
    # the exact match 2 px away wins; a tolerance of 1e-3 would call it a tie and pick distance 0.
    rng = np.random.default_rng(5)
    shape = (20, 24)
    sign = np.where(np.arange(shape[1]) % 2 == 0, 1.0, -1.0)
    image = 0.5 + 0.3 * rng.uniform(0.5, 1.0, (shape[0], 1)) * sign + 0.003 * rng.standard_normal(shape)
    reference = np.roll(image, 2, axis=1)  # image(p) = reference(p + (0, 2))
    result = registration_error(image, reference, radius=3.0)
    assert_array_equal(result.distance[3:-3, 3:-5], 2.0)


def test_registration_radius_past_the_limit_is_refused_before_any_allocation():
    from vergence.metrics import MAX_REGISTRATION_RADIUS

    img = np.random.default_rng(0).random((12, 12))
    with pytest.raises(ValueError, match=rf"radius must be at most {MAX_REGISTRATION_RADIUS} px.*got 1e\+06"):
        registration_error(img, img, radius=1e6)
    # the limit itself is accepted on the arithmetic (no allocation of the offsets at 1e6)
    assert registration_error(img, img, radius=20, min_contrast=0).rms == 0.0


def test_patch_contrast_by_hand_and_as_the_registration_gate_reads_it():
    # 5 x 5 checkerboard of +-a: RMS deviation a sqrt(1 - 1/25^2) (13 of one sign, 12 of the other)
    a = 3.5 / 255.0
    board = _checkerboard((12, 12), 0.5, a)
    assert_allclose(patch_contrast(board)[2:-2, 2:-2], a * math.sqrt(1.0 - 1.0 / 25**2), atol=FLOAT32_TOL)
    assert_array_equal(patch_contrast(np.full((9, 9, 3), 0.25)), 0.0)
    result = registration_error(board, board, radius=2.0, min_contrast=float(patch_contrast(board).min()))
    assert result.evaluated_fraction == 1.0
    assert REGISTRATION_PATCH == result.patch_size == 5


def test_patch_contrast_refuses_bad_patches():
    with pytest.raises(ValueError, match="patch_size must be an odd integer >= 3; got 4"):
        patch_contrast(np.zeros((8, 8)), patch_size=4)
    with pytest.raises(ValueError, match="patch_size must not exceed the image's smaller side 2; got 5"):
        patch_contrast(np.zeros((2, 8)))
    with pytest.raises(ValueError, match=r"image values must lie in \[0, 1\]"):
        patch_contrast(np.full((8, 8), 2.0))


def test_ssim_window_is_scikit_images_default():
    a, b = _noise((16, 16), 1), _noise((16, 16), 2)
    assert SSIM_WINDOW == 7
    reference = structural_similarity(a.astype(np.float64), b.astype(np.float64), data_range=1.0)
    assert ssim(a, b) == pytest.approx(reference, abs=FLOAT64_TOL)


def test_registration_rms_of_a_subnormal_radius_does_not_underflow():
    """Kin of the sweep's 5e-324 cases (issue 9): every distance was the radius 5e-324, their RMS 0."""
    rng = np.random.default_rng(0)
    image = rng.random((24, 48)).astype(np.float32)
    res = registration_error(image, np.roll(image, 1, axis=1), radius=5e-324)
    assert res.median == 5e-324 and res.rms == 5e-324  # every distance is d = r: RMS = r


def test_ssim_with_whole_windows_ignores_the_holes_next_to_the_mask():
    """A perfect synthesis with a black hole: over the covered pixels, windows that reach into the
    hole compare black with the truth and lower the SSIM; with whole windows only, the covered area
    is exact (SSIM 1). The pixels averaged are those whose 7x7 window misses the 10x10 hole."""
    rng = np.random.default_rng(0)
    truth = rng.random((40, 40))
    image = truth.copy()
    covered = np.ones((40, 40), dtype=bool)
    covered[15:25, 15:25] = False
    image[~covered] = 0.0
    assert ssim(image, truth, mask=covered) < 0.96  # measured 0.957: the ring of windows around the hole
    assert ssim(image, truth, mask=covered, whole_windows=True) == pytest.approx(1.0, abs=1e-12)
    assert dssim(image, truth, mask=covered, whole_windows=True) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="whole 7x7 window"):
        ssim(image, truth, mask=np.eye(40, dtype=bool), whole_windows=True)
    with pytest.raises(TypeError, match="whole_windows"):
        ssim(image, truth, mask=covered, whole_windows="yes")
