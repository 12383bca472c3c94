"""assess_view: PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13) in one call."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import ndimage

from vergence.metrics import MIN_CONTRAST, SSIM_WINDOW, psnr, ssim
from vergence.synthesis import assess_view


def test_identical_views():
    ref = np.random.default_rng(0).random((20, 20, 3))
    q = assess_view(ref, ref)
    assert q.psnr_db == math.inf and q.ssim == 1.0 and q.dssim == 0.0
    assert q.registration_rms_px == 0.0 and q.registration_ranked_px[1.0] == 0.0
    assert q.to_dict()["psnr_db"] is None and q.to_dict()["identical"] is True and q.pixels == 400
    assert q.registration_pixels == 400 and q.registration_min_contrast == MIN_CONTRAST
    assert q.to_dict()["registration_fraction"] == 1.0


def test_misregistered_view_has_registration_error_sqrt5():
    # S1 Eqs. (11)-(13): a (2, 1)-px shift gives d = sqrt(5) on interior pixels.
    ref = ndimage.gaussian_filter(np.random.default_rng(2).random((40, 40)), 1.0)
    syn = np.roll(ref, (1, 2), axis=(0, 1))
    mask = np.zeros((40, 40), bool)
    mask[8:-8, 8:-8] = True
    q = assess_view(syn, ref, mask=mask)
    assert q.registration_median_px == pytest.approx(math.sqrt(5))
    assert q.pixels == 24 * 24


def test_registration_skips_flat_noisy_pixels():
    # Left half textured and shifted by (2, 1) px; right half flat grey with independent 1/255 noise.
    rng = np.random.default_rng(3)
    clean = np.full((40, 60), 0.5)
    clean[:, :30] = ndimage.gaussian_filter(rng.random((40, 30)), 1.0)
    ref = clean + rng.normal(0, 1 / 255, clean.shape)
    syn = np.roll(clean, (1, 2), axis=(0, 1)) + rng.normal(0, 1 / 255, clean.shape)
    syn, ref = np.clip(syn, 0, 1), np.clip(ref, 0, 1)
    mask = np.zeros((40, 60), bool)
    mask[8:-8, 8:-8] = True  # 24 x 44 pixels, columns 8..51
    plain = assess_view(syn, ref, mask=mask, min_contrast=0)
    assert plain.registration_pixels == plain.pixels == 24 * 44
    assert plain.registration_ranked_px[0.8] == 10.0  # noise matches noise at random: d = r
    q = assess_view(syn, ref, mask=mask)
    # syn's texture spans columns 2..31 after the shift; 5x5 patches centred up to column 33 reach it
    assert q.pixels == 24 * 44 and q.registration_pixels == 24 * (33 - 8 + 1)
    assert q.registration_ranked_px[0.95] == pytest.approx(math.sqrt(5))
    flat_mask = np.zeros((40, 60), bool)
    flat_mask[:, 40:] = True  # only flat pixels: nothing to register, PSNR and SSIM still defined
    flat = assess_view(syn, ref, mask=flat_mask)
    assert flat.registration_pixels == 0 and flat.registration_rms_px is None and flat.pixels == 40 * 20
    assert flat.psnr_db == pytest.approx(psnr(syn, ref, mask=flat_mask))


@pytest.mark.parametrize("levels", [(0.0, 0.0), (0.4, 0.45), (0.5, 0.5)])
def test_flat_views_have_psnr_and_ssim_but_no_registration(levels):
    """Issue 9: "compare refuses flat images outright (PSNR and SSIM are still defined) and writes PSNR
    as the string "inf" in JSON"."""
    image, reference = np.full((20, 30), levels[0]), np.full((20, 30), levels[1])
    q = assess_view(image, reference)
    assert q.ssim == pytest.approx(ssim(image, reference)) and q.psnr_db == psnr(image, reference)
    assert q.registration_pixels == 0 and q.registration_median_px is None and dict(q.registration_ranked_px) == {}
    data = q.to_dict()
    assert data["identical"] is (levels[0] == levels[1])
    assert data["psnr_db"] == (None if levels[0] == levels[1] else pytest.approx(20 * math.log10(1 / 0.05)))
    assert data["registration_rms_px"] is None and data["registration_fraction"] == 0.0
    json.dumps(data, allow_nan=False)  # no infinity, no NaN


def test_images_smaller_than_the_ssim_window_are_refused_by_name():
    """Issue 9: "compare on a 2x2 image: win_size ..." (a parameter the user never gave)."""
    for h, w in ((2, 2), (6, 40), (40, 6)):
        with pytest.raises(ValueError, match=rf"^image must be at least {SSIM_WINDOW} px on each side for SSIM's "
                                             rf"{SSIM_WINDOW} x {SSIM_WINDOW} window \(SSIM_WINDOW\); got {w} x {h} px"):
            assess_view(np.zeros((h, w)), np.zeros((h, w)))
    assert assess_view(np.zeros((7, 7)), np.zeros((7, 7))).pixels == 49


def test_mask_restricts_psnr():
    ref = np.zeros((16, 16))
    img = ref.copy()
    img[:, 8:] = 0.5
    mask = np.zeros((16, 16), bool)
    mask[:, :8] = True
    assert assess_view(img, ref, mask=mask).psnr_db == math.inf
    assert assess_view(img, ref).psnr_db == pytest.approx(10 * math.log10(1 / 0.125))


def test_bad_input():
    with pytest.raises(ValueError, match="reference must have the same shape as image"):
        assess_view(np.zeros((16, 16)), np.zeros((16, 17)))
    with pytest.raises(ValueError, match="mask must select at least one pixel"):
        assess_view(np.zeros((16, 16)), np.zeros((16, 16)), mask=np.zeros((16, 16), bool))


def test_ranked_registration_values_are_read_only():
    rng = np.random.default_rng(3)
    img = rng.random((24, 24)).astype(np.float32)
    q = assess_view(img, img)
    with pytest.raises(TypeError):
        q.registration_ranked_px[0.5] = 3.0  # type: ignore[index]


def test_error_image_is_gain_times_the_channel_mean_error():
    from vergence.synthesis import error_image

    a = np.zeros((1, 2, 3), np.float32)
    b = np.zeros((1, 2, 3), np.float32)
    b[0, 1] = [0.1, 0.2, 0.3]  # mean error 0.2, times 4 = 0.8
    b[0, 0] = [0.3, 0.3, 0.3]  # 1.2 clipped to 1
    np.testing.assert_allclose(error_image(a, b), [[1.0, 0.8]], rtol=1e-6)
    with pytest.raises(ValueError, match="gain must be > 0; got 0"):
        error_image(a, b, gain=0.0)
    with pytest.raises(ValueError, match="reference"):
        error_image(a, np.zeros((1, 3, 3)))
