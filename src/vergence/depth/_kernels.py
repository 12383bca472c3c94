"""Numba kernels of the disparity refinement; the public functions in ``refine.py`` validate first.

Each kernel has a slow, obviously correct reference in ``tests/depth/test_kernels.py``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["fill_background_rows", "weighted_median"]  # the PatchMatch kernels are private to patchmatch.py


@numba.njit(parallel=True, cache=True)
def fill_background_rows(disp: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Replace each NaN by the smaller (farther) of the nearest known values left and right on its row.

    A NaN with a known value on one side only takes that value; a row with no known value stays NaN.
    """
    h, w = disp.shape
    out = disp.copy()
    for y in numba.prange(h):
        left = np.empty(w, disp.dtype)
        last = np.nan
        for x in range(w):
            if not math.isnan(disp[y, x]):
                last = disp[y, x]
            left[x] = last
        last = np.nan
        for x in range(w - 1, -1, -1):
            v = disp[y, x]
            if not math.isnan(v):
                last = v
                continue
            a = left[x]
            if math.isnan(a):
                out[y, x] = last
            elif math.isnan(last):
                out[y, x] = a
            else:
                out[y, x] = min(a, last)
    return out


@numba.njit(parallel=True, cache=True)
def weighted_median(
    disp: np.ndarray,
    guide: np.ndarray,
    update: np.ndarray,
    support: np.ndarray,
    weight_lut: np.ndarray,
    radius: int,
    step: int,
    d_min: float,
    bin_width: float,
    nbins: int,
    space_weights: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """Colour-weighted median of ``disp`` over a sparse window, at the pixels where ``update`` is set.

    Samples ``(y + i*step, x + j*step)`` for ``|i*step|, |j*step| <= radius`` that lie in the image and
    in ``support`` vote with weight ``weight_lut[|I_p - I_q|^2] * space_weights[i + n, j + n]`` (guide in
    integer levels; ``n = radius // step``, ``space_weights`` of shape ``(2n + 1, 2n + 1)``). Votes are
    binned by ``bin_width`` from ``d_min`` into ``nbins`` bins (which must cover every supporting
    value); the result is the mean of the votes in the bin where the cumulative
    weight first reaches half the total. Pixels with no supporting sample keep their value.
    """
    h, w = disp.shape
    c = guide.shape[2]
    n = radius // step
    out = disp.copy()
    for y in numba.prange(h):
        hist = np.zeros(nbins, np.float32)
        hsum = np.zeros(nbins, np.float32)
        for x in range(w):
            if not update[y, x]:
                continue
            lo = nbins
            hi = -1
            for i in range(-n, n + 1):
                v = y + i * step
                if v < 0 or v >= h:
                    continue
                for j in range(-n, n + 1):
                    u = x + j * step
                    if u < 0 or u >= w or not support[v, u]:
                        continue
                    b = int((disp[v, u] - d_min) / bin_width)
                    lo = min(lo, b)
                    hi = max(hi, b)
            if hi < 0:
                continue
            for b in range(lo, hi + 1):
                hist[b] = 0.0
                hsum[b] = 0.0
            total = 0.0
            for i in range(-n, n + 1):
                v = y + i * step
                if v < 0 or v >= h:
                    continue
                for j in range(-n, n + 1):
                    u = x + j * step
                    if u < 0 or u >= w or not support[v, u]:
                        continue
                    d2 = 0
                    for k in range(c):
                        t = np.int32(guide[y, x, k]) - np.int32(guide[v, u, k])
                        d2 += t * t
                    wt = weight_lut[d2] * space_weights[i + n, j + n]
                    b = int((disp[v, u] - d_min) / bin_width)
                    hist[b] += wt
                    hsum[b] += wt * disp[v, u]
                    total += wt
            half = 0.5 * total
            acc = 0.0
            for b in range(lo, hi + 1):
                acc += hist[b]
                if acc >= half and hist[b] > 0.0:
                    out[y, x] = hsum[b] / hist[b]
                    break
    return out


# ---------------------------------------------------------------------------------------------------
# PatchMatch Stereo (Bleyer, Rhemann & Rother 2011, "PatchMatch Stereo - Stereo Matching with Slanted
# Support Windows", BMVC). A view is described by its sign ``sgn``: a pixel x of the view matches the
# pixel ``x + sgn * d`` of the other view (-1 for the left view, +1 for the right one). A plane is
# ``d = a x + b y + c`` in the view's own pixel coordinates; ``planes[y, x] = (a, b, c)``.
# ---------------------------------------------------------------------------------------------------

_SM_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_SM_MUL1 = np.uint64(0xBF58476D1CE4E5B9)
_SM_MUL2 = np.uint64(0x94D049BB133111EB)
_U30 = np.uint64(30)
_U27 = np.uint64(27)
_U31 = np.uint64(31)
_U11 = np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0
# Smallest |n_z| of a plane normal: a steeper plane (|a| or |b| above about 10) is no surface a window sees.
_MIN_NZ = 0.1
# Smallest 1 + sgn a of a plane (the width of its window's image in the other view over the window's own, see
# admissible), and of the denominator of the plane transfer to the other view. PMS states no such limit; on
# venus its random normals left planes with |a| about 1 in weakly textured areas, wrong and failing the
# left-right check; limited, tsukuba 4.20 -> 4.10 %, venus 1.13 -> 1.03 % bad (within the run-to-run
# spread of about 0.2 of another seed, but it also removes a degenerate case).
_MIN_TRANSFER = 0.1
# Window samples whose support weight exp(-|I_p - I_q|_1 / gamma) falls below this are left out of the
# cost: at gamma 10 a colour distance above 69 levels, a sample that adds less than 0.1 % of the centre's.
PMS_MIN_WEIGHT = 1e-3


@numba.njit(cache=True, inline="always")
def admissible(x, y, a, b, c, sgn, d_min, d_max):  # pragma: no cover - compiled
    """Whether the plane ``(a, b, c)`` may stand at ``(x, y)``: its disparity there in ``[d_min, d_max]``, and
    the plane seen from the front in the other view, where the pixel x lands at ``x + sgn d`` with
    ``d(x + sgn d) / dx = 1 + sgn a >= _MIN_TRANSFER`` (a plane with ``1 + sgn a <= 0`` is seen edge-on or
    from behind there: it maps the whole window onto one column, or mirrors it)."""
    return d_min <= a * x + b * y + c <= d_max and 1.0 + sgn * a >= _MIN_TRANSFER


@numba.njit(cache=True, inline="always")
def _uniform(seed: np.uint64, index: np.int64) -> float:  # pragma: no cover - compiled
    """A uniform number in [0, 1) from ``(seed, index)``: splitmix64, so every pixel draws independently."""
    z = seed ^ (np.uint64(index) * _SM_GAMMA)
    z = z + _SM_GAMMA
    z = (z ^ (z >> _U30)) * _SM_MUL1
    z = (z ^ (z >> _U27)) * _SM_MUL2
    z = z ^ (z >> _U31)
    return float(z >> _U11) * _TWO_M53


@numba.njit(cache=True)
def gather_window(y, x, img, grad, lut, radius, step, us, vs, wts, cols, grads):  # pragma: no cover - compiled
    """Collect the window samples of pixel ``(x, y)``: positions, support weights, colours, gradients.

    Samples ``(x + j step, y + i step)``, ``|i step|, |j step| <= radius``, inside the image, with weight
    ``lut[|I_p - I_q|_1]`` (PMS Eq. 4) of at least :data:`PMS_MIN_WEIGHT`. Returns their count.
    """
    h, w, ch = img.shape
    n = radius // step
    m = 0
    for i in range(-n, n + 1):
        v = y + i * step
        if v < 0 or v >= h:
            continue
        for j in range(-n, n + 1):
            u = x + j * step
            if u < 0 or u >= w:
                continue
            dist = 0.0
            for k in range(ch):
                dist += abs(img[y, x, k] - img[v, u, k])
            wt = lut[int(dist)]
            if wt < PMS_MIN_WEIGHT:
                continue
            us[m] = u
            vs[m] = v
            wts[m] = wt
            for k in range(ch):
                cols[m, k] = img[v, u, k]
            for k in range(grad.shape[2]):
                grads[m, k] = grad[v, u, k]
            m += 1
    return m


@numba.njit(cache=True)
def window_cost(m, us, vs, wts, cols, grads, a, b, c, other, other_grad, up, sgn, alpha, tau_color, tau_grad,
                bound):  # pragma: no cover - compiled
    """PMS Eq. (2)-(5) over gathered samples: ``sum w rho(q, q + sgn (a q_x + b q_y + c))``, stopped at ``bound``.

    ``rho = (1 - alpha) min(|I_q - I'_q'|_1, tau_color) + alpha min(|grad I_q - grad I'_q'|, tau_grad)`` with
    I' linearly interpolated along the row and clamped at the image edge: ``other`` and ``other_grad`` are
    the other view sampled every ``1 / up`` pixel (``up * (W - 1) + 1`` columns; cubic in-between samples
    make the linear interpolation nearly cubic). Every term is >= 0, so the sum stops as soon as it
    reaches ``bound`` (such a plane cannot win).
    """
    w = other.shape[1]
    ch = other.shape[2]
    total = 0.0
    for s in range(m):
        u = us[s]
        v = vs[s]
        xm = up * (u + sgn * (a * u + b * v + c))
        if xm < 0.0:
            xm = 0.0
        elif xm > w - 1:
            xm = w - 1.0
        x0 = min(int(xm), w - 2)
        f = xm - x0
        col = 0.0
        for k in range(ch):
            col += abs(cols[s, k] - ((1.0 - f) * other[v, x0, k] + f * other[v, x0 + 1, k]))
        gd = 0.0
        for k in range(other_grad.shape[2]):
            gd += abs(grads[s, k] - ((1.0 - f) * other_grad[v, x0, k] + f * other_grad[v, x0 + 1, k]))
        total += wts[s] * ((1.0 - alpha) * min(col, tau_color) + alpha * min(gd, tau_grad))
        if total >= bound:
            return total
    return total


@numba.njit(cache=True)
def _buffers(radius, step, ch, gch):  # pragma: no cover - compiled
    k = (2 * (radius // step) + 1) ** 2
    return (np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k), np.empty((k, ch)), np.empty((k, gch)))


@numba.njit(cache=True)
def plane_cost(y, x, a, b, c, img, grad, other, other_grad, lut, radius, step, sgn, alpha, tau_color, tau_grad,
               d_min, d_max):  # pragma: no cover - compiled
    """Aggregated cost of the plane ``(a, b, c)`` at pixel ``(x, y)`` (PMS Eq. 2-5; see :func:`window_cost`);
    inf when the plane's disparity at the pixel leaves ``[d_min, d_max]``."""
    if not admissible(x, y, a, b, c, sgn, d_min, d_max):
        return np.inf
    us, vs, wts, cols, grads = _buffers(radius, step, img.shape[2], grad.shape[2])
    m = gather_window(y, x, img, grad, lut, radius, step, us, vs, wts, cols, grads)
    up = (other.shape[1] - 1) // (img.shape[1] - 1)
    return window_cost(m, us, vs, wts, cols, grads, a, b, c, other, other_grad, up, sgn, alpha, tau_color,
                       tau_grad, np.inf)


@numba.njit(cache=True, parallel=True)
def random_planes(h: int, w: int, d_min: float, d_max: float, seed: np.uint64) -> np.ndarray:  # pragma: no cover
    """Random planes (Bleyer et al. 2011 §2): a disparity uniform in [d_min, d_max] and a random unit normal."""
    planes = np.empty((h, w, 3))
    for y in numba.prange(h):
        for x in range(w):
            i = (y * w + x) * 4
            z0 = d_min + (d_max - d_min) * _uniform(seed, i)
            nx = 2.0 * _uniform(seed, i + 1) - 1.0
            ny = 2.0 * _uniform(seed, i + 2) - 1.0
            nz = max(_uniform(seed, i + 3), _MIN_NZ)
            a = -nx / nz
            b = -ny / nz
            planes[y, x, 0] = a
            planes[y, x, 1] = b
            planes[y, x, 2] = z0 - a * x - b * y
    return planes


@numba.njit(cache=True, parallel=True)
def all_costs(planes, img, grad, other, other_grad, lut, radius, step, sgn, alpha, tau_color, tau_grad, d_min,
              d_max):  # pragma: no cover - compiled
    """:func:`plane_cost` of every pixel's own plane."""
    h, w = planes.shape[:2]
    up = (other.shape[1] - 1) // (w - 1)
    out = np.empty((h, w))
    for y in numba.prange(h):
        us, vs, wts, cols, grads = _buffers(radius, step, img.shape[2], grad.shape[2])
        for x in range(w):
            a, b, c = planes[y, x, 0], planes[y, x, 1], planes[y, x, 2]
            if not admissible(x, y, a, b, c, sgn, d_min, d_max):
                out[y, x] = np.inf
                continue
            m = gather_window(y, x, img, grad, lut, radius, step, us, vs, wts, cols, grads)
            out[y, x] = window_cost(m, us, vs, wts, cols, grads, a, b, c, other, other_grad, up, sgn, alpha,
                                    tau_color, tau_grad, np.inf)
    return out


@numba.njit(cache=True)
def _try_plane(planes, costs, y, x, a, b, c, win, m, other, other_grad, up, sgn, alpha, tau_color, tau_grad, d_min,
               d_max):  # pragma: no cover - compiled
    """Adopt the plane ``(a, b, c)`` at ``(x, y)`` if its cost over the gathered window ``win`` is lower."""
    if not admissible(x, y, a, b, c, sgn, d_min, d_max):
        return
    us, vs, wts, cols, grads = win
    cost = window_cost(m, us, vs, wts, cols, grads, a, b, c, other, other_grad, up, sgn, alpha, tau_color,
                       tau_grad, costs[y, x])
    if cost < costs[y, x]:
        costs[y, x] = cost
        planes[y, x, 0] = a
        planes[y, x, 1] = b
        planes[y, x, 2] = c


@numba.njit(cache=True)
def _refine_pixel(planes, costs, y, x, win, m, other, other_grad, up, sgn, alpha, tau_color, tau_grad, d_min, d_max,
                  dz_start, dz_stop, seed, index):  # pragma: no cover - compiled
    """Plane refinement (PMS §3.3): random moves of the disparity (up to ``dz``) and of the normal (up to
    ``dn`` per component) at the pixel, both halved after each try, from ``dz_start`` and 1 until ``dz < dz_stop``."""
    dz = dz_start
    dn = 1.0
    i = index
    while dz >= dz_stop:
        a = planes[y, x, 0]
        b = planes[y, x, 1]
        z0 = a * x + b * y + planes[y, x, 2]
        norm = math.sqrt(a * a + b * b + 1.0)  # the normal of d = a x + b y + c is (-a, -b, 1) / norm
        nx = -a / norm + dn * (2.0 * _uniform(seed, i) - 1.0)
        ny = -b / norm + dn * (2.0 * _uniform(seed, i + 1) - 1.0)
        nz = 1.0 / norm + dn * (2.0 * _uniform(seed, i + 2) - 1.0)
        z1 = z0 + dz * (2.0 * _uniform(seed, i + 3) - 1.0)
        i += 4
        dz *= 0.5
        dn *= 0.5
        if nz < _MIN_NZ * math.sqrt(nx * nx + ny * ny + nz * nz):
            continue
        a1 = -nx / nz
        b1 = -ny / nz
        _try_plane(planes, costs, y, x, a1, b1, z1 - a1 * x - b1 * y, win, m, other, other_grad, up, sgn, alpha,
                   tau_color, tau_grad, d_min, d_max)


@numba.njit(cache=True, parallel=True)
def sweep_rows(planes, costs, img, grad, other, other_grad, lut, radius, step, sgn, alpha, tau_color, tau_grad,
               d_min, d_max, forward, dz_start, dz_stop, seed):  # pragma: no cover - compiled
    """Spatial propagation along every row (in parallel), then plane refinement, pixel after pixel.

    PMS §3.2: pixel x tries the plane of its predecessor on the row (x - 1 when ``forward``, else
    x + 1), already updated in this sweep, so a good plane travels the whole row; then
    :func:`_refine_pixel` (no refinement when ``dz_start < dz_stop``). ``planes`` and ``costs`` are
    updated in place.
    """
    h, w = costs.shape
    up = (other.shape[1] - 1) // (w - 1)
    for y in numba.prange(h):
        win = _buffers(radius, step, img.shape[2], grad.shape[2])
        us, vs, wts, cols, grads = win
        for k in range(w):
            x = k if forward else w - 1 - k
            xn = x - 1 if forward else x + 1
            m = gather_window(y, x, img, grad, lut, radius, step, us, vs, wts, cols, grads)
            if 0 <= xn < w:
                _try_plane(planes, costs, y, x, planes[y, xn, 0], planes[y, xn, 1], planes[y, xn, 2], win, m,
                           other, other_grad, up, sgn, alpha, tau_color, tau_grad, d_min, d_max)
            _refine_pixel(planes, costs, y, x, win, m, other, other_grad, up, sgn, alpha, tau_color, tau_grad, d_min,
                          d_max, dz_start, dz_stop, seed, (y * w + x) * 64)


@numba.njit(cache=True, parallel=True)
def sweep_columns(planes, costs, img, grad, other, other_grad, lut, radius, step, sgn, alpha, tau_color, tau_grad,
                  d_min, d_max, forward):  # pragma: no cover - compiled
    """Spatial propagation down (``forward``) or up every column, in parallel over the columns (PMS §3.2)."""
    h, w = costs.shape
    up = (other.shape[1] - 1) // (w - 1)
    for x in numba.prange(w):
        win = _buffers(radius, step, img.shape[2], grad.shape[2])
        us, vs, wts, cols, grads = win
        for k in range(h):
            y = k if forward else h - 1 - k
            yn = y - 1 if forward else y + 1
            if 0 <= yn < h:
                m = gather_window(y, x, img, grad, lut, radius, step, us, vs, wts, cols, grads)
                _try_plane(planes, costs, y, x, planes[yn, x, 0], planes[yn, x, 1], planes[yn, x, 2], win, m,
                           other, other_grad, up, sgn, alpha, tau_color, tau_grad, d_min, d_max)


@numba.njit(cache=True, parallel=True)
def view_propagation(planes, costs, other_planes, img, grad, other, other_grad, lut, radius, step, sgn, alpha,
                     tau_color, tau_grad, d_min, d_max):  # pragma: no cover - compiled
    """View propagation (PMS §3.2): each pixel tries the plane of the other view's pixel it matches now,
    ``x' = round(x + sgn d)``, transferred to this view: ``d = a' x' + b' y + c'`` with ``x' = x + sgn d``
    gives ``(a, b, c) = (a', b', c') / (1 - sgn a')``."""
    h, w = costs.shape
    up = (other.shape[1] - 1) // (w - 1)
    for y in numba.prange(h):
        win = _buffers(radius, step, img.shape[2], grad.shape[2])
        us, vs, wts, cols, grads = win
        for x in range(w):
            d = planes[y, x, 0] * x + planes[y, x, 1] * y + planes[y, x, 2]
            xo = int(math.floor(x + sgn * d + 0.5))
            if xo < 0 or xo >= w:
                continue
            den = 1.0 - sgn * other_planes[y, xo, 0]
            if den < _MIN_TRANSFER:
                continue
            m = gather_window(y, x, img, grad, lut, radius, step, us, vs, wts, cols, grads)
            _try_plane(planes, costs, y, x, other_planes[y, xo, 0] / den, other_planes[y, xo, 1] / den,
                       other_planes[y, xo, 2] / den, win, m, other, other_grad, up, sgn, alpha, tau_color, tau_grad,
                       d_min, d_max)


@numba.njit(cache=True, parallel=True)
def plane_fill(disp: np.ndarray, planes: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Plane-based filling (Bleyer et al. 2011 §3.4): a NaN takes the lower of the disparities that the planes
    of its nearest valid neighbours left and right on the row give at it (the background); one side if only one."""
    h, w = disp.shape
    out = disp.copy()
    for y in numba.prange(h):
        last = -1
        left_of = np.full(w, -1, np.int64)
        for x in range(w):
            if not math.isnan(disp[y, x]):
                last = x
            left_of[x] = last
        nxt = -1
        for x in range(w - 1, -1, -1):
            if not math.isnan(disp[y, x]):
                nxt = x
                continue
            best = np.inf
            for q in (left_of[x], nxt):
                if q >= 0:
                    best = min(best, planes[y, q, 0] * x + planes[y, q, 1] * y + planes[y, q, 2])
            out[y, x] = best if best < np.inf else np.nan
    return out
