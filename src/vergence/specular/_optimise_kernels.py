"""Numba kernels of the per-pixel offset optimisation (S3 §3.4): the cost of S3 Eq. 2 at one pixel
and the descent on the tabulated disparity, rivalry and importance. The public function
(:func:`vergence.specular.optimise_offsets`) validates; the kernels trust their inputs. The slow,
obviously-correct twins are :func:`vergence.specular.disparity_cost` (numpy) and a brute-force
search in ``tests/specular/test_optimise.py``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["descend"]


@nb.njit(cache=True, inline="always")
def _lookup(table, y, x, i, yi, k):  # pragma: no cover - compiled
    """Linear interpolation of ``table[:, i, y, x, ...]`` (k + 1 offsets m / k) at offset ``yi``:
    ``(lower index, fraction)``."""
    pos = yi * k
    m = min(int(pos), k - 1)
    return m, pos - m


@nb.njit(cache=True)
def _state(disp, riv, imp, y, x, ys, k, d, r, w, dd, dr):  # pragma: no cover - compiled
    """Disparity ``d (N, 2)``, rivalry ``r``, importance ``w`` at offsets ``ys`` and the slopes of
    ``d`` and ``r`` along each layer's offset (the table's segment slope; NaN: no match)."""
    n = ys.shape[0]
    for i in range(n):
        m, t = _lookup(disp, y, x, i, ys[i], k)
        for c in range(2):
            a, b = disp[m, i, y, x, c], disp[m + 1, i, y, x, c]
            d[i, c] = a + t * (b - a)
            dd[i, c] = (b - a) * k
        a, b = riv[m, i, y, x], riv[m + 1, i, y, x]
        r[i] = a + t * (b - a)
        dr[i] = (b - a) * k
        a, b = imp[m, i, y, x], imp[m + 1, i, y, x]
        w[i] = a + t * (b - a)


@nb.njit(cache=True)
def _cost(d, r, w, orig, maps, y, x, alpha, comfort, zlo, zhi, lamx, lamy, gd, gr):  # pragma: no cover - compiled
    """S3 Eq. 2 at one pixel (as :func:`vergence.specular.disparity_cost`) and its gradient in
    ``d`` and ``r`` (into ``gd``, ``gr``). A layer whose ``d``, ``r`` or original is NaN adds
    nothing (no match: importance 0)."""
    n = d.shape[0]
    total = 0.0
    for i in range(n):
        gd[i, 0] = 0.0
        gd[i, 1] = 0.0
        gr[i] = 0.0
    for i in range(n):
        if not (d[i, 0] == d[i, 0] and d[i, 1] == d[i, 1] and r[i] == r[i] and w[i] == w[i]
                and orig[i, y, x, 0] == orig[i, y, x, 0] and orig[i, y, x, 1] == orig[i, y, x, 1]):
            continue
        w2 = w[i] * w[i]
        ax = d[i, 0]
        if comfort:
            ax = ax - zhi if ax > zhi else (ax - zlo if ax < zlo else 0.0)
        ma = maps[0, i, y, x] * w2
        total += alpha[0] * ma * (ax * ax + d[i, 1] * d[i, 1])
        gd[i, 0] += alpha[0] * 2.0 * ma * ax
        gd[i, 1] += alpha[0] * 2.0 * ma * d[i, 1]
        mr = maps[2, i, y, x] * w2
        total += alpha[2] * mr * r[i] * r[i]
        gr[i] += alpha[2] * 2.0 * mr * r[i]
        md = maps[3, i, y, x] * w2
        for c in range(2):
            e = d[i, c] - orig[i, y, x, c]
            total += alpha[3] * md * e * e
            gd[i, c] += alpha[3] * 2.0 * md * e
        for j in range(i + 1, n):
            if not (d[j, 0] == d[j, 0] and d[j, 1] == d[j, 1] and r[j] == r[j] and w[j] == w[j]
                    and orig[j, y, x, 0] == orig[j, y, x, 0] and orig[j, y, x, 1] == orig[j, y, x, 1]):
                continue
            pair = 0.5 * (maps[1, i, y, x] + maps[1, j, y, x]) * (w[i] * w[j]) ** 2
            for c in range(2):
                phys = orig[j, y, x, c] - orig[i, y, x, c]  # the pair keeps its physical order
                now = d[j, c] - d[i, c]
                sigma = 1.0 if phys > 0 else (-1.0 if phys < 0 else (1.0 if now >= 0 else -1.0))
                gap = sigma * now - (lamx if c == 0 else lamy)
                total += alpha[1] * pair * gap * gap
                g = alpha[1] * 2.0 * pair * gap * sigma
                gd[j, c] += g
                gd[i, c] -= g
    return total


@nb.njit(cache=True, parallel=True)
def descend(disp, riv, imp, orig, maps, free, starts, steps, first_step, alpha, comfort, zlo, zhi, lamx, lamy,
            out_y, out_cost):  # pragma: no cover - compiled
    """Per pixel, the offsets ``y`` in [0, 1]^N minimising S3 Eq. 2 on the tabulated ``g(y)``.

    ``disp (K+1, N, H, W, 2)``, ``riv``/``imp (K+1, N, H, W)``: the table at offsets ``m / K``;
    ``orig (N, H, W, 2)``; ``maps (4, N, H, W)``; ``free (N,)``: layers that move (the diffuse one
    stays at 1). From each start ``starts[s] (N,)``: ``steps`` steps of projected gradient descent,
    ``dy = -step * grad / max|grad|`` (``grad_i = df/dd_i . d'_i + df/dr_i r'_i``, the table's
    slopes, importance held at its current value), a step kept only when it lowers the cost, else
    halved. The best of the starts wins (ties to the first). Writes ``out_y (N, H, W)`` and
    ``out_cost (H, W)``.
    """
    kp1, n, h, w = riv.shape
    k = kp1 - 1
    for yrow in nb.prange(h):
        d = np.empty((n, 2))
        dd = np.empty((n, 2))
        r = np.empty(n)
        dr = np.empty(n)
        wt = np.empty(n)
        gd = np.empty((n, 2))
        gr = np.empty(n)
        cur = np.empty(n)
        trial = np.empty(n)
        grad = np.empty(n)
        best_y = np.empty(n)
        for x in range(w):
            best = np.inf
            for s in range(starts.shape[0]):
                for i in range(n):
                    cur[i] = starts[s, i] if free[i] else 1.0
                _state(disp, riv, imp, yrow, x, cur, k, d, r, wt, dd, dr)
                f = _cost(d, r, wt, orig, maps, yrow, x, alpha, comfort, zlo, zhi, lamx, lamy, gd, gr)
                step = first_step
                for _ in range(steps):
                    top = 0.0
                    for i in range(n):
                        g = 0.0
                        if free[i]:
                            for c in range(2):
                                if dd[i, c] == dd[i, c]:
                                    g += gd[i, c] * dd[i, c]
                            if dr[i] == dr[i]:
                                g += gr[i] * dr[i]
                        grad[i] = g
                        top = max(top, abs(g))
                    if top == 0.0:
                        break
                    for i in range(n):
                        trial[i] = min(1.0, max(0.0, cur[i] - step * grad[i] / top))
                    _state(disp, riv, imp, yrow, x, trial, k, d, r, wt, dd, dr)
                    ft = _cost(d, r, wt, orig, maps, yrow, x, alpha, comfort, zlo, zhi, lamx, lamy, gd, gr)
                    if ft < f:
                        f = ft
                        for i in range(n):
                            cur[i] = trial[i]
                    else:
                        step *= 0.5
                        _state(disp, riv, imp, yrow, x, cur, k, d, r, wt, dd, dr)
                        _cost(d, r, wt, orig, maps, yrow, x, alpha, comfort, zlo, zhi, lamx, lamy, gd, gr)
                if f < best:
                    best = f
                    for i in range(n):
                        best_y[i] = cur[i]
            for i in range(n):
                out_y[i, yrow, x] = best_y[i]
            out_cost[yrow, x] = best
