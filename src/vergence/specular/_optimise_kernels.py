"""Numba kernels of the per-pixel offset optimisation (S3 §3.4): the cost of S3 Eq. 2 at one pixel
and the descent on the tabulated disparity and rivalry, importance held at the physical pair's.
The public function (:func:`vergence.specular.optimise_offsets`) validates; the kernels trust their
inputs. The slow, obviously-correct twins are :func:`vergence.specular.disparity_cost` (numpy) and
a brute-force search in ``tests/specular/test_optimise.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["descend"]


@nb.njit(cache=True)
def _fill_rows(px):  # pragma: no cover - compiled
    """In place, per layer of one pixel's table ``px (N, K + 1, 3)``: rows without a match (NaN
    disparity) take the disparity interpolated linearly between the nearest matched rows (held
    beyond the first and last), so that losing the match at some offset is no escape from the
    cost; NaN rivalry likewise, 0 where no row has one."""
    n, kp1, _ = px.shape
    for i in range(n):
        for c0, c1 in ((0, 2), (2, 3)):
            prev = -1
            for m in range(kp1):
                if px[i, m, c0] == px[i, m, c0]:
                    if prev == -1 and m > 0:
                        for q in range(m):
                            for c in range(c0, c1):
                                px[i, q, c] = px[i, m, c]
                    elif prev >= 0 and m - prev > 1:
                        for q in range(prev + 1, m):
                            t = (q - prev) / (m - prev)
                            for c in range(c0, c1):
                                px[i, q, c] = px[i, prev, c] + t * (px[i, m, c] - px[i, prev, c])
                    prev = m
            if prev == -1:
                if c0 == 2:
                    for q in range(kp1):
                        px[i, q, 2] = 0.0
            else:
                for q in range(prev + 1, kp1):
                    for c in range(c0, c1):
                        px[i, q, c] = px[i, prev, c]


@nb.njit(cache=True)
def _state(tab, ys, k, d, r, dd, dr):  # pragma: no cover - compiled
    """Disparity ``d (N, 2)`` and rivalry ``r`` of one pixel at offsets ``ys`` and their slopes along
    each layer's offset (the table's segment slope; NaN: the layer has no match at any offset).
    ``tab (N, K + 1, 3)``: the pixel's table, channels (dx, dy, rivalry)."""
    n = ys.shape[0]
    for i in range(n):
        pos = ys[i] * k
        m = min(int(pos), k - 1)
        t = pos - m
        for c in range(2):
            a, b = tab[i, m, c], tab[i, m + 1, c]
            d[i, c] = a + t * (b - a)
            dd[i, c] = (b - a) * k
        a, b = tab[i, m, 2], tab[i, m + 1, 2]
        r[i] = a + t * (b - a)
        dr[i] = (b - a) * k


@nb.njit(cache=True)
def _cost(d, r, w, orig, maps, alpha, comfort, lo, hi, vert, rho0, lamx, lamy, gd, gr):  # pragma: no cover - compiled
    """S3 Eq. 2 at one pixel (as :func:`vergence.specular.disparity_cost`, ``comfort`` selecting our
    variant with target zone ``[lo, hi]``, vertical tolerance ``vert`` and rivalry tolerance
    ``rho0``) and its gradient in ``d`` and ``r`` (into ``gd``, ``gr``); ``w (N,)``, ``orig (N, 2)``
    and ``maps (4, N)`` are the pixel's. A layer whose ``d``, ``r`` or original is NaN adds nothing."""
    n = d.shape[0]
    total = 0.0
    for i in range(n):
        gd[i, 0] = 0.0
        gd[i, 1] = 0.0
        gr[i] = 0.0
    for i in range(n):
        if not (d[i, 0] == d[i, 0] and d[i, 1] == d[i, 1] and r[i] == r[i]
                and orig[i, 0] == orig[i, 0] and orig[i, 1] == orig[i, 1]) or w[i] == 0.0:
            continue
        w2 = w[i] * w[i]
        if comfort:
            x, v = d[i, 0], d[i, 1]
            ax = x - hi if x > hi else (x - lo if x < lo else 0.0)
            ay = v - vert if v > vert else (v + vert if v < -vert else 0.0)
            tx = min(hi, max(lo, orig[i, 0]))
            ty = min(vert, max(-vert, orig[i, 1]))
        else:
            ax, ay = d[i, 0], d[i, 1]
            tx, ty = orig[i, 0], orig[i, 1]
        ma = maps[0, i] * w2
        total += alpha[0] * ma * (ax * ax + ay * ay)
        gd[i, 0] += alpha[0] * 2.0 * ma * ax
        gd[i, 1] += alpha[0] * 2.0 * ma * ay
        mr = maps[2, i] * w2
        if comfort:
            rho = math.sqrt(max(r[i], 0.0))
            over = rho - rho0
            if over > 0.0:
                total += alpha[2] * mr * over * over
                gr[i] += alpha[2] * mr * over / rho
        else:
            total += alpha[2] * mr * r[i] * r[i]
            gr[i] += alpha[2] * 2.0 * mr * r[i]
        md = maps[3, i] * w2
        ex, ey = d[i, 0] - tx, d[i, 1] - ty
        total += alpha[3] * md * (ex * ex + ey * ey)
        gd[i, 0] += alpha[3] * 2.0 * md * ex
        gd[i, 1] += alpha[3] * 2.0 * md * ey
        for j in range(i + 1, n):
            if not (d[j, 0] == d[j, 0] and d[j, 1] == d[j, 1] and r[j] == r[j]
                    and orig[j, 0] == orig[j, 0] and orig[j, 1] == orig[j, 1]) or w[j] == 0.0:
                continue
            pair = 0.5 * (maps[1, i] + maps[1, j]) * (w[i] * w[j]) ** 2
            for c in range(1 if comfort else 2):
                phys = orig[j, c] - orig[i, c]  # the pair keeps its physical order
                now = d[j, c] - d[i, c]
                sigma = 1.0 if phys > 0 else (-1.0 if phys < 0 else (1.0 if now >= 0 else -1.0))
                gap = sigma * now - (lamx if c == 0 else lamy)
                if comfort and gap > 0.0:
                    continue  # ours: only closer than lambda (or swapped) costs
                total += alpha[1] * pair * gap * gap
                g = alpha[1] * 2.0 * pair * gap * sigma
                gd[j, c] += g
                gd[i, c] -= g
    return total


@nb.njit(cache=True, parallel=True)
def descend(tab, weight, orig, maps, free, starts, steps, first_step, alpha, comfort, lo, hi, vert, rho0, lamx, lamy,
            out_y, out_cost):  # pragma: no cover - compiled
    """Per pixel, the offsets ``y`` in [0, 1]^N minimising S3 Eq. 2 on the tabulated ``g(y)``.

    Pixel-major inputs, so that one pixel's table is one contiguous block: ``tab (H, W, N, K+1, 3)``,
    channels (dx, dy, rivalry) at offsets ``m / K``; ``weight (H, W, N)``: the importance, fixed;
    ``orig (H, W, N, 2)``; ``maps (H, W, 4, N)``; ``free (N,)``: layers that move (the diffuse one
    stays at 1). A layer whose four maps are 0 at the pixel is frozen there (stays at 1). Rows without
    a match are filled first (:func:`_fill_rows`). From each start ``starts[s] (N,)``: ``steps`` steps
    of projected gradient descent, ``dy = -step * grad / max|grad|`` (``grad_i = df/dd_i . d'_i +
    df/dr_i r'_i``, the table's slopes), a step kept only when it lowers the cost, else halved. The
    best of the starts wins (ties to the first). A pixel where no moving layer has importance keeps
    ``y = 1`` without descending. Writes ``out_y (N, H, W)`` and ``out_cost (H, W)``.
    """
    h, w, n, kp1, _ = tab.shape
    k = kp1 - 1
    for yrow in nb.prange(h):
        px = np.empty((n, kp1, 3))
        d = np.empty((n, 2))
        dd = np.empty((n, 2))
        r = np.empty(n)
        dr = np.empty(n)
        gd = np.empty((n, 2))
        gr = np.empty(n)
        keep_gd = np.empty((n, 2))
        keep_gr = np.empty(n)
        keep_dd = np.empty((n, 2))
        keep_dr = np.empty(n)
        cur = np.empty(n)
        trial = np.empty(n)
        grad = np.empty(n)
        best_y = np.empty(n)
        moves = np.empty(n, np.bool_)
        for x in range(w):
            px[:] = tab[yrow, x]
            _fill_rows(px)
            wt, po, pm = weight[yrow, x], orig[yrow, x], maps[yrow, x]
            active = False  # some moving layer has importance
            for i in range(n):
                moves[i] = free[i] and (pm[0, i] + pm[1, i] + pm[2, i] + pm[3, i]) > 0.0
                if moves[i] and wt[i] > 0.0:
                    active = True
            best = np.inf
            for s in range(starts.shape[0] if active else 1):
                for i in range(n):
                    cur[i] = starts[s, i] if moves[i] else 1.0
                _state(px, cur, k, d, r, dd, dr)
                f = _cost(d, r, wt, po, pm, alpha, comfort, lo, hi, vert, rho0, lamx, lamy, gd, gr)
                step = first_step
                for _ in range(steps if active else 0):
                    top = 0.0
                    for i in range(n):
                        g = 0.0
                        if moves[i]:
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
                        keep_gr[i] = gr[i]
                        keep_dr[i] = dr[i]
                        for c in range(2):
                            keep_gd[i, c] = gd[i, c]
                            keep_dd[i, c] = dd[i, c]
                    _state(px, trial, k, d, r, dd, dr)
                    ft = _cost(d, r, wt, po, pm, alpha, comfort, lo, hi, vert, rho0, lamx, lamy, gd, gr)
                    if ft < f:
                        f = ft
                        for i in range(n):
                            cur[i] = trial[i]
                    else:  # back to cur: only its slopes and gradient are read again
                        step *= 0.5
                        for i in range(n):
                            gr[i] = keep_gr[i]
                            dr[i] = keep_dr[i]
                            for c in range(2):
                                gd[i, c] = keep_gd[i, c]
                                dd[i, c] = keep_dd[i, c]
                if f < best:
                    best = f
                    for i in range(n):
                        best_y[i] = cur[i]
            for i in range(n):
                out_y[i, yrow, x] = best_y[i]
            out_cost[yrow, x] = best
