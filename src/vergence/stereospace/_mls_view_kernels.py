"""Numba kernels of S2's novel view (:func:`vergence.stereospace.s2_view`): the angle penalty on a
proxy plane and the ULR blend. The public function validates; the kernels trust their inputs.
Their slow, obviously-correct numpy twins are in ``tests/stereospace/test_mls_view.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from vergence.synthesis._ibr_kernels import lift

__all__ = ["blend", "proxy_angles"]


@nb.njit(cache=True, parallel=True)
def proxy_angles(Kinv, R, t, centre, centres, depth, out):  # pragma: no cover - compiled
    """``out[i, y, x]``: the angle between ``centre - P`` and ``centres[i] - P``, P being the world
    point ``R^T (depth K^-1 (x, y, 1) - t)`` of the target pixel (S2 §3.1 Eq. (4), P_ANG)."""
    s_count, h, w = out.shape
    for y in nb.prange(h):
        for x in range(w):
            px, py, pz = lift(Kinv, R, t, x, y, depth)
            nx, ny, nz = centre[0] - px, centre[1] - py, centre[2] - pz
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            for i in range(s_count):
                cx, cy, cz = centres[i, 0] - px, centres[i, 1] - py, centres[i, 2] - pz
                cn = math.sqrt(cx * cx + cy * cy + cz * cz)
                c = (nx * cx + ny * cy + nz * cz) / (nn * cn)
                out[i, y, x] = math.acos(min(1.0, max(-1.0, c)))


@nb.njit(cache=True, parallel=True)
def blend(warped, penalty, k, scale, image, weights):  # pragma: no cover - compiled
    """ULR blend (Buehler et al. 2001) of ``warped (S, h, w, C)`` with ``penalty (S, h, w)`` (inf:
    no sample): with m >= k finite penalties, ``w_i = max(0, 1 - P_i / (scale P_(k)))``, ``P_(k)``
    the k-th smallest; with 0 < m < k, equal weights; normalised. Writes ``image (h, w, C)`` and
    ``weights (S, h, w)`` (all 0 where m = 0)."""
    s_count, h, w, n_ch = warped.shape
    for y in nb.prange(h):
        pen = np.empty(s_count)
        for x in range(w):
            m = 0
            for i in range(s_count):
                pen[i] = penalty[i, y, x]
                if pen[i] < np.inf:
                    m += 1
            total = 0.0
            if m >= k:
                for i in range(1, s_count):  # insertion sort of at most a few penalties
                    v = pen[i]
                    j = i - 1
                    while j >= 0 and pen[j] > v:
                        pen[j + 1] = pen[j]
                        j -= 1
                    pen[j + 1] = v
                thresh = scale * pen[k - 1]
                for i in range(s_count):
                    wi = 1.0 - penalty[i, y, x] / thresh if penalty[i, y, x] < np.inf else 0.0
                    weights[i, y, x] = max(0.0, wi)
                    total += weights[i, y, x]
            else:
                for i in range(s_count):
                    weights[i, y, x] = 1.0 if penalty[i, y, x] < np.inf else 0.0
                    total += weights[i, y, x]
            for c in range(n_ch):
                image[y, x, c] = 0.0
            if total > 0.0:
                for i in range(s_count):
                    weights[i, y, x] /= total
                    wi = weights[i, y, x]
                    if wi > 0.0:
                        for c in range(n_ch):
                            image[y, x, c] += wi * warped[i, y, x, c]
