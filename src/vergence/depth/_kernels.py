"""Numba kernels of the disparity refinement; the public functions in ``refine.py`` validate first.

Each kernel has a slow, obviously correct reference in ``tests/depth/test_kernels.py``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["fill_background_rows", "weighted_median"]


@numba.njit(parallel=True, cache=True)
def fill_background_rows(disp: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Replace each NaN by the smaller (farther) of the nearest known values left and right on its row.

    A NaN with a known value on one side only takes that value; a row with no known value stays NaN.
    """
    h, w = disp.shape
    out = disp.copy()
    for y in numba.prange(h):
        left = np.empty(w, disp.dtype)
        last = np.nan
        for x in range(w):
            if not math.isnan(disp[y, x]):
                last = disp[y, x]
            left[x] = last
        last = np.nan
        for x in range(w - 1, -1, -1):
            v = disp[y, x]
            if not math.isnan(v):
                last = v
                continue
            a = left[x]
            if math.isnan(a):
                out[y, x] = last
            elif math.isnan(last):
                out[y, x] = a
            else:
                out[y, x] = min(a, last)
    return out


@numba.njit(parallel=True, cache=True)
def weighted_median(
    disp: np.ndarray,
    guide: np.ndarray,
    update: np.ndarray,
    support: np.ndarray,
    weight_lut: np.ndarray,
    radius: int,
    step: int,
    d_min: float,
    bin_width: float,
    nbins: int,
) -> np.ndarray:  # pragma: no cover - compiled
    """Colour-weighted median of ``disp`` over a sparse window, at the pixels where ``update`` is set.

    Samples ``(y + i*step, x + j*step)`` for ``|i*step|, |j*step| <= radius`` that lie in the image and
    in ``support`` vote with weight ``weight_lut[|I_p - I_q|^2]`` (guide in integer levels). Votes are
    binned by ``bin_width`` from ``d_min`` into ``nbins`` bins (which must cover every supporting
    value); the result is the mean of the votes in the bin where the cumulative
    weight first reaches half the total. Pixels with no supporting sample keep their value.
    """
    h, w = disp.shape
    c = guide.shape[2]
    n = radius // step
    out = disp.copy()
    for y in numba.prange(h):
        hist = np.zeros(nbins, np.float32)
        hsum = np.zeros(nbins, np.float32)
        for x in range(w):
            if not update[y, x]:
                continue
            lo = nbins
            hi = -1
            for i in range(-n, n + 1):
                v = y + i * step
                if v < 0 or v >= h:
                    continue
                for j in range(-n, n + 1):
                    u = x + j * step
                    if u < 0 or u >= w or not support[v, u]:
                        continue
                    b = int((disp[v, u] - d_min) / bin_width)
                    lo = min(lo, b)
                    hi = max(hi, b)
            if hi < 0:
                continue
            for b in range(lo, hi + 1):
                hist[b] = 0.0
                hsum[b] = 0.0
            total = 0.0
            for i in range(-n, n + 1):
                v = y + i * step
                if v < 0 or v >= h:
                    continue
                for j in range(-n, n + 1):
                    u = x + j * step
                    if u < 0 or u >= w or not support[v, u]:
                        continue
                    d2 = 0
                    for k in range(c):
                        t = np.int32(guide[y, x, k]) - np.int32(guide[v, u, k])
                        d2 += t * t
                    wt = weight_lut[d2]
                    b = int((disp[v, u] - d_min) / bin_width)
                    hist[b] += wt
                    hsum[b] += wt * disp[v, u]
                    total += wt
            half = 0.5 * total
            acc = 0.0
            for b in range(lo, hi + 1):
                acc += hist[b]
                if acc >= half and hist[b] > 0.0:
                    out[y, x] = hsum[b] / hist[b]
                    break
    return out
