"""Numba kernels of the renderer. The numpy reference of each lives beside its caller and in the tests."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "ao_rays",
    "bilinear_wrap",
    "equirect_lookup",
    "offset_points",
    "pinhole_directions",
    "refine_hits",
    "scatter_nodes",
    "scatter_weighted",
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


@numba.njit(parallel=True, cache=True)
def refine_hits(
    kind: np.ndarray, center: np.ndarray, radius: np.ndarray, normal: np.ndarray, right: np.ndarray, up: np.ndarray,
    size: np.ndarray, tri_offset: np.ndarray, tri_v: np.ndarray, tri_n: np.ndarray, tri_uv: np.ndarray,
    obj: np.ndarray, prim: np.ndarray, o: np.ndarray, d: np.ndarray, t_approx: np.ndarray, rows: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Float64 distance, point, outward geometric and shading normals and uv of hits: ``surfaces.refine_hits``.

    The same maths, one ray per iteration: the sphere root nearest Mitsuba's distance (``q = -(b +
    sign(b) sqrt(b^2 - c))``, roots ``q`` and ``c/q``), the rectangle's plane, the triangle's plane
    with barycentric normals and texture coordinates. ``kind`` 0 = sphere, 1 = rectangle, 2 = mesh.
    Hit ``i`` belongs to the ray ``rows[i]`` of ``o`` and ``d`` (gathered here, not by the caller).
    """
    m = obj.shape[0]
    t = np.empty(m)
    p = np.empty((m, 3))
    ng = np.empty((m, 3))
    ns = np.empty((m, 3))
    uv = np.zeros((m, 2))
    for i in numba.prange(m):
        k = obj[i]
        r_ = rows[i]
        ox, oy, oz = o[r_, 0], o[r_, 1], o[r_, 2]
        dx, dy, dz = d[r_, 0], d[r_, 1], d[r_, 2]
        if kind[k] == 0:
            cx, cy, cz, r = center[k, 0], center[k, 1], center[k, 2], radius[k]
            ux, uy, uz = ox - cx, oy - cy, oz - cz
            b = ux * dx + uy * dy + uz * dz
            cc = ux * ux + uy * uy + uz * uz - r * r
            sq = math.sqrt(max(b * b - cc, 0.0))
            q = -(b + (sq if b >= 0 else -sq))
            r2 = cc / q if q != 0 else q
            ti = q if abs(q - t_approx[i]) <= abs(r2 - t_approx[i]) else r2
            qx, qy, qz = (ox + ti * dx - cx) / r, (oy + ti * dy - cy) / r, (oz + ti * dz - cz) / r
            ln = math.sqrt(qx * qx + qy * qy + qz * qz)
            qx, qy, qz = qx / ln, qy / ln, qz / ln
            ng[i, 0], ng[i, 1], ng[i, 2] = qx, qy, qz
            ns[i, 0], ns[i, 1], ns[i, 2] = qx, qy, qz
            uv[i, 0] = 0.5 + math.atan2(qx, qz) / (2 * math.pi)
            uv[i, 1] = 1.0 - math.acos(min(max(qy, -1.0), 1.0)) / math.pi
        elif kind[k] == 1:
            nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
            cx, cy, cz = center[k, 0], center[k, 1], center[k, 2]
            ti = ((cx - ox) * nx + (cy - oy) * ny + (cz - oz) * nz) / (dx * nx + dy * ny + dz * nz)
            rx, ry, rz = ox + ti * dx - cx, oy + ti * dy - cy, oz + ti * dz - cz
            ng[i, 0], ng[i, 1], ng[i, 2] = nx, ny, nz
            ns[i, 0], ns[i, 1], ns[i, 2] = nx, ny, nz
            uv[i, 0] = 0.5 + (rx * right[k, 0] + ry * right[k, 1] + rz * right[k, 2]) / size[k, 0]
            uv[i, 1] = 0.5 + (rx * up[k, 0] + ry * up[k, 1] + rz * up[k, 2]) / size[k, 1]
        else:
            f = tri_offset[k] + prim[i]
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
            ng[i, 0], ng[i, 1], ng[i, 2] = nx / ln, ny / ln, nz / ln
            if math.isnan(tri_n[f, 0, 0]):
                ns[i, 0], ns[i, 1], ns[i, 2] = ng[i, 0], ng[i, 1], ng[i, 2]
            else:
                sx = b0 * tri_n[f, 0, 0] + b1 * tri_n[f, 1, 0] + b2 * tri_n[f, 2, 0]
                sy = b0 * tri_n[f, 0, 1] + b1 * tri_n[f, 1, 1] + b2 * tri_n[f, 2, 1]
                sz = b0 * tri_n[f, 0, 2] + b1 * tri_n[f, 1, 2] + b2 * tri_n[f, 2, 2]
                ls = math.sqrt(sx * sx + sy * sy + sz * sz)
                ns[i, 0], ns[i, 1], ns[i, 2] = sx / ls, sy / ls, sz / ls
            if not math.isnan(tri_uv[f, 0, 0]):
                for c in range(2):
                    uv[i, c] = b0 * tri_uv[f, 0, c] + b1 * tri_uv[f, 1, c] + b2 * tri_uv[f, 2, c]
        t[i] = ti
        p[i, 0], p[i, 1], p[i, 2] = ox + ti * dx, oy + ti * dy, oz + ti * dz
    return t, p, ng, ns, uv


@numba.njit(parallel=True, cache=True)
def equirect_lookup(table: np.ndarray, dirs: np.ndarray, rotation: float) -> np.ndarray:
    """Bilinear lookup ``(M, 3)`` of an equirectangular ``(h, w, 3)`` table at unit directions: ``shading.Lighting``.

    ``u = frac(1/2 + (atan2(x, -z) - rotation) / 2 pi)`` (wraps), ``v = acos(y) / pi`` (clamped at
    the poles); texel centres at ``(i + 1/2) / w``.
    """
    h, w = table.shape[0], table.shape[1]
    m = dirs.shape[0]
    out = np.empty((m, 3))
    for i in numba.prange(m):
        phi = math.atan2(dirs[i, 0], -dirs[i, 2]) - rotation
        u = (0.5 + phi / (2 * math.pi)) % 1.0
        v = math.acos(min(max(dirs[i, 1], -1.0), 1.0)) / math.pi
        x = u * w - 0.5
        y = min(max(v * h - 0.5, 0.0), h - 1.0)
        xf, yf = math.floor(x), math.floor(y)
        fx, fy = x - xf, y - yf
        x0 = int(xf) % w
        y0 = int(yf)
        x1 = (x0 + 1) % w
        y1 = min(y0 + 1, h - 1)
        for c in range(3):
            top = table[y0, x0, c] * (1 - fx) + table[y0, x1, c] * fx
            bottom = table[y1, x0, c] * (1 - fx) + table[y1, x1, c] * fx
            out[i, c] = top * (1 - fy) + bottom * fy
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
def take_rows(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``a[idx]`` for a 2-D array: the rows ``idx`` gathered in parallel (numpy's ``take`` is one thread)."""
    m, k = idx.shape[0], a.shape[1]
    out = np.empty((m, k), dtype=a.dtype)
    for i in numba.prange(m):
        for c in range(k):
            out[i, c] = a[idx[i], c]
    return out
