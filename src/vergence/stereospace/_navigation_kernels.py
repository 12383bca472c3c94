"""Numba kernel of the coarse search of S2 §4.1's jump: every region's best sample in the cone at once.

:func:`vergence.stereospace.navigation._coarse_candidates` prepares the arrays and calls this; the kernel
trusts them: ``s0``, ``u`` (m, 3) float64 segment starts and directions, ``regions`` (R, 2) int64,
``grid`` (G,) float64 parameters of the tessellation, ``p`` (4,) the current stereo point, ``unit`` (4,)
the unit direction of movement, ``baseline`` (3,), outputs (R,). Its slow, obviously-correct twin is
:func:`vergence.stereospace.navigation._closest_in_cone` without refinement, compared in
``tests/stereospace/test_navigation.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["coarse_candidates"]


@nb.njit(cache=True)
def _sample(s0, u, i, j, li, lj, p, unit, cos_max, baseline, tol):  # pragma: no cover - compiled
    """``(dist, ok, orientation)`` of the sample ``(li, lj)`` of region ``(i, j)``: its stereo point's
    distance to ``p``, whether it lies in the cone, and ``(b - a) . baseline``."""
    a0, a1, a2 = s0[i, 0] + li * u[i, 0], s0[i, 1] + li * u[i, 1], s0[i, 2] + li * u[i, 2]
    b0, b1, b2 = s0[j, 0] + lj * u[j, 0], s0[j, 1] + lj * u[j, 1], s0[j, 2] + lj * u[j, 2]
    d0, d1, d2 = a0 - b0, a1 - b1, a2 - b2
    q0, q1, q2 = (a0 + b0) / 2.0 - p[0], (a1 + b1) / 2.0 - p[1], (a2 + b2) / 2.0 - p[2]
    q3 = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - p[3]
    dist = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    ok = dist > tol and q0 * unit[0] + q1 * unit[1] + q2 * unit[2] + q3 * unit[3] >= cos_max * dist
    if i == j and li > lj:  # a triangle holds li <= lj only
        ok = False
    orientation = -d0 * baseline[0] - d1 * baseline[1] - d2 * baseline[2]
    return dist, ok, orientation


@nb.njit(cache=True, parallel=True)
def coarse_candidates(s0, u, regions, grid, p, unit, cos_max, baseline, tol,
                      found, best_k, best_dist, agrees):  # pragma: no cover - compiled
    """For each region ``r``: ``found[r]`` whether a sample of the ``G x G`` tessellation (sample
    ``k`` at ``(grid[k // G], grid[k % G])``) lies in the cone; among those, the ones whose baseline
    keeps the orientation of ``baseline`` when there are any (``agrees[r]``); the closest to ``p``
    (``best_dist[r]``), ties within ``tol`` broken by the largest ``(b - a) . baseline``, the first
    on a tie again (``best_k[r]``)."""
    g = grid.shape[0]
    for r in nb.prange(regions.shape[0]):
        i, j = regions[r, 0], regions[r, 1]
        any_ok, any_agree, best_ok, best_agree = False, False, np.inf, np.inf
        for k in range(g * g):
            dist, ok, orientation = _sample(s0, u, i, j, grid[k // g], grid[k % g], p, unit, cos_max, baseline, tol)
            if ok:
                any_ok = True
                best_ok = min(best_ok, dist)
                if orientation >= 0.0:
                    any_agree = True
                    best_agree = min(best_agree, dist)
        found[r], agrees[r], best_k[r], best_dist[r] = any_ok, any_agree, -1, np.inf
        if not any_ok:
            continue
        best = best_agree if any_agree else best_ok
        top = -np.inf
        for k in range(g * g):
            dist, ok, orientation = _sample(s0, u, i, j, grid[k // g], grid[k % g], p, unit, cos_max, baseline, tol)
            if ok and (orientation >= 0.0 or not any_agree) and dist <= best + tol and orientation > top:
                top, best_k[r] = orientation, k
        best_dist[r] = _sample(s0, u, i, j, grid[best_k[r] // g], grid[best_k[r] % g], p, unit, cos_max,
                               baseline, tol)[0]
