"""Numba kernels of the per-layer position matching (S3 §3.2); caller in :mod:`.matching`.

All arithmetic on positions is float32, in one fixed order, so that every kernel (and the numpy
reference of the tests) computes bit-identical squared distances:
``d2 = (dx * dx + dy * dy) + dz * dz`` with ``dx = x_right - x_left`` and so on. Positions arrive as
``(N, H, W, 3)`` float32 with no inf (refused by the caller) and NaN where a pixel has no surface:
such a left pixel is skipped, and a right pixel's ``d2`` is NaN, which never wins a comparison.

Tie rule (every kernel): among candidates with the same smallest ``d2``, the first in raster order
of the other eye's image wins (smallest row, then smallest column).
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["match_bounded", "match_exhaustive", "position_bounds", "row_boxes", "window_boxes"]

# A box is 6 float32: min x, min y, min z, max x, max y, max z. An empty box (no finite pixel) has
# min = +inf and max = -inf, so its lower bound is +inf and it is always skipped.
_BOX = 6


@numba.njit(parallel=True, cache=True)
def position_bounds(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """Bounding box of the pixels of ``(N, H, W, 3)`` positions finite on all three coordinates
    (``lo``, ``hi``, each (3,) float64; lo > hi when there is none), the number of values that are
    inf, and ``(N, H)`` bool: whether each row of each layer has such a pixel."""
    n_layers, h, w, _ = positions.shape
    row_lo = np.full((n_layers * h, 3), np.inf)
    row_hi = np.full((n_layers * h, 3), -np.inf)
    row_inf = np.zeros(n_layers * h, dtype=np.int64)
    active = np.zeros((n_layers, h), dtype=np.bool_)
    for t in numba.prange(n_layers * h):
        n = t // h
        y = t - n * h
        lx, ly, lz, hx, hy, hz = np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf
        n_inf = 0
        for x in range(w):
            vx, vy, vz = positions[n, y, x, 0], positions[n, y, x, 1], positions[n, y, x, 2]
            if math.isfinite(vx) and math.isfinite(vy) and math.isfinite(vz):
                lx, ly, lz = min(lx, vx), min(ly, vy), min(lz, vz)
                hx, hy, hz = max(hx, vx), max(hy, vy), max(hz, vz)
            else:
                n_inf += math.isinf(vx) + math.isinf(vy) + math.isinf(vz)
        row_lo[t, 0], row_lo[t, 1], row_lo[t, 2] = lx, ly, lz
        row_hi[t, 0], row_hi[t, 1], row_hi[t, 2] = hx, hy, hz
        row_inf[t] = n_inf
        active[n, y] = lx <= hx
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for t in range(n_layers * h):
        for c in range(3):
            lo[c] = min(lo[c], row_lo[t, c])
            hi[c] = max(hi[c], row_hi[t, c])
    return lo, hi, int(row_inf.sum()), active


@numba.njit(cache=True, inline="always")
def _has_surface(positions: np.ndarray, n: int, y: int, x: int) -> bool:
    """Whether pixel ``(n, y, x)`` has a position (no coordinate NaN; inf was refused before)."""
    vx, vy, vz = positions[n, y, x, 0], positions[n, y, x, 1], positions[n, y, x, 2]
    return vx == vx and vy == vy and vz == vz


@numba.njit(parallel=True, cache=True)
def row_boxes(positions: np.ndarray, block: int) -> np.ndarray:
    """Bounding box ``(N, H, B, 6)`` of the finite pixels of each run of ``block`` columns of each row."""
    n_layers, h, w, _ = positions.shape
    n_blocks = (w + block - 1) // block
    boxes = np.empty((n_layers, h, n_blocks, _BOX), dtype=np.float32)
    inf = np.float32(np.inf)
    for t in numba.prange(n_layers * h):
        n = t // h
        y = t - n * h
        for b in range(n_blocks):
            for c in range(3):
                boxes[n, y, b, c] = inf
                boxes[n, y, b, 3 + c] = -inf
            for x in range(b * block, min(b * block + block, w)):
                if _has_surface(positions, n, y, x):
                    for c in range(3):
                        v = positions[n, y, x, c]
                        boxes[n, y, b, c] = min(boxes[n, y, b, c], v)
                        boxes[n, y, b, 3 + c] = max(boxes[n, y, b, 3 + c], v)
    return boxes


@numba.njit(parallel=True, cache=True)
def window_boxes(boxes: np.ndarray, half_height: int, active: np.ndarray) -> np.ndarray:
    """Union of the row boxes of rows ``y - half_height .. y + half_height`` (clipped), per row ``y``
    where ``active[n, y]`` (the left row has a surface to match; other rows are left unset)."""
    n_layers, h, n_blocks, _ = boxes.shape
    out = np.empty_like(boxes)
    for t in numba.prange(n_layers * h):
        n = t // h
        y = t - n * h
        if not active[n, y]:
            continue
        y0, y1 = max(y - half_height, 0), min(y + half_height, h - 1)
        for b in range(n_blocks):
            for c in range(3):
                lo, hi = boxes[n, y0, b, c], boxes[n, y0, b, 3 + c]
                for yy in range(y0 + 1, y1 + 1):
                    lo = min(lo, boxes[n, yy, b, c])
                    hi = max(hi, boxes[n, yy, b, 3 + c])
                out[n, y, b, c] = lo
                out[n, y, b, 3 + c] = hi
    return out


@numba.njit(cache=True, inline="always")
def _box_bound(boxes: np.ndarray, n: int, y: int, b: int, px: np.float32, py: np.float32, pz: np.float32) -> np.float32:
    """Lower bound of ``d2`` from ``p`` to any pixel in box ``(n, y, b)``, in the float32 form of ``d2``.

    Per axis the gap ``max(lo - p, p - hi, 0)``: for a coordinate ``q`` in ``[lo, hi]``, rounding is
    monotone, so ``fl(lo - p) <= fl(q - p)`` (and alike above), hence gap² <= dq² after rounding and
    the bound never exceeds the ``d2`` of any pixel in the box.
    """
    zero = np.float32(0.0)
    gx = max(boxes[n, y, b, 0] - px, px - boxes[n, y, b, 3], zero)
    gy = max(boxes[n, y, b, 1] - py, py - boxes[n, y, b, 4], zero)
    gz = max(boxes[n, y, b, 2] - pz, pz - boxes[n, y, b, 5], zero)
    return gx * gx + gy * gy + gz * gz


@numba.njit(parallel=True, cache=True)
def match_exhaustive(
    left: np.ndarray, right: np.ndarray, active: np.ndarray, half_width: int, half_height: int, eps2: np.float32
) -> tuple[np.ndarray, np.ndarray]:
    """Every candidate of the window, in raster order: disparity ``(N, H, W, 2)`` and distance ``(N, H, W)``.

    Disparity is ``(x_left - x_right, y_left - y_right)``, distance ``sqrt(d2)`` (float32); NaN
    where no candidate has ``d2 < eps2``. A strict ``<`` in raster order keeps the first of equal
    candidates (the tie rule). Rows with ``active[n, y]`` False (no left surface) are all NaN.
    """
    n_layers, h, w, _ = left.shape
    disp = np.empty((n_layers, h, w, 2), dtype=np.float32)
    dist = np.empty((n_layers, h, w), dtype=np.float32)
    nan = np.float32(np.nan)
    for t in numba.prange(n_layers * h):
        y = t // n_layers  # rows interleave the layers: each thread's share holds all of them
        n = t - y * n_layers
        if not active[n, y]:
            disp[n, y, :, :] = nan
            dist[n, y, :] = nan
            continue
        y0, y1 = max(y - half_height, 0), min(y + half_height, h - 1)
        for x in range(w):
            px, py, pz = left[n, y, x, 0], left[n, y, x, 1], left[n, y, x, 2]
            if not (px == px and py == py and pz == pz):  # a NaN: no surface, never matched
                disp[n, y, x, 0], disp[n, y, x, 1], dist[n, y, x] = nan, nan, nan
                continue
            x0, x1 = max(x - half_width, 0), min(x + half_width, w - 1)
            best, bi, bj = eps2, -1, -1
            for yy in range(y0, y1 + 1):
                for xx in range(x0, x1 + 1):
                    dx = right[n, yy, xx, 0] - px
                    dy = right[n, yy, xx, 1] - py
                    dz = right[n, yy, xx, 2] - pz
                    d2 = dx * dx + dy * dy + dz * dz
                    if d2 < best:
                        best, bi, bj = d2, yy, xx
            if bi >= 0:
                disp[n, y, x, 0], disp[n, y, x, 1], dist[n, y, x] = x - bj, y - bi, np.sqrt(best)
            else:
                disp[n, y, x, 0], disp[n, y, x, 1], dist[n, y, x] = nan, nan, nan
    return disp, dist


@numba.njit(parallel=True, cache=True)
def match_bounded(
    left: np.ndarray,
    right: np.ndarray,
    active: np.ndarray,
    boxes: np.ndarray,
    wboxes: np.ndarray,
    block: int,
    half_width: int,
    half_height: int,
    eps2: np.float32,
) -> tuple[np.ndarray, np.ndarray]:
    """The same result as :func:`match_exhaustive`, found by branch and bound.

    Per left pixel: a first guess (the right pixel one column past the previous pixel's match),
    then the window's column blocks outward from the guess; a block is skipped when the lower bound
    of its window box (``wboxes``: all window rows) exceeds the best ``d2`` so far, a row of it
    when its row box (``boxes``) does; the pixels left are tested exactly. A skipped pixel has
    ``d2 >= bound > best``, so it could neither win nor tie: the minimum and the tie rule are those
    of the exhaustive scan.
    """
    n_layers, h, w, _ = left.shape
    disp = np.empty((n_layers, h, w, 2), dtype=np.float32)
    dist = np.empty((n_layers, h, w), dtype=np.float32)
    nan = np.float32(np.nan)
    for t in numba.prange(n_layers * h):
        y = t // n_layers  # rows interleave the layers: each thread's share holds all of them
        n = t - y * n_layers
        if not active[n, y]:
            disp[n, y, :, :] = nan
            dist[n, y, :] = nan
            continue
        y0, y1 = max(y - half_height, 0), min(y + half_height, h - 1)
        prev_i, prev_j = -1, -1  # the right pixel matched by the previous left pixel of this row
        for x in range(w):
            px, py, pz = left[n, y, x, 0], left[n, y, x, 1], left[n, y, x, 2]
            if not (px == px and py == py and pz == pz):  # a NaN: no surface, never matched
                disp[n, y, x, 0], disp[n, y, x, 1], dist[n, y, x] = nan, nan, nan
                prev_j = -1
                continue
            x0, x1 = max(x - half_width, 0), min(x + half_width, w - 1)
            best, bi, bj = eps2, -1, -1
            guess = x
            if prev_j >= 0:
                guess = min(max(prev_j + 1, x0), x1)
                dx = right[n, prev_i, guess, 0] - px
                dy = right[n, prev_i, guess, 1] - py
                dz = right[n, prev_i, guess, 2] - pz
                d2 = dx * dx + dy * dy + dz * dz
                if d2 < best:
                    best, bi, bj = d2, prev_i, guess
            b_lo, b_hi = x0 // block, x1 // block
            centre = guess // block
            span = max(centre - b_lo, b_hi - centre)
            for k in range(2 * span + 1):
                off = (k + 1) // 2
                b = centre + off if k % 2 == 1 else centre - off  # centre, +1, -1, +2, -2, ...
                if b < b_lo or b > b_hi:
                    continue
                if _box_bound(wboxes, n, y, b, px, py, pz) > best:
                    continue
                xs, xe = max(b * block, x0), min(b * block + block - 1, x1)
                for yy in range(y0, y1 + 1):
                    if _box_bound(boxes, n, yy, b, px, py, pz) > best:
                        continue
                    for xx in range(xs, xe + 1):
                        dx = right[n, yy, xx, 0] - px
                        dy = right[n, yy, xx, 1] - py
                        dz = right[n, yy, xx, 2] - pz
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 < best or (d2 == best and bi >= 0 and (yy < bi or (yy == bi and xx < bj))):
                            best, bi, bj = d2, yy, xx
            if bi >= 0:
                disp[n, y, x, 0], disp[n, y, x, 1], dist[n, y, x] = x - bj, y - bi, np.sqrt(best)
                prev_i, prev_j = bi, bj
            else:
                disp[n, y, x, 0], disp[n, y, x, 1], dist[n, y, x] = nan, nan, nan
                prev_j = -1
    return disp, dist
