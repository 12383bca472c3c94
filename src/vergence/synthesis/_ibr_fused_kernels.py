"""The fused Numba kernel of ULR image-based rendering: one parallel pass over the target's rows.

:func:`vergence.synthesis.render_ibr` (``weights="ulr"``) validates its inputs and calls
:func:`ulr_render`; it trusts them: proxy points float64 ``(h, w, 3)`` (NaN = no proxy), per
source a C-contiguous float32 image ``(H, W, 3)`` and float64 depth ``(H, W)`` (NaN = no surface),
passed as Numba typed lists (one compiled version for any number of sources; tuples compiled one per
count, about 40 s each on first use).

Per target row, each source in turn: project the row's proxy points, test field of view and
visibility, and compute the ULR penalty (row buffers of ``S x w`` numbers); then per pixel the k best,
the threshold, the weights and their normalisation; then each source in turn samples its colour
where its weight is positive and adds it to the row's image. No full-frame per-source array is
made: the depth slopes of the visibility test are computed from the depth map where a pixel is
tested, by the rule of :func:`vergence.synthesis._ibr_kernels.surface_slopes`, and only when the
relative tolerance alone does not already accept the pixel. Arithmetic is float64 and the stored
weights and colours float32, as in the staged kernels of ``_ibr_kernels.py`` (``sample_source``,
``ulr_weights``, ``normalise_blend``), which stay the slow reference in
``tests/synthesis/test_ibr_fused.py``; the one difference is the angle's arccos, fdlibm's
(:func:`acos`, within 1 ulp of the C library's, which took a fifth of the kernel's time), so a
weight may differ from the staged one by a float32 rounding step.

Speed (``benchmarks/ibr.py --repeats 5``, 4 sources into 1920 x 1080, given proxy, 2 cores shared at
load 3-7, three runs): bicubic 2.1-2.5x and bilinear 1.6-1.8x faster than the staged path in the same
process (CPU 1.3-1.7 s and 0.9-1.05 s a frame against 2.8-3.6 s and 1.6-1.75 s); the goal of 150 ms
is not met.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from vergence.synthesis._ibr_kernels import catmull_rom, fov_penalty

__all__ = ["acos", "agrees", "sample_all", "side_slope", "ulr_render"]


# fdlibm's e_acos.c (Sun Microsystems 1993, the algorithm of most C libraries' acos before glibc's
# correctly rounded one): a rational approximation of asin around 0 and sqrt reductions near +-1,
# error below 1 ulp. glibc's acos took a fifth of the fused kernel's time.
_PIO2_HI = 1.57079632679489655800e00
_PIO2_LO = 6.12323399573676603587e-17
_PI = 3.14159265358979311600e00
_PS0, _PS1, _PS2 = 1.66666666666666657415e-01, -3.25565818622400915405e-01, 2.01212532134862925881e-01
_PS3, _PS4, _PS5 = -4.00555345006794114027e-02, 7.91534994289814532176e-04, 3.47933107596021167570e-05
_QS1, _QS2 = -2.40339491173441421878e00, 2.02094576023350569471e00
_QS3, _QS4 = -6.88283971605453293030e-01, 7.70381505559019352791e-02
_SPLIT = 134217729.0  # 2^27 + 1: Veltkamp's split, a high part with at most 26 bits


@nb.njit(cache=True, inline="always")
def _rational(z):  # pragma: no cover - compiled
    """fdlibm's ``R(z) = (asin(sqrt z) - sqrt z) / (z sqrt z)`` as the ratio of its two polynomials."""
    p = z * (_PS0 + z * (_PS1 + z * (_PS2 + z * (_PS3 + z * (_PS4 + z * _PS5)))))
    q = 1.0 + z * (_QS1 + z * (_QS2 + z * (_QS3 + z * _QS4)))
    return p / q


@nb.njit(cache=True, inline="always")
def acos(x):  # pragma: no cover - compiled
    """``arccos(x)`` for ``x`` in [-1, 1] (fdlibm ``__ieee754_acos``), within 1 ulp."""
    if x >= 1.0:
        return 0.0
    if x <= -1.0:
        return _PI
    if abs(x) < 0.5:
        return _PIO2_HI - (x - (_PIO2_LO - x * _rational(x * x)))
    if x < 0.0:
        z = (1.0 + x) * 0.5
        s = math.sqrt(z)
        w = _rational(z) * s - _PIO2_LO
        return _PI - 2.0 * (s + w)
    z = (1.0 - x) * 0.5
    s = math.sqrt(z)
    t = _SPLIT * s
    df = t - (t - s)
    c = (z - df * df) / (s + df)
    w = _rational(z) * s + c
    return 2.0 * (df + w)


@nb.njit(cache=True, inline="always")
def _abs_diff(depth, y, x, yy, xx):  # pragma: no cover - compiled
    """``|z(yy, xx) - z(y, x)|``; NaN outside the image or where either depth is unknown."""
    h, w = depth.shape
    if yy < 0 or yy >= h or xx < 0 or xx >= w:
        return np.nan
    return abs(depth[yy, xx] - depth[y, x])


@nb.njit(cache=True, inline="always")
def side_slope(depth, xj, yj, dx, dy, cap, ratio):  # pragma: no cover - compiled
    """The one-sided depth slope of source pixel ``(xj, yj)`` towards ``(dx, dy)`` (one of the four
    of ``_ibr_kernels.surface_slopes``, same operations): ``|difference|`` on that side, at most
    ``ratio`` times the opposite side's; the opposite side's where that side is unknown; 0 if
    neither; at most ``cap`` times the depth."""
    mine = _abs_diff(depth, yj, xj, yj + dy, xj + dx)
    other = _abs_diff(depth, yj, xj, yj - dy, xj - dx)
    if math.isnan(mine):
        s = other
    elif math.isnan(other):
        s = mine
    else:
        s = min(mine, ratio * other)
    if math.isnan(s):
        s = 0.0
    limit = cap * depth[yj, xj]
    if s > limit:
        s = limit
    return s


@nb.njit(cache=True, inline="always")
def agrees(depth, xj, yj, u, v, qz, tol, cap, ratio):  # pragma: no cover - compiled
    """Source pixel ``(xj, yj)`` sees the point at depth ``qz`` projected to ``(u, v)``:
    ``|z_j - q_z| <= tol q_z + s_x |u - x_j| + s_y |v - y_j|``, the slopes on the projection's side
    (the rule of ``_ibr_kernels.sample_source``). The slope terms are >= 0, so a pixel within the
    relative tolerance agrees without them (the same outcome, fewer reads)."""
    d = abs(depth[yj, xj] - qz)
    base = tol * qz
    if d <= base:
        return True
    if not d == d or cap == 0.0:  # NaN depth never agrees; cap 0: the relative test alone
        return False
    sx = side_slope(depth, xj, yj, 1 if u > xj else -1, 0, cap, ratio)
    sy = side_slope(depth, xj, yj, 0, 1 if v > yj else -1, cap, ratio)
    return d <= base + sx * abs(u - xj) + sy * abs(v - yj)


@nb.njit(cache=True, inline="always")
def project(K, R, t, px, py, pz):  # pragma: no cover - compiled
    """World point ``(px, py, pz)`` into the camera ``K, R, t``: pixel ``(u, v)`` and camera-frame depth ``qz``
    (``u``, ``v`` meaningless unless ``qz > 0``)."""
    qx = R[0, 0] * px + R[0, 1] * py + R[0, 2] * pz + t[0]
    qy = R[1, 0] * px + R[1, 1] * py + R[1, 2] * pz + t[1]
    qz = R[2, 0] * px + R[2, 1] * py + R[2, 2] * pz + t[2]
    if not qz > 0.0:
        return np.nan, np.nan, qz
    return (K[0, 0] * qx + K[0, 1] * qy + K[0, 2] * qz) / qz, (K[1, 1] * qy + K[1, 2] * qz) / qz, qz


@nb.njit(cache=True, inline="always")
def seen(depth, u, v, qz, margin, tol, cap, ratio):  # pragma: no cover - compiled
    """Whether the source with ``depth`` sees the projected point: ``(u, v)`` within ``margin`` pixels of
    its image and :func:`agrees` at the source pixel nearest to it (clamped into the image)."""
    hs, ws = depth.shape
    if not (-margin <= u <= ws - 1.0 + margin and -margin <= v <= hs - 1.0 + margin):
        return False
    uc = min(max(u, 0.0), ws - 1.0)
    vc = min(max(v, 0.0), hs - 1.0)
    xn = min(int(math.floor(uc + 0.5)), ws - 1)
    yn = min(int(math.floor(vc + 0.5)), hs - 1)
    return agrees(depth, xn, yn, uc, vc, qz, tol, cap, ratio)


@nb.njit(cache=True, inline="always")
def _sample(image, depth, u, v, qz, tol, cap, ratio, cubic, out):  # pragma: no cover - compiled
    """Colour of a visible point at ``(u, v)`` into ``out`` (3,): the renormalised bilinear blend of
    the agreeing pixels among the four around it; with ``cubic``, where all 16 around it agree, the
    Catmull-Rom sample clamped to the range of the four nearest (``_ibr_kernels.sample_source``)."""
    hs, ws = depth.shape
    uc = min(max(u, 0.0), ws - 1.0)
    vc = min(max(v, 0.0), hs - 1.0)
    x0 = min(int(math.floor(uc)), ws - 1)
    y0 = min(int(math.floor(vc)), hs - 1)
    fx = uc - x0
    fy = vc - y0
    if cubic:
        inside = True
        for j in range(16):
            xj = min(max(x0 - 1 + (j & 3), 0), ws - 1)
            yj = min(max(y0 - 1 + (j >> 2), 0), hs - 1)
            if not agrees(depth, xj, yj, uc, vc, qz, tol, cap, ratio):
                inside = False
                break
        if inside:
            wx0, wx1, wx2, wx3 = catmull_rom(fx, 0), catmull_rom(fx, 1), catmull_rom(fx, 2), catmull_rom(fx, 3)
            xa, xb = max(x0 - 1, 0), min(x0 + 1, ws - 1)
            xc = min(x0 + 2, ws - 1)
            for c in range(3):
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
                out[c] = min(max(acc, lo), hi)
            return
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
        if not agrees(depth, xj, yj, uc, vc, qz, tol, cap, ratio):
            continue
        total += b
        acc0 += b * image[yj, xj, 0]
        acc1 += b * image[yj, xj, 1]
        acc2 += b * image[yj, xj, 2]
    out[0] = acc0 / total  # total > 0: the nearest pixel agrees and has a bilinear weight >= 1/4
    out[1] = acc1 / total
    out[2] = acc2 / total


@nb.njit(cache=True, parallel=True, error_model="numpy")
def ulr_render(points, rays, centre, Ks, Rs, ts, centres, sizes, band, images, depths, tol, cap, ratio, margin, cubic,
               k, alpha, beta, gamma, relative, floor, scale, weights, image, coverage):  # pragma: no cover - compiled
    """ULR image-based rendering of every target pixel (Buehler et al. 2001 Sec. 4; SIBR ``ulr_v3.frag``).

    Source ``i``: camera ``Ks[i]``, ``Rs[i]``, ``ts[i]``, centre ``centres[i]``, size ``sizes[i]`` =
    ``(W, H)``, field-of-view band ``band[i]`` pixels, ``images[i]``, ``depths[i]``. For each proxy
    point ``p``: ``q = R p + t``, ``(u, v) = (K q)_{xy} / q_z``; the point is visible when ``q_z > 0``,
    ``(u, v)`` lies in the pixel hull widened by ``margin`` and the source pixel nearest to the
    clamped projection agrees (:func:`agrees`: ``tol``, slopes capped at ``cap`` with ``ratio``).
    Penalties, threshold and weights as ``_ibr_kernels.ulr_weights`` (desired ray ``rays[y, x]``, or
    ``p - centre`` when ``rays`` is ``(0, 0, 3)``); weights rounded to float32, normalised over the
    sources (``weights`` ``(S, h, w)``, float32), ``coverage`` where their sum is positive; ``image``
    ``(h, w, 3)`` = ``sum_i w_i c_i`` with each colour (:func:`_sample`) rounded to float32, 0 where
    not covered (``_ibr_kernels.normalise_blend``).
    """
    s_count = centres.shape[0]
    h, w = points.shape[0], points.shape[1]
    use_rays = rays.shape[0] > 0
    for y in nb.prange(h):
        ray = np.empty((w, 4))  # the desired ray and its length; length NaN: no ULR weight
        us = np.empty((s_count, w))
        vs = np.empty((s_count, w))
        zs = np.empty((s_count, w))
        pen = np.empty((s_count, w))
        wrow = np.empty((s_count, w), dtype=np.float32)
        rank = np.empty(s_count, dtype=np.int64)
        colour = np.empty(3)
        acc = np.zeros((w, 3))
        for x in range(w):
            px, py, pz = points[y, x, 0], points[y, x, 1], points[y, x, 2]
            if use_rays:
                rx, ry, rz = rays[y, x, 0], rays[y, x, 1], rays[y, x, 2]
            else:
                rx, ry, rz = px - centre[0], py - centre[1], pz - centre[2]
            dn = math.sqrt(rx * rx + ry * ry + rz * rz)
            ok = math.isfinite(px) and math.isfinite(py) and math.isfinite(pz) and math.isfinite(px + py + pz)
            ray[x, 0], ray[x, 1], ray[x, 2] = rx, ry, rz
            ray[x, 3] = dn if ok and dn > 0.0 and math.isfinite(dn) else np.nan
        for i in range(s_count):
            K, R, t = Ks[i], Rs[i], ts[i]
            depth = depths[i]
            width, height, band_i = sizes[i, 0], sizes[i, 1], band[i]
            cx, cy, cz = centres[i, 0], centres[i, 1], centres[i, 2]
            for x in range(w):
                pen[i, x] = np.inf
                dn = ray[x, 3]
                if not dn > 0.0:
                    continue
                px, py, pz = points[y, x, 0], points[y, x, 1], points[y, x, 2]
                u, v, qz = project(K, R, t, px, py, pz)
                if not (qz > 0.0 and seen(depth, u, v, qz, margin, tol, cap, ratio)):
                    continue
                us[i, x] = u
                vs[i, x] = v
                zs[i, x] = qz
                vx, vy, vz = px - cx, py - cy, pz - cz
                di = math.sqrt(vx * vx + vy * vy + vz * vz)
                if not di > 0.0:
                    continue
                cosang = min(1.0, max(-1.0, (vx * ray[x, 0] + vy * ray[x, 1] + vz * ray[x, 2]) / (di * dn)))
                res = (di - dn) / di
                fov = fov_penalty(u, v, width, height, band_i, gamma)
                pen[i, x] = alpha * max(floor, acos(cosang)) + beta * max(floor, res) + fov
        for x in range(w):
            best = np.inf
            for i in range(s_count):
                best = min(best, pen[i, x])
                wrow[i, x] = 0.0
            coverage[y, x] = False
            if not best < np.inf:
                continue
            kth = np.inf
            for i in range(s_count):
                rank[i] = s_count
                if pen[i, x] == np.inf:
                    continue
                r = 0
                for j in range(s_count):
                    if pen[j, x] < pen[i, x] or (pen[j, x] == pen[i, x] and j < i):
                        r += 1
                rank[i] = r
                if r == k - 1:
                    kth = pen[i, x]
            thresh = scale * min(kth, relative * best)
            total = 0.0
            for i in range(s_count):
                if rank[i] < k:
                    wrow[i, x] = max(0.0, 1.0 - pen[i, x] / thresh)  # float32, as the staged weights
                    total += wrow[i, x]
            if not total > 0.0:
                for i in range(s_count):
                    wrow[i, x] = 0.0
                continue
            coverage[y, x] = True
            for i in range(s_count):
                wrow[i, x] = wrow[i, x] / total
        for i in range(s_count):
            img, depth = images[i], depths[i]
            for x in range(w):
                wi = wrow[i, x]
                weights[i, y, x] = wi
                if not wi > 0.0:
                    continue
                _sample(img, depth, us[i, x], vs[i, x], zs[i, x], tol, cap, ratio, cubic, colour)
                for c in range(3):
                    acc[x, c] += wi * np.float32(colour[c])  # float32 colours, as the staged blend
        for x in range(w):
            for c in range(3):
                image[y, x, c] = acc[x, c]


@nb.njit(cache=True, parallel=True, error_model="numpy")
def sample_all(points, Ks, Rs, ts, images, depths, tol, cap, ratio, margin, cubic, pixels, visible,
               colours):  # pragma: no cover - compiled
    """Every source's projection, visibility and colour of every proxy point in one pass over the
    target's rows (the outputs of ``_ibr_kernels.sample_source`` for each source, without its
    precomputed slope maps): ``pixels`` ``(S, h, w, 2)`` (NaN when behind; not written when it is
    ``(S, 0, 0, 2)``), ``visible`` ``(S, h, w)``, ``colours`` ``(S, h, w, 3)`` float32 (0 where not
    visible). For the Bayesian weights, which need the full maps."""
    s_count = Ks.shape[0]
    h, w = points.shape[0], points.shape[1]
    store = pixels.shape[1] > 0
    for y in nb.prange(h):
        colour = np.empty(3)
        for i in range(s_count):
            K, R, t = Ks[i], Rs[i], ts[i]
            img, depth = images[i], depths[i]
            for x in range(w):
                visible[i, y, x] = False
                if store:
                    pixels[i, y, x, 0] = np.nan
                    pixels[i, y, x, 1] = np.nan
                for c in range(3):
                    colours[i, y, x, c] = 0.0
                px, py, pz = points[y, x, 0], points[y, x, 1], points[y, x, 2]
                if not (math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)):
                    continue
                u, v, qz = project(K, R, t, px, py, pz)
                if not qz > 0.0:
                    continue
                if store:
                    pixels[i, y, x, 0] = u
                    pixels[i, y, x, 1] = v
                if not seen(depth, u, v, qz, margin, tol, cap, ratio):
                    continue
                visible[i, y, x] = True
                _sample(img, depth, u, v, qz, tol, cap, ratio, cubic, colour)
                for c in range(3):
                    colours[i, y, x, c] = colour[c]
