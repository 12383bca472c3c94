"""Numba kernels of the renderer. The numpy reference of each lives beside its caller and in the tests."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["ao_rays"]


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
