"""Exact hit geometry and surface albedo, in float64 numpy, for the hits Mitsuba reports.

Mitsuba (float32) says which object and triangle a ray hits first; here the hit is recomputed in
float64 from the object's own definition: the sphere quadratic (the root nearest Mitsuba's
distance, in the cancellation-free form ``q = -(b + sign(b) sqrt(b^2 - c))``, roots ``q`` and
``c/q``), the rectangle's plane, the triangle's plane with barycentric interpolation of vertex
normals and texture coordinates. Normals returned here are **outward** (sphere radial, rectangle
``normal``, triangle counter-clockwise); the caller orients them against the ray.

Texture coordinates: sphere ``u = 1/2 + atan2(q_x, q_z) / 2 pi`` (u = 1/2 faces +z, growing towards
+x), ``v = 1 - acos(q_y) / pi`` (v = 1 at the top, +y); rectangle ``u = 1/2 + (p - c).right / w``,
``v = 1/2 + (p - c).up / h``; mesh: interpolated from its ``uv``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.render.scene import Checker, Diffuse, Glass, Mesh, Mirror, Rectangle, Scene, Sphere, Texture

__all__ = ["DIFFUSE", "GLASS", "MIRROR", "PackedScene", "albedo", "pack_scene", "refine_hits", "refine_hits_fast"]

SPHERE, RECTANGLE, MESH = 0, 1, 2
DIFFUSE, MIRROR, GLASS = 0, 1, 2


@dataclass(frozen=True, slots=True, eq=False)
class PackedScene:
    """Per-object arrays for vectorised hit refinement and shading (index = object id)."""

    kind: np.ndarray  # (K,) SPHERE / RECTANGLE / MESH
    material: np.ndarray  # (K,) index into materials
    materials: tuple  # Material objects
    mat_kind: np.ndarray  # (Nm,) DIFFUSE / MIRROR / GLASS
    mat_color: np.ndarray  # (Nm, 3) mirror / glass colour
    mat_ior: np.ndarray  # (Nm,)
    center: np.ndarray  # (K, 3) sphere or rectangle centre
    radius: np.ndarray  # (K,)
    normal: np.ndarray  # (K, 3) rectangle normal
    up: np.ndarray  # (K, 3)
    right: np.ndarray  # (K, 3)
    size: np.ndarray  # (K, 2)
    tri_offset: np.ndarray  # (K,) first triangle of each mesh in the tri_* arrays
    tri_v: np.ndarray  # (T, 3, 3)
    tri_n: np.ndarray  # (T, 3, 3) vertex normals (NaN when flat)
    tri_uv: np.ndarray  # (T, 3, 2) (NaN when absent)
    shapes: list  # Caster input


def pack_scene(scene: Scene) -> PackedScene:
    """Pack a validated scene's objects and materials into arrays."""
    names = list(scene.materials)
    mats = tuple(scene.materials[n] for n in names)
    mat_kind = np.array([GLASS if isinstance(m, Glass) else MIRROR if isinstance(m, Mirror) else DIFFUSE for m in mats],
                        dtype=np.int64)  # fmt: skip
    mat_color = np.array([m.color if isinstance(m, Glass | Mirror) else np.ones(3) for m in mats]).reshape(-1, 3)
    mat_ior = np.array([m.ior if isinstance(m, Glass) else 1.0 for m in mats])
    k = len(scene.objects)
    kind = np.zeros(k, dtype=np.int64)
    material = np.array([names.index(o.material) for o in scene.objects], dtype=np.int64)
    center, normal, up, right = (np.zeros((k, 3)) for _ in range(4))
    radius, size = np.zeros(k), np.zeros((k, 2))
    tri_offset = np.zeros(k, dtype=np.int64)
    tris_v, tris_n, tris_uv, shapes = [], [], [], []
    n_tri = 0
    for i, obj in enumerate(scene.objects):
        if isinstance(obj, Sphere):
            kind[i], center[i], radius[i] = SPHERE, obj.center, obj.radius
            shapes.append(("sphere", (obj.center, obj.radius)))
        elif isinstance(obj, Rectangle):
            kind[i], center[i], normal[i], up[i], right[i] = RECTANGLE, obj.center, obj.normal, obj.up, obj.right
            size[i] = obj.size
            shapes.append(("rectangle", (obj.center, obj.normal, obj.up, obj.size)))
        else:
            assert isinstance(obj, Mesh)
            kind[i], tri_offset[i] = MESH, n_tri
            f = obj.faces
            tris_v.append(obj.vertices[f])
            tris_n.append(obj.normals[f] if obj.normals is not None else np.full((len(f), 3, 3), np.nan))
            tris_uv.append(obj.uv[f] if obj.uv is not None else np.full((len(f), 3, 2), np.nan))
            n_tri += len(f)
            shapes.append(("mesh", (obj.vertices, obj.faces)))
    cat = lambda parts, shape: np.concatenate(parts) if parts else np.zeros((0, *shape))  # noqa: E731
    return PackedScene(kind, material, mats, mat_kind, mat_color, mat_ior, center, radius, normal, up, right, size,
                       tri_offset, cat(tris_v, (3, 3)), cat(tris_n, (3, 3)), cat(tris_uv, (3, 2)), shapes)  # fmt: skip


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def refine_hits(
    packed: PackedScene, obj: np.ndarray, prim: np.ndarray, origins: np.ndarray, dirs: np.ndarray, t_approx: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Float64 position, outward geometric and shading normals and uv of hits ``(M,)``."""
    m = len(obj)
    t = np.array(t_approx, dtype=np.float64)
    ng = np.zeros((m, 3))
    ns = np.zeros((m, 3))
    uv = np.zeros((m, 2))
    kind = packed.kind[obj]
    o, d = origins, dirs
    # Spheres: |o + t d - c|^2 = r^2 with |d| = 1: t^2 + 2 b t + cc = 0.
    s = np.flatnonzero(kind == SPHERE)
    if len(s):
        c, r = packed.center[obj[s]], packed.radius[obj[s]]
        oc = o[s] - c
        b = _dot(oc, d[s])
        cc = _dot(oc, oc) - r * r
        sq = np.sqrt(np.maximum(b * b - cc, 0.0))
        q = -(b + np.where(b >= 0, sq, -sq))
        with np.errstate(divide="ignore", invalid="ignore"):
            r1, r2 = q, np.where(q != 0, cc / q, q)
        t[s] = np.where(np.abs(r1 - t[s]) <= np.abs(r2 - t[s]), r1, r2)
        qv = (o[s] + t[s, None] * d[s] - c) / r[:, None]
        ng[s] = ns[s] = qv / np.linalg.norm(qv, axis=1, keepdims=True)
        uv[s, 0] = 0.5 + np.arctan2(ng[s, 0], ng[s, 2]) / (2 * np.pi)
        uv[s, 1] = 1.0 - np.arccos(np.clip(ng[s, 1], -1.0, 1.0)) / np.pi
    # Rectangles: plane through the centre.
    s = np.flatnonzero(kind == RECTANGLE)
    if len(s):
        n, c = packed.normal[obj[s]], packed.center[obj[s]]
        t[s] = _dot(c - o[s], n) / _dot(d[s], n)
        rel = o[s] + t[s, None] * d[s] - c
        ng[s] = ns[s] = n
        uv[s, 0] = 0.5 + _dot(rel, packed.right[obj[s]]) / packed.size[obj[s], 0]
        uv[s, 1] = 0.5 + _dot(rel, packed.up[obj[s]]) / packed.size[obj[s], 1]
    # Triangles: plane of the face, barycentrics from the float64 hit point.
    s = np.flatnonzero(kind == MESH)
    if len(s):
        tri = packed.tri_offset[obj[s]] + prim[s]
        v = packed.tri_v[tri]
        e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        n = np.cross(e1, e2)
        t[s] = _dot(v[:, 0] - o[s], n) / _dot(d[s], n)
        rel = o[s] + t[s, None] * d[s] - v[:, 0]
        d11, d12, d22 = _dot(e1, e1), _dot(e1, e2), _dot(e2, e2)
        r1, r2 = _dot(rel, e1), _dot(rel, e2)
        den = d11 * d22 - d12 * d12
        b1 = (d22 * r1 - d12 * r2) / den
        b2 = (d11 * r2 - d12 * r1) / den
        w = np.stack([1.0 - b1 - b2, b1, b2], axis=1)[:, :, None]
        ng[s] = n / np.linalg.norm(n, axis=1, keepdims=True)
        vn = packed.tri_n[tri]
        smooth = ~np.isnan(vn[:, 0, 0])
        interp = (w * vn).sum(axis=1)
        interp = interp / np.linalg.norm(interp, axis=1, keepdims=True)
        ns[s] = np.where(smooth[:, None], interp, ng[s])
        tuv = packed.tri_uv[tri]
        uv[s] = np.where(np.isnan(tuv[:, 0, :1]), 0.0, (w * tuv).sum(axis=1))
    p = o + t[:, None] * d
    return p, ng, ns, uv


def refine_hits_fast(
    packed: PackedScene, obj: np.ndarray, prim: np.ndarray, origins: np.ndarray, dirs: np.ndarray, t_approx: np.ndarray,
    rows: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`refine_hits` as one Numba kernel (the renderer's path); also returns the distance ``t``.

    With ``rows``, hit ``i`` is that of the ray ``rows[i]`` of ``origins`` and ``dirs`` (default: ray ``i``).

    :func:`refine_hits` stays as the vectorised numpy reference the tests compare against.
    """
    from vergence.render import _kernels

    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    pk = packed
    return _kernels.refine_hits(pk.kind, pk.center, pk.radius, pk.normal, pk.right, pk.up, pk.size, pk.tri_offset,
                                pk.tri_v, pk.tri_n, pk.tri_uv, np.ascontiguousarray(obj, dtype=np.int64),
                                np.ascontiguousarray(prim, dtype=np.int64), f64(origins), f64(dirs), f64(t_approx),
                                np.arange(len(obj)) if rows is None else np.ascontiguousarray(rows, dtype=np.int64))  # fmt: skip


def albedo(packed: PackedScene, mat: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Diffuse albedo ``(M, 3)`` of material indices ``mat`` at texture coordinates ``uv``."""
    out = np.zeros((len(mat), 3))
    for k, m in enumerate(packed.materials):
        s = np.flatnonzero(mat == k)
        if not len(s):
            continue
        if isinstance(m, Diffuse):
            out[s] = m.color
        elif isinstance(m, Checker):
            cell = np.floor(uv[s, 0] * m.squares[0]) + np.floor(uv[s, 1] * m.squares[1])
            out[s] = m.colors[(cell.astype(np.int64) % 2)]
        elif isinstance(m, Texture):
            out[s] = _bilinear_wrap(m.image, uv[s, 0] * m.image.shape[1] - 0.5, (1.0 - uv[s, 1]) * m.image.shape[0] - 0.5)
    return out


def _bilinear_wrap(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear lookup with periodic wrap in both axes (texture repeat), as a Numba kernel."""
    from vergence.render import _kernels

    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return _kernels.bilinear_wrap(np.ascontiguousarray(img), f64(x), f64(y))
