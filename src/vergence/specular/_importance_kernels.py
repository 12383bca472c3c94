"""Numba kernels of distinctiveness and rivalry (S3 §3.2); callers in :mod:`.importance_factors`,
:mod:`.rivalry_map`.

Both compare a square patch of the left eye's L* around pixel ``(x, y)`` of layer ``n`` with the
patch of the right eye's L* around its match ``(x - dx, y - dy)`` (plus an offset), reading pixel
coordinates outside the image from the nearest border pixel (edge replication).
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["landscape_hessian", "patch_difference"]


@numba.njit(cache=True, inline="always")
def _clamp(v: int, n: int) -> int:
    return 0 if v < 0 else (n - 1 if v >= n else v)


@numba.njit(cache=True, inline="always")
def _ssd(left, right, n, y, x, ry, rx, half):  # noqa: ANN001, ANN202
    """Sum over the ``(2 half + 1)^2`` patch of ``(left[y + u] - right[r + u])^2``."""
    h, w = left.shape[1], left.shape[2]
    s = 0.0
    for uy in range(-half, half + 1):
        ly = _clamp(y + uy, h)
        qy = _clamp(ry + uy, h)
        for ux in range(-half, half + 1):
            d = float(left[n, ly, _clamp(x + ux, w)]) - float(right[n, qy, _clamp(rx + ux, w)])
            s += d * d
    return s


@numba.njit(parallel=True, cache=True)
def landscape_hessian(left, right, disparity, half, radius, wxx, wxy, wyy):  # noqa: ANN001, ANN201
    """Smaller eigenvalue ``(N, H, W)`` float64 of ``[[hxx, hxy], [hxy, hyy]]``, with
    ``hab = sum_o w_ab[o] * alpha(o)`` over the ``(2 radius + 1)^2`` offsets ``o`` of the SSD landscape
    ``alpha(o)`` (patch ``2 half + 1`` squared) at the match; NaN where ``disparity`` is NaN."""
    n_layers, h, w = left.shape
    out = np.full((n_layers, h, w), np.nan)
    for t in numba.prange(n_layers * h):
        n = t // h
        y = t - n * h
        for x in range(w):
            dx = disparity[n, y, x, 0]
            dy = disparity[n, y, x, 1]
            if math.isnan(dx) or math.isnan(dy):
                continue
            mx = x - int(dx)
            my = y - int(dy)
            hxx = 0.0
            hxy = 0.0
            hyy = 0.0
            for oy in range(-radius, radius + 1):
                for ox in range(-radius, radius + 1):
                    a = _ssd(left, right, n, y, x, my + oy, mx + ox, half)
                    hxx += wxx[oy + radius, ox + radius] * a
                    hxy += wxy[oy + radius, ox + radius] * a
                    hyy += wyy[oy + radius, ox + radius] * a
            mean = 0.5 * (hxx + hyy)
            dev = 0.5 * (hxx - hyy)
            out[n, y, x] = mean - math.sqrt(dev * dev + hxy * hxy)
    return out


@numba.njit(parallel=True, cache=True)
def patch_difference(left, right, disparity, half):  # noqa: ANN001, ANN201
    """Mean squared difference over the ``(2 half + 1)^2`` patch at the match, and the absolute
    difference of the two centre pixels, each ``(N, H, W)`` float64; NaN where ``disparity`` is NaN."""
    n_layers, h, w = left.shape
    mean_sq = np.full((n_layers, h, w), np.nan)
    point = np.full((n_layers, h, w), np.nan)
    count = float((2 * half + 1) ** 2)
    for t in numba.prange(n_layers * h):
        n = t // h
        y = t - n * h
        for x in range(w):
            dx = disparity[n, y, x, 0]
            dy = disparity[n, y, x, 1]
            if math.isnan(dx) or math.isnan(dy):
                continue
            mx = x - int(dx)
            my = y - int(dy)
            mean_sq[n, y, x] = _ssd(left, right, n, y, x, my, mx, half) / count
            point[n, y, x] = abs(float(left[n, y, x]) - float(right[n, _clamp(my, h), _clamp(mx, w)]))
    return mean_sq, point
