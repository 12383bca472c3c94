"""Numba kernel of the moving-least-squares similarity deformation (Schaefer, McPhail, Warren 2006).

:func:`vergence.stereospace.mls_similarity` validates its inputs and calls this; the kernel trusts
them: C-contiguous ``points (N, 2)``, ``src (M, 2)``, ``dst (M, 2)``, all float64 (or all float32: S2's
views), ``offsets`` (G + 1,) int64 splitting the handles into G sets of at least 2 with distinct ``src``
rows, ``alpha > 0``, ``out (G, N, 2)``. Its slow, obviously-correct twin is in
``tests/stereospace/test_mls.py``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["interpolate_grid", "mls_similarity_points"]


@nb.njit(cache=True, parallel=True, error_model="numpy", fastmath={"reassoc", "contract"})
def mls_similarity_points(points, src, dst, offsets, alpha, out):  # pragma: no cover - compiled
    """``out[g, k] = f_g(points[k])`` for the handle sets ``g``: ``src[offsets[g]:offsets[g + 1]] ->
    dst[...]`` (Schaefer et al. 2006 §2.2, similarity deformations, in its complex closed form
    ``f(v) = (v - p*) a + q*`` with ``a = sum w conj(p^) q^ / sum w |p^|^2``), in the precision of
    ``src`` (float64 or float32). Several sets (S2's sources of one view) share one parallel loop.

    One pass over the handles per point: with ``a_i = p_i - v``, ``b_i = q_i - v`` and
    ``w_i = |a_i|^(-2 alpha)``, the centred sums follow from the raw ones,
    ``sum w |p^|^2 = sum w |a|^2 - W |a*|^2`` and ``sum w conj(p^) q^ = sum w conj(a) b - W conj(a*) b*``
    (``W = sum w``, ``a* = p* - v``, ``b* = q* - v``), so that ``f(v) = v - a* a + b*``. Near a
    handle ``w |a|^2`` stays 1 (alpha = 1) and ``W |a*|^2`` about 1: no cancellation. A point on a
    handle (or so near that a weight overflows) returns the nearest handle's target, the limit of
    the formula. Sums may be reassociated (SIMD); they hold at most a few thousand terms.
    """
    n = points.shape[0]
    px = np.ascontiguousarray(src[:, 0])
    py = np.ascontiguousarray(src[:, 1])
    qx = np.ascontiguousarray(dst[:, 0])
    qy = np.ascontiguousarray(dst[:, 1])
    # the constants in the handles' precision (float literals would promote float32 sums to float64)
    consts = np.empty(3, src.dtype)
    consts[0] = 0.0
    consts[1] = 1.0
    consts[2] = alpha
    zero, one, exponent = consts[0], consts[1], consts[2]
    unit = alpha == 1.0
    for task in nb.prange(n * (offsets.shape[0] - 1)):
        g, k = task // n, task % n
        start, stop = offsets[g], offsets[g + 1]
        gpx, gpy, gqx, gqy = px[start:stop], py[start:stop], qx[start:stop], qy[start:stop]
        vx = one * points[k, 0]
        vy = one * points[k, 1]
        sw = zero
        sax = zero
        say = zero
        sbx = zero
        sby = zero
        saa = zero
        sab = zero
        sac = zero
        if unit:  # w = 1 / |a|^2: one division, w |a|^2 = 1
            for i in range(stop - start):
                ax = gpx[i] - vx
                ay = gpy[i] - vy
                bx = gqx[i] - vx
                by = gqy[i] - vy
                w = one / (ax * ax + ay * ay)
                sw += w
                sax += w * ax
                say += w * ay
                sbx += w * bx
                sby += w * by
                saa += one
                sab += w * (ax * bx + ay * by)
                sac += w * (ax * by - ay * bx)
        else:
            for i in range(stop - start):
                ax = gpx[i] - vx
                ay = gpy[i] - vy
                bx = gqx[i] - vx
                by = gqy[i] - vy
                d2 = ax * ax + ay * ay
                w = d2 ** -exponent
                sw += w
                sax += w * ax
                say += w * ay
                sbx += w * bx
                sby += w * by
                saa += w * d2
                sab += w * (ax * bx + ay * by)
                sac += w * (ax * by - ay * bx)
        psx = sax / sw
        psy = say / sw
        qsx = sbx / sw
        qsy = sby / sw
        mu = saa - sw * (psx * psx + psy * psy)
        if not (sw < np.inf and mu > zero):
            # on a handle (w = inf), or so near one that the others' weights vanish beside its own
            dmin = np.inf
            imin = 0
            for i in range(start, stop):
                d2 = (px[i] - vx) ** 2 + (py[i] - vy) ** 2
                if d2 < dmin:
                    dmin = d2
                    imin = i
            out[g, k, 0] = qx[imin]
            out[g, k, 1] = qy[imin]
            continue
        ar = (sab - sw * (psx * qsx + psy * qsy)) / mu
        ai = (sac - sw * (psx * qsy - psy * qsx)) / mu
        out[g, k, 0] = vx + qsx - psx * ar + psy * ai
        out[g, k, 1] = vy + qsy - psx * ai - psy * ar


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
