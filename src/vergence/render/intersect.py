"""Intersection, the second stage of the renderer: rays to their first surface hits.

Mitsuba (float32, ``_mitsuba.Caster``) finds which object and triangle each ray meets first; the hit
is then recomputed in float64 from the object's own definition (``surfaces.refine_hits``): position,
outward geometric and shading normals, texture coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array
from vergence.render import surfaces
from vergence.render._mitsuba import Caster
from vergence.render.scene import Scene

__all__ = ["Hits", "Intersector"]


@dataclass(frozen=True, slots=True, eq=False)
class Hits:
    """First hits of some of ``M`` rays: ``rays`` ``(K,)`` are the indices of the rays that hit.

    ``obj`` and ``prim`` name the object and triangle; ``t`` is the float64 distance along the unit
    direction, ``points`` the hit ``(K, 3)``, ``n_geo`` and ``n_shade`` the **outward** unit normals,
    ``uv`` the texture coordinates ``(K, 2)``.
    """

    rays: np.ndarray
    obj: np.ndarray
    prim: np.ndarray
    t: np.ndarray
    points: np.ndarray
    n_geo: np.ndarray
    n_shade: np.ndarray
    uv: np.ndarray


class Intersector:
    """Mitsuba's first-hit cast followed by our float64 hit refinement, for one scene.

    Parameters
    ----------
    scene : Scene
    packed : PackedScene, optional
        The scene's packed arrays when the caller has them already.
    """

    def __init__(self, scene: Scene, packed: surfaces.PackedScene | None = None) -> None:
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vergence.render.Scene; got {type(scene).__name__}")
        if packed is not None and not isinstance(packed, surfaces.PackedScene):
            raise TypeError(f"packed must be a PackedScene or None; got {type(packed).__name__}")
        self.packed = surfaces.pack_scene(scene) if packed is None else packed
        self.caster = Caster(self.packed.shapes)

    @property
    def variant(self) -> str:
        """The Mitsuba variant casting the rays."""
        return self.caster.variant

    def __call__(
        self, origins: np.ndarray, directions: np.ndarray, *, cast_from: np.ndarray | None = None,
        tmax: np.ndarray | None = None,
    ) -> Hits:  # fmt: skip
        """First hits of rays ``origins + t directions`` (unit directions, ``(M, 3)`` float64).

        ``cast_from`` are the origins handed to Mitsuba when they differ from the exact ones (moved
        off the surface a secondary ray leaves); the refinement starts from the exact ``origins``.
        With ``tmax`` ``(M,)``, a hit whose float64 distance exceeds ``tmax`` is not a hit.
        """
        origins = as_float_array("origins", origins, shape=(None, 3))
        directions = as_float_array("directions", directions, shape=(len(origins), 3))
        if cast_from is not None:
            cast_from = as_float_array("cast_from", cast_from, shape=(len(origins), 3))
        if tmax is not None:  # inf allowed: an unbounded ray
            tmax = np.asarray(tmax, dtype=np.float64)
            if tmax.shape != (len(origins),) or np.isnan(tmax).any():
                raise ValueError(f"tmax must have shape ({len(origins)},) without NaN; got {tmax.shape}")
        obj, prim, t32 = self.caster.intersect(origins if cast_from is None else cast_from, directions, tmax)
        rays = np.flatnonzero(obj >= 0)
        obj, prim = obj[rays], prim[rays]
        t, p, ng, ns, uv = surfaces.refine_hits_fast(self.packed, obj, prim, origins, directions, t32[rays], rays)
        if tmax is not None:
            keep = t <= tmax[rays]
            rays, obj, prim, t, p, ng, ns, uv = (a[keep] for a in (rays, obj, prim, t, p, ng, ns, uv))
        return Hits(rays=rays, obj=obj, prim=prim, t=t, points=p, n_geo=ng, n_shade=ns, uv=uv)
