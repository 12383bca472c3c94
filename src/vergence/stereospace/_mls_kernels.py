"""Numba kernel of the moving-least-squares similarity deformation (Schaefer, McPhail, Warren 2006).

:func:`vergence.stereospace.mls_similarity` validates its inputs and calls this; the kernel trusts
them: float64 C-contiguous ``points (N, 2)``, ``src (M, 2)`` with M >= 2 distinct rows, ``dst (M, 2)``,
``alpha > 0``. Its slow, obviously-correct twin is in ``tests/stereospace/test_mls.py``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["mls_similarity_points"]


@nb.njit(cache=True, parallel=True, error_model="numpy")
def mls_similarity_points(points, src, dst, alpha, out):  # pragma: no cover - compiled
    """``out[k] = f_s(points[k])`` for the handles ``src -> dst`` (Schaefer et al. 2006 §2.2,
    similarity deformations, in its complex closed form ``f(v) = (v - p*) a + q*`` with
    ``a = sum w conj(p^) q^ / sum w |p^|^2``).

    The weights ``w_i = |p_i - v|^(-2 alpha)`` are scaled by ``min_j |p_j - v|^(2 alpha)`` (every
    ratio in the formula is unchanged) so that they lie in [0, 1] and cannot overflow near a
    handle; a point on a handle returns that handle's target exactly (the limit of the formula).
    """
    n = points.shape[0]
    m = src.shape[0]
    for k in nb.prange(n):
        vx = points[k, 0]
        vy = points[k, 1]
        # pass 1: the nearest handle
        dmin = np.inf
        imin = 0
        for i in range(m):
            dx = src[i, 0] - vx
            dy = src[i, 1] - vy
            d2 = dx * dx + dy * dy
            if d2 < dmin:
                dmin = d2
                imin = i
        if dmin == 0.0:
            out[k, 0] = dst[imin, 0]
            out[k, 1] = dst[imin, 1]
            continue
        # pass 2: weighted centroids p*, q*
        sw = 0.0
        spx = 0.0
        spy = 0.0
        sqx = 0.0
        sqy = 0.0
        for i in range(m):
            dx = src[i, 0] - vx
            dy = src[i, 1] - vy
            r = dmin / (dx * dx + dy * dy)
            w = r if alpha == 1.0 else r**alpha
            sw += w
            spx += w * src[i, 0]
            spy += w * src[i, 1]
            sqx += w * dst[i, 0]
            sqy += w * dst[i, 1]
        psx = spx / sw
        psy = spy / sw
        qsx = sqx / sw
        qsy = sqy / sw
        # pass 3: mu = sum w |p^|^2 and sum w conj(p^) q^
        mu = 0.0
        ar = 0.0
        ai = 0.0
        for i in range(m):
            dx = src[i, 0] - vx
            dy = src[i, 1] - vy
            r = dmin / (dx * dx + dy * dy)
            w = r if alpha == 1.0 else r**alpha
            phx = src[i, 0] - psx
            phy = src[i, 1] - psy
            qhx = dst[i, 0] - qsx
            qhy = dst[i, 1] - qsy
            mu += w * (phx * phx + phy * phy)
            ar += w * (phx * qhx + phy * qhy)
            ai += w * (phx * qhy - phy * qhx)
        if not mu > 0.0:
            # v so close to one handle that the others' weights underflow: the limit is q_nearest
            out[k, 0] = dst[imin, 0]
            out[k, 1] = dst[imin, 1]
            continue
        ar /= mu
        ai /= mu
        ux = vx - psx
        uy = vy - psy
        out[k, 0] = ux * ar - uy * ai + qsx
        out[k, 1] = ux * ai + uy * ar + qsy
