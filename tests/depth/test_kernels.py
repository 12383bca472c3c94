"""Numba kernels of the refinement against slow, obviously correct Python loops."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vergence.depth import _kernels

# float32 sums of at most a few hundred weights in a different order: a few ulps of the values.
WM_ATOL = 1e-4


def _slow_fill_rows(d: np.ndarray) -> np.ndarray:
    out = d.copy()
    h, w = d.shape
    for y in range(h):
        for x in range(w):
            if not math.isnan(d[y, x]):
                continue
            left = next((d[y, u] for u in range(x - 1, -1, -1) if not math.isnan(d[y, u])), math.nan)
            right = next((d[y, u] for u in range(x + 1, w) if not math.isnan(d[y, u])), math.nan)
            vals = [v for v in (left, right) if not math.isnan(v)]
            out[y, x] = min(vals) if vals else math.nan
    return out


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), nan_fraction=st.floats(0.0, 1.0))
def test_fill_background_rows_matches_the_loop(seed, nan_fraction):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0, 50, (7, 23)).astype(np.float32)
    d[rng.random(d.shape) < nan_fraction] = np.nan
    np.testing.assert_array_equal(_kernels.fill_background_rows(d), _slow_fill_rows(d))


def _slow_weighted_median(d, guide, update, support, lut, radius, step, d_min, bin_w, sigma_space=None):
    h, w = d.shape
    out = d.copy()
    n = radius // step
    for y in range(h):
        for x in range(w):
            if not update[y, x]:
                continue
            votes = []
            for i in range(-n, n + 1):
                for j in range(-n, n + 1):
                    v, u = y + i * step, x + j * step
                    if 0 <= v < h and 0 <= u < w and support[v, u]:
                        d2 = int(((guide[y, x].astype(int) - guide[v, u].astype(int)) ** 2).sum())
                        near = 1.0 if sigma_space is None else math.exp(-((v - y) ** 2 + (u - x) ** 2) / (2 * sigma_space**2))
                        votes.append((int((d[v, u] - d_min) / bin_w), lut[d2] * near, d[v, u]))
            if not votes:
                continue
            total = sum(wt for _, wt, _ in votes)
            acc = 0.0
            for b in sorted({b for b, _, _ in votes}):
                in_bin = [(wt, val) for bb, wt, val in votes if bb == b]
                acc += sum(wt for wt, _ in in_bin)
                if acc >= 0.5 * total and sum(wt for wt, _ in in_bin) > 0:
                    out[y, x] = sum(wt * val for wt, val in in_bin) / sum(wt for wt, _ in in_bin)
                    break
    return out


@pytest.mark.parametrize("sigma_space", [None, 1.5, 4.0])
@pytest.mark.parametrize(("radius", "step", "channels"), [(2, 1, 3), (4, 2, 1), (5, 3, 3)])
def test_weighted_median_matches_the_loop(radius, step, channels, sigma_space):
    rng = np.random.default_rng(radius * 10 + step)
    h, w = 14, 19
    d = np.round(rng.uniform(2, 12, (h, w)) * 4).astype(np.float32) / 4 + rng.uniform(0, 0.2, (h, w)).astype(np.float32)
    guide = rng.integers(0, 256, (h, w, channels)).astype(np.uint8)
    update = rng.random((h, w)) < 0.6
    support = rng.random((h, w)) < 0.7
    sigma = 40.0
    lut = np.exp(-np.arange(channels * 255 * 255 + 1) / (2 * sigma * sigma)).astype(np.float32)
    d_min, bin_w = float(d[support].min()), 0.5
    nbins = int((float(d[support].max()) - d_min) / bin_w) + 1
    offsets = np.arange(-(radius // step), radius // step + 1) * step
    dist2 = offsets[:, None] ** 2 + offsets[None, :] ** 2
    space = np.ones(dist2.shape) if sigma_space is None else np.exp(-dist2 / (2 * sigma_space**2))
    fast = _kernels.weighted_median(d, guide, update, support, lut, radius, step, d_min, bin_w, nbins,
                                    space.astype(np.float32))
    slow = _slow_weighted_median(d, guide, update, support, lut, radius, step, d_min, bin_w, sigma_space)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=WM_ATOL)
    np.testing.assert_array_equal(fast[~update], d[~update])
