"""Numba kernels of the view-synthesis primitives (whole images, one row per parallel task).

The public functions in ``warp.py``, ``warp3d.py``, ``filters.py`` and ``holes.py`` validate their
inputs and call these; the kernels trust them: images are C-contiguous float32 ``(H, W, C)``,
disparities float32 ``(H, W)`` with NaN for unknown, masks bool ``(H, W)``. Each kernel has a slow,
obviously-correct Python twin in ``tests/synthesis`` that it is checked against.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = [
    "backward_warp_rows",
    "count_nonfinite",
    "count_outside",
    "dilate_near_rows",
    "fill_guide_rows",
    "fill_holes_rows",
    "fill_nan_rows",
    "forward_warp_rows",
    "median3_changes",
    "mesh_links",
    "splat_mesh",
    "splat_ordered",
    "splat_zbuffer",
]


@nb.njit(cache=True, parallel=True, error_model="numpy")
def forward_warp_rows(img, disp, scale, limit, out, zbuf, holes):  # pragma: no cover - compiled
    """Rectified forward warp ``x' = x - scale d`` with z-buffer and the gap/hole rule (S1 Sec. IV.B.1).

    Fills ``out`` (0 in holes), ``zbuf`` (the winning source disparity, NaN in holes) and ``holes``;
    their previous contents are ignored. A pair of neighbours whose target shifts differ by at most
    ``limit`` (``|scale (d1 - d0)| <= limit``) is one surface: every target pixel centre between
    their warped positions gets the linear interpolation of the pair (colour and disparity, in
    float32). A pixel not covered by such an interval on one side splats its own value at its
    nearest target pixel. Within a row the larger disparity wins; on a tie the first write stays.
    """
    h, w = disp.shape
    nc = img.shape[2]
    for y in nb.prange(h):
        pos = np.empty(w, dtype=np.float64)  # target abscissa of each source pixel (NaN: unknown)
        link = np.empty(w, dtype=np.bool_)  # x and x + 1 are one surface
        for x in range(w):
            zbuf[y, x] = -np.inf
            pos[x] = x - scale * disp[y, x]  # S1 Eq. (7) on rectified rows: x' = x - scale d
        for x in range(w - 1):
            # S1 Sec. IV.B.1 gap/hole rule; False when either is NaN.
            link[x] = abs(scale * (disp[y, x + 1] - disp[y, x])) <= limit
        link[w - 1] = False
        prev = False  # link[x - 1]
        for x in range(w):
            a = pos[x]
            if math.isnan(a):
                prev = False
                continue
            d0 = disp[y, x]
            right = link[x]
            lo = a
            hi = a
            if right:
                b = pos[x + 1]
                lo = min(a, b)
                hi = max(a, b)
                start = max(int(math.ceil(lo)), 0)
                stop = min(int(math.floor(hi)), w - 1)
                if stop >= start:
                    inv_span = 1.0 / (b - a) if b != a else 0.0
                    dd = disp[y, x + 1] - d0
                    for xt in range(start, stop + 1):
                        s = np.float32((xt - a) * inv_span)
                        z = d0 + s * dd
                        if z > zbuf[y, xt]:
                            zbuf[y, xt] = z
                            r = np.float32(1.0) - s  # (1 - s) v0 + s v1: exact at both ends
                            if nc == 3:  # unrolled: the common case (whole kernel ~7 % faster, 1080p RGB)
                                out[y, xt, 0] = r * img[y, x, 0] + s * img[y, x + 1, 0]
                                out[y, xt, 1] = r * img[y, x, 1] + s * img[y, x + 1, 1]
                                out[y, xt, 2] = r * img[y, x, 2] + s * img[y, x + 1, 2]
                            else:
                                for c in range(nc):
                                    out[y, xt, c] = r * img[y, x, c] + s * img[y, x + 1, c]
            # Own nearest-pixel splat, unless a linked interval already covers that pixel centre.
            xn = int(math.floor(a + 0.5))
            if 0 <= xn < w:
                covered = right and lo <= xn <= hi
                if prev and not covered:
                    ap = pos[x - 1]
                    covered = min(ap, a) <= xn <= max(ap, a)
                if not covered and d0 > zbuf[y, xn]:
                    zbuf[y, xn] = d0
                    for c in range(nc):
                        out[y, xn, c] = img[y, x, c]
            prev = right
        for x in range(w):
            hole = zbuf[y, x] == -np.inf
            holes[y, x] = hole
            if hole:
                zbuf[y, x] = np.nan
                for c in range(nc):
                    out[y, x, c] = 0.0


@nb.njit(cache=True, parallel=True)
def backward_warp_rows(img, disp, scale, out, valid):  # pragma: no cover - compiled
    """Inverse warp: ``out[y, x] = img[y, x + scale d(x)]`` by linear interpolation along the row.

    ``valid`` is set where ``disp`` is known and the source position lies inside the row
    (within half a pixel of the outermost centres, clamped there).
    """
    h, w = disp.shape
    for y in nb.prange(h):
        for x in range(w):
            d = disp[y, x]
            if math.isnan(d):
                continue
            xs = x + scale * d
            if xs < -0.5 or xs > w - 0.5:
                continue
            xs = min(max(xs, 0.0), w - 1.0)
            x0 = int(math.floor(xs))
            x1 = min(x0 + 1, w - 1)
            s = xs - x0
            for c in range(img.shape[2]):
                out[y, x, c] = (1.0 - s) * img[y, x0, c] + s * img[y, x1, c]
            valid[y, x] = True


@nb.njit(cache=True, parallel=True)
def fill_guide_rows(disp, src, scale, limit, out):  # pragma: no cover - compiled
    """Hole-filling guide of a forward-warped view (see ``_stages.fill_guide``).

    ``g = src[y, x_s]`` at the source pixel ``x_s`` nearest to ``x + scale disp[y, x]`` (clamped to
    the row); where the warped ``disp`` exceeds ``g`` by more than ``limit`` (a background pixel
    moved with the foreground) the guide is halfway, ``(g + disp) / 2``. NaN where disp is NaN.
    """
    h, w = disp.shape
    ws = src.shape[1]
    for y in nb.prange(h):
        for x in range(w):
            d = disp[y, x]
            if math.isnan(d):
                out[y, x] = np.nan
                continue
            xs = int(math.floor(x + scale * d + 0.5))
            g = src[y, min(max(xs, 0), ws - 1)]
            out[y, x] = np.float32(0.5) * (g + d) if d > g + limit else g


@nb.njit(cache=True, parallel=True)
def median3_changes(disp, holes, tol, min_count, med, changed):  # pragma: no cover - compiled
    """3x3 median of the known (non-NaN) values and where it differs from ``disp`` by more than ``tol``.

    ``med`` gets the median where at least ``min_count`` neighbours (the pixel included) are known,
    NaN elsewhere; for an even count the lower middle value is taken (a value that occurs, so a step
    stays a step). ``changed`` is set for holes with a median and for known pixels whose median
    differs by more than ``tol``. Where all known neighbours lie within ``tol`` of the pixel the
    median does too, so ``med`` is the pixel's own value and no sort is needed.
    """
    h, w = disp.shape
    for y in nb.prange(h):
        buf = np.empty(9, dtype=np.float32)
        for x in range(w):
            n = 0
            lo = np.inf
            hi = -np.inf
            for dy in range(-1, 2):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                for dx in range(-1, 2):
                    xx = x + dx
                    if xx < 0 or xx >= w:
                        continue
                    v = disp[yy, xx]
                    if not math.isnan(v):
                        buf[n] = v
                        n += 1
                        lo = min(lo, v)
                        hi = max(hi, v)
            changed[y, x] = False
            if n < min_count:
                med[y, x] = np.nan
                continue
            own = disp[y, x]
            if not holes[y, x] and hi - own <= tol and own - lo <= tol:
                med[y, x] = own
                continue
            for i in range(1, n):  # insertion sort of at most nine values
                v = buf[i]
                j = i - 1
                while j >= 0 and buf[j] > v:
                    buf[j + 1] = buf[j]
                    j -= 1
                buf[j + 1] = v
            m = buf[(n - 1) // 2]
            med[y, x] = m
            changed[y, x] = holes[y, x] or abs(m - own) > tol


@nb.njit(cache=True, parallel=True)
def fill_holes_rows(img, disp, holes, mirror, out, out_disp):  # pragma: no cover - compiled
    """Background-directed scanline fill: each hole run takes the values of its farther neighbour.

    ``out`` and ``out_disp`` start as copies of ``img`` and ``disp``, or are those arrays themselves
    (in place: only hole pixels are written and only non-hole pixels are read). For each run of holes on a
    row, the bounding pixel with the smaller disparity (the background) is the source; a run
    touching the image border uses its only neighbour. With ``mirror`` the run copies the row
    reflected about that neighbour (``x -> 2 x_b - x``) as long as the reflected pixel is known and
    no nearer than the background by more than one pixel of disparity; otherwise the neighbour's
    value is repeated. The filled disparity is the background disparity.
    """
    h, w = disp.shape
    for y in nb.prange(h):
        x = 0
        while x < w:
            if not holes[y, x]:
                x += 1
                continue
            x0 = x
            while x < w and holes[y, x]:
                x += 1
            x1 = x - 1  # run x0..x1
            xl = x0 - 1
            xr = x1 + 1
            if xl < 0 and xr >= w:
                break  # a whole row of holes: nothing to copy from
            if xl < 0:
                xb = xr
            elif xr >= w:
                xb = xl
            else:
                xb = xl if disp[y, xl] <= disp[y, xr] else xr
            db = disp[y, xb]
            for xt in range(x0, x1 + 1):
                src = xb
                if mirror:
                    xm = 2 * xb - xt
                    if 0 <= xm < w and not holes[y, xm] and disp[y, xm] <= db + 1.0:
                        src = xm
                for c in range(img.shape[2]):
                    out[y, xt, c] = img[y, src, c]
                out_disp[y, xt] = db


@nb.njit(cache=True, parallel=True)
def fill_nan_rows(disp, out):  # pragma: no cover - compiled
    """``out = disp`` with each run of NaN on a row set to the smaller of its two bounding values
    (the only one at a border); an all-NaN row stays NaN."""
    h, w = disp.shape
    for y in nb.prange(h):
        x = 0
        while x < w:
            v = disp[y, x]
            if not math.isnan(v):
                out[y, x] = v
                x += 1
                continue
            x0 = x
            while x < w and math.isnan(disp[y, x]):
                x += 1
            left = disp[y, x0 - 1] if x0 > 0 else np.nan
            right = disp[y, x] if x < w else np.nan
            if math.isnan(left):
                fill = right
            elif math.isnan(right):
                fill = left
            else:
                fill = min(left, right)
            for xt in range(x0, x):
                out[y, xt] = fill


@nb.njit(cache=True, parallel=True)
def count_nonfinite(arr, row_nan, row_inf):  # pragma: no cover - compiled
    """Per row of a 2-D float array: NaN count and inf count (branch-free, vectorised)."""
    h, w = arr.shape
    for y in nb.prange(h):
        n_nan = 0
        n_inf = 0
        for x in range(w):
            v = arr[y, x]
            n_nan += v != v
            n_inf += abs(v) == np.inf
        row_nan[y] = n_nan
        row_inf[y] = n_inf


@nb.njit(cache=True, parallel=True)
def count_outside(arr, low, high, row_bad):  # pragma: no cover - compiled
    """Per row of a 2-D float array: how many values are not in ``[low, high]`` (NaN counts)."""
    h, w = arr.shape
    for y in nb.prange(h):
        n = 0
        for x in range(w):
            v = arr[y, x]
            n += not (v >= low and v <= high)
        row_bad[y] = n


@nb.njit(cache=True, parallel=True)
def dilate_near_rows(disp, radius, threshold, out):  # pragma: no cover - compiled
    """``out = max`` of the known values in the ``(2 radius + 1)^2`` window where it exceeds the
    pixel by more than ``threshold``, else the pixel (NaN stays NaN).

    Separable: NaN becomes -inf, a horizontal maximum, then a vertical one; branch-free inner loops.
    """
    h, w = disp.shape
    known = np.empty((h, w), dtype=np.float32)
    hmax = np.empty((h, w), dtype=np.float32)
    for y in nb.prange(h):
        for x in range(w):
            v = disp[y, x]
            known[y, x] = v if v == v else -np.inf
        if radius == 1:  # the default: a fixed three-tap maximum that LLVM vectorises
            hmax[y, 0] = max(known[y, 0], known[y, min(1, w - 1)])
            for x in range(1, w - 1):
                hmax[y, x] = max(max(known[y, x - 1], known[y, x]), known[y, x + 1])
            hmax[y, w - 1] = max(known[y, max(w - 2, 0)], known[y, w - 1])
        else:
            for x in range(w):
                m = known[y, x]
                for k in range(1, radius + 1):
                    m = max(m, known[y, max(x - k, 0)])
                    m = max(m, known[y, min(x + k, w - 1)])
                hmax[y, x] = m
    for y in nb.prange(h):
        for x in range(w):
            m = hmax[y, x]
            for k in range(1, radius + 1):
                m = max(m, max(hmax[max(y - k, 0), x], hmax[min(y + k, h - 1), x]))
            v = disp[y, x]
            out[y, x] = m if m - v > threshold else v  # NaN - m is NaN: not > threshold


@nb.njit(cache=True)
def splat_zbuffer(u, v, z, colours, out, zbuf, painted):  # pragma: no cover - compiled
    """Nearest-pixel splat of points at (u, v) with depth z: the smallest depth wins (z-buffer).

    ``zbuf`` must start at +inf. Serial: a parallel scatter would race on the z-test.
    """
    h, w = zbuf.shape
    for i in range(u.shape[0]):
        zi = z[i]
        if not zi > 0.0:
            continue
        xt = int(math.floor(u[i] + 0.5))
        yt = int(math.floor(v[i] + 0.5))
        if xt < 0 or xt >= w or yt < 0 or yt >= h:
            continue
        if zi < zbuf[yt, xt]:
            zbuf[yt, xt] = zi
            painted[yt, xt] = True
            for c in range(colours.shape[1]):
                out[yt, xt, c] = colours[i, c]


@nb.njit(cache=True)
def splat_ordered(order, u, v, z, colours, out, zbuf, painted):  # pragma: no cover - compiled
    """Painter's algorithm: splat points in ``order``, later writes overwrite earlier ones (McMillan)."""
    h, w = zbuf.shape
    for k in range(order.shape[0]):
        i = order[k]
        zi = z[i]
        if not zi > 0.0:
            continue
        xt = int(math.floor(u[i] + 0.5))
        yt = int(math.floor(v[i] + 0.5))
        if xt < 0 or xt >= w or yt < 0 or yt >= h:
            continue
        zbuf[yt, xt] = zi
        painted[yt, xt] = True
        for c in range(colours.shape[1]):
            out[yt, xt, c] = colours[i, c]


@nb.njit(cache=True, parallel=True)
def mesh_links(z, u, v, zt, A, c, limit, link_r, link_d):  # pragma: no cover - compiled
    """Right and lower links of the mesh warp (2-D gradient rule of S1 Sec. IV.B.1).

    A source pixel ``m = (x, y, 1)`` with depth ``Z`` lands at ``h = Z A m + c`` (homogeneous target
    pixel; ``A = K_t R_t R_s^T K_s^{-1}``, ``c = K_t (t_t - R_t R_s^T t_s)``, S1 Eq. 5). Pixel
    (y, x) and its neighbour are linked when both land in front of the target (finite ``u, v``,
    ``zt > 0``) and the neighbour, lifted with this pixel's depth, lands within ``limit`` pixels of
    where it lands with its own.
    """
    h, w = z.shape
    for y in nb.prange(h):
        for x in range(w):
            link_r[y, x] = False
            link_d[y, x] = False
            i = y * w + x
            if not (zt[i] > 0.0 and math.isfinite(u[i]) and math.isfinite(v[i])):
                continue
            za = z[y, x]
            for k in range(2):
                xb = x + 1 - k
                yb = y + k
                if xb >= w or yb >= h:
                    continue
                j = yb * w + xb
                if not (zt[j] > 0.0 and math.isfinite(u[j]) and math.isfinite(v[j])):
                    continue
                hx = za * (A[0, 0] * xb + A[0, 1] * yb + A[0, 2]) + c[0]
                hy = za * (A[1, 0] * xb + A[1, 1] * yb + A[1, 2]) + c[1]
                hz = za * (A[2, 0] * xb + A[2, 1] * yb + A[2, 2]) + c[2]
                if not hz > 0.0:
                    continue
                ok = math.hypot(hx / hz - u[j], hy / hz - v[j]) <= limit
                if k == 0:
                    link_r[y, x] = ok
                else:
                    link_d[y, x] = ok


@nb.njit(cache=True)
def _raster_triangle(i0, i1, i2, u, v, z, colours, use_z, out, zbuf, painted):  # pragma: no cover - compiled
    """Fill the target pixel centres inside the triangle of source points i0, i1, i2.

    Depth is ``1 / (interpolated 1/z)`` (1/z is affine in the image for a planar facet), colours are
    perspective-correct (weighted by 1/z). A pixel centre on a shared edge belongs to both triangles.
    """
    h, w = zbuf.shape
    x0, y0, x1, y1, x2, y2 = u[i0], v[i0], u[i1], v[i1], u[i2], v[i2]
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if area == 0.0:
        return
    # Pixel centres on an edge, up to the round-off of the projection (~1e-15 px), are inside.
    eps = 1e-9
    xa = max(int(math.ceil(min(x0, min(x1, x2)) - eps)), 0)
    xb = min(int(math.floor(max(x0, max(x1, x2)) + eps)), w - 1)
    ya = max(int(math.ceil(min(y0, min(y1, y2)) - eps)), 0)
    yb = min(int(math.floor(max(y0, max(y1, y2)) + eps)), h - 1)
    q0, q1, q2 = 1.0 / z[i0], 1.0 / z[i1], 1.0 / z[i2]
    tol = -eps
    for yy in range(ya, yb + 1):
        for xx in range(xa, xb + 1):
            b0 = ((x1 - xx) * (y2 - yy) - (x2 - xx) * (y1 - yy)) / area
            b1 = ((xx - x0) * (y2 - y0) - (x2 - x0) * (yy - y0)) / area
            b2 = 1.0 - b0 - b1
            if b0 < tol or b1 < tol or b2 < tol:
                continue
            q = b0 * q0 + b1 * q1 + b2 * q2
            zz = 1.0 / q
            if use_z and not zz < zbuf[yy, xx]:
                continue
            zbuf[yy, xx] = zz
            painted[yy, xx] = True
            for c in range(colours.shape[1]):
                out[yy, xx, c] = (b0 * q0 * colours[i0, c] + b1 * q1 * colours[i1, c] + b2 * q2 * colours[i2, c]) / q


@nb.njit(cache=True, nogil=True)  # nogil: render_ibr draws several sources in threads
def splat_mesh(order, u, v, z, link_r, link_d, colours, max_side, use_z, out, zbuf, painted):  # pragma: no cover - compiled
    """Mesh warp: linked source neighbours are one surface, rasterized as triangles (S1 Sec. IV.B.1 in 2-D).

    Source points (flat index ``i = y W_s + x``) at target ``(u, v)`` with target depth ``z``
    (NaN or <= 0: not drawn). ``link_r[y, x]`` / ``link_d[y, x]``: the point and its right / lower
    neighbour are one surface. Each source quad is two triangles, (i, i+1, i+W_s) and
    (i+1, i+W_s+1, i+W_s), drawn when both of its legs are linked and its target bounding box is
    at most ``max_side`` pixels; a point in no drawn triangle is splatted at its nearest pixel.
    Drawing follows ``order`` (triangles with their top-left point); ``use_z``: smaller depth wins
    (``zbuf`` starts at +inf), else later writes win (McMillan's painter's order). Serial.
    """
    hs, ws = link_r.shape
    n = hs * ws
    tri_a = np.zeros(n, dtype=np.bool_)
    tri_b = np.zeros(n, dtype=np.bool_)
    covered = np.zeros(n, dtype=np.bool_)
    for y in range(hs - 1):
        for x in range(ws - 1):
            i = y * ws + x
            for k in range(2):
                if k == 0:
                    ok = link_r[y, x] and link_d[y, x]
                    j0, j1, j2 = i, i + 1, i + ws
                else:
                    ok = link_d[y, x + 1] and link_r[y + 1, x]
                    j0, j1, j2 = i + 1, i + ws + 1, i + ws
                if not ok:
                    continue
                side = max(max(u[j0], u[j1]), u[j2]) - min(min(u[j0], u[j1]), u[j2])
                side = max(side, max(max(v[j0], v[j1]), v[j2]) - min(min(v[j0], v[j1]), v[j2]))
                if not side <= max_side:
                    continue
                if k == 0:
                    tri_a[i] = True
                else:
                    tri_b[i] = True
                covered[j0] = True
                covered[j1] = True
                covered[j2] = True
    h, w = zbuf.shape
    for k in range(order.shape[0]):
        i = order[k]
        if tri_a[i]:
            _raster_triangle(i, i + 1, i + ws, u, v, z, colours, use_z, out, zbuf, painted)
        if tri_b[i]:
            _raster_triangle(i + 1, i + ws + 1, i + ws, u, v, z, colours, use_z, out, zbuf, painted)
        zi = z[i]
        if covered[i] or not zi > 0.0:
            continue
        xt = int(math.floor(u[i] + 0.5))
        yt = int(math.floor(v[i] + 0.5))
        if xt < 0 or xt >= w or yt < 0 or yt >= h:
            continue
        if use_z and not zi < zbuf[yt, xt]:
            continue
        zbuf[yt, xt] = zi
        painted[yt, xt] = True
        for c in range(colours.shape[1]):
            out[yt, xt, c] = colours[i, c]
