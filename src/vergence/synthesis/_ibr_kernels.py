"""Numba kernels of multi-view image-based rendering (whole target images, one row per parallel task).

:func:`vergence.synthesis.render_ibr` validates its inputs and calls these; the kernels trust them:
proxy points float64 ``(h, w, 3)`` (NaN = no proxy), source images C-contiguous float32
``(H, W, 3)``, source depths float64 ``(H, W)`` (NaN = no surface), per-source maps ``(S, h, w)``.
Each kernel has a slow, obviously-correct Python twin in ``tests/synthesis/test_ibr.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


__all__ = [
    "backproject", "catmull_rom", "fov_penalty", "normalise_blend", "project_depth", "sample_source", "surface_slopes",
    "ulr_weights",
]


@nb.njit(cache=True, error_model="numpy")
def lift(Kinv, R, t, x, y, z):  # pragma: no cover - compiled
    """The world point ``R^T (z K^-1 (x, y, 1) - t)`` of pixel ``(x, y)`` at camera-frame depth ``z``."""
    a0 = z * (Kinv[0, 0] * x + Kinv[0, 1] * y + Kinv[0, 2]) - t[0]
    a1 = z * (Kinv[1, 0] * x + Kinv[1, 1] * y + Kinv[1, 2]) - t[1]
    a2 = z * (Kinv[2, 0] * x + Kinv[2, 1] * y + Kinv[2, 2]) - t[2]
    return (R[0, 0] * a0 + R[1, 0] * a1 + R[2, 0] * a2, R[0, 1] * a0 + R[1, 1] * a1 + R[2, 1] * a2,
            R[0, 2] * a0 + R[1, 2] * a1 + R[2, 2] * a2)  # fmt: skip


@nb.njit(cache=True, parallel=True, error_model="numpy")
def backproject(depth, Kinv, R, t, out):  # pragma: no cover - compiled
    """World points ``R^T (z K^-1 (x, y, 1) - t)`` of a depth map (``Camera.backproject_depth``);
    NaN where the depth is NaN."""
    h, w = depth.shape
    for y in nb.prange(h):
        for x in range(w):
            z = depth[y, x]
            if not z > 0.0:
                out[y, x, 0] = np.nan
                out[y, x, 1] = np.nan
                out[y, x, 2] = np.nan
                continue
            out[y, x, 0], out[y, x, 1], out[y, x, 2] = lift(Kinv, R, t, x, y, z)


@nb.njit(cache=True, parallel=True, error_model="numpy")
def project_depth(depth, Kinv, R, t, Kt, Rt, tt, u, v, zt):  # pragma: no cover - compiled
    """A source depth map lifted to world points (as :func:`backproject`) and projected into the
    target ``(Kt, Rt, tt)``: flat target columns ``u``, rows ``v`` (NaN when not in front) and
    camera-frame depths ``zt`` (NaN where the source depth is NaN)."""
    h, w = depth.shape
    for y in nb.prange(h):
        for x in range(w):
            i = y * w + x
            z = depth[y, x]
            u[i] = np.nan
            v[i] = np.nan
            zt[i] = np.nan
            if not z > 0.0:
                continue
            px, py, pz = lift(Kinv, R, t, x, y, z)
            qx = Rt[0, 0] * px + Rt[0, 1] * py + Rt[0, 2] * pz + tt[0]
            qy = Rt[1, 0] * px + Rt[1, 1] * py + Rt[1, 2] * pz + tt[1]
            qz = Rt[2, 0] * px + Rt[2, 1] * py + Rt[2, 2] * pz + tt[2]
            zt[i] = qz
            if qz > 0.0:
                u[i] = (Kt[0, 0] * qx + Kt[0, 1] * qy + Kt[0, 2] * qz) / qz
                v[i] = (Kt[1, 1] * qy + Kt[1, 2] * qz) / qz


@nb.njit(cache=True, error_model="numpy")
def catmull_rom(t, j):  # pragma: no cover - compiled
    """Catmull-Rom (Keys 1981, a = -1/2) weight of tap j in {0, 1, 2, 3} (taps at -1, 0, 1, 2) at offset t."""
    t2 = t * t
    t3 = t2 * t
    if j == 0:
        return 0.5 * (-t3 + 2.0 * t2 - t)
    if j == 1:
        return 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0)
    if j == 2:
        return 0.5 * (-3.0 * t3 + 4.0 * t2 + t)
    return 0.5 * (t3 - t2)


@nb.njit(cache=True, inline="always")
def _agrees(depth, slopes, xj, yj, u, v, qz, tol):  # pragma: no cover - compiled
    """Source pixel ``(xj, yj)`` sees the point at depth ``qz`` projected to ``(u, v)`` (see sample_source)."""
    sx = slopes[1, yj, xj] if u > xj else slopes[0, yj, xj]
    sy = slopes[3, yj, xj] if v > yj else slopes[2, yj, xj]
    return abs(depth[yj, xj] - qz) <= tol * qz + sx * abs(u - xj) + sy * abs(v - yj)


@nb.njit(cache=True, parallel=True, error_model="numpy")
def sample_source(points, K, R, t, image, depth, slopes, tol, margin, cubic, pixels, visible, colours):  # pragma: no cover - compiled
    """Project every proxy point into one source, test field of view and visibility, sample its colour.

    Camera frame ``q = R p + t``; in front when ``q_z > 0``; pixel ``(u, v) = (K q)_{xy} / q_z``
    (written to ``pixels`` unless it is empty, NaN when behind). Field of view: the hull of the
    pixel centres, ``0 <= u <= W - 1``, ``0 <= v <= H - 1``, widened by ``margin`` pixels (``render_ibr``:
    half a pixel, the pixel rectangle; the sample is clamped to the hull). A source pixel ``j`` agrees with
    the point when ``|z_j - q_z| <= tol q_z + s_x,j |u - u_j| + s_y,j |v - v_j|`` (NaN never agrees): the
    relative tolerance plus the change of the pixel's surface between its centre and the projection,
    ``s_x``, ``s_y`` its one-sided depth slopes (metres per pixel) on the projection's side, ``slopes``
    ``(4, H, W)`` towards -x, +x, -y, +y (``_ibr_stages.surface_slopes``; zeros: the relative test alone). The point is visible when the source pixel
    nearest to the projection agrees; its colour is the bilinear blend of the agreeing pixels among
    the four neighbours, renormalised (an occluder's pixels never bleed in). With ``cubic``, where
    all 16 pixels around the projection agree (inside one surface), the colour is the Catmull-Rom
    bicubic instead, clamped to the range of the four nearest pixels (no ringing).
    """
    h, w = points.shape[0], points.shape[1]
    hs, ws = depth.shape
    nc = image.shape[2]
    store = pixels.shape[0] > 0
    for y in nb.prange(h):
        for x in range(w):
            visible[y, x] = False
            if store:
                pixels[y, x, 0] = np.nan
                pixels[y, x, 1] = np.nan
            for c in range(nc):
                colours[y, x, c] = 0.0
            px, py, pz = points[y, x, 0], points[y, x, 1], points[y, x, 2]
            if not (math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)):
                continue
            qx = R[0, 0] * px + R[0, 1] * py + R[0, 2] * pz + t[0]
            qy = R[1, 0] * px + R[1, 1] * py + R[1, 2] * pz + t[1]
            qz = R[2, 0] * px + R[2, 1] * py + R[2, 2] * pz + t[2]
            if not qz > 0.0:
                continue
            u = (K[0, 0] * qx + K[0, 1] * qy + K[0, 2] * qz) / qz
            v = (K[1, 1] * qy + K[1, 2] * qz) / qz
            if store:
                pixels[y, x, 0] = u
                pixels[y, x, 1] = v
            if not (-margin <= u <= ws - 1.0 + margin and -margin <= v <= hs - 1.0 + margin):
                continue
            uc = min(max(u, 0.0), ws - 1.0)
            vc = min(max(v, 0.0), hs - 1.0)
            x0 = min(int(math.floor(uc)), ws - 1)
            y0 = min(int(math.floor(vc)), hs - 1)
            fx = uc - x0
            fy = vc - y0
            xn = min(int(math.floor(uc + 0.5)), ws - 1)
            yn = min(int(math.floor(vc + 0.5)), hs - 1)
            if not _agrees(depth, slopes, xn, yn, uc, vc, qz, tol):
                continue
            total = 0.0
            acc0 = 0.0
            acc1 = 0.0
            acc2 = 0.0
            for j in range(4):
                xj = x0 + (j & 1)
                yj = y0 + (j >> 1)
                bx = fx if j & 1 else 1.0 - fx
                by = fy if j >> 1 else 1.0 - fy
                b = bx * by
                if not b > 0.0 or xj >= ws or yj >= hs:
                    continue
                if not _agrees(depth, slopes, xj, yj, uc, vc, qz, tol):
                    continue
                total += b
                acc0 += b * image[yj, xj, 0]
                acc1 += b * image[yj, xj, 1]
                acc2 += b * image[yj, xj, 2]
            if total > 0.0:
                visible[y, x] = True
                colours[y, x, 0] = acc0 / total
                colours[y, x, 1] = acc1 / total
                colours[y, x, 2] = acc2 / total
            if not (cubic and total > 0.0):
                continue
            inside = True
            for j in range(16):
                xj = min(max(x0 - 1 + (j & 3), 0), ws - 1)
                yj = min(max(y0 - 1 + (j >> 2), 0), hs - 1)
                if not _agrees(depth, slopes, xj, yj, uc, vc, qz, tol):
                    inside = False
                    break
            if not inside:
                continue
            wx0, wx1, wx2, wx3 = catmull_rom(fx, 0), catmull_rom(fx, 1), catmull_rom(fx, 2), catmull_rom(fx, 3)
            xa, xb = max(x0 - 1, 0), min(x0 + 1, ws - 1)
            xc = min(x0 + 2, ws - 1)
            for c in range(nc):
                lo = np.inf
                hi = -np.inf
                acc = 0.0
                for jy in range(4):
                    yj = min(max(y0 - 1 + jy, 0), hs - 1)
                    row = (wx0 * image[yj, xa, c] + wx1 * image[yj, x0, c] + wx2 * image[yj, xb, c]
                           + wx3 * image[yj, xc, c])  # fmt: skip
                    acc += catmull_rom(fy, jy) * row
                    if jy == 1 or jy == 2:
                        lo = min(lo, image[yj, x0, c], image[yj, xb, c])
                        hi = max(hi, image[yj, x0, c], image[yj, xb, c])
                colours[y, x, c] = min(max(acc, lo), hi)


@nb.njit(cache=True, error_model="numpy")
def fov_penalty(u, v, width, height, band, gamma):  # pragma: no cover - compiled
    """Field-of-view penalty of a source pixel ``(u, v)``: ``gamma (band / e - 1)^2`` within ``band``
    pixels of the image's edge, 0 deeper inside (and everywhere when ``gamma`` is 0); ``e = min(u + 1/2, W - 1/2 - u, v + 1/2, H - 1/2 - v)``
    is the distance to the edge of the pixel rectangle (>= 0 for a sampled point), so the penalty
    grows without bound towards that edge (+inf on it: no weight)."""
    e = min(u + 0.5, width - 0.5 - u, v + 0.5, height - 0.5 - v)
    if not (gamma > 0.0 and e < band):
        return 0.0
    if not e > 0.0:
        return np.inf
    g = band / e - 1.0
    return gamma * g * g


@nb.njit(cache=True, parallel=True, error_model="numpy")
def ulr_weights(points, rays, centre, centres, visible, pixels, sizes, k, alpha, beta, gamma, band, relative, floor,
                scale, out):  # pragma: no cover - compiled
    """Unnormalised ULR weights (Buehler et al. 2001 Sec. 4; SIBR ``ulr_v3.frag``) of every source.

    Desired ray ``r = rays[y, x]`` (``rays`` of shape ``(0, 0, 3)``: ``r = p - centre``); for each
    visible source ``i``: ``v = p - C_i``, ``ang = acos(v.r / |v||r|)``, ``res = (|v| - |r|) / |v|``,
    ``fov`` = :func:`fov_penalty` of its pixel ``pixels[i, y, x]`` in an image of ``sizes[i]`` =
    ``(W, H)`` with ``band[i]`` pixels, ``penalty = alpha max(floor, ang) + beta max(floor, res) + fov``.
    The ``k`` best of the ``m`` visible sources (ties to the lower index) form the set;
    ``thresh = scale * min(k-th penalty, relative * best penalty)`` (the k-th is +inf when
    ``m < k``); ``w_i = max(0, 1 - penalty_i / thresh)`` in the set, 0 elsewhere.
    """
    s_count = centres.shape[0]
    h, w = points.shape[0], points.shape[1]
    use_rays = rays.shape[0] > 0
    for y in nb.prange(h):
        pen = np.empty(s_count)
        rank = np.empty(s_count, dtype=np.int64)
        for x in range(w):
            for i in range(s_count):
                out[i, y, x] = 0.0
            px, py, pz = points[y, x, 0], points[y, x, 1], points[y, x, 2]
            if use_rays:
                rx, ry, rz = rays[y, x, 0], rays[y, x, 1], rays[y, x, 2]
            else:
                rx, ry, rz = px - centre[0], py - centre[1], pz - centre[2]
            dn = math.sqrt(rx * rx + ry * ry + rz * rz)
            if not (dn > 0.0 and math.isfinite(dn) and math.isfinite(px + py + pz)):
                continue
            m = 0
            best = np.inf
            for i in range(s_count):
                pen[i] = np.inf
                if not visible[i, y, x]:
                    continue
                vx, vy, vz = px - centres[i, 0], py - centres[i, 1], pz - centres[i, 2]
                di = math.sqrt(vx * vx + vy * vy + vz * vz)
                if not di > 0.0:
                    continue
                cosang = min(1.0, max(-1.0, (vx * rx + vy * ry + vz * rz) / (di * dn)))
                ang = math.acos(cosang)
                res = (di - dn) / di
                fov = fov_penalty(pixels[i, y, x, 0], pixels[i, y, x, 1], sizes[i, 0], sizes[i, 1], band[i], gamma)
                pen[i] = alpha * max(floor, ang) + beta * max(floor, res) + fov
                if not pen[i] < np.inf:
                    continue
                best = min(best, pen[i])
                m += 1
            if m == 0:
                continue
            kth = np.inf
            for i in range(s_count):
                rank[i] = s_count
                if pen[i] == np.inf:
                    continue
                r = 0
                for j in range(s_count):
                    if pen[j] < pen[i] or (pen[j] == pen[i] and j < i):
                        r += 1
                rank[i] = r
                if r == k - 1:
                    kth = pen[i]
            thresh = scale * min(kth, relative * best)
            for i in range(s_count):
                if rank[i] < k:
                    out[i, y, x] = max(0.0, 1.0 - pen[i] / thresh)


@nb.njit(cache=True, parallel=True, error_model="numpy")
def normalise_blend(weights, visible, colours, image, coverage):  # pragma: no cover - compiled
    """Normalise the weights of the visible sources per pixel (in place) and blend their colours.

    ``w_i <- w_i / sum_j w_j`` over visible sources (0 for the others); ``image = sum_i w_i c_i``;
    ``coverage`` where the sum is positive (elsewhere the weights and the image are 0).
    """
    s_count, h, w = weights.shape
    nc = colours.shape[3]
    for y in nb.prange(h):
        for x in range(w):
            total = 0.0
            for i in range(s_count):
                if visible[i, y, x]:
                    total += weights[i, y, x]
                else:
                    weights[i, y, x] = 0.0
            coverage[y, x] = total > 0.0
            if not total > 0.0:
                for i in range(s_count):
                    weights[i, y, x] = 0.0
                for c in range(nc):
                    image[y, x, c] = 0.0
                continue
            for i in range(s_count):
                weights[i, y, x] = weights[i, y, x] / total
            for c in range(nc):
                acc = 0.0
                for i in range(s_count):
                    acc += weights[i, y, x] * colours[i, y, x, c]
                image[y, x, c] = acc


@nb.njit(cache=True, inline="always")
def _abs_diff(depth, y, x, yy, xx):  # pragma: no cover - compiled
    """``|z(yy, xx) - z(y, x)|``; NaN outside the image or where either depth is unknown."""
    h, w = depth.shape
    if yy < 0 or yy >= h or xx < 0 or xx >= w:
        return np.nan
    return abs(depth[yy, xx] - depth[y, x])


@nb.njit(cache=True, parallel=True)
def surface_slopes(depth, cap, ratio, out):  # pragma: no cover - compiled
    """One-sided depth slopes towards -x, +x, -y, +y into ``out`` ``(4, H, W)``
    (``_ibr_stages.surface_slopes``): a side's ``|difference|``, at most ``ratio`` times the opposite
    side's; the opposite side's where that side is unknown; 0 if neither; at most ``cap`` times the
    depth."""
    h, w = depth.shape
    for y in nb.prange(h):
        for x in range(w):
            limit = cap * depth[y, x]
            for axis in range(2):
                if axis == 0:
                    back, fwd = _abs_diff(depth, y, x, y, x - 1), _abs_diff(depth, y, x, y, x + 1)
                else:
                    back, fwd = _abs_diff(depth, y, x, y - 1, x), _abs_diff(depth, y, x, y + 1, x)
                for side in range(2):
                    mine, other = (back, fwd) if side == 0 else (fwd, back)
                    if math.isnan(mine):
                        s = other
                    elif math.isnan(other):
                        s = mine
                    else:
                        s = min(mine, ratio * other)
                    if math.isnan(s):
                        s = 0.0
                    if s > limit:  # False where the depth is unknown: that pixel never agrees anyway
                        s = limit
                    out[2 * axis + side, y, x] = s
