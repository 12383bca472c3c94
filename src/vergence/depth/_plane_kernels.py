"""Numba kernels of the segment planes (:mod:`vergence.depth.planes`), which validates first.

Graph segmentation (Felzenszwalb & Huttenlocher 2004, IJCV 59(2), "Efficient Graph-Based Image
Segmentation", §4, Algorithm 1) on edges sorted once for every scale, and the per-segment sums and
medians of the planes' IRLS. Slow, obviously correct references in ``tests/depth/test_plane_kernels.py``
(scikit-image's ``felzenszwalb`` for the segmentation, the vectorised NumPy IRLS for the sums).

All run on one thread: the union-find is sequential, and the per-segment loops, parallel over segments,
gained 17 % at 1920x1080 (85 segments of unequal size) and lost 10x on two busy shared cores.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["centred_moments", "grid_edges", "group_by_segment", "inlier_counts", "irls_sums", "segment_graph",
           "segment_medians", "sort_distinct"]


@numba.njit(cache=True)
def grid_edges(order: np.ndarray, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    """Flat pixel indices ``(p, q)`` of the 8-connected grid edges ``order`` lists.

    Edge numbering (as scikit-image's ``felzenszwalb``): first the ``h (w - 1)`` horizontal edges
    ``(y, x)-(y, x + 1)``, then the ``(h - 1) w`` vertical ones ``(y, x)-(y + 1, x)``, then the
    ``(h - 1)(w - 1)`` diagonals ``(y, x)-(y + 1, x + 1)``, then the anti-diagonals ``(y, x + 1)-(y + 1, x)``,
    each block in row-major order of ``(y, x)``.
    """
    n_right = h * (w - 1)
    n_down = (h - 1) * w
    n_diag = (h - 1) * (w - 1)
    p = np.empty(order.size, np.int64)
    q = np.empty(order.size, np.int64)
    for i in range(order.size):
        e = order[i]
        if e < n_right:
            y, x = divmod(e, w - 1)
            p[i] = y * w + x
            q[i] = p[i] + 1
        elif e < n_right + n_down:
            p[i] = e - n_right
            q[i] = p[i] + w
        elif e < n_right + n_down + n_diag:
            y, x = divmod(e - n_right - n_down, w - 1)
            p[i] = y * w + x
            q[i] = p[i] + w + 1
        else:
            y, x = divmod(e - n_right - n_down - n_diag, w - 1)
            p[i] = y * w + x + 1
            q[i] = p[i] + w - 1
    return p, q


_DIGIT_BITS = 16  # radix of sort_distinct: 4 passes over 64-bit keys (11 bits, 6 passes, measured slower)


@numba.njit(cache=True)
def sort_distinct(keys: np.ndarray) -> tuple[np.ndarray, bool]:  # pragma: no cover - compiled
    """Order sorting the non-negative float64 ``keys`` (LSD radix sort of their bits), and whether they are
    all distinct: then it is the only sorting order, ``numpy.argsort``'s included; with ties it is the
    stable order, which ``argsort`` need not give.
    """
    n = keys.size
    digits = 1 << _DIGIT_BITS
    mask = np.uint64(digits - 1)
    kb = keys.view(np.uint64).copy()  # +0.0 <= x: the bits of non-negative doubles order as the numbers
    idx = np.arange(n)
    kb2 = np.empty(n, np.uint64)
    idx2 = np.empty(n, np.int64)
    counts = np.zeros(digits, np.int64)
    for shift in range(0, 64, _DIGIT_BITS):
        sh = np.uint64(shift)
        counts[:] = 0
        for i in range(n):
            counts[(kb[i] >> sh) & mask] += 1
        if counts.max() == n:
            continue  # one digit value for all: the order stands
        total = 0
        for b in range(digits):
            c = counts[b]
            counts[b] = total
            total += c
        for i in range(n):
            b = (kb[i] >> sh) & mask
            j = counts[b]
            counts[b] = j + 1
            kb2[j] = kb[i]
            idx2[j] = idx[i]
        kb, kb2 = kb2, kb
        idx, idx2 = idx2, idx
    for i in range(1, n):
        if kb[i] == kb[i - 1]:
            return idx, False
    return idx, True


@numba.njit(cache=True, inline="always")
def _root(parent: np.ndarray, i: int) -> int:  # pragma: no cover - compiled
    """Root of ``i`` (the smallest pixel index of its segment), halving the path on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True)
def segment_graph(p: np.ndarray, q: np.ndarray, cost: np.ndarray, n: int, k: float,
                  min_size: int) -> np.ndarray:  # pragma: no cover - compiled
    """Felzenszwalb-Huttenlocher segments of ``n`` pixels from edges ``(p, q)`` sorted by ``cost``.

    An edge joins its two segments when its cost is below both ``Int(C) + k / |C|`` (FH 2004 Eq. 3-5;
    ``Int(C)``, the largest edge of the segment's minimum spanning tree, is the last edge that joined it,
    and the threshold is rounded to float32, as scikit-image's ``felzenszwalb``); a second pass over the
    same order joins the ends of any edge with a segment smaller than ``min_size`` (FH 2004 §4.2).
    Returns the labels ``0 .. N-1``, numbered in row-major order of each segment's first pixel.
    """
    parent = np.arange(n)
    size = np.ones(n, np.int64)
    internal = np.zeros(n)
    for i in range(p.size):
        a = _root(parent, p[i])
        b = _root(parent, q[i])
        if a == b:
            continue
        ta = np.float32(internal[a] + k / size[a])
        tb = np.float32(internal[b] + k / size[b])
        if cost[i] < min(ta, tb):
            if b < a:
                a, b = b, a
            parent[b] = a
            size[a] += size[b]
            internal[a] = cost[i]
    for i in range(n):
        parent[i] = parent[parent[i]]  # parent[i] <= i, whose root is known: every pixel now points at its root
    for i in range(p.size):
        a = _root(parent, p[i])
        b = _root(parent, q[i])
        if a == b or (size[a] >= min_size and size[b] >= min_size):
            continue
        if b < a:
            a, b = b, a
        parent[b] = a
        size[a] += size[b]
    labels = np.empty(n, np.int64)
    count = 0
    for i in range(n):
        r = _root(parent, i)
        if r == i:
            labels[i] = count
            count += 1
        else:
            labels[i] = labels[r]  # r < i: labelled already
    return labels


@numba.njit(cache=True)
def group_by_segment(lab: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Stable counting sort of the pixels by segment: ``perm`` lists segment ``s``'s pixels, in their
    order, at ``perm[start[s]:start[s + 1]]``.

    Summing a segment's pixels in this order adds them as ``numpy.bincount`` does, to the bit.
    """
    start = np.zeros(n + 1, np.int64)
    for i in range(lab.size):
        start[lab[i] + 1] += 1
    for s in range(n):
        start[s + 1] += start[s]
    fill = start[:n].copy()
    perm = np.empty(lab.size, np.int64)
    for i in range(lab.size):
        perm[fill[lab[i]]] = i
        fill[lab[i]] += 1
    return perm, start


@numba.njit(cache=True)
def centred_moments(x: np.ndarray, y: np.ndarray, perm: np.ndarray, start: np.ndarray):  # pragma: no cover
    """Centroid ``(cx, cy)`` of each segment, its pixels' centred coordinates ``u = x - cx``, ``v = y - cy``
    (grouped as ``perm``) and the second moments ``mean u^2``, ``mean u v``, ``mean v^2`` (an empty
    segment: 0).
    """
    n = start.size - 1
    cx = np.zeros(n)
    cy = np.zeros(n)
    suu = np.zeros(n)
    suv = np.zeros(n)
    svv = np.zeros(n)
    u = np.empty(perm.size)
    v = np.empty(perm.size)
    for s in range(n):
        lo = start[s]
        hi = start[s + 1]
        safe = max(hi - lo, 1)
        sx = 0.0
        sy = 0.0
        for j in range(lo, hi):
            sx += x[perm[j]]
            sy += y[perm[j]]
        cx[s] = sx / safe
        cy[s] = sy / safe
        a = 0.0
        b = 0.0
        c = 0.0
        for j in range(lo, hi):
            uj = x[perm[j]] - cx[s]
            vj = y[perm[j]] - cy[s]
            u[j] = uj
            v[j] = vj
            a += uj * uj
            b += uj * vj
            c += vj * vj
        suu[s] = a / safe
        suv[s] = b / safe
        svv[s] = c / safe
    return cx, cy, u, v, suu, suv, svv


@numba.njit(cache=True)
def segment_medians(d: np.ndarray, start: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """The ``m // 2``-th smallest value of each segment's ``m`` values ``d[start[s]:start[s + 1]]`` (empty: 0)."""
    n = start.size - 1
    med = np.zeros(n)
    for s in range(n):
        m = start[s + 1] - start[s]
        if m > 0:
            med[s] = np.partition(d[start[s]:start[s + 1]], m // 2)[m // 2]  # a copy: d is left alone
    return med


@numba.njit(cache=True)
def irls_sums(u: np.ndarray, v: np.ndarray, d: np.ndarray, start: np.ndarray, abc: np.ndarray, k: float,
              tukey: bool) -> np.ndarray:  # pragma: no cover - compiled
    """Per-segment sums of one IRLS step: ``w uu, w uv, w u, w vv, w v, w, w u d, w v d, w d`` as (n, 9).

    The pixels are grouped by segment (``start`` as :func:`group_by_segment`). ``w`` is Huber's weight
    ``min(1, k / |r|)`` or Tukey's bisquare ``max(0, 1 - (r / 3k)^2)^2`` of the residual
    ``r = d - (a u + b v + c)`` to the segment's plane ``abc[s]``. Each segment's pixels are summed in
    their order, each product formed as in the NumPy reference: the same sums to the bit.
    """
    n = start.size - 1
    out = np.zeros((n, 9))
    c3 = 3.0 * k
    for s in range(n):
        a = abc[s, 0]
        b = abc[s, 1]
        c = abc[s, 2]
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = 0.0  # scalars: registers, not memory
        for i in range(start[s], start[s + 1]):
            ui = u[i]
            vi = v[i]
            di = d[i]
            r = abs(di - (a * ui + b * vi + c))
            if tukey:
                t = max(1.0 - (r / c3) * (r / c3), 0.0)
                wt = t * t
            else:
                wt = min(1.0, k / max(r, k))
            s0 += wt * ui * ui
            s1 += wt * ui * vi
            s2 += wt * ui
            s3 += wt * vi * vi
            s4 += wt * vi
            s5 += wt
            s6 += wt * ui * di
            s7 += wt * vi * di
            s8 += wt * di
        out[s, 0], out[s, 1], out[s, 2], out[s, 3], out[s, 4] = s0, s1, s2, s3, s4
        out[s, 5], out[s, 6], out[s, 7], out[s, 8] = s5, s6, s7, s8
    return out


@numba.njit(cache=True)
def inlier_counts(u: np.ndarray, v: np.ndarray, d: np.ndarray, start: np.ndarray, abc: np.ndarray,
                  k: float) -> np.ndarray:  # pragma: no cover - compiled
    """Pixels of each segment within ``k`` of its plane (``|d - (a u + b v + c)| <= k``), as float64."""
    n = start.size - 1
    out = np.zeros(n)
    for s in range(n):
        count = 0
        for i in range(start[s], start[s + 1]):
            if abs(d[i] - (abc[s, 0] * u[i] + abc[s, 1] * v[i] + abc[s, 2])) <= k:
                count += 1
        out[s] = count
    return out
