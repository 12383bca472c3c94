"""The non-occluded mask from two ground-truth disparities (Middlebury 2005/2006 layout): reference loop, data, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vergence.cli import main
from vergence.depth import evaluate_disparity, middlebury_regions, nonoccluded_mask
from vergence.io import read_disparity

# Bad-pixel percentages are means of float64 flags over the same pixels: 1e-12 relative.
RTOL = 1e-12


def _slow_nonoccluded(t: np.ndarray, tr: np.ndarray, tol: float) -> np.ndarray:
    """The rule pixel by pixel: known, match inside the image, right truth known and not nearer."""
    h, w = t.shape
    out = np.zeros((h, w), bool)
    for y in range(h):
        for x in range(w):
            d = t[y, x]
            if np.isnan(d):
                continue
            xr = x - int(np.floor(d + 0.5)) if d % 1 != 0.5 else x - int(np.rint(d))  # numpy rounds half to even
            if not 0 <= xr < w:
                continue
            dr = tr[y, xr]
            out[y, x] = bool(not np.isnan(dr) and dr <= d + tol)
    return out


def test_hand_example():
    # a near patch (d = 3) at left x = 2, 3 on a far wall (d = 1): the right view sees it at x = -1, 0
    left = np.array([[1.0, 1.0, 3.0, 3.0, 1.0, 1.0]])
    right = np.array([[3.0, 1.0, 1.0, 1.0, 1.0, 1.0]])
    # x = 0 and x = 2 leave the image; the wall at x = 1 hides behind the patch in the right view
    assert nonoccluded_mask(left, right).tolist() == [[False, False, False, True, True, True]]
    # a tolerance of 2 px forgives the nearer patch
    assert nonoccluded_mask(left, right, tolerance=2.0).tolist() == [[False, True, False, True, True, True]]
    right[0, 3] = np.nan  # x = 4 now matches an unknown right pixel: out
    assert nonoccluded_mask(left, right).tolist() == [[False, False, False, True, False, True]]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_matches_the_reference_loop(seed):
    rng = np.random.default_rng(seed)
    t = np.round(rng.uniform(0, 12, (9, 23)) * 2) / 2  # half-pixel truths, as disp1.png / 2
    tr = np.round(rng.uniform(0, 12, (9, 23)) * 2) / 2
    t[rng.random(t.shape) < 0.1] = np.nan
    tr[rng.random(tr.shape) < 0.1] = np.nan
    for tol in (0.0, 1.0):
        np.testing.assert_array_equal(nonoccluded_mask(t, tr, tolerance=tol), _slow_nonoccluded(t, tr, tol))


def test_refusals():
    t = np.ones((4, 5))
    with pytest.raises(ValueError, match="truth_right must have"):
        nonoccluded_mask(t, np.ones((4, 6)))
    with pytest.raises(ValueError, match="tolerance must be a finite number of pixels >= 0; got -1"):
        nonoccluded_mask(t, t, tolerance=-1.0)


def test_dolls_and_the_cli(shared_data, capsys, tmp_path):
    folder = shared_data / "multiview" / "dolls"
    t = read_disparity(folder / "disp1.png", scale=2)
    tr = read_disparity(folder / "disp5.png", scale=2)
    mask = nonoccluded_mask(t, tr)
    assert 0.80 < mask.mean() < 0.90  # measured 85.4 %: 13.8 % occluded, 0.6 % unknown, 0.2 % on unknown disp5
    regions = middlebury_regions(t, truth_right=tr, border=0)
    np.testing.assert_array_equal(regions["nonocc"], mask)
    est = np.where(np.isfinite(t), t + (np.arange(t.shape[1]) % 3 == 0) * 1.5, np.nan).astype(np.float32)
    np.save(tmp_path / "est.npy", est)
    code = main(["evaluate-disparity", str(tmp_path / "est.npy"), str(folder / "disp1.png"), "--truth-scale", "2",
                 "--truth-right", str(folder / "disp5.png"), "--border", "0", "--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    got = json.loads(out.out)["nonocc"]
    want = evaluate_disparity(est, t, truth_right=tr, border=0)["nonocc"]
    assert got["pixels"] == int(mask.sum()) == want.pixels
    np.testing.assert_allclose(got["bad"], 100.0 * np.mean(np.abs(est - t)[mask] > 1.0), rtol=RTOL)
    code = main(["evaluate-disparity", str(tmp_path / "est.npy"), str(folder / "disp1.png"), "--truth-scale", "2",
                 "--masks", str(tmp_path), "--border", "0"])
    assert code == 2 and "do not combine it with" in capsys.readouterr().err
