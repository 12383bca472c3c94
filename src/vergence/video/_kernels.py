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
