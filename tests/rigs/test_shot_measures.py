"""The figures of ``vergence rig render``'s report, on hand-made images whose answers are worked out here."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vergence.rigs.shoot import measure_against_truth


def test_filled_figure_fills_each_hole_run_from_its_farther_side():
    # A 20 x 30 grey truth; the synthesis is exact but leaves columns 10-14 of every row as holes. The
    # proxy puts the left neighbour (column 9) at 2 m and the right one (column 15) at 5 m: the holes
    # take column 15's colour (the farther side). Truth 0.5 everywhere except column 15, 0.8, so each
    # filled pixel is 0.3 off: MSE = 5 * 0.09 / 30 over the whole image.
    truth = np.full((20, 30, 3), 0.5, dtype=np.float32)
    truth[:, 15] = 0.8
    image = truth.copy()
    coverage = np.ones((20, 30), dtype=bool)
    coverage[:, 10:15] = False
    image[~coverage] = 0.0
    depth = np.full((20, 30), 3.0)
    depth[:, :10] = 2.0
    depth[:, 15:] = 5.0
    depth[~coverage] = np.nan
    m = measure_against_truth(image, truth, coverage, depth)
    assert m["psnr"] is None  # exact where covered
    assert m["coverage"] == pytest.approx(25 / 30)
    assert m["psnr_filled"] == pytest.approx(10 * math.log10(1 / (5 * 0.09 / 30)), abs=1e-3)
    # The nearer side instead would be exact: the rule is what makes the figure, so the test pins it.
    depth[:, :10], depth[:, 15:] = 5.0, 2.0
    assert measure_against_truth(image, truth, coverage, depth)["psnr_filled"] is None


def test_dropping_pixels_does_not_raise_the_filled_figure():
    rng = np.random.default_rng(0)
    truth = rng.random((24, 32, 3)).astype(np.float32)
    image = np.clip(truth + rng.normal(0, 0.02, truth.shape), 0, 1).astype(np.float32)
    depth = np.full((24, 32), 4.0)
    full = np.ones((24, 32), dtype=bool)
    dropped = full.copy()
    dropped[:, 5:20] = False  # the worst way to gain PSNR over covered pixels: drop them
    a = measure_against_truth(image, truth, full, depth)
    b = measure_against_truth(np.where(dropped[..., None], image, 0), truth, dropped, depth)
    assert b["psnr"] == pytest.approx(a["psnr"], abs=0.3)  # over the covered pixels: no worse
    assert b["psnr_filled"] < a["psnr_filled"] - 5
