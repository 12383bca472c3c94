"""The texture gate of the matching pipeline: uniform pairs refused, mostly flat pairs warned."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vergence.depth import compute_disparity
from vergence.depth.texture import (
    LOW_TEXTURED_PERCENT,
    MIN_TEXTURE,
    MIN_TEXTURED_PERCENT,
    TEXTURE_WINDOW,
    textured_pixels,
)
from vergence.io import read_image

# A step of height a covering 2 of the 5 columns of a window: RMS deviation a sqrt(p (1 - p)), p = 2/5.
STEP_SHARE = 2.0 / TEXTURE_WINDOW
# Margin around the threshold in the hand-worked step: 1 % on either side.
MARGIN = 0.01


def _random_texture(h: int, w: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).random((h, w)).astype(np.float32)


def test_textured_pixels_of_a_step_by_hand():
    """A vertical step 0 | a at column 12: the windows of columns 11 and 12 hold 2 or 3 columns of a
    (contrast a sqrt(6/25)), those of 10 and 13 one or four (a sqrt(4/25)), the others none."""
    for factor, expect in ((1.0 + MARGIN, True), (1.0 - MARGIN, False)):
        a = factor * MIN_TEXTURE / math.sqrt(STEP_SHARE * (1.0 - STEP_SHARE))
        img = np.zeros((9, 24), np.float64)
        img[:, 12:] = a
        expected = np.zeros(img.shape, bool)
        expected[:, 11:13] = expect
        np.testing.assert_array_equal(textured_pixels(img), expected)


def test_sensor_noise_alone_is_not_texture():
    """A flat grey wall with the Middlebury cameras' noise (1.2 levels RMS) has no texture."""
    rng = np.random.default_rng(1)
    wall = np.clip(0.5 + rng.normal(0.0, 1.2 / 255.0, (200, 300)), 0, 1)
    assert 100.0 * textured_pixels(wall).mean() < MIN_TEXTURED_PERCENT


def test_middlebury_shares_of_textured_pixels(shared_data):
    """Measured: tsukuba 80 %, venus 68 % (2 levels); plastic, Middlebury's near-textureless scene, 16 %."""
    tsukuba = read_image(shared_data / "stereo" / "tsukuba" / "im3.png")
    plastic = read_image(shared_data / "multiview" / "plastic" / "view1.png")
    assert 100.0 * textured_pixels(tsukuba).mean() > 75.0
    assert LOW_TEXTURED_PERCENT < 100.0 * textured_pixels(plastic).mean() < 20.0


@pytest.mark.parametrize("level", [0.0, 0.5, 1.0])
def test_a_uniform_pair_is_refused(level):
    """Issue 9: "match on a black or uniform-grey pair: matched_percent 75, an all-zero map"."""
    flat = np.full((60, 120, 3), level, np.float32)
    refusal = r"^left has no texture to match: 0 % of its pixels .* \(MIN_TEXTURED_PERCENT\)"
    with pytest.raises(ValueError, match=refusal):
        compute_disparity(flat, flat, max_disparity=15)
    with pytest.raises(ValueError, match=r"^right has no texture to match"):
        compute_disparity(_random_texture(60, 120), flat[:, :, 0], max_disparity=15)


def test_a_mostly_flat_pair_is_matched_with_a_warning():
    left = np.full((100, 200), 0.5, np.float32)
    left[30:60, 60:110] = _random_texture(30, 50)  # 30 x 50 of 100 x 200, plus the window's rim: about 9 %
    res = compute_disparity(left, left, max_disparity=15)
    assert MIN_TEXTURED_PERCENT < res.textured_percent < LOW_TEXTURED_PERCENT
    assert len(res.warnings) == 3 and res.warnings[0].startswith("only 9.2 % of left has texture to match")
    # a pair matched against itself sits at disparity 0, the search's lower bound: said (it could lie past it)
    assert "sit at the search's lower bound (0 px)" in res.warnings[2]
    summary = res.to_dict()
    assert summary["warnings"] == list(res.warnings) and summary["textured_percent"] == res.textured_percent
    textured = compute_disparity(_random_texture(60, 120), _random_texture(60, 120), max_disparity=15)
    # no texture warning (two unrelated textures do pile up at a search bound, which is said: test_search.py)
    assert not any("texture" in w for w in textured.warnings) and textured.textured_percent == 100.0


def test_textured_pixels_refuses_bad_thresholds():
    for bad in (0.0, -1.0, 0.6, float("nan"), "0.1"):
        with pytest.raises(ValueError, match="min_texture must be a number in"):
            textured_pixels(np.zeros((4, 4)), min_texture=bad)


def test_textured_pixels_against_a_float64_loop_over_windows():
    # The obviously-correct rule: RMS deviation of each 5 x 5 window (mirrored borders, as cv2.blur's
    # BORDER_REFLECT_101), channels pooled, in float64; float32 may differ only on the threshold itself.
    rng = np.random.default_rng(3)
    img = np.clip(0.5 + rng.normal(0, 1, (12, 15, 3)) * rng.choice([0.0, 0.004, 0.02], (12, 15, 1)), 0, 1)
    r = TEXTURE_WINDOW // 2
    padded = np.pad(img, ((r, r), (r, r), (0, 0)), mode="reflect")
    rms = np.empty(img.shape[:2])
    for y in range(img.shape[0]):
        for x in range(img.shape[1]):
            window = padded[y:y + TEXTURE_WINDOW, x:x + TEXTURE_WINDOW].reshape(-1, 3)
            rms[y, x] = np.sqrt(window.var(axis=0).mean())
    got = textured_pixels(img)
    clear = np.abs(rms - MIN_TEXTURE) > 1e-3 * MIN_TEXTURE
    assert 0.2 < got.mean() < 0.9 and clear.mean() > 0.95
    np.testing.assert_array_equal(got[clear], (rms >= MIN_TEXTURE)[clear])
