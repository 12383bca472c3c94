"""Numba kernels of S2's novel view (:func:`vergence.stereospace.s2_view`).

- :func:`render_view`: the MLS maps read off their grid, the angle + field-of-view penalty on a
  proxy plane, the ULR weights and the bilinear samples of the sources, fused in one pass over the
  target's pixels (no full-size intermediate);
- :func:`select_handles`: each source's MLS handles, one per cell of the target image;
- :func:`node_angles`: the angle penalty at the grid nodes.

The public function validates; the kernels trust their inputs. Their slow, obviously-correct numpy
twins are in ``tests/stereospace/test_mls_view.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.extending import overload

__all__ = ["node_angles", "render_view", "select_handles"]

# Cell coordinates are clipped to +-2**62 to fit int64 (a point 2**62 cells out shares its cell with
# the others as far).
_KEY_CLIP = 1 << 62


@nb.njit(cache=True, inline="always")
def _taps(u, v, last_x, last_y, base, row_stride, px_stride, weight):  # pragma: no cover - compiled
    """Offsets (into the flattened image stack) of the 4 pixels around ``(u, v)``, ``-1 <= floor(u) <=
    last_x`` and ``-1 <= floor(v) <= last_y`` (the image's last column and row, as floats), of an image
    starting at ``base`` (``row_stride`` and ``px_stride`` values a row and a pixel; all three floats),
    edge pixels repeated, and their bilinear weights times ``weight``. The first offset is computed in
    float64 (exact below 2**53) and the others added by selects: no integer multiplication, which the
    vectorised loop would do in 64-bit lanes."""
    fx, fy = np.floor(u), np.floor(v)
    dx, dy = u - fx, v - fy
    o00 = np.int64(base + max(fy, 0.0) * row_stride + max(fx, 0.0) * px_stride)
    o01 = o00 + (np.int64(px_stride) if (fx >= 0.0) & (fx < last_x) else 0)
    down = np.int64(row_stride) if (fy >= 0.0) & (fy < last_y) else 0
    top, bottom = weight * (1.0 - dy), weight * dy
    return (o00, o01, o00 + down, o01 + down, top * (1.0 - dx), top * dx, bottom * (1.0 - dx),
            bottom * dx)  # fmt: skip


def _add_sample(flat, o00, o01, o10, o11, w00, w01, w10, w11, red, green, blue, row, x, values):  # pragma: no cover
    """The bilinear sample (taps ``o..``, weights ``w..``) added to the pixel ``x`` of the row's sums:
    ``red``, ``green``, ``blue`` for RGB, ``row[x, c]`` for other channel counts. RGB packed in a uint32
    (``R | G << 8 | B << 16``), bytes read through ``values`` (their float64), float32 values as they are.
    Replaced by its overload in compiled code."""
    raise NotImplementedError("compiled only")


@overload(_add_sample, inline="always")
def _add_sample_overload(flat, o00, o01, o10, o11, w00, w01, w10, w11, red, green, blue, row, x,
                         values):  # pragma: no cover - compiled
    if flat.dtype == nb.types.uint32:
        def packed(flat, o00, o01, o10, o11, w00, w01, w10, w11, red, green, blue, row, x, values):
            p00, p01, p10, p11 = flat[np.uint64(o00)], flat[np.uint64(o01)], flat[np.uint64(o10)], flat[np.uint64(o11)]
            red[x] += (w00 * np.float64(p00 & 255) + w01 * np.float64(p01 & 255)
                       + w10 * np.float64(p10 & 255) + w11 * np.float64(p11 & 255))
            green[x] += (w00 * np.float64((p00 >> 8) & 255) + w01 * np.float64((p01 >> 8) & 255)
                         + w10 * np.float64((p10 >> 8) & 255) + w11 * np.float64((p11 >> 8) & 255))
            blue[x] += (w00 * np.float64((p00 >> 16) & 255) + w01 * np.float64((p01 >> 16) & 255)
                        + w10 * np.float64((p10 >> 16) & 255) + w11 * np.float64((p11 >> 16) & 255))
        return packed

    def channels(flat, o00, o01, o10, o11, w00, w01, w10, w11, red, green, blue, row, x, values):
        if row.shape[1] == 3:
            red[x] += (w00 * _stored(flat, o00, values) + w01 * _stored(flat, o01, values)
                       + w10 * _stored(flat, o10, values) + w11 * _stored(flat, o11, values))
            green[x] += (w00 * _stored(flat, o00 + 1, values) + w01 * _stored(flat, o01 + 1, values)
                         + w10 * _stored(flat, o10 + 1, values) + w11 * _stored(flat, o11 + 1, values))
            blue[x] += (w00 * _stored(flat, o00 + 2, values) + w01 * _stored(flat, o01 + 2, values)
                        + w10 * _stored(flat, o10 + 2, values) + w11 * _stored(flat, o11 + 2, values))
        else:
            for c in range(row.shape[1]):
                row[x, c] += (w00 * _stored(flat, o00 + c, values) + w01 * _stored(flat, o01 + c, values)
                              + w10 * _stored(flat, o10 + c, values) + w11 * _stored(flat, o11 + c, values))
    return channels


def _stored(flat, o, values):  # pragma: no cover - replaced by its overload in compiled code
    """The value at ``flat[o]`` as float64: a byte through ``values`` (its float64), else itself."""
    return values[flat[o]] if flat.dtype == np.uint8 else float(flat[o])


@overload(_stored, inline="always")
def _stored_overload(flat, o, values):  # pragma: no cover - compiled
    if flat.dtype == nb.types.uint8:
        return lambda flat, o, values: values[flat[np.uint64(o)]]
    return lambda flat, o, values: np.float64(flat[np.uint64(o)])


@nb.njit(cache=True, parallel=True, error_model="numpy")
def render_view(images, sizes, ids, at_nodes, xs, ys, step, floor, k, scale, negligible, image, weights,
                unit):  # pragma: no cover - compiled
    """S2's view of a target camera from ``S`` warped sources.

    Source ``s`` is the image ``unit * images[ids[s]]`` (``images (N, Hm, Wm, C)`` float32 with
    ``unit`` 1, or uint8 with ``unit`` 1/255: the colour is summed from the stored values and scaled
    once; or ``(N, Hm, Wm)`` uint32, 8-bit RGB packed ``R | G << 8 | B << 16``, with ``unit``
    1/255); its pixels
    ``sizes[ids[s]] = (h_s, w_s)``; ``ids[s] < 0``: left out). ``at_nodes[s] (ny, nx, 3)`` holds at
    the node columns ``xs`` and rows ``ys`` (``0, step, 2 step, ..., last pixel``; at least 2 of
    each) its MLS map (target pixel -> source position ``(u, v)``) and its angle penalty ``P_ANG``
    (radians), both bilinear in between (as ``_mls_kernels.interpolate_grid``). At each pixel:

    - ``(u, v)`` is valid when ``-0.5 <= u <= w_s - 0.5``, ``-0.5 <= v <= h_s - 0.5`` (``P_FOV = 0``,
      else inf: S2 §3.1 Eq. (4)); ``P = max(floor, P_ANG)`` where valid;
    - ULR weights (Buehler et al. 2001): with m >= k valid sources ``w_s = max(0, 1 - P_s / (scale P_(k)))``,
      ``P_(k)`` the k-th smallest; with 0 < m < k equal weights; normalised;
    - the colour is ``sum_s w_s I_s(u, v)`` over the sources with ``w_s > negligible`` (the k-th
      source's weight of about 1e-7 left out changes the colour by less than that), ``I_s`` sampled
      bilinearly with the edge pixels repeated (cv2.remap's ``BORDER_REPLICATE``, with exact
      weights where cv2 rounds them to 1/32 pixel).

    Writes ``image (h, w, C)`` (0 where no source is valid) and, when ``weights`` is ``(S, h, w)``
    (not ``(S, 0, 0)``), the normalised weights. One row per task, each stage a loop over the row
    (branch-free where it can be, so that the compiler vectorises it): the maps and penalties cell
    by cell of the grid, the ULR threshold (with exactly k valid sources ``P_(k)`` is the largest
    valid penalty: no sort), the weights and their normalisation (the same divisions as pixel by
    pixel: the same weights); the colour is gathered source by source (each source's rows read in
    order: twice as fast as pixel by pixel, where the sources' rows evict each other from the cache)
    into one sum a channel, 8-bit values read through a table of their float64 values or unpacked
    from their uint32. The row's arrays are indexed, never sliced into views: with no view in the
    parallel loop Numba tells LLVM that its arrays do not overlap (``noalias``), and the row loops
    are vectorised without run-time overlap checks, the colour gather included (masked AVX gathers,
    the taps' offsets from float64 products: no 64-bit integer multiplication in the lanes). With
    views and RGB read byte by byte (the tree at ``a8db4fb``) kermit's and dino's pairs took 1.1-1.3
    times the CPU time, with identical images (``tools.stereospace_pair_ab``, docs/stereospace.md).
    """
    s_count = ids.shape[0]
    h, w, n_ch = image.shape
    nx = xs.shape[0]
    ny = ys.shape[0]
    keep = weights.shape[1] == h and weights.shape[2] == w
    flat = images.reshape(-1)
    image_stride = flat.shape[0] // images.shape[0]
    row_stride = image_stride // images.shape[1]
    px_stride = row_stride // images.shape[2]  # 1 packed, else the channels
    rows_f, px_f = np.float64(row_stride), np.float64(px_stride)
    values = np.arange(256).astype(np.float64)  # a stored byte's value (unused for other images)
    frac = np.empty(w)  # each column's position in its grid cell
    for x in range(w):
        i = min(x // step, nx - 2)
        frac[x] = (x - xs[i]) / (xs[i + 1] - xs[i])
    for y in nb.prange(h):
        pen = np.empty((s_count, w))  # the penalties, then the weights
        us = np.empty((s_count, w))
        vs = np.empty((s_count, w))
        along = np.empty((3, nx))
        count = np.zeros(w, dtype=np.int64)  # valid sources at each pixel
        largest = np.zeros(w)  # their largest penalty
        thresh = np.empty(w)
        total = np.zeros(w)
        order = np.empty(s_count)
        red = np.zeros(w)  # the colour: RGB in three sums (one array each: they cannot overlap)
        green = np.zeros(w)
        blue = np.zeros(w)
        row = np.zeros((w if n_ch != 3 else 0, n_ch))  # other channel counts
        j = min(y // step, ny - 2)
        ty = (y - ys[j]) / (ys[j + 1] - ys[j])
        for s in range(s_count):
            if ids[s] < 0:
                for x in range(w):
                    pen[s, x] = np.inf
                continue
            v_max, u_max = sizes[ids[s], 0] - 0.5, sizes[ids[s], 1] - 0.5
            for i in range(nx):  # the node rows j and j + 1 mixed: the map and angle along this row
                for c in range(3):
                    along[c, i] = at_nodes[s, j, i, c] + ty * (at_nodes[s, j + 1, i, c] - at_nodes[s, j, i, c])
            for i in range(nx - 1):  # cell i: columns i * step to the next node (the last cell: to w)
                u0, v0, t0 = along[0, i], along[1, i], along[2, i]
                du, dv, dt = along[0, i + 1] - u0, along[1, i + 1] - v0, along[2, i + 1] - t0
                for x in range(i * step, (i + 1) * step if i < nx - 2 else w):
                    tx = frac[x]
                    u = u0 + tx * du
                    v = v0 + tx * dv
                    us[s, x] = u
                    vs[s, x] = v
                    valid = (u >= -0.5) & (u <= u_max) & (v >= -0.5) & (v <= v_max)
                    pen[s, x] = max(floor, t0 + tx * dt) if valid else np.inf
            for x in range(w):
                valid = pen[s, x] < np.inf
                count[x] += 1 if valid else 0
                largest[x] = max(largest[x], pen[s, x]) if valid else largest[x]
        for x in range(w):  # scale P_(k) where m >= k
            m = count[x]
            if m == k:
                thresh[x] = scale * largest[x]
            elif m > k:
                for s in range(s_count):  # insertion sort of at most a few penalties
                    val = pen[s, x]
                    r = s - 1
                    while r >= 0 and order[r] > val:
                        order[r + 1] = order[r]
                        r -= 1
                    order[r + 1] = val
                thresh[x] = scale * order[k - 1]
            else:
                thresh[x] = np.inf
        for s in range(s_count):
            for x in range(w):
                p = pen[s, x]
                wt = max(0.0, 1.0 - p / thresh[x]) if count[x] >= k else 1.0
                wt = wt if p < np.inf else 0.0
                pen[s, x] = wt
                total[x] += wt
        for x in range(w):
            total[x] = total[x] if total[x] > 0.0 else np.inf  # no valid source: weights 0
        for s in range(s_count):
            for x in range(w):
                pen[s, x] /= total[x]
            if keep:
                for x in range(w):
                    weights[s, y, x] = pen[s, x]
        for s in range(s_count):  # the colour source by source: each source's rows read in order
            n = ids[s]
            if n < 0:
                continue
            last_x, last_y = np.float64(sizes[n, 1] - 1), np.float64(sizes[n, 0] - 1)
            base = np.float64(n * image_stride)
            for x in range(w):
                wn = pen[s, x]
                if wn > negligible:
                    o00, o01, o10, o11, w00, w01, w10, w11 = _taps(us[s, x], vs[s, x], last_x, last_y, base,
                                                                   rows_f, px_f, wn)  # fmt: skip
                    _add_sample(flat, o00, o01, o10, o11, w00, w01, w10, w11, red, green, blue, row, x, values)
        if n_ch == 3:
            for x in range(w):
                image[y, x, 0] = red[x] * unit
                image[y, x, 1] = green[x] * unit
                image[y, x, 2] = blue[x] * unit
        else:
            for x in range(w):
                for c in range(n_ch):
                    image[y, x, c] = row[x, c] * unit


@nb.njit(cache=True, inline="always")  # inlined: compiled with select_handles, never on its own
def _first_per_cell(kx, ky, keep):  # pragma: no cover - compiled
    """``keep[r]`` True for the first ``r`` (in order) of each distinct ``(kx[r], ky[r])``: two stable sorts."""
    by_y = np.argsort(ky, kind="mergesort")
    order = by_y[np.argsort(kx[by_y], kind="mergesort")]
    for r in range(order.shape[0]):
        a = order[r]
        keep[a] = r == 0 or kx[a] != kx[order[r - 1]] or ky[a] != ky[order[r - 1]]


@nb.njit(cache=True, parallel=True)
def select_handles(seen, ids, in_front, q, cell, window, chosen, counts):  # pragma: no cover - compiled
    """The handles of the sources ``ids``: one point per ``cell`` x ``cell`` square of the target image.

    Source ``s`` keeps, of the points ``p`` with ``seen[ids[s], p]`` and ``in_front[p]`` (its
    ``(N, P)`` and ``(P,)`` bool masks), the first (in index order) whose target position ``q[p]``
    falls in each cell ``floor(q / cell)``; writes their indices, ascending, to
    ``chosen[s, :counts[s]]`` (``chosen (S, P)`` int64). Cells inside ``window = (x0, y0, x1, y1)``
    (cell coordinates, ``x0 <= kx < x1``) are marked in a grid in one pass; the few points outside
    it are sorted by cell (two stable sorts). The numpy twin sorts all cells with ``np.lexsort``
    (``tests/stereospace/test_mls_view.py``).
    """
    n_points = in_front.shape[0]
    gx0, gy0, gx1, gy1 = window[0], window[1], window[2], window[3]
    for s in nb.prange(ids.shape[0]):
        n = ids[s]
        taken = np.zeros((gy1 - gy0, gx1 - gx0), dtype=np.bool_)
        keep = np.zeros(n_points, dtype=np.bool_)
        out_idx = np.empty(n_points, dtype=np.int64)
        out_kx = np.empty(n_points, dtype=np.int64)
        out_ky = np.empty(n_points, dtype=np.int64)
        m_out = 0
        for p in range(n_points):
            if not (seen[n, p] and in_front[p]):
                continue
            kx = np.int64(min(max(math.floor(q[p, 0] / cell), -_KEY_CLIP), _KEY_CLIP))
            ky = np.int64(min(max(math.floor(q[p, 1] / cell), -_KEY_CLIP), _KEY_CLIP))
            if gx0 <= kx < gx1 and gy0 <= ky < gy1:
                if not taken[ky - gy0, kx - gx0]:
                    taken[ky - gy0, kx - gx0] = True
                    keep[p] = True
            else:
                out_idx[m_out] = p
                out_kx[m_out] = kx
                out_ky[m_out] = ky
                m_out += 1
        if m_out:
            first = np.zeros(m_out, dtype=np.bool_)
            _first_per_cell(out_kx[:m_out], out_ky[:m_out], first)
            for r in range(m_out):
                if first[r]:
                    keep[out_idx[r]] = True
        c = 0
        for p in range(n_points):
            if keep[p]:
                chosen[s, c] = p
                c += 1
        counts[s] = c


@nb.njit(cache=True, parallel=True, error_model="numpy")
def node_angles(nodes, K_inv, R_t, centre, centres, depth, out):  # pragma: no cover - compiled
    """``P_ANG (S, len(nodes))`` (S2 §3.1 Eq. (4)) into ``out``: at each node's proxy point ``P`` (its
    ray at camera-frame depth ``depth``: ``P = R^T (depth K^-1 [x, y, 1] - t)``, given as
    ``centre + depth R^T K^-1 [x, y, 1]``), the angle between ``centre - P`` and ``centres[s] - P``
    as ``atan2(|a x b|, a . b)`` (accurate at small angles too)."""
    for k in nb.prange(nodes.shape[0]):
        ray = np.empty(3)
        for r in range(3):
            ray[r] = K_inv[r, 0] * nodes[k, 0] + K_inv[r, 1] * nodes[k, 1] + K_inv[r, 2]
        px = centre[0] + depth * (R_t[0, 0] * ray[0] + R_t[0, 1] * ray[1] + R_t[0, 2] * ray[2])
        py = centre[1] + depth * (R_t[1, 0] * ray[0] + R_t[1, 1] * ray[1] + R_t[1, 2] * ray[2])
        pz = centre[2] + depth * (R_t[2, 0] * ray[0] + R_t[2, 1] * ray[1] + R_t[2, 2] * ray[2])
        ax, ay, az = centre[0] - px, centre[1] - py, centre[2] - pz
        for s in range(centres.shape[0]):
            bx, by, bz = centres[s, 0] - px, centres[s, 1] - py, centres[s, 2] - pz
            cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            out[s, k] = math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz)
