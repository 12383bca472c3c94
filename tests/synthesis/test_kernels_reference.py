"""Fast kernels of ``vergence.synthesis._kernels`` against slow, obviously-correct Python loops.

Small random inputs; each reference restates the kernel's docstring one pixel at a time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.synthesis import _kernels

# float32 interpolation in the kernels against float64 in the references: a few ulps of [0, 1].
F32_ATOL = 1e-6
# Barycentric tests of the rasteriser: pixel centres within this of an edge are inside (the kernel's eps).
EDGE_EPS = 1e-9


def _backward_reference(img, disp, scale):
    h, w, c = img.shape
    out = np.zeros((h, w, c))
    valid = np.zeros((h, w), bool)
    for y in range(h):
        for x in range(w):
            if math.isnan(disp[y, x]):
                continue
            xs = x + scale * disp[y, x]
            if not -0.5 <= xs <= w - 0.5:
                continue
            xs = min(max(xs, 0.0), w - 1.0)
            x0 = math.floor(xs)
            x1 = min(x0 + 1, w - 1)
            s = xs - x0
            out[y, x] = (1 - s) * img[y, x0] + s * img[y, x1]
            valid[y, x] = True
    return out, valid


@pytest.mark.parametrize("seed", range(4))
def test_backward_warp_rows_matches_slow_reference(seed):
    rng = np.random.default_rng(seed)
    h, w, c = 5, 13, 3
    img = rng.random((h, w, c), dtype=np.float32)
    disp = rng.uniform(-6, 6, (h, w)).astype(np.float32)
    disp[rng.random((h, w)) < 0.2] = np.nan
    scale = float(rng.uniform(-1, 1))
    out = np.zeros((h, w, c), np.float32)
    valid = np.zeros((h, w), bool)
    _kernels.backward_warp_rows(img, disp, scale, out, valid)
    ref, ref_valid = _backward_reference(img, disp, scale)
    assert_array_equal(valid, ref_valid)
    assert_allclose(out, ref, atol=F32_ATOL)


def _fill_holes_reference(img, disp, holes, mirror):
    h, w, _ = img.shape
    out, out_d = img.astype(np.float64).copy(), disp.astype(np.float64).copy()
    for y in range(h):
        runs, x = [], 0
        while x < w:  # runs of holes on the row
            if holes[y, x]:
                x0 = x
                while x < w and holes[y, x]:
                    x += 1
                runs.append((x0, x - 1))
            else:
                x += 1
        for x0, x1 in runs:
            neighbours = [xb for xb in (x0 - 1, x1 + 1) if 0 <= xb < w]
            if not neighbours:
                continue
            xb = min(neighbours, key=lambda xb: (disp[y, xb], xb != x0 - 1))  # farther; left on a tie
            for xt in range(x0, x1 + 1):
                src = xb
                xm = 2 * xb - xt
                if mirror and 0 <= xm < w and not holes[y, xm] and disp[y, xm] <= disp[y, xb] + 1.0:
                    src = xm
                out[y, xt] = img[y, src]
                out_d[y, xt] = disp[y, xb]
    return out, out_d


@pytest.mark.parametrize("mirror", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_fill_holes_rows_matches_slow_reference(seed, mirror):
    rng = np.random.default_rng(seed)
    h, w, c = 6, 17, 2
    img = rng.random((h, w, c), dtype=np.float32)
    disp = rng.choice(np.array([1.0, 1.5, 3.0, 6.0], np.float32), size=(h, w))
    holes = rng.random((h, w)) < 0.35
    holes[0] = True  # a whole row of holes stays as it was
    out, out_d = img.copy(), disp.copy()
    _kernels.fill_holes_rows(img, disp, holes, mirror, out, out_d)
    ref, ref_d = _fill_holes_reference(img, disp, holes, mirror)
    assert_allclose(out, ref, atol=0)
    assert_allclose(out_d, ref_d, atol=0)


@pytest.mark.parametrize("seed", range(4))
def test_fill_nan_rows_matches_slow_reference(seed):
    rng = np.random.default_rng(seed)
    disp = rng.uniform(0, 9, (5, 12)).astype(np.float32)
    disp[rng.random((5, 12)) < 0.4] = np.nan
    disp[0] = np.nan
    out = np.empty_like(disp)
    _kernels.fill_nan_rows(disp, out)
    ref = disp.copy()
    for y in range(5):
        for x in range(12):
            if not np.isnan(disp[y, x]):
                continue
            left = [disp[y, k] for k in range(x - 1, -1, -1) if not np.isnan(disp[y, k])][:1]
            right = [disp[y, k] for k in range(x + 1, 12) if not np.isnan(disp[y, k])][:1]
            ref[y, x] = min(left + right) if left + right else np.nan
    assert_array_equal(out, ref)


def _inside(p, a, b, c):
    """Barycentric coordinates of p in triangle abc (None outside or degenerate)."""
    m = np.array([[a[0] - c[0], b[0] - c[0]], [a[1] - c[1], b[1] - c[1]]])
    if abs(np.linalg.det(m)) == 0.0:
        return None
    l0, l1 = np.linalg.solve(m, [p[0] - c[0], p[1] - c[1]])
    bary = (l0, l1, 1.0 - l0 - l1)
    return bary if min(bary) >= -EDGE_EPS else None


def _splat_mesh_reference(u, v, z, link_r, link_d, colours, max_side, shape):
    """Z-buffer mesh warp, pixel by pixel: every drawable triangle and every uncovered point
    offers (depth, colour) to the pixels it covers; the smallest depth wins."""
    hs, ws = link_r.shape
    tris, covered = [], set()
    for y in range(hs - 1):
        for x in range(ws - 1):
            i = y * ws + x
            for ok, tri in (
                (link_r[y, x] and link_d[y, x], (i, i + 1, i + ws)),
                (link_d[y, x + 1] and link_r[y + 1, x], (i + 1, i + ws + 1, i + ws)),
            ):
                us, vs = [u[j] for j in tri], [v[j] for j in tri]
                if ok and max(max(us) - min(us), max(vs) - min(vs)) <= max_side:
                    tris.append(tri)
                    covered.update(tri)
    h, w = shape
    best = np.full((h, w), np.inf)
    out = np.zeros((h, w, colours.shape[1]))
    for yy in range(h):
        for xx in range(w):
            for tri in tris:
                bary = _inside((xx, yy), *[(u[j], v[j]) for j in tri])
                if bary is None:
                    continue
                q = [1.0 / z[j] for j in tri]
                qq = sum(b * qj for b, qj in zip(bary, q))
                if 1.0 / qq < best[yy, xx]:
                    best[yy, xx] = 1.0 / qq
                    out[yy, xx] = sum(b * qj * colours[j] for b, qj, j in zip(bary, q, tri)) / qq
    for i in range(u.size):
        if i in covered or not z[i] > 0:
            continue
        xt, yt = math.floor(u[i] + 0.5), math.floor(v[i] + 0.5)
        if 0 <= xt < w and 0 <= yt < h and z[i] < best[yt, xt]:
            best[yt, xt] = z[i]
            out[yt, xt] = colours[i]
    return out, best


@pytest.mark.parametrize("seed", range(3))
def test_splat_mesh_matches_slow_reference(seed):
    rng = np.random.default_rng(seed)
    hs, ws, h, w = 5, 6, 9, 11
    ys, xs = np.mgrid[0:hs, 0:ws].astype(np.float64)
    u = (1.6 * xs + rng.uniform(-0.3, 0.3, xs.shape)).ravel()  # magnified 1.6 times, jittered
    v = (1.6 * ys + rng.uniform(-0.3, 0.3, ys.shape)).ravel()
    z = rng.uniform(1.0, 3.0, hs * ws)
    z[rng.random(hs * ws) < 0.1] = np.nan
    link_r = rng.random((hs, ws)) < 0.8
    link_d = rng.random((hs, ws)) < 0.8
    colours = rng.random((hs * ws, 2)).astype(np.float32)
    out = np.zeros((h, w, 2), np.float32)
    zbuf = np.full((h, w), np.inf)
    painted = np.zeros((h, w), bool)
    order = np.arange(hs * ws, dtype=np.int64)
    _kernels.splat_mesh(order, u, v, z, link_r, link_d, colours, 3.0, True, out, zbuf, painted)
    ref, best = _splat_mesh_reference(u, v, z, link_r, link_d, colours, 3.0, (h, w))
    assert_array_equal(painted, np.isfinite(best))
    assert_allclose(zbuf, best, rtol=1e-12)
    assert_allclose(out, ref, atol=F32_ATOL)


def test_splat_zbuffer_matches_slow_reference():
    rng = np.random.default_rng(3)
    n, h, w = 60, 6, 7
    u, v = rng.uniform(-1, w, n), rng.uniform(-1, h, n)
    z = rng.uniform(-0.5, 3.0, n)
    colours = rng.random((n, 1)).astype(np.float32)
    out = np.zeros((h, w, 1), np.float32)
    zbuf = np.full((h, w), np.inf)
    painted = np.zeros((h, w), bool)
    _kernels.splat_zbuffer(u, v, z, colours, out, zbuf, painted)
    best = np.full((h, w), np.inf)
    ref = np.zeros((h, w, 1))
    for i in range(n):
        xt, yt = math.floor(u[i] + 0.5), math.floor(v[i] + 0.5)
        if z[i] > 0 and 0 <= xt < w and 0 <= yt < h and z[i] < best[yt, xt]:
            best[yt, xt], ref[yt, xt] = z[i], colours[i]
    assert_array_equal(zbuf, best)
    assert_array_equal(painted, np.isfinite(best))
    assert_allclose(out, ref, atol=0)


def test_counting_kernels_match_numpy():
    rng = np.random.default_rng(7)
    a = rng.uniform(-0.5, 1.5, (6, 9)).astype(np.float32)
    a[rng.random((6, 9)) < 0.2] = np.nan
    a[rng.random((6, 9)) < 0.1] = np.inf
    n_nan, n_inf = np.empty(6, np.int64), np.empty(6, np.int64)
    _kernels.count_nonfinite(a, n_nan, n_inf)
    assert_array_equal(n_nan, [sum(math.isnan(v) for v in row) for row in a])
    assert_array_equal(n_inf, [sum(math.isinf(v) for v in row) for row in a])
    bad = np.empty(6, np.int64)
    _kernels.count_outside(a, np.float32(0.0), np.float32(1.0), bad)
    assert_array_equal(bad, [sum(not (0.0 <= v <= 1.0) for v in row) for row in a])  # NaN counts as outside
