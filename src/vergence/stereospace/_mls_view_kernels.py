"""Numba kernel of S2's novel view (:func:`vergence.stereospace.s2_view`): the MLS maps read off
their grid, the angle + field-of-view penalty on a proxy plane, the ULR weights and the bilinear
samples of the sources, fused in one pass over the target's pixels (no full-size intermediate).
The public function validates; the kernel trusts its inputs. Its slow, obviously-correct numpy
twin is in ``tests/stereospace/test_mls_view.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from vergence.synthesis._ibr_kernels import lift

__all__ = ["render_view"]


@nb.njit(cache=True, parallel=True, error_model="numpy")
def render_view(images, sizes, ids, at_nodes, xs, ys, step, Kinv, R, t, centre, centres, depth, floor, k, scale,
                image, weights):  # pragma: no cover - compiled
    """S2's view of the target camera ``(Kinv, R, t, centre)`` from ``S`` warped sources.

    Source ``s`` is the image ``images[ids[s]]`` (``images (N, Hm, Wm, C)`` float32, its pixels
    ``sizes[ids[s]] = (h_s, w_s)``; ``ids[s] < 0``: left out), camera centre ``centres[s]``; its
    MLS map (target pixel -> source position) is ``at_nodes[s] (ny, nx, 2)`` at the node columns
    ``xs`` and rows ``ys`` (``0, step, 2 step, ..., last pixel``; at least 2 of each), bilinear in
    between (as ``_mls_kernels.interpolate_grid``). At each pixel:

    - the source position ``(u, v)`` is valid when ``-0.5 <= u <= w_s - 0.5``, ``-0.5 <= v <= h_s - 0.5``
      (``P_FOV = 0``, else inf: S2 §3.1 Eq. (4));
    - ``P_ANG`` is the angle at ``P = R^T (depth K^-1 (x, y, 1) - t)`` between ``centre - P`` and
      ``centres[s] - P``, floored at ``floor``;
    - ULR weights (Buehler et al. 2001): with m >= k valid sources ``w_s = max(0, 1 - P_s / (scale P_(k)))``,
      ``P_(k)`` the k-th smallest; with 0 < m < k equal weights; normalised;
    - the colour is ``sum_s w_s I_s(u, v)``, ``I_s`` sampled bilinearly with the edge pixels repeated
      (cv2.remap's ``BORDER_REPLICATE``, with exact weights where cv2 rounds them to 1/32 pixel).

    Writes ``image (h, w, C)`` (0 where no source is valid) and, when ``weights`` is ``(S, h, w)``
    (not ``(S, 0, 0)``), the normalised weights.
    """
    s_count = ids.shape[0]
    h, w, n_ch = image.shape
    nx = xs.shape[0]
    ny = ys.shape[0]
    keep = weights.shape[1] == h and weights.shape[2] == w
    for y in nb.prange(h):
        pen = np.empty(s_count)
        order = np.empty(s_count)
        wts = np.empty(s_count)
        us = np.empty(s_count)
        vs = np.empty(s_count)
        acc = np.empty(n_ch)
        j = min(y // step, ny - 2)
        ty = (y - ys[j]) / (ys[j + 1] - ys[j])
        for x in range(w):
            i = min(x // step, nx - 2)
            tx = (x - xs[i]) / (xs[i + 1] - xs[i])
            px, py, pz = lift(Kinv, R, t, x, y, depth)
            ax, ay, az = centre[0] - px, centre[1] - py, centre[2] - pz
            an = math.sqrt(ax * ax + ay * ay + az * az)
            m = 0
            for s in range(s_count):
                pen[s] = np.inf
                if ids[s] < 0:
                    continue
                a = at_nodes[s]
                top = a[j, i, 0] + tx * (a[j, i + 1, 0] - a[j, i, 0])
                bottom = a[j + 1, i, 0] + tx * (a[j + 1, i + 1, 0] - a[j + 1, i, 0])
                u = top + ty * (bottom - top)
                top = a[j, i, 1] + tx * (a[j, i + 1, 1] - a[j, i, 1])
                bottom = a[j + 1, i, 1] + tx * (a[j + 1, i + 1, 1] - a[j + 1, i, 1])
                v = top + ty * (bottom - top)
                if not (-0.5 <= u <= sizes[ids[s], 1] - 0.5 and -0.5 <= v <= sizes[ids[s], 0] - 0.5):
                    continue
                us[s] = u
                vs[s] = v
                bx, by, bz = centres[s, 0] - px, centres[s, 1] - py, centres[s, 2] - pz
                bn = math.sqrt(bx * bx + by * by + bz * bz)
                c = (ax * bx + ay * by + az * bz) / (an * bn)
                pen[s] = max(floor, math.acos(min(1.0, max(-1.0, c))))
                m += 1
            total = 0.0
            if m >= k:
                for s in range(s_count):  # insertion sort of at most a few penalties
                    val = pen[s]
                    r = s - 1
                    while r >= 0 and order[r] > val:
                        order[r + 1] = order[r]
                        r -= 1
                    order[r + 1] = val
                thresh = scale * order[k - 1]
                for s in range(s_count):
                    wts[s] = max(0.0, 1.0 - pen[s] / thresh) if pen[s] < np.inf else 0.0
                    total += wts[s]
            else:
                for s in range(s_count):
                    wts[s] = 1.0 if pen[s] < np.inf else 0.0
                    total += wts[s]
            for c in range(n_ch):
                acc[c] = 0.0
            for s in range(s_count):
                ws = wts[s] / total if total > 0.0 else 0.0
                if keep:
                    weights[s, y, x] = ws
                if ws > 0.0:
                    img = images[ids[s]]
                    hs, wd = sizes[ids[s], 0], sizes[ids[s], 1]
                    fx, fy = math.floor(us[s]), math.floor(vs[s])
                    dx, dy = us[s] - fx, vs[s] - fy
                    x0, y0 = min(max(int(fx), 0), wd - 1), min(max(int(fy), 0), hs - 1)
                    x1, y1 = min(int(fx) + 1, wd - 1), min(int(fy) + 1, hs - 1)
                    for c in range(n_ch):
                        upper = img[y0, x0, c] + dx * (img[y0, x1, c] - img[y0, x0, c])
                        lower = img[y1, x0, c] + dx * (img[y1, x1, c] - img[y1, x0, c])
                        acc[c] += ws * (upper + dy * (lower - upper))
            for c in range(n_ch):
                image[y, x, c] = acc[c]
