"""The renderer's Numba kernels against slow, obviously-correct references (plain Python loops).

Small random inputs; the float64 kernels agree with the references to rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.render import Mesh, Rectangle, Sphere, _kernels
from vergence.render.scene import Diffuse, Environment, Scene, SceneCamera
from vergence.render.surfaces import pack_scene, refine_hits, refine_hits_fast

RTOL = 1e-12  # a few float64 roundings of O(1) quantities
ATOL = 1e-12


def _ref_sphere(o, d, c, r, t_approx):
    oc = [o[k] - c[k] for k in range(3)]
    b = sum(oc[k] * d[k] for k in range(3))
    cc = sum(v * v for v in oc) - r * r
    roots = [-b - math.sqrt(b * b - cc), -b + math.sqrt(b * b - cc)]
    t = min(roots, key=lambda x: abs(x - t_approx))
    n = [(o[k] + t * d[k] - c[k]) / r for k in range(3)]
    return t, n


def _ref_triangle(o, d, a, b, c):
    """Moller-Trumbore (a different route to the same hit): t, barycentrics (1 - u - v, u, v)."""
    e1 = [b[k] - a[k] for k in range(3)]
    e2 = [c[k] - a[k] for k in range(3)]
    pv = [d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]]
    det = sum(e1[k] * pv[k] for k in range(3))
    tv = [o[k] - a[k] for k in range(3)]
    u = sum(tv[k] * pv[k] for k in range(3)) / det
    qv = [tv[1] * e1[2] - tv[2] * e1[1], tv[2] * e1[0] - tv[0] * e1[2], tv[0] * e1[1] - tv[1] * e1[0]]
    v = sum(d[k] * qv[k] for k in range(3)) / det
    t = sum(e2[k] * qv[k] for k in range(3)) / det
    return t, (1.0 - u - v, u, v)


def _scene(rng):
    verts = rng.normal(size=(4, 3)) + [0, 0, -6]
    normals = rng.normal(size=(4, 3))
    uv = rng.random((4, 2))
    objects = (
        Sphere(center=tuple(rng.normal(size=3) + [0, 0, -5]), radius=1.5, material="m"),
        Rectangle(center=(0.2, -0.1, -8), normal=(0.1, 0.2, 1.0), up=(0, 1, 0), size=(3.0, 2.0), material="m"),
        Mesh(vertices=verts, faces=[[0, 1, 2], [0, 2, 3]], material="m", normals=normals, uv=uv),
    )
    cam = SceneCamera(position=(0, 0, 0), look_at=(0, 0, -1), up=(0, 1, 0), fov_deg=40.0, width=4, height=4)
    return Scene(camera=cam, environment=Environment(color=(1, 1, 1)), materials={"m": Diffuse(color=(1, 1, 1))},
                 objects=objects)  # fmt: skip


def test_refine_hits_kernel_against_python_loops():
    rng = np.random.default_rng()
    scene = _scene(rng)
    pk = pack_scene(scene)
    m = 60
    obj = rng.integers(0, 3, m)
    prim = np.where(obj == 2, rng.integers(0, 2, m), 0)
    o = rng.normal(size=(m, 3)) * 0.3
    # Aim every ray at a point of its object so that a hit exists.
    targets = np.empty((m, 3))
    for i in range(m):
        if obj[i] == 0:
            targets[i] = scene.objects[0].center
        elif obj[i] == 1:
            targets[i] = scene.objects[1].center
        else:
            targets[i] = pk.tri_v[prim[i]].mean(axis=0)
    d = targets - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t_approx = np.linalg.norm(targets - o, axis=1)  # near the right root for the spheres (the near side)
    t_approx[obj == 0] -= 1.5
    t, p, ng, ns, uv = refine_hits_fast(pk, obj, prim, o, d, t_approx)
    for i in range(m):
        if obj[i] == 0:
            tr, nr = _ref_sphere(o[i], d[i], scene.objects[0].center, 1.5, t_approx[i])
            assert t[i] == pytest.approx(tr, rel=RTOL)
            assert_allclose(ng[i], nr, atol=1e-9)
            assert_allclose(ns[i], nr, atol=1e-9)
        elif obj[i] == 1:
            n = np.array(scene.objects[1].normal)
            tr = sum((scene.objects[1].center[k] - o[i, k]) * n[k] for k in range(3)) / sum(d[i, k] * n[k] for k in range(3))
            assert t[i] == pytest.approx(tr, rel=RTOL)
            assert_allclose(ng[i], n, atol=ATOL)
        else:
            a, b, c = pk.tri_v[prim[i]]
            tr, w = _ref_triangle(o[i], d[i], a, b, c)
            assert t[i] == pytest.approx(tr, rel=1e-9)
            vn = pk.tri_n[prim[i]]
            sn = [sum(w[j] * vn[j, k] for j in range(3)) for k in range(3)]
            length = math.sqrt(sum(v * v for v in sn))
            assert_allclose(ns[i], [v / length for v in sn], atol=1e-9)
            tuv = pk.tri_uv[prim[i]]
            assert_allclose(uv[i], [sum(w[j] * tuv[j, k] for j in range(3)) for k in range(2)], atol=1e-9)
        assert_allclose(p[i], o[i] + t[i] * d[i], atol=ATOL)
    # Gathering the rays inside the kernel (rows) equals gathering them first.
    perm = rng.permutation(m)
    inv = np.argsort(perm)
    got = refine_hits_fast(pk, obj, prim, o[perm], d[perm], t_approx, rows=inv)
    for x, y in zip(got, (t, p, ng, ns, uv)):
        assert_array_equal(x, y)
    # ... and the vectorised numpy version agrees everywhere.
    ref = refine_hits(pk, obj, prim, o, d, t_approx)
    for got, want in zip((p, ng, ns, uv), ref):
        assert_allclose(got, want, rtol=1e-10, atol=1e-12)


def _ref_lookup(table, dirs, rot):
    h, w = table.shape[:2]
    out = np.empty((len(dirs), 3))
    for i, (x, y, z) in enumerate(dirs):
        u = (0.5 + (math.atan2(x, -z) - rot) / (2 * math.pi)) % 1.0
        v = math.acos(max(-1.0, min(1.0, y))) / math.pi
        px, py = u * w - 0.5, min(max(v * h - 0.5, 0.0), h - 1.0)
        x0, y0 = math.floor(px), math.floor(py)
        fx, fy = px - x0, py - y0
        for c in range(3):
            val = 0.0
            for dy, wy in ((0, 1 - fy), (1, fy)):
                for dx, wx in ((0, 1 - fx), (1, fx)):
                    val += wy * wx * float(table[min(y0 + dy, h - 1), (x0 + dx) % w, c])
            out[i, c] = val
    return out


def test_equirect_lookup_against_python_loops():
    rng = np.random.default_rng()
    table = rng.random((5, 8, 3)).astype(np.float32)
    dirs = rng.normal(size=(50, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dirs[0] = [0, 1, 0]  # the pole
    rot = float(rng.uniform(-3, 3))
    assert_allclose(_kernels.equirect_lookup(table, dirs, rot), _ref_lookup(table, dirs, rot), rtol=1e-6, atol=1e-7)


def test_scatter_kernels_against_python_loops():
    rng = np.random.default_rng()
    n, s, m = 3, 10, 12
    pairs = rng.permutation(n * s)[:m]  # distinct (node, slot) pairs
    node, slot = pairs // s + 1, pairs % s
    values, weight = rng.random((m, 3)), rng.random((m, 3))
    got = np.full((n, s, 3), np.nan, dtype=np.float32)
    _kernels.scatter_nodes(got, node, slot, values)
    want = np.full((n, s, 3), np.nan, dtype=np.float32)
    for j in range(m):
        for c in range(3):
            want[node[j] - 1, slot[j], c] = values[j, c]
    assert_array_equal(got, want)
    _kernels.scatter_weighted(got, node, slot, weight, values)
    for j in range(m):
        for c in range(3):
            want[node[j] - 1, slot[j], c] = weight[j, c] * values[j, c]
    assert_array_equal(got, want)


def test_offset_bilinear_and_pinhole_kernels_against_python_loops():
    from vergence.camera import look_at

    rng = np.random.default_rng()
    p, n = rng.normal(size=(20, 3)) * 10, rng.normal(size=(20, 3))
    want = np.array([[p[i, c] - 1e-4 * (1 + max(abs(v) for v in p[i])) * n[i, c] for c in range(3)] for i in range(20)])
    assert_allclose(_kernels.offset_points(p, n, -1.0, 1e-4), want, rtol=0, atol=1e-12)
    img = rng.random((3, 4, 3))
    x, y = rng.uniform(-6, 6, 30), rng.uniform(-6, 6, 30)
    want = np.empty((30, 3))
    for i in range(30):
        x0, y0 = math.floor(x[i]), math.floor(y[i])
        fx, fy = x[i] - x0, y[i] - y0
        for c in range(3):
            want[i, c] = sum(wy * wx * img[(y0 + dy) % 3, (x0 + dx) % 4, c]
                             for dy, wy in ((0, 1 - fy), (1, fy)) for dx, wx in ((0, 1 - fx), (1, fx)))  # fmt: skip
    assert_allclose(_kernels.bilinear_wrap(img, x, y), want, rtol=1e-12, atol=1e-14)
    cam = look_at(rng.normal(size=3), [0, 0, 0], [0, 1, 0], fov_deg=float(rng.uniform(20, 120)), width=7, height=5)
    k_inv = np.linalg.inv(cam.K)
    got = _kernels.pinhole_directions(k_inv, cam.R, 7, 5)
    for row in range(5):
        for col in range(7):
            v = cam.R.T @ (k_inv @ [col, row, 1.0])
            assert_allclose(got[row * 7 + col], v / math.sqrt(sum(c * c for c in v)), atol=1e-14)


def test_take_rows_against_python_loops():
    rng = np.random.default_rng()
    a = rng.random((9, 3))
    idx = rng.integers(0, 9, 14)
    got = _kernels.take_rows(a, idx)
    assert_array_equal(got, np.array([[a[i, c] for c in range(3)] for i in idx]))
