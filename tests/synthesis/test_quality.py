"""assess_view: PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13) in one call."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from vergence.synthesis import assess_view


def test_identical_views():
    ref = np.random.default_rng(0).random((20, 20, 3))
    q = assess_view(ref, ref)
    assert q.psnr_db == math.inf and q.ssim == 1.0 and q.dssim == 0.0
    assert q.registration_rms_px == 0.0 and q.registration_ranked_px[1.0] == 0.0
    assert q.to_dict()["psnr_db"] == "inf" and q.pixels == 400


def test_misregistered_view_has_registration_error_sqrt5():
    # SPEC §6.5 [V]: a (2, 1)-px shift gives d = sqrt(5) on interior pixels.
    ref = ndimage.gaussian_filter(np.random.default_rng(2).random((40, 40)), 1.0)
    syn = np.roll(ref, (1, 2), axis=(0, 1))
    mask = np.zeros((40, 40), bool)
    mask[8:-8, 8:-8] = True
    q = assess_view(syn, ref, mask=mask)
    assert q.registration_median_px == pytest.approx(math.sqrt(5))
    assert q.pixels == 24 * 24


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
