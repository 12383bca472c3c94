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

__all__ = ["MAX_SHARED_SETS", "interpolate_grid", "mls_shared_handles", "mls_similarity_points"]


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


# Handle sets of one call of mls_shared_handles (S2's sources of one view).
MAX_SHARED_SETS = 4


@nb.njit(cache=True, parallel=True, error_model="numpy", fastmath={"reassoc", "contract"})
def mls_shared_handles(points, src, dst, extra_src, extra_dst, extra_offsets, alpha,
                       out):  # pragma: no cover - compiled
    """``out[g, k] = f_g(points[k])`` for up to :data:`MAX_SHARED_SETS` handle sets that share most
    of their handles (S2's sources of one view: the points each source sees, mostly the same).

    Set ``g`` is the shared handles ``src (C, 2) -> dst[g] (C, 2)`` (``dst (G, C, 2)``) and its own
    ``extra_src[e0:e1] -> extra_dst[e0:e1]`` (``e0, e1 = extra_offsets[g], extra_offsets[g + 1]``),
    at least 2 in all, their sources distinct; all float32 (or all float64). The deformation is
    :func:`mls_similarity_points`'s (Schaefer et al. 2006 §2.2 in its one-pass form, with
    ``d = q - p`` for ``q`` and ``b = a + d``): the weight ``w_i = |p_i - v|^(-2 alpha)`` and the
    sums ``W``, ``sum w a``, ``sum w |a|^2`` of a shared handle depend on the point only, so they
    are computed once for all the sets, which add ``sum w d``, ``sum w conj(a) d`` of their own
    targets (one division and 10 operations per shared handle, 6 per set, where each set alone
    takes one division and 19). One task per point.
    """
    n = points.shape[0]
    groups = dst.shape[0]
    common = src.shape[0]
    qx = np.ascontiguousarray(src[:, 0])
    qy = np.ascontiguousarray(src[:, 1])
    d = np.zeros((MAX_SHARED_SETS, 2, common), src.dtype)  # sets past the last: offsets 0, unused
    for g in range(groups):
        for i in range(common):
            d[g, 0, i] = dst[g, i, 0] - src[i, 0]
            d[g, 1, i] = dst[g, i, 1] - src[i, 1]
    d0x, d0y, d1x, d1y = d[0, 0], d[0, 1], d[1, 0], d[1, 1]
    d2x, d2y, d3x, d3y = d[2, 0], d[2, 1], d[3, 0], d[3, 1]
    ex = np.ascontiguousarray(extra_src[:, 0])
    ey = np.ascontiguousarray(extra_src[:, 1])
    edx = np.ascontiguousarray(extra_dst[:, 0] - extra_src[:, 0])
    edy = np.ascontiguousarray(extra_dst[:, 1] - extra_src[:, 1])
    consts = np.empty(3, src.dtype)  # the constants in the handles' precision
    consts[0] = 0.0
    consts[1] = 1.0
    consts[2] = alpha
    zero, one, exponent = consts[0], consts[1], consts[2]
    unit = alpha == 1.0
    for k in nb.prange(n):
        vx = one * points[k, 0]
        vy = one * points[k, 1]
        sw = zero
        sax = zero
        say = zero
        saa = zero
        s0x, s0y, a0, c0 = zero, zero, zero, zero
        s1x, s1y, a1, c1 = zero, zero, zero, zero
        s2x, s2y, a2, c2 = zero, zero, zero, zero
        s3x, s3y, a3, c3 = zero, zero, zero, zero
        if unit:  # w = 1 / |a|^2: one division, w |a|^2 = 1
            saa = one * common
            for i in range(common):
                ax = qx[i] - vx
                ay = qy[i] - vy
                w = one / (ax * ax + ay * ay)
                u = w * ax
                t = w * ay
                sw += w
                sax += u
                say += t
                s0x += w * d0x[i]
                s0y += w * d0y[i]
                a0 += u * d0x[i] + t * d0y[i]
                c0 += u * d0y[i] - t * d0x[i]
                s1x += w * d1x[i]
                s1y += w * d1y[i]
                a1 += u * d1x[i] + t * d1y[i]
                c1 += u * d1y[i] - t * d1x[i]
                s2x += w * d2x[i]
                s2y += w * d2y[i]
                a2 += u * d2x[i] + t * d2y[i]
                c2 += u * d2y[i] - t * d2x[i]
                s3x += w * d3x[i]
                s3y += w * d3y[i]
                a3 += u * d3x[i] + t * d3y[i]
                c3 += u * d3y[i] - t * d3x[i]
        else:
            for i in range(common):
                ax = qx[i] - vx
                ay = qy[i] - vy
                dd = ax * ax + ay * ay
                w = dd ** -exponent
                u = w * ax
                t = w * ay
                sw += w
                sax += u
                say += t
                saa += w * dd
                s0x += w * d0x[i]
                s0y += w * d0y[i]
                a0 += u * d0x[i] + t * d0y[i]
                c0 += u * d0y[i] - t * d0x[i]
                s1x += w * d1x[i]
                s1y += w * d1y[i]
                a1 += u * d1x[i] + t * d1y[i]
                c1 += u * d1y[i] - t * d1x[i]
                s2x += w * d2x[i]
                s2y += w * d2y[i]
                a2 += u * d2x[i] + t * d2y[i]
                c2 += u * d2y[i] - t * d2x[i]
                s3x += w * d3x[i]
                s3y += w * d3y[i]
                a3 += u * d3x[i] + t * d3y[i]
                c3 += u * d3y[i] - t * d3x[i]
        for g in range(groups):
            if g == 0:
                sdx, sdy, sad, scd = s0x, s0y, a0, c0
            elif g == 1:
                sdx, sdy, sad, scd = s1x, s1y, a1, c1
            elif g == 2:
                sdx, sdy, sad, scd = s2x, s2y, a2, c2
            else:
                sdx, sdy, sad, scd = s3x, s3y, a3, c3
            gw, gax, gay, gaa = sw, sax, say, saa
            start, stop = extra_offsets[g], extra_offsets[g + 1]
            if unit:  # the set's own handles
                gaa += one * (stop - start)
                for j in range(start, stop):
                    ax = ex[j] - vx
                    ay = ey[j] - vy
                    w = one / (ax * ax + ay * ay)
                    u = w * ax
                    t = w * ay
                    gw += w
                    gax += u
                    gay += t
                    sdx += w * edx[j]
                    sdy += w * edy[j]
                    sad += u * edx[j] + t * edy[j]
                    scd += u * edy[j] - t * edx[j]
            else:
                for j in range(start, stop):
                    ax = ex[j] - vx
                    ay = ey[j] - vy
                    dd = ax * ax + ay * ay
                    w = dd ** -exponent
                    u = w * ax
                    t = w * ay
                    gw += w
                    gax += u
                    gay += t
                    gaa += w * dd
                    sdx += w * edx[j]
                    sdy += w * edy[j]
                    sad += u * edx[j] + t * edy[j]
                    scd += u * edy[j] - t * edx[j]
            psx = gax / gw
            psy = gay / gw
            qsx = psx + sdx / gw
            qsy = psy + sdy / gw
            mu = gaa - gw * (psx * psx + psy * psy)
            if gw < np.inf and mu > zero:
                ar = (gaa + sad - gw * (psx * qsx + psy * qsy)) / mu
                ai = (scd - gw * (psx * qsy - psy * qsx)) / mu
                out[g, k, 0] = vx + qsx - psx * ar + psy * ai
                out[g, k, 1] = vy + qsy - psx * ai - psy * ar
                continue
            # on a handle (w = inf), or so near one that the others' weights vanish beside its own
            dmin = np.inf
            imin = 0
            for i in range(common):
                dd = (qx[i] - vx) ** 2 + (qy[i] - vy) ** 2
                if dd < dmin:
                    dmin = dd
                    imin = i
            out[g, k, 0] = dst[g, imin, 0]
            out[g, k, 1] = dst[g, imin, 1]
            for j in range(start, stop):
                dd = (ex[j] - vx) ** 2 + (ey[j] - vy) ** 2
                if dd < dmin:
                    dmin = dd
                    out[g, k, 0] = extra_dst[j, 0]
                    out[g, k, 1] = extra_dst[j, 1]
