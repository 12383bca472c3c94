"""Numba kernels of :mod:`vergence.video` (the public functions validate, then call these)."""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, parallel=True)
def stabilize_kernel(previous_grey: np.ndarray, grey: np.ndarray, previous: np.ndarray, disparity: np.ndarray,
                     threshold: float, alpha: float) -> np.ndarray:  # fmt: skip
    """Colour-gated recursive filter of a disparity map; see :func:`vergence.video.stabilize_disparity`."""
    h, w = disparity.shape
    out = np.empty((h, w), np.float32)
    for y in nb.prange(h):
        for x in range(w):
            d = disparity[y, x]
            p = previous[y, x]
            if abs(grey[y, x] - previous_grey[y, x]) <= threshold and np.isfinite(p):
                out[y, x] = p + alpha * (d - p) if np.isfinite(d) else p
            else:
                out[y, x] = d
    return out


@nb.njit(cache=True, parallel=True)
def grey_kernel(frame: np.ndarray) -> np.ndarray:
    """Mean of R, G, B of a float32 ``(H, W, 3)`` frame, summed in float32 in :func:`grey_levels`' order."""
    h, w = frame.shape[0], frame.shape[1]
    out = np.empty((h, w), np.float32)
    third = np.float32(1.0 / 3.0)
    for y in nb.prange(h):
        for x in range(w):
            out[y, x] = (frame[y, x, 0] + frame[y, x, 1] + frame[y, x, 2]) * third
    return out


@nb.njit(cache=True, parallel=True)
def unit_float_kernel(rgb: np.ndarray) -> np.ndarray:
    """uint8 ``(H, W, C)`` to float32 ``v / 255`` (the bits of ``rgb.astype(float32) / float32(255)``)."""
    h, w, c = rgb.shape
    out = np.empty((h, w, c), np.float32)
    scale = np.float32(255.0)
    for y in nb.prange(h):
        for x in range(w):
            for k in range(c):
                out[y, x, k] = np.float32(rgb[y, x, k]) / scale
    return out


@nb.njit(cache=True, parallel=True)
def to_uint8_kernel(src: np.ndarray, out: np.ndarray) -> None:
    """``out = rint(clip(src, 0, 1) * 255)`` as uint8 (NaN -> 0), for float32 ``(H, W, C)`` views."""
    h, w, c = src.shape
    scale = np.float32(255.0)
    for y in nb.prange(h):
        for x in range(w):
            for k in range(c):
                v = src[y, x, k]
                if not v > 0.0:
                    v = np.float32(0.0)
                elif v > 1.0:
                    v = np.float32(1.0)
                out[y, x, k] = np.uint8(np.rint(v * scale))


@nb.njit(cache=True)
def _flicker_row(previous_grey, grey, previous, disparity, threshold):  # pragma: no cover - compiled
    s = 0.0
    n = 0
    for x in range(disparity.shape[0]):
        if abs(grey[x] - previous_grey[x]) <= threshold:
            change = abs(disparity[x] - previous[x])
            if np.isfinite(change):
                s += change
                n += 1
    return s, n


@nb.njit(cache=True, parallel=True)
def flicker_kernel(previous_grey: np.ndarray, grey: np.ndarray, previous: np.ndarray, disparity: np.ndarray,
                   threshold: np.float32) -> tuple[float, int]:  # fmt: skip
    """Sum and count of ``|D_t - D_{t-1}|`` over static (grey change <= threshold, in float32), known pixels.

    One row per call of ``_flicker_row``: accumulating in the ``prange`` body trips Numba 0.68.0's
    reduction analysis ("unexpected cycle in lookup()").
    """
    h = disparity.shape[0]
    sums = np.zeros(h, np.float64)
    counts = np.zeros(h, np.int64)
    for y in nb.prange(h):
        s, n = _flicker_row(previous_grey[y], grey[y], previous[y], disparity[y], threshold)
        sums[y] = s
        counts[y] = n
    return sums.sum(), counts.sum()


@nb.njit(cache=True, parallel=True)
def rgbd_kernel(rgbd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An iw3 RGBD uint8 frame ``(H, 2W, 3)`` to its colour, float32 ``(H, W, 3)`` ``v / 255``, and its depth
    half's grey level, float32 ``(H, W)``: the bits of :func:`unit_float_kernel` then :func:`grey_kernel`."""
    h, w = rgbd.shape[0], rgbd.shape[1] // 2
    image = np.empty((h, w, 3), np.float32)
    grey = np.empty((h, w), np.float32)
    scale = np.float32(255.0)
    third = np.float32(1.0 / 3.0)
    for y in nb.prange(h):
        for x in range(w):
            for k in range(3):
                image[y, x, k] = np.float32(rgbd[y, x, k]) / scale
            r = np.float32(rgbd[y, w + x, 0]) / scale
            g = np.float32(rgbd[y, w + x, 1]) / scale
            b = np.float32(rgbd[y, w + x, 2]) / scale
            grey[y, x] = (r + g + b) * third
    return image, grey
