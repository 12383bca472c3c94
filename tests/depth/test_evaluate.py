"""Middlebury evaluation (S1 Eq. 9-10; Scharstein & Szeliski 2002): hand values, reference loops, official masks, errors."""

from __future__ import annotations

import re

import cv2
import numpy as np
import pytest

from vergence.depth import (
    evaluate_disparity,
    mask_agreement,
    middlebury_regions,
    read_middlebury_masks,
)
from vergence.io import read_disparity, read_image

# Bad-pixel percentages and RMS are sums of a few thousand float64 terms: 1e-12 relative.
RTOL = 1e-12
# Agreement of our computed regions with the official Middlebury v2 masks (measured: tsukuba
# nonocc 99.986 / all 100 / disc 99.965 %, venus 99.817 / 100 / 99.731 %): the few differing
# pixels sit on occlusion edges where StereoMatcher warps a white image instead of testing d_R.
MIN_AGREEMENT = {"tsukuba": {"nonocc": 99.95, "all": 100.0, "disc": 99.9},
                 "venus": {"nonocc": 99.7, "all": 100.0, "disc": 99.6}}


def test_bad_is_strictly_greater_than_the_threshold_and_rms_by_hand():
    truth = np.full((30, 30), 10.0)
    est = truth.copy()
    est[12, 12] = 11.0  # error exactly 1: not bad
    est[12, 13] = 8.5  # error 1.5: bad
    est[13, 12] = np.nan  # unknown: bad, error = 10 in the RMS
    est[13, 13] = 0.0  # a real disparity 0 (NaN marks unknown): error 10, bad
    scores = evaluate_disparity(est, truth)
    assert list(scores) == ["nonocc", "all"]  # a flat truth has no discontinuity region
    s = scores["all"]  # 10 x 10 pixels inside the 10-px border
    assert s.pixels == 100
    assert s.bad == pytest.approx(3.0, rel=RTOL)
    assert s.rms == pytest.approx(np.sqrt((1.0 + 2.25 + 100.0 + 100.0) / 100.0), rel=RTOL)
    assert evaluate_disparity(est, truth, threshold=1.6)["all"].bad == pytest.approx(2.0, rel=RTOL)


def test_zero_is_a_real_estimate_and_nan_is_unknown():
    """Only NaN is unknown (docs/conventions.md); a PNG estimate's 0 becomes NaN in read_disparity."""
    truth = np.full((30, 30), 0.75)
    est = np.zeros((30, 30))  # error 0.75 everywhere: not bad
    est[12, 12:14] = np.nan  # unknown: bad, error = 0.75 in the RMS
    s = evaluate_disparity(est, truth)["all"]
    assert s.bad == pytest.approx(2.0, rel=RTOL) and s.rms == pytest.approx(0.75, rel=RTOL)


def test_unknown_truth_is_never_evaluated():
    truth = np.full((40, 40), 7.0)
    truth[15:20, :] = np.nan
    s = evaluate_disparity(np.full((40, 40), 7.0), truth)
    assert s["all"].pixels == 20 * 20 - 5 * 20 and s["all"].bad == 0.0 and s["all"].rms == 0.0


def _step_scene() -> tuple[np.ndarray, np.ndarray]:
    """verify_dibr_perception.py: background 5 px, a 40x40 square at 20 px, a flat grey patch."""
    rng = np.random.default_rng(0)
    disp = np.full((80, 120), 5.0)
    disp[20:60, 50:90] = 20.0
    grey = rng.uniform(0, 255, (80, 120))
    grey[30:50, 10:40] = 128.0
    return disp, (grey / 255.0).astype(np.float32)


def test_regions_on_the_step_scene():
    disp, grey = _step_scene()
    r = middlebury_regions(disp, image=grey, disc_includes_occlusions=False)
    # occluded strip = d_fg - d_bg = 15 px left of the foreground (cols 35..49)
    assert not r["nonocc"][40, 35:50].any() and r["nonocc"][40, 30:35].all() and r["nonocc"][40, 50:110].all()
    # disc: the jump at cols 89|90 marks both, dilated by 9x9 -> cols 85..94 (band of 2 + 8 px)
    assert r["disc"][40, 85:95].all() and not r["disc"][40, 84] and not r["disc"][40, 95]
    # the flat patch (cols 10..39, its edge columns excepted) is textureless; cols 35.. are occluded (not counted)
    assert r["textureless"][33:47, 13:35].all() and r["textureless"][60:70, 60:110].mean() < 0.01
    assert not (r["disc"] & ~r["nonocc"]).any() and not (r["all"] & ~np.pad(np.ones((60, 100), bool), 10)).any()
    with_occ = middlebury_regions(disp)["disc"]
    # occluded cols 35..49 also seed the band (official v2 masks): 4 px either side, within nonocc
    assert with_occ[40, 31:35].all() and not with_occ[40, 30] and (with_occ | r["disc"]).sum() == with_occ.sum()


def _slow_textureless(image: np.ndarray) -> np.ndarray:
    """StcEvaluate.cpp ComputeTextureless, loop by loop (box filter with replicated edges)."""
    img = image.astype(np.float64) * 255.0
    h, w, c = img.shape
    s = np.zeros((h, w))
    for y in range(h):
        for x in range(w - 1):
            sum2 = sum((img[y, x, b] - img[y, x + 1, b]) ** 2 for b in range(c)) / c
            s[y, x + 1] = sum2
            if x == 0:
                s[y, x] = sum2
            s[y, x] = max(sum2, s[y, x])
    out = np.zeros((h, w), bool)
    for y in range(h):
        for x in range(w):
            ys = np.clip(np.arange(y - 1, y + 2), 0, h - 1)
            xs = np.clip(np.arange(x - 1, x + 2), 0, w - 1)
            out[y, x] = s[np.ix_(ys, xs)].mean() < 16.0
    return out


def _slow_discont(d: np.ndarray, border: int = 10) -> np.ndarray:
    """StcEvaluate.cpp ComputeDisparityDiscont (jumps only), loop by loop."""
    h, w = d.shape
    mark = np.zeros((h, w), bool)
    bor = border + 1
    for y in range(bor, h - bor):
        for x in range(bor, w - bor - 1):
            if abs(d[y, x] - d[y, x + 1]) >= 2.0:
                mark[y, x] = mark[y, x + 1] = True
            if abs(d[y, x] - d[y + 1, x]) >= 2.0:
                mark[y, x] = mark[y + 1, x] = True
    out = np.zeros((h, w), bool)
    for y, x in zip(*np.nonzero(mark)):
        out[max(0, y - 4):y + 5, max(0, x - 4):x + 5] = True
    return out


def test_regions_against_the_reference_loops():
    rng = np.random.default_rng(3)
    d = np.kron(rng.integers(0, 6, (6, 8)).astype(float) * 1.5, np.ones((8, 8)))[:45, :60]
    img = rng.random((45, 60, 3)).astype(np.float32)
    img[10:30, 10:40] = 0.5
    r = middlebury_regions(d, image=img, disc_includes_occlusions=False)
    np.testing.assert_array_equal(r["textureless"], r["nonocc"] & _slow_textureless(img))
    np.testing.assert_array_equal(r["disc"], r["nonocc"] & _slow_discont(d))


@pytest.mark.parametrize(("scene", "truth", "scale", "right"),
                         [("tsukuba", "groundtruth.png", 16, None), ("venus", "disp2.pgm", 8, "disp6.pgm")])
def test_computed_regions_agree_with_the_official_masks(shared_data, scene, truth, scale, right):
    folder = shared_data / "stereo" / scene
    t = read_disparity(folder / truth, scale=scale)
    tr = read_disparity(folder / right, scale=scale) if right else None
    official = read_middlebury_masks(folder)
    computed = middlebury_regions(t, truth_right=tr)
    for name, minimum in MIN_AGREEMENT[scene].items():
        assert mask_agreement(computed[name], official[name]) >= minimum, name
    assert (official["disc"] <= official["nonocc"]).all()  # disc.png 128 = other nonocc pixels, not counted


def test_official_masks_and_truth_score_perfectly(shared_data):
    folder = shared_data / "stereo" / "venus"
    t = read_disparity(folder / "disp2.pgm", scale=8)
    scores = evaluate_disparity(t, t, masks=read_middlebury_masks(folder))
    assert list(scores) == ["nonocc", "all", "disc"]
    assert all(s.bad == 0.0 and s.rms == 0.0 for s in scores.values())
    shifted = evaluate_disparity(t + 1.25, t, masks=read_middlebury_masks(folder))
    assert shifted["all"].bad == 100.0 and shifted["all"].rms == pytest.approx(1.25, rel=RTOL)


def test_read_masks_counts_only_255(tmp_path):
    disc = np.array([[0, 128, 255]], np.uint8)
    cv2.imwrite(str(tmp_path / "disc.png"), disc)
    cv2.imwrite(str(tmp_path / "nonocc.png"), np.dstack([disc] * 3))
    m = read_middlebury_masks(tmp_path)
    assert sorted(m) == ["disc", "nonocc"]
    np.testing.assert_array_equal(m["disc"], [[False, False, True]])
    np.testing.assert_array_equal(m["nonocc"], [[False, False, True]])
    with pytest.raises(ValueError, match="no Middlebury masks"):
        read_middlebury_masks(tmp_path / "..")


def test_bad_input():
    t = np.full((30, 30), 5.0)
    with pytest.raises(ValueError, match=r"estimate must have shape \(30, 30\) matching truth; got \(30, 29\)"):
        evaluate_disparity(t[:, :-1], t)
    with pytest.raises(ValueError, match="estimate must not contain inf"):
        evaluate_disparity(np.where(t > 0, np.inf, 0), t)
    with pytest.raises(ValueError, match="no pixel with known truth in any region"):
        evaluate_disparity(t, np.full((30, 30), np.nan))
    with pytest.raises(ValueError, match="mask 'nonocc' must be a boolean array"):
        evaluate_disparity(t, t, masks={"nonocc": np.ones((30, 30))})
    with pytest.raises(ValueError, match="masks replace the computed regions"):
        evaluate_disparity(t, t, masks={"all": np.ones((30, 30), bool)}, image=np.zeros((30, 30), np.float32))
    with pytest.raises(ValueError, match="threshold must be > 0"):
        evaluate_disparity(t, t, threshold=0)
    with pytest.raises(ValueError, match=r"image must have shape \(H, W\) matching truth \(30, 30\)"):
        middlebury_regions(t, image=np.zeros((31, 30), np.float32))
    with pytest.raises(ValueError, match="border must be an integer >= 0"):
        middlebury_regions(t, border=-1)
    with pytest.raises(ValueError, match=r"truth must have shape \(H, W\); got \(30,\)"):
        middlebury_regions(t[0])
    with pytest.raises(TypeError, match="masks must be a non-empty dict of region name"):
        evaluate_disparity(t, t, masks={})
    with pytest.raises(ValueError, match=r"mask must have the shape of reference \(30, 30\); got \(30, 29\)"):
        mask_agreement(np.ones((30, 29), bool), np.ones((30, 30), bool))


def test_mask_agreement_refuses_empty_and_non_boolean_masks():
    """Issue 9: "mask_agreement of empty masks" returned NaN (with a numpy warning) instead of an error."""
    for empty in (np.ones((0, 0), bool), np.ones((0, 5), bool)):
        message = r"^mask must be a non-empty \(H, W\) array; got shape " + re.escape(str(empty.shape))
        with pytest.raises(ValueError, match=message):
            mask_agreement(empty, empty)
    with pytest.raises(ValueError, match=r"^reference must be a non-empty \(H, W\) array; got shape \(4,\)"):
        mask_agreement(np.ones((1, 4), bool), np.ones(4, bool))
    with pytest.raises(TypeError, match="^mask must be a boolean array; got dtype uint8"):
        mask_agreement(np.full((2, 2), 255, np.uint8), np.ones((2, 2), bool))
    agree = np.array([[True, False], [False, False]])
    assert mask_agreement(agree, np.zeros((2, 2), bool)) == 75.0


def test_bad_mask_folders(tmp_path):
    with pytest.raises(FileNotFoundError, match="masks folder .* does not exist"):
        read_middlebury_masks(tmp_path / "nope")
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[..., 0] = 255
    cv2.imwrite(str(tmp_path / "nonocc.png"), rgb)
    with pytest.raises(ValueError, match="must be grey"):
        read_middlebury_masks(tmp_path)


@pytest.mark.parametrize(("step", "textureless"), [(3.9, True), (4.1, False)])
def test_textureless_threshold_is_an_rms_gradient_of_4_grey_levels(step, textureless):
    """A horizontal ramp of ``step`` grey levels per pixel: the squared difference is step^2 everywhere,
    so it is textureless exactly when step < 4 (Scharstein & Szeliski 2002: eval_textureless_thresh 4)."""
    ramp = (np.arange(40) * step / 255.0)[None, :].repeat(30, axis=0).astype(np.float32)
    r = middlebury_regions(np.full((30, 40), 5.0), image=ramp)
    assert r["nonocc"].any()
    assert (r["textureless"] == r["nonocc"]).all() if textureless else not r["textureless"].any()


def test_textureless_region_on_tsukuba_is_plausible(shared_data):
    folder = shared_data / "stereo" / "tsukuba"
    r = middlebury_regions(read_disparity(folder / "groundtruth.png", scale=16), image=read_image(folder / "im3.png"))
    frac = r["textureless"].sum() / r["nonocc"].sum()
    assert 0.2 < frac < 0.6  # tsukuba: large dark, flat background areas; not everything
