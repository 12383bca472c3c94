"""Gradient-domain disparity mapping of a disparity map (Lang et al. 2010)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.viewing.mapping_gradient import _solve_sparse, gradient_domain_mapping

# Exact solves (DCT or sparse direct) on disparities of order 10 and a few hundred pixels.
EXACT = 1e-9


def test_spec_example_jump_compressed_detail_kept():
    # Lang et al. 2010's gradient operator: detail slopes + a 10-px jump, x0.2 above |g| > 1.
    profile = np.concatenate([np.linspace(0.0, 3.0, 50), np.linspace(13.0, 16.0, 50)])
    out = gradient_domain_mapping(profile, threshold=1.0, scale=0.2)
    assert out[50] - out[49] == pytest.approx(2.0, abs=EXACT)
    assert_allclose(np.diff(out[:50]), np.diff(profile[:50]), atol=EXACT)
    assert_allclose(np.diff(out[50:]), np.diff(profile[50:]), atol=EXACT)
    assert out.mean() == pytest.approx(profile.mean(), abs=EXACT)  # the anchor


def test_slow_reference_dense_least_squares():
    # Independent reference: dense lstsq of [grad; mean row] on a small 2-D map with a ramp and a step.
    rng = np.random.default_rng(7)
    d = rng.normal(scale=0.3, size=(6, 7)) + np.where(np.arange(7) >= 4, 8.0, 0.0)
    d[0, 0] += 5.0  # a non-integrable jump: the solution is a least-squares compromise
    h, w = d.shape
    rows, rhs = [], []
    idx = np.arange(h * w).reshape(h, w)
    for (p, q) in [(idx[i, j], idx[i, j + 1]) for i in range(h) for j in range(w - 1)] + [
        (idx[i, j], idx[i + 1, j]) for i in range(h - 1) for j in range(w)
    ]:
        row = np.zeros(h * w)
        row[p], row[q] = -1.0, 1.0
        g = d.flat[q] - d.flat[p]
        rows.append(row)
        rhs.append(0.2 * g if abs(g) > 1.0 else g)
    rows.append(np.full(h * w, 1.0 / (h * w)))
    rhs.append(d.mean())
    ref = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0].reshape(h, w)
    assert_allclose(gradient_domain_mapping(d, threshold=1.0, scale=0.2), ref, atol=EXACT)  # DCT path
    assert_allclose(_solve_sparse(d, np.ones(d.shape, bool), 1.0, 0.2), ref, atol=EXACT)  # sparse path


def test_step_edge_in_2d_is_reproduced_exactly():
    # A vertical step (integrable after compression): every row becomes the compressed profile.
    d = np.tile(np.where(np.arange(20) >= 10, 10.0, 0.0) + 0.05 * np.arange(20), (8, 1))
    out = gradient_domain_mapping(d, threshold=1.0, scale=0.5)
    assert_allclose(out[:, 10] - out[:, 9], 0.5 * 10.05, atol=EXACT)  # (10 + 0.05) x 0.5
    assert_allclose(np.diff(out[:, :10], axis=1), 0.05, atol=EXACT)
    assert_allclose(np.diff(out, axis=0), 0.0, atol=EXACT)


def test_nan_pixels_stay_nan_and_each_region_keeps_its_mean():
    d = np.array([[0.0, 5.0, np.nan, 20.0, 21.0], [0.5, 5.5, np.nan, 20.5, 21.5]])
    out = gradient_domain_mapping(d, threshold=1.0, scale=0.2)
    assert np.isnan(out[:, 2]).all()
    left, right = out[:, :2], out[:, 3:]
    assert left.mean() == pytest.approx(d[:, :2].mean(), abs=EXACT)
    assert right.mean() == pytest.approx(d[:, 3:].mean(), abs=EXACT)
    assert_allclose(left[:, 1] - left[:, 0], 1.0, atol=EXACT)  # the 5-px jump becomes 1 px
    assert_allclose(right[:, 1] - right[:, 0], 1.0, atol=EXACT)  # small gradients kept


def test_shape_dtype_and_isolated_pixel():
    d = np.array([[1.0, np.nan], [np.nan, 3.0]], dtype=np.float32)
    out = gradient_domain_mapping(d, threshold=1.0, scale=0.2)
    assert out.shape == (2, 2) and out.dtype == np.float64
    assert_allclose(out[[0, 1], [0, 1]], [1.0, 3.0])  # lone pixels keep their value


@pytest.mark.parametrize(
    ("disparity", "kwargs", "match"),
    [
        (np.zeros((2, 2, 2)), {}, r"disparity must have shape \(N,\) or \(H, W\)"),
        (np.zeros((0, 3)), {}, "not be empty"),
        (np.array([0.0, np.inf]), {}, "must not contain inf"),
        (np.zeros(3), {"threshold": 0.0}, "threshold must be > 0"),
        (np.zeros(3), {"scale": -1.0}, "scale must be > 0"),
        # issue 9: an all-NaN map gave an all-NaN map back, a 1e308 one numpy overflow warnings
        (np.full((2, 3), np.nan), {}, r"^disparity must hold at least one valid \(not NaN\) value; got 6 NaN$"),
        (np.array([0.0, 1e308, -1e308]), {}, r"^disparity must lie in \[-1e\+30, 1e\+30\]; got 1e\+308$"),
        (np.zeros(3), {"scale": 1e308}, r"^scale must lie in \[1e-06, 1e\+06\]; got 1e\+308$"),
    ],
)
def test_bad_input(disparity, kwargs, match):
    args = {"threshold": 1.0, "scale": 0.2} | kwargs
    with pytest.raises(ValueError, match=match):
        gradient_domain_mapping(disparity, **args)


def test_text_is_not_a_disparity_map():
    with pytest.raises(TypeError, match="^disparity must be numeric; got list$"):
        gradient_domain_mapping(["1", "2"], threshold=1.0, scale=0.2)
