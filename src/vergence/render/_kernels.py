"""Numba kernels of the renderer. The numpy reference of each lives beside its caller and in the tests."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "ao_rays",
    "bilinear_wrap",
    "equirect_lookup",
    "equirect_one",
    "neighbour_steps",
    "offset_points",
    "pinhole_directions",
    "refine_hits",
    "refine_one",
    "scatter_nodes",
    "segment_gaps_ok",
    "scatter_weighted",
    "subpixel_directions",
    "take_rows",
]


@numba.njit(parallel=True, cache=True)
def ao_rays(
    points: np.ndarray, n_geo: np.ndarray, n_shade: np.ndarray, lattice: np.ndarray, shifts: np.ndarray, eps_rel: float
) -> tuple[np.ndarray, np.ndarray]:
    """Ambient-occlusion rays in Mitsuba's layout: origins and directions ``(3, M * S)`` float32.

    Point ``m`` gets rays ``m * S .. m * S + S - 1``: origin ``p + eps_rel (1 + |p|_inf) n_geo``;
    direction the lattice point ``k`` (shifted by ``shifts[m]`` modulo 1 when ``shifts`` has M
    rows) mapped to the cosine-weighted hemisphere around ``n_shade`` in the Duff et al. (2017)
    frame: the same maths as :func:`vergence.render.shading.ao_directions`.
    """
    m_count = points.shape[0]
    s_count = lattice.shape[0]
    origins = np.empty((3, m_count * s_count), dtype=np.float32)
    dirs = np.empty((3, m_count * s_count), dtype=np.float32)
    shifted = shifts.shape[0] == m_count
    fixed = np.empty((s_count, 3))  # the unshifted local directions, shared by every point
    for k in range(s_count):
        r = math.sqrt(lattice[k, 0])
        phi = 2.0 * math.pi * lattice[k, 1]
        fixed[k, 0], fixed[k, 1], fixed[k, 2] = r * math.cos(phi), r * math.sin(phi), math.sqrt(1.0 - lattice[k, 0])
    for m in numba.prange(m_count):
        px, py, pz = points[m, 0], points[m, 1], points[m, 2]
        eps = eps_rel * (1.0 + max(abs(px), abs(py), abs(pz)))
        ox, oy, oz = px + eps * n_geo[m, 0], py + eps * n_geo[m, 1], pz + eps * n_geo[m, 2]
        nx, ny, nz = n_shade[m, 0], n_shade[m, 1], n_shade[m, 2]
        sign = 1.0 if nz >= 0.0 else -1.0
        a = -1.0 / (sign + nz)
        b = nx * ny * a
        t1x, t1y, t1z = 1.0 + sign * nx * nx * a, sign * b, -sign * nx
        t2x, t2y, t2z = b, sign + ny * ny * a, -ny
        for k in range(s_count):
            if shifted:
                u = (lattice[k, 0] + shifts[m, 0]) % 1.0
                v = (lattice[k, 1] + shifts[m, 1]) % 1.0
                r = math.sqrt(u)
                lx, ly, lz = r * math.cos(2.0 * math.pi * v), r * math.sin(2.0 * math.pi * v), math.sqrt(1.0 - u)
            else:
                lx, ly, lz = fixed[k, 0], fixed[k, 1], fixed[k, 2]
            j = m * s_count + k
            origins[0, j], origins[1, j], origins[2, j] = ox, oy, oz
            dirs[0, j] = lx * t1x + ly * t2x + lz * nx
            dirs[1, j] = lx * t1y + ly * t2y + lz * ny
            dirs[2, j] = lx * t1z + ly * t2z + lz * nz
    return origins, dirs


@numba.njit(cache=True, inline="always")
def refine_one(
    kind: np.ndarray, center: np.ndarray, radius: np.ndarray, normal: np.ndarray, right: np.ndarray, up: np.ndarray,
    size: np.ndarray, tri_offset: np.ndarray, tri_v: np.ndarray, tri_n: np.ndarray, tri_uv: np.ndarray,
    k: int, prim: int, ox: float, oy: float, oz: float, dx: float, dy: float, dz: float, t_approx: float,
    want_uv: bool,
) -> tuple:  # fmt: skip
    """One hit of :func:`refine_hits`: ``(t, ng_x, ng_y, ng_z, ns_x, ns_y, ns_z, u, v)``, the outward geometric
    and shading normals and the texture coordinates (a sphere's left 0 unless ``want_uv``)."""
    u, v = 0.0, 0.0
    if kind[k] == 0:
        cx, cy, cz, r = center[k, 0], center[k, 1], center[k, 2], radius[k]
        ux, uy, uz = ox - cx, oy - cy, oz - cz
        b = ux * dx + uy * dy + uz * dz
        cc = ux * ux + uy * uy + uz * uz - r * r
        sq = math.sqrt(max(b * b - cc, 0.0))
        q = -(b + (sq if b >= 0 else -sq))
        r2 = cc / q if q != 0 else q
        ti = q if abs(q - t_approx) <= abs(r2 - t_approx) else r2
        qx, qy, qz = (ox + ti * dx - cx) / r, (oy + ti * dy - cy) / r, (oz + ti * dz - cz) / r
        ln = math.sqrt(qx * qx + qy * qy + qz * qz)
        qx, qy, qz = qx / ln, qy / ln, qz / ln
        if want_uv:
            u = 0.5 + math.atan2(qx, qz) / (2 * math.pi)
            v = 1.0 - math.acos(min(max(qy, -1.0), 1.0)) / math.pi
        return ti, qx, qy, qz, qx, qy, qz, u, v
    elif kind[k] == 1:
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        cx, cy, cz = center[k, 0], center[k, 1], center[k, 2]
        ti = ((cx - ox) * nx + (cy - oy) * ny + (cz - oz) * nz) / (dx * nx + dy * ny + dz * nz)
        rx, ry, rz = ox + ti * dx - cx, oy + ti * dy - cy, oz + ti * dz - cz
        u = 0.5 + (rx * right[k, 0] + ry * right[k, 1] + rz * right[k, 2]) / size[k, 0]
        v = 0.5 + (rx * up[k, 0] + ry * up[k, 1] + rz * up[k, 2]) / size[k, 1]
        return ti, nx, ny, nz, nx, ny, nz, u, v
    else:
        f = tri_offset[k] + prim
        ax, ay, az = tri_v[f, 0, 0], tri_v[f, 0, 1], tri_v[f, 0, 2]
        e1x, e1y, e1z = tri_v[f, 1, 0] - ax, tri_v[f, 1, 1] - ay, tri_v[f, 1, 2] - az
        e2x, e2y, e2z = tri_v[f, 2, 0] - ax, tri_v[f, 2, 1] - ay, tri_v[f, 2, 2] - az
        nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        ti = ((ax - ox) * nx + (ay - oy) * ny + (az - oz) * nz) / (dx * nx + dy * ny + dz * nz)
        rx, ry, rz = ox + ti * dx - ax, oy + ti * dy - ay, oz + ti * dz - az
        d11 = e1x * e1x + e1y * e1y + e1z * e1z
        d12 = e1x * e2x + e1y * e2y + e1z * e2z
        d22 = e2x * e2x + e2y * e2y + e2z * e2z
        s1 = rx * e1x + ry * e1y + rz * e1z
        s2 = rx * e2x + ry * e2y + rz * e2z
        den = d11 * d22 - d12 * d12
        b1 = (d22 * s1 - d12 * s2) / den
        b2 = (d11 * s2 - d12 * s1) / den
        b0 = 1.0 - b1 - b2
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        gx, gy, gz = nx / ln, ny / ln, nz / ln
        sx, sy, sz = gx, gy, gz
        if not math.isnan(tri_n[f, 0, 0]):
            sx = b0 * tri_n[f, 0, 0] + b1 * tri_n[f, 1, 0] + b2 * tri_n[f, 2, 0]
            sy = b0 * tri_n[f, 0, 1] + b1 * tri_n[f, 1, 1] + b2 * tri_n[f, 2, 1]
            sz = b0 * tri_n[f, 0, 2] + b1 * tri_n[f, 1, 2] + b2 * tri_n[f, 2, 2]
            ls = math.sqrt(sx * sx + sy * sy + sz * sz)
            sx, sy, sz = sx / ls, sy / ls, sz / ls
        if not math.isnan(tri_uv[f, 0, 0]):
            u = b0 * tri_uv[f, 0, 0] + b1 * tri_uv[f, 1, 0] + b2 * tri_uv[f, 2, 0]
            v = b0 * tri_uv[f, 0, 1] + b1 * tri_uv[f, 1, 1] + b2 * tri_uv[f, 2, 1]
        return ti, gx, gy, gz, sx, sy, sz, u, v


@numba.njit(parallel=True, cache=True)
def refine_hits(
    kind: np.ndarray, center: np.ndarray, radius: np.ndarray, normal: np.ndarray, right: np.ndarray, up: np.ndarray,
    size: np.ndarray, tri_offset: np.ndarray, tri_v: np.ndarray, tri_n: np.ndarray, tri_uv: np.ndarray,
    obj: np.ndarray, prim: np.ndarray, o: np.ndarray, d: np.ndarray, t_approx: np.ndarray, rows: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Float64 distance, point, outward geometric and shading normals and uv of hits: ``surfaces.refine_hits``.

    The same maths, one ray per iteration (:func:`refine_one`): the sphere root nearest Mitsuba's
    distance (``q = -(b + sign(b) sqrt(b^2 - c))``, roots ``q`` and ``c/q``), the rectangle's plane,
    the triangle's plane with barycentric normals and texture coordinates. ``kind`` 0 = sphere,
    1 = rectangle, 2 = mesh. Hit ``i`` belongs to the ray ``rows[i]`` of ``o`` and ``d`` (gathered
    here, not by the caller).
    """
    m = obj.shape[0]
    t = np.empty(m)
    p = np.empty((m, 3))
    ng = np.empty((m, 3))
    ns = np.empty((m, 3))
    uv = np.zeros((m, 2))
    for i in numba.prange(m):
        r_ = rows[i]
        ox, oy, oz = o[r_, 0], o[r_, 1], o[r_, 2]
        dx, dy, dz = d[r_, 0], d[r_, 1], d[r_, 2]
        ti, ng[i, 0], ng[i, 1], ng[i, 2], ns[i, 0], ns[i, 1], ns[i, 2], uv[i, 0], uv[i, 1] = refine_one(
            kind, center, radius, normal, right, up, size, tri_offset, tri_v, tri_n, tri_uv, obj[i], prim[i],
            ox, oy, oz, dx, dy, dz, t_approx[i], True)  # fmt: skip
        t[i] = ti
        p[i, 0], p[i, 1], p[i, 2] = ox + ti * dx, oy + ti * dy, oz + ti * dz
    return t, p, ng, ns, uv


@numba.njit(cache=True, inline="always")
def equirect_one(table: np.ndarray, rotation: float, dx: float, dy: float, dz: float) -> tuple:
    """One direction of :func:`equirect_lookup`: the bilinear ``(r, g, b)`` of ``table`` along unit ``(dx, dy, dz)``."""
    h, w = table.shape[0], table.shape[1]
    phi = math.atan2(dx, -dz) - rotation
    u = (0.5 + phi / (2 * math.pi)) % 1.0
    v = math.acos(min(max(dy, -1.0), 1.0)) / math.pi
    x = u * w - 0.5
    y = min(max(v * h - 0.5, 0.0), h - 1.0)
    xf, yf = math.floor(x), math.floor(y)
    fx, fy = x - xf, y - yf
    x0 = int(xf) % w
    y0 = int(yf)
    x1 = (x0 + 1) % w
    y1 = min(y0 + 1, h - 1)
    r0 = (table[y0, x0, 0] * (1 - fx) + table[y0, x1, 0] * fx) * (1 - fy) + (table[y1, x0, 0] * (1 - fx) + table[y1, x1, 0] * fx) * fy
    r1 = (table[y0, x0, 1] * (1 - fx) + table[y0, x1, 1] * fx) * (1 - fy) + (table[y1, x0, 1] * (1 - fx) + table[y1, x1, 1] * fx) * fy
    r2 = (table[y0, x0, 2] * (1 - fx) + table[y0, x1, 2] * fx) * (1 - fy) + (table[y1, x0, 2] * (1 - fx) + table[y1, x1, 2] * fx) * fy
    return r0, r1, r2


@numba.njit(parallel=True, cache=True)
def equirect_lookup(table: np.ndarray, dirs: np.ndarray, rotation: float) -> np.ndarray:
    """Bilinear lookup ``(M, 3)`` of an equirectangular ``(h, w, 3)`` table at unit directions: ``shading.Lighting``.

    ``u = frac(1/2 + (atan2(x, -z) - rotation) / 2 pi)`` (wraps), ``v = acos(y) / pi`` (clamped at
    the poles); texel centres at ``(i + 1/2) / w`` (:func:`equirect_one`).
    """
    m = dirs.shape[0]
    out = np.empty((m, 3))
    for i in numba.prange(m):
        out[i, 0], out[i, 1], out[i, 2] = equirect_one(table, rotation, dirs[i, 0], dirs[i, 1], dirs[i, 2])
    return out


@numba.njit(parallel=True, cache=True)
def scatter_nodes(dst: np.ndarray, node: np.ndarray, slot: np.ndarray, values: np.ndarray) -> None:
    """``dst[node[j] - 1, slot[j]] = values[j]`` for layer arrays ``(N, S, 3)`` (pairs must not repeat)."""
    for j in numba.prange(node.shape[0]):
        for c in range(3):
            dst[node[j] - 1, slot[j], c] = values[j, c]


@numba.njit(parallel=True, cache=True)
def scatter_weighted(dst: np.ndarray, node: np.ndarray, slot: np.ndarray, weight: np.ndarray, values: np.ndarray) -> None:
    """``dst[node[j] - 1, slot[j]] = weight[j] * values[j]`` (radiance = throughput x local light)."""
    for j in numba.prange(node.shape[0]):
        for c in range(3):
            dst[node[j] - 1, slot[j], c] = weight[j, c] * values[j, c]


@numba.njit(parallel=True, cache=True)
def offset_points(p: np.ndarray, n: np.ndarray, sign: float, eps_rel: float) -> np.ndarray:
    """Secondary-ray origins ``p + sign eps_rel (1 + |p|_inf) n`` ``(M, 3)``: ``shader.offset``."""
    m = p.shape[0]
    out = np.empty((m, 3))
    for i in numba.prange(m):
        e = sign * eps_rel * (1.0 + max(abs(p[i, 0]), abs(p[i, 1]), abs(p[i, 2])))
        for c in range(3):
            out[i, c] = p[i, c] + e * n[i, c]
    return out


@numba.njit(parallel=True, cache=True)
def bilinear_wrap(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear lookup ``(M, C)`` of an ``(h, w, C)`` image at pixel coordinates, periodic in both axes."""
    h, w, nc = img.shape
    m = x.shape[0]
    out = np.empty((m, nc))
    for i in numba.prange(m):
        xf, yf = math.floor(x[i]), math.floor(y[i])
        fx, fy = x[i] - xf, y[i] - yf
        x0, y0 = int(xf) % w, int(yf) % h
        x1, y1 = (x0 + 1) % w, (y0 + 1) % h
        for c in range(nc):
            top = img[y0, x0, c] * (1 - fx) + img[y0, x1, c] * fx
            bottom = img[y1, x0, c] * (1 - fx) + img[y1, x1, c] * fx
            out[i, c] = top * (1 - fy) + bottom * fy
    return out


@numba.njit(parallel=True, cache=True)
def pinhole_directions(k_inv: np.ndarray, r: np.ndarray, width: int, height: int) -> np.ndarray:
    """Unit world directions ``(H W, 3)`` through pixel centres: ``normalise(R^T K^-1 (x, y, 1))``."""
    out = np.empty((width * height, 3))
    for row in numba.prange(height):
        for col in range(width):
            cx = k_inv[0, 0] * col + k_inv[0, 1] * row + k_inv[0, 2]
            cy = k_inv[1, 0] * col + k_inv[1, 1] * row + k_inv[1, 2]
            cz = k_inv[2, 0] * col + k_inv[2, 1] * row + k_inv[2, 2]
            wx = r[0, 0] * cx + r[1, 0] * cy + r[2, 0] * cz
            wy = r[0, 1] * cx + r[1, 1] * cy + r[2, 1] * cz
            wz = r[0, 2] * cx + r[1, 2] * cy + r[2, 2] * cz
            ln = math.sqrt(wx * wx + wy * wy + wz * wz)
            j = row * width + col
            out[j, 0], out[j, 1], out[j, 2] = wx / ln, wy / ln, wz / ln
    return out


@numba.njit(parallel=True, cache=True)
def subpixel_directions(k_inv: np.ndarray, r: np.ndarray, width: int, height: int, grid: np.ndarray,
                        jitter: np.ndarray) -> np.ndarray:  # fmt: skip
    """Unit world directions ``(G H W, 3)`` through ``(x + gx, y + gy)`` for the ``G`` offsets ``grid (G, 2)``.

    Block ``g`` holds the pixels of offset ``g`` row-major; ``jitter (G, H, W, 2)``, when not empty,
    adds a per-pixel offset (``rays.subpixel_rays`` is the reference: ``normalise(R^T K^-1 (x, y, 1))``).
    """
    g_count = grid.shape[0]
    n = width * height
    out = np.empty((g_count * n, 3))
    jittered = jitter.shape[0] == g_count
    for gr in numba.prange(g_count * height):
        g, row = gr // height, gr % height
        for col in range(width):
            ox, oy = grid[g, 0], grid[g, 1]
            if jittered:
                ox, oy = ox + jitter[g, row, col, 0], oy + jitter[g, row, col, 1]
            x, y = col + ox, row + oy
            cx = k_inv[0, 0] * x + k_inv[0, 1] * y + k_inv[0, 2]
            cy = k_inv[1, 0] * x + k_inv[1, 1] * y + k_inv[1, 2]
            cz = k_inv[2, 0] * x + k_inv[2, 1] * y + k_inv[2, 2]
            wx = cx * r[0, 0] + cy * r[1, 0] + cz * r[2, 0]
            wy = cx * r[0, 1] + cy * r[1, 1] + cz * r[2, 1]
            wz = cx * r[0, 2] + cy * r[1, 2] + cz * r[2, 2]
            ln = math.sqrt(wx * wx + wy * wy + wz * wz)
            j = g * n + row * width + col
            out[j, 0], out[j, 1], out[j, 2] = wx / ln, wy / ln, wz / ln
    return out


@numba.njit(cache=True, inline="always", error_model="numpy")
def _chord_gap(pa: np.ndarray, pb: np.ndarray, p: np.ndarray, jx: np.ndarray, jy: np.ndarray, i: int) -> float:
    """``curved._gap_px`` of row ``i``: pixels between ``p`` and the chord ``[pa, pb]`` (Cramer's rule)."""
    c0, c1, c2 = pb[i, 0] - pa[i, 0], pb[i, 1] - pa[i, 1], pb[i, 2] - pa[i, 2]
    s = ((p[i, 0] - pa[i, 0]) * c0 + (p[i, 1] - pa[i, 1]) * c1 + (p[i, 2] - pa[i, 2]) * c2) / (c0 * c0 + c1 * c1 + c2 * c2)
    if not math.isnan(s):
        s = min(max(s, 0.0), 1.0)
    e0, e1, e2 = p[i, 0] - (pa[i, 0] + s * c0), p[i, 1] - (pa[i, 1] + s * c1), p[i, 2] - (pa[i, 2] + s * c2)
    y0 = jy[i, 1] * c2 - jy[i, 2] * c1  # J_y x chord
    y1 = jy[i, 2] * c0 - jy[i, 0] * c2
    y2 = jy[i, 0] * c1 - jy[i, 1] * c0
    det = jx[i, 0] * y0 + jx[i, 1] * y1 + jx[i, 2] * y2
    a = (e0 * y0 + e1 * y1 + e2 * y2) / det
    x0, x1, x2 = e1 * c2 - e2 * c1, e2 * c0 - e0 * c2, e0 * c1 - e1 * c0  # e x chord
    b = (jx[i, 0] * x0 + jx[i, 1] * x1 + jx[i, 2] * x2) / det
    return math.hypot(a, b)


@numba.njit(cache=True, inline="always")
def _fmax(a: float, b: float) -> float:
    """``numpy.fmax``: the larger, ignoring a NaN."""
    if math.isnan(a):
        return b
    if math.isnan(b):
        return a
    return max(a, b)


@numba.njit(parallel=True, cache=True, error_model="numpy")
def segment_gaps_ok(pa: np.ndarray, pb: np.ndarray, pm: np.ndarray, jx: np.ndarray, jy: np.ndarray, q1: np.ndarray,
                    q2: np.ndarray, tol: float) -> np.ndarray:  # fmt: skip
    """Whether each segment ``[pa, pb]`` follows its curve within ``tol`` pixels (``curved._sample_chunk``).

    The largest gap of the midpoint ``pm`` and the quarter points ``q1``, ``q2`` to the chord
    (``numpy.fmax`` of :func:`_chord_gap`, the kernel of ``curved._gap_px``); 0 where ``J_x`` or
    ``J_y`` is undefined beside a defined midpoint (unmeasurable: kept); never where ``pb`` is undefined.
    """
    m = pa.shape[0]
    ok = np.empty(m, dtype=np.bool_)
    for i in numba.prange(m):
        gap = _fmax(_chord_gap(pa, pb, pm, jx, jy, i),
                    _fmax(_chord_gap(pa, pb, q1, jx, jy, i), _chord_gap(pa, pb, q2, jx, jy, i)))  # fmt: skip
        if (math.isnan(jx[i, 0]) or math.isnan(jy[i, 0])) and not math.isnan(pm[i, 0]):
            gap = 0.0
        ok[i] = not math.isnan(pb[i, 0]) and gap <= tol
    return ok


@numba.njit(cache=True)
def neighbour_steps(pm: np.ndarray, nb: np.ndarray, mapped: np.ndarray) -> np.ndarray:
    """``J[i] = P[nb[i]] - P[i]`` where ``nb[i] >= 0``, else the next row of ``mapped`` minus ``P[i]``
    (``curved._jacobian``'s forward differences; ``mapped`` holds the rows without a neighbour, in order)."""
    m = pm.shape[0]
    j = np.empty_like(pm)
    k = 0
    for i in range(m):
        if nb[i] >= 0:
            for c in range(3):
                j[i, c] = pm[nb[i], c] - pm[i, c]
        else:
            for c in range(3):
                j[i, c] = mapped[k, c] - pm[i, c]
            k += 1
    return j


@numba.njit(parallel=True, cache=True)
def take_rows(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``a[idx]`` for a 2-D array: the rows ``idx`` gathered in parallel (numpy's ``take`` is one thread)."""
    m, k = idx.shape[0], a.shape[1]
    out = np.empty((m, k), dtype=a.dtype)
    for i in numba.prange(m):
        for c in range(k):
            out[i, c] = a[idx[i], c]
    return out
