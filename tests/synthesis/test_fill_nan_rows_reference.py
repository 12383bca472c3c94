"""``synthesis._kernels.fill_nan_rows`` against a slow, obviously correct Python loop."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vergence.synthesis import _kernels


def _slow_fill_nan_rows(d: np.ndarray) -> np.ndarray:
    """Each NaN takes the smaller of the nearest known values left and right on its row (the one
    there is at a border); a row with no known value stays NaN."""
    out = d.copy()
    h, w = d.shape
    for y in range(h):
        for x in range(w):
            if not math.isnan(d[y, x]):
                continue
            left = next((d[y, u] for u in range(x - 1, -1, -1) if not math.isnan(d[y, u])), math.nan)
            right = next((d[y, u] for u in range(x + 1, w) if not math.isnan(d[y, u])), math.nan)
            known = [v for v in (left, right) if not math.isnan(v)]
            out[y, x] = min(known) if known else math.nan
    return out


def test_hand_case():
    d = np.array([[np.nan, 3.0, np.nan, np.nan, 1.0, np.nan], [np.nan] * 6], np.float32)
    out = np.empty_like(d)
    _kernels.fill_nan_rows(d, out)
    np.testing.assert_array_equal(out, [[3.0, 3.0, 1.0, 1.0, 1.0, 1.0], [np.nan] * 6])


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), nan_fraction=st.floats(0.0, 1.0))
def test_fill_nan_rows_matches_the_loop(seed, nan_fraction):
    rng = np.random.default_rng(seed)
    d = rng.uniform(-5, 50, (6, 19)).astype(np.float32)
    d[rng.random(d.shape) < nan_fraction] = np.nan
    out = np.empty_like(d)
    _kernels.fill_nan_rows(d, out)
    np.testing.assert_array_equal(out, _slow_fill_nan_rows(d))
