"""The boundary to Mitsuba 3: rays in, first hits (or occlusion) out, whole wavefronts at a time.

Mitsuba is only the ray caster (BVH build and traversal). We hand it spheres, rectangles and
triangle meshes, cast rays with ``Scene.ray_intersect_preliminary`` (which object, which triangle,
distance) and ``Scene.ray_test`` (occluded or not), and compute everything else ourselves
(``surfaces.py``). Full surface interactions are avoided on purpose: with LLVM 15 (Debian 12) the
``llvm_ad_rgb`` kernels for texture coordinates and vertex normals abort the process
(``Cannot select: fminimum``).

The variant is chosen once per process: ``cuda_ad_rgb`` when Dr.Jit finds a CUDA device, else
``llvm_ad_rgb``; the environment variable ``VERGENCE_MITSUBA_VARIANT`` forces one.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np


@contextmanager
def _deferred_sigint() -> Iterator[None]:
    """Hold Ctrl-C while Mitsuba's C++ code runs and deliver it, in Python, on the way out.

    A ``KeyboardInterrupt`` raised by a Python SIGINT handler while nanobind is inside C++ that calls
    back into Python is thrown through C++ as ``nanobind::python_error``: ``std::terminate``, the
    process aborts (exit -6, issue 9 sweep: ``sigint/render``). Here the handler only records the
    signal; the previous handler then runs once the block is left, where raising is safe. Outside
    the main thread, or with no Python handler installed, nothing changes.
    """
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield
        return
    caught: list[tuple[int, object]] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append((signum, frame)))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught:
            previous(*caught[0])  # raises KeyboardInterrupt (or whatever the caller's handler does) here


try:
    with _deferred_sigint():
        import drjit as dr
        import mitsuba as mi
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError(
        f"vergence.render needs Mitsuba 3 and Dr.Jit (pip install 'mitsuba>=3.5'); import failed: {exc}"
    ) from exc

__all__ = ["Caster", "select_variant"]

# Rays per Mitsuba call: bounds the memory of one wavefront (about 100 bytes per ray in flight).
_CHUNK = 1 << 22


def select_variant() -> str:
    """Set (once) and return the Mitsuba variant: CUDA when a device is present, else LLVM (CPU)."""
    current = mi.variant()
    if current is not None:
        return current
    with _deferred_sigint():
        return _set_variant()


def _set_variant() -> str:
    forced = os.environ.get("VERGENCE_MITSUBA_VARIANT")
    if forced:
        if forced not in mi.variants():
            raise ValueError(f"VERGENCE_MITSUBA_VARIANT must be one of {', '.join(mi.variants())}; got {forced!r}")
        chosen = forced
    elif "cuda_ad_rgb" in mi.variants() and dr.has_backend(dr.JitBackend.CUDA):
        chosen = "cuda_ad_rgb"
    else:
        chosen = "llvm_ad_rgb"
    mi.set_variant(chosen)
    mi.set_log_level(mi.LogLevel.Error)
    return chosen


def _rectangle_transform(center: np.ndarray, normal: np.ndarray, up: np.ndarray, size: tuple) -> list:
    # Mitsuba's rectangle is [-1, 1]^2 in the local xy plane with normal +z.
    right = np.cross(up, normal)
    M = np.eye(4)
    M[:3, 0] = right * size[0] / 2.0
    M[:3, 1] = up * size[1] / 2.0
    M[:3, 2] = normal
    M[:3, 3] = center
    return M.tolist()


def _mesh(name: str, vertices: np.ndarray, faces: np.ndarray) -> mi.Mesh:
    mesh = mi.Mesh(name, vertex_count=len(vertices), face_count=len(faces),
                   has_vertex_normals=False, has_vertex_texcoords=False)  # fmt: skip
    params = mi.traverse(mesh)
    params["vertex_positions"] = np.ascontiguousarray(vertices, dtype=np.float32).ravel()
    params["faces"] = np.ascontiguousarray(faces, dtype=np.uint32).ravel()
    params.update()
    return mesh


class Caster:
    """A Mitsuba scene of some objects, answering first-hit and visibility queries.

    Parameters
    ----------
    shapes : list of (kind, params)
        ``("sphere", (center, radius))``, ``("rectangle", (center, normal, up, size))`` or
        ``("mesh", (vertices, faces))``, in world coordinates. The list index is the object id
        returned by :meth:`intersect`.
    """

    def __init__(self, shapes: list[tuple[str, tuple]]) -> None:
        self.variant = select_variant()
        with _deferred_sigint():
            self._build(shapes)

    def _build(self, shapes: list[tuple[str, tuple]]) -> None:
        spec: dict = {"type": "scene"}
        for i, (kind, p) in enumerate(shapes):
            key = f"obj{i}"
            if kind == "sphere":
                spec[key] = {"type": "sphere", "center": [float(v) for v in p[0]], "radius": float(p[1])}
            elif kind == "rectangle":
                spec[key] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(_rectangle_transform(*p))}
            elif kind == "mesh":
                spec[key] = _mesh(key, *p)
            else:  # pragma: no cover - callers pass validated objects
                raise ValueError(f"unknown shape kind {kind!r}")
        self._scene = mi.load_dict(spec)
        ids = [(int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0]), int(s.id()[3:])) for s in self._scene.shapes()]
        self.lookup = np.full(max([r for r, _ in ids], default=0) + 1, -1, dtype=np.int64)
        for registry_id, obj in ids:
            self.lookup[registry_id] = obj

    def intersect(
        self, origins: np.ndarray, dirs: np.ndarray, maxt: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First hits of rays ``(M, 3)``: object id (-1 for a miss), primitive index, distance (float32 accuracy).

        ``maxt`` ``(M,)`` bounds each ray's search (unbounded when None; ``inf`` entries are unbounded).
        """
        m = len(origins)
        obj = np.full(m, -1, dtype=np.int64)
        prim = np.zeros(m, dtype=np.int64)
        t = np.full(m, np.inf)
        with _deferred_sigint():
            self._intersect(origins, dirs, maxt, obj, prim, t)
        miss = ~np.isfinite(t) | (obj < 0)
        obj[miss] = -1
        return obj, prim, t

    def _intersect(self, origins, dirs, maxt, obj, prim, t) -> None:  # noqa: ANN001
        """Fill ``obj``, ``prim`` and ``t`` chunk by chunk (Mitsuba calls only)."""
        m = len(origins)
        for s in range(0, m, _CHUNK):
            e = min(m, s + _CHUNK)
            registry, prim[s:e], t[s:e] = self._cast(np.ascontiguousarray(origins[s:e].T, dtype=np.float32),
                                                     np.ascontiguousarray(dirs[s:e].T, dtype=np.float32),
                                                     None if maxt is None else maxt[s:e])  # fmt: skip
            obj[s:e] = self.lookup[np.minimum(registry, len(self.lookup) - 1)]

    def _cast(self, o32: np.ndarray, d32: np.ndarray, maxt: np.ndarray | None):  # noqa: ANN202
        """One ``ray_intersect_preliminary`` of rays in Mitsuba's layout; its three answers evaluated in one
        kernel (read one at a time, each ``numpy()`` would launch the traversal again)."""
        ray = mi.Ray3f(mi.Point3f(o32), mi.Vector3f(d32))
        if maxt is not None:
            ray.maxt = mi.Float(np.ascontiguousarray(np.minimum(maxt, np.finfo(np.float32).max), dtype=np.float32))
        pi = self._scene.ray_intersect_preliminary(ray, True)
        registry = dr.reinterpret_array(mi.UInt32, pi.shape)
        dr.eval(registry, pi.prim_index, pi.t)
        return registry.numpy(), pi.prim_index.numpy(), pi.t.numpy()

    def cast(self, o32: np.ndarray, d32: np.ndarray, maxt: np.ndarray | None = None):  # noqa: ANN201
        """First hits of rays in Mitsuba's layout, float32 ``(3, M)``: the shape registry ids (``lookup`` turns
        them into object ids, -1 for none), primitive indices and float32 distances (``inf``: no hit).

        ``maxt`` ``(M,)`` bounds each ray's search (unbounded when None; ``inf`` entries are unbounded).
        """
        m = o32.shape[1]
        registry = np.zeros(m, dtype=np.uint32)
        prim = np.zeros(m, dtype=np.uint32)
        t = np.full(m, np.inf, dtype=np.float32)
        with _deferred_sigint():
            for s in range(0, m, _CHUNK):
                e = min(m, s + _CHUNK)
                registry[s:e], prim[s:e], t[s:e] = self._cast(np.ascontiguousarray(o32[:, s:e]),
                                                              np.ascontiguousarray(d32[:, s:e]),
                                                              None if maxt is None else maxt[s:e])  # fmt: skip
        return registry, prim, t

    def occluded(self, origins: np.ndarray, dirs: np.ndarray, maxt: np.ndarray | None = None) -> np.ndarray:
        """Whether each ray hits anything before ``maxt`` (unbounded when None), in one Mitsuba call.

        The rays come in Mitsuba's layout, float32 ``(3, M)`` origins and directions (as
        ``_kernels.ao_rays`` writes them); the caller bounds ``M``.
        """
        with _deferred_sigint():
            ray = mi.Ray3f(mi.Point3f(origins), mi.Vector3f(dirs))
            if maxt is not None:
                ray.maxt = mi.Float(np.ascontiguousarray(maxt, dtype=np.float32))
            return self._scene.ray_test(ray, True).numpy()
