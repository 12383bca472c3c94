"""Numba kernel of the moving-least-squares similarity deformation (Schaefer, McPhail, Warren 2006).

:func:`vergence.stereospace.mls_similarity` validates its inputs and calls this; the kernel trusts
them: float64 C-contiguous ``points (N, 2)``, ``src (M, 2)`` with M >= 2 distinct rows, ``dst (M, 2)``,
``alpha > 0``. Its slow, obviously-correct twin is in ``tests/stereospace/test_mls.py``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["interpolate_grid", "mls_similarity_points"]


# Points per parallel task: each task owns one scratch buffer of per-handle weights.
_BLOCK = 64


@nb.njit(cache=True, parallel=True, error_model="numpy", fastmath={"reassoc", "contract"})
def mls_similarity_points(points, src, dst, alpha, out):  # pragma: no cover - compiled
    """``out[k] = f_s(points[k])`` for the handles ``src -> dst`` (Schaefer et al. 2006 §2.2,
    similarity deformations, in its complex closed form ``f(v) = (v - p*) a + q*`` with
    ``a = sum w conj(p^) q^ / sum w |p^|^2``).

    The weights ``w_i = |p_i - v|^(-2 alpha)`` are scaled by ``min_j |p_j - v|^(2 alpha)`` (every
    ratio in the formula is unchanged) so that they lie in [0, 1] and cannot overflow near a
    handle; a point on a handle returns that handle's target exactly (the limit of the formula).
    Sums may be reassociated (SIMD); they hold at most a few thousand terms.
    """
    n = points.shape[0]
    m = src.shape[0]
    px = np.ascontiguousarray(src[:, 0])
    py = np.ascontiguousarray(src[:, 1])
    qx = np.ascontiguousarray(dst[:, 0])
    qy = np.ascontiguousarray(dst[:, 1])
    n_blocks = (n + _BLOCK - 1) // _BLOCK
    for b in nb.prange(n_blocks):
        w = np.empty(m)
        for k in range(b * _BLOCK, min(n, (b + 1) * _BLOCK)):
            vx = points[k, 0]
            vy = points[k, 1]
            # pass 1: squared distances and the nearest handle
            dmin = np.inf
            imin = 0
            for i in range(m):
                dx = px[i] - vx
                dy = py[i] - vy
                d2 = dx * dx + dy * dy
                w[i] = d2
                if d2 < dmin:
                    dmin = d2
                    imin = i
            if dmin == 0.0:
                out[k, 0] = qx[imin]
                out[k, 1] = qy[imin]
                continue
            # pass 2: weights and the weighted centroids p*, q*
            sw = 0.0
            spx = 0.0
            spy = 0.0
            sqx = 0.0
            sqy = 0.0
            if alpha == 1.0:
                for i in range(m):
                    w[i] = dmin / w[i]
            else:
                for i in range(m):
                    w[i] = (dmin / w[i]) ** alpha
            for i in range(m):
                sw += w[i]
                spx += w[i] * px[i]
                spy += w[i] * py[i]
                sqx += w[i] * qx[i]
                sqy += w[i] * qy[i]
            psx = spx / sw
            psy = spy / sw
            qsx = sqx / sw
            qsy = sqy / sw
            # pass 3: mu = sum w |p^|^2 and sum w conj(p^) q^
            mu = 0.0
            ar = 0.0
            ai = 0.0
            for i in range(m):
                phx = px[i] - psx
                phy = py[i] - psy
                qhx = qx[i] - qsx
                qhy = qy[i] - qsy
                mu += w[i] * (phx * phx + phy * phy)
                ar += w[i] * (phx * qhx + phy * qhy)
                ai += w[i] * (phx * qhy - phy * qhx)
            if not mu > 0.0:
                # v so close to one handle that the others' weights underflow: the limit is q_nearest
                out[k, 0] = qx[imin]
                out[k, 1] = qy[imin]
                continue
            ar /= mu
            ai /= mu
            ux = vx - psx
            uy = vy - psy
            out[k, 0] = ux * ar - uy * ai + qsx
            out[k, 1] = ux * ai + uy * ar + qsy


@nb.njit(cache=True, parallel=True)
def interpolate_grid(at_nodes, xs, ys, step, map_x, map_y):  # pragma: no cover - compiled
    """Bilinear interpolation of ``at_nodes (len(ys), len(xs), 2)``, given at the node columns
    ``xs = 0, step, 2 step, ..., W - 1`` and rows ``ys`` likewise (at least 2 of each), at every
    pixel of ``map_x, map_y (H, W)`` (float32: ``cv2.remap``'s maps)."""
    h, w = map_x.shape
    nx = xs.shape[0]
    ny = ys.shape[0]
    for y in nb.prange(h):
        j = min(y // step, ny - 2)
        ty = (y - ys[j]) / (ys[j + 1] - ys[j])
        for x in range(w):
            i = min(x // step, nx - 2)
            tx = (x - xs[i]) / (xs[i + 1] - xs[i])
            for c in range(2):
                top = at_nodes[j, i, c] + tx * (at_nodes[j, i + 1, c] - at_nodes[j, i, c])
                bottom = at_nodes[j + 1, i, c] + tx * (at_nodes[j + 1, i + 1, c] - at_nodes[j + 1, i, c])
                value = top + ty * (bottom - top)
                if c == 0:
                    map_x[y, x] = value
                else:
                    map_y[y, x] = value
