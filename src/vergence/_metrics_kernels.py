"""Numba kernels for :func:`vergence.metrics.registration_error` (validated inputs only).

The patch similarity of every pixel with every candidate offset is computed offset by offset with
separable box sums: for an offset ``o``, the per-pixel product ``sum_c a_c(q) b_c(q + o)`` is summed
over each k x k patch (a row pass then a column pass), which costs O(C + 2k) per pixel and offset
instead of O(C k^2). The patch sums of ``a`` and ``a^2`` come from the same passes, in the same
order, so a patch compared with itself has a ZNCC of 1 up to one rounding of the inverse
deviations (far below the tie tolerance).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

__all__ = ["patch_sums", "registration_search"]

SIMILARITY_ZNCC = 0
SIMILARITY_SSD = 1
# Output rows per thread task: the k - 1 extra rows of each band are recomputed (4/32 for 5 x 5).
BAND = 32


@numba.njit(cache=True, parallel=True)
def patch_sums(img_pad: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel patch sums of each channel ``(H, W, C)`` and of all squares ``(H, W)``.

    ``img_pad`` is the image padded by ``k // 2`` on each side, ``(H + k - 1, W + k - 1, C)``.
    The sum of squares follows the exact order of :func:`registration_search` (channels, then the
    patch row, then the patch column) so that identical patches give bit-identical sums.
    """
    hp, wp, nc = img_pad.shape
    height, width = hp - k + 1, wp - k + 1
    sums = np.zeros((height, width, nc))
    squares = np.zeros((height, width))
    prod = np.empty((hp, wp))
    rowsum = np.empty((hp, width))
    for u in prange(hp):
        for v in range(wp):
            s = 0.0
            for c in range(nc):
                s += img_pad[u, v, c] * img_pad[u, v, c]
            prod[u, v] = s
        for x in range(width):
            s = 0.0
            for q in range(k):
                s += prod[u, x + q]
            rowsum[u, x] = s
    for y in prange(height):
        for x in range(width):
            s = 0.0
            for q in range(k):
                s += rowsum[y + q, x]
            squares[y, x] = s
            for c in range(nc):
                t = 0.0
                for qy in range(k):
                    for qx in range(k):
                        t += img_pad[y + qy, x + qx, c]
                sums[y, x, c] = t
    return sums, squares


@numba.njit(cache=True, parallel=True)
def _inverse_deviations(sums: np.ndarray, squares: np.ndarray, n: float, flat_variance: float) -> np.ndarray:
    """``1 / sqrt(sum of squared deviations)`` of each patch, 0 for a flat patch (<= flat_variance)."""
    height, width, nc = sums.shape
    out = np.zeros((height, width))
    for y in prange(height):
        for x in range(width):
            mean_term = 0.0
            for c in range(nc):
                mean_term += sums[y, x, c] * sums[y, x, c]
            variance = squares[y, x] - mean_term / n
            if variance > flat_variance:
                out[y, x] = 1.0 / np.sqrt(variance)
    return out


@numba.njit(cache=True, parallel=True)
def registration_search(
    a_pad: np.ndarray,
    b_pad: np.ndarray,
    sums_a: np.ndarray,
    squares_a: np.ndarray,
    sums_b: np.ndarray,
    squares_b: np.ndarray,
    offsets: np.ndarray,
    distances: np.ndarray,
    k: int,
    similarity: int,
    flat_variance: float,
    tie_tolerance: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Best similarity and its distance for each pixel of ``a`` over the candidate offsets (S1 Eq. 11).

    Offsets ``(dy, dx)`` are visited in the given order (ascending distance), and a candidate
    replaces the best one only when its similarity exceeds it by more than ``tie_tolerance``: ties go
    to the nearest candidate. Candidates outside ``b`` are skipped. ZNCC: two flat patches (sum of
    squared deviations <= ``flat_variance``) score 1, one flat patch 0. SSD: minus the mean squared
    difference over the patch and channels. Threads own bands of ``BAND`` output rows and loop over
    all offsets inside their band (one parallel region; the band stays in cache).
    """
    hp, wp, nc = a_pad.shape
    height, width = hp - k + 1, wp - k + 1
    n = float(k * k)
    best = np.full((height, width), -np.inf)
    best_distance = np.zeros((height, width))
    isd_a = _inverse_deviations(sums_a, squares_a, n, flat_variance)
    isd_b = _inverse_deviations(sums_b, squares_b, n, flat_variance)
    n_bands = (height + BAND - 1) // BAND
    for band in prange(n_bands):
        ys, ye = band * BAND, min(height, (band + 1) * BAND)
        prod = np.empty((BAND + k - 1, wp))
        rowsum = np.empty((BAND + k - 1, width))
        for o in range(offsets.shape[0]):
            dy, dx = offsets[o, 0], offsets[o, 1]
            y0, y1 = max(ys, -dy), min(ye, height - dy)
            x0, x1 = max(0, -dx), min(width, width - dx)
            if y0 >= y1 or x0 >= x1:
                continue
            dist = distances[o]
            for u in range(y0, y1 + k - 1):
                lu = u - ys
                for v in range(x0, x1 + k - 1):
                    s = 0.0
                    for c in range(nc):
                        s += a_pad[u, v, c] * b_pad[u + dy, v + dx, c]
                    prod[lu, v] = s
                for x in range(x0, x1):
                    s = 0.0
                    for q in range(k):
                        s += prod[lu, x + q]
                    rowsum[lu, x] = s
            for y in range(y0, y1):
                ly = y - ys
                for x in range(x0, x1):
                    cross = 0.0
                    for q in range(k):
                        cross += rowsum[ly + q, x]
                    yb, xb = y + dy, x + dx
                    if similarity == SIMILARITY_ZNCC:
                        mean_term = 0.0
                        for c in range(nc):
                            mean_term += sums_a[y, x, c] * sums_b[yb, xb, c]
                        ia, ib = isd_a[y, x], isd_b[yb, xb]
                        if ia == 0.0 and ib == 0.0:
                            sim = 1.0
                        elif ia == 0.0 or ib == 0.0:
                            sim = 0.0
                        else:  # Cauchy-Schwarz bounds ZNCC by 1: min() removes rounding only
                            sim = min((cross - mean_term / n) * ia * ib, 1.0)
                    else:
                        ssd = squares_a[y, x] + squares_b[yb, xb] - 2.0 * cross
                        sim = -max(ssd, 0.0) / (n * nc)  # ssd >= 0: rounding only
                    if sim > best[y, x] + tie_tolerance:
                        best[y, x] = sim
                        best_distance[y, x] = dist
    return best, best_distance
