"""Shading, the third stage of the renderer: what light each node of the ray tree carries.

:class:`WhittedShader` is the default (S3 §3.1, Whitted 1980): an escaping ray takes the environment
radiance; a diffuse hit takes ``albedo / pi * E(n) * AO`` (image-based lighting times ambient
occlusion); a glass hit splits into a reflected and a refracted child by Schlick's Fresnel factor
(Schlick 1994), a mirror reflects everything, tinted by its colour. The maths is in
:mod:`vergence.render.shading`; this class binds it to a scene. A replacement passed to
:class:`~vergence.render.Tracer` needs the same three methods.
"""

from __future__ import annotations

import numpy as np

from vergence.render import _kernels, surfaces
from vergence.render._mitsuba import Caster
from vergence.render.scene import Glass, Scene
from vergence.render.shading import Lighting, ao_lattice, reflect, refract, schlick

__all__ = ["AO_PATTERNS", "SpecularSplit", "WhittedShader"]

# Offset of secondary ray origins, relative to the coordinates' magnitude: well above the float32
# error of Mitsuba's intersection (~1e-6 relative), well below any feature of the built-in scenes.
EPS_REL = 1e-4
#: Shadow rays per Mitsuba call of the ambient occlusion (staged and fused alike).
AO_CHUNK = 1 << 21


def offset(p: np.ndarray, n: np.ndarray, sign: float = 1.0) -> np.ndarray:
    """Move points ``(M, 3)`` off the surface along ``sign n``: ``p + sign 1e-4 (1 + |p|_inf) n`` (a Numba kernel)."""
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return _kernels.offset_points(f64(p), f64(n), sign, EPS_REL)


# Quantum of the position hash of the "hashed" AO pattern, metres: far below any feature of a scene,
# far above float64 rounding of the refined hit points.
_HASH_QUANTUM = 1e-6
_U64 = np.uint64


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser (Steele et al. 2014) on uint64 arrays: a well-mixed hash."""
    with np.errstate(over="ignore"):
        x = (x + _U64(0x9E3779B97F4A7C15)) & _U64(0xFFFFFFFFFFFFFFFF)
        x = (x ^ (x >> _U64(30))) * _U64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> _U64(27))) * _U64(0x94D049BB133111EB)
        return x ^ (x >> _U64(31))


def _hashed_shifts(points: np.ndarray) -> np.ndarray:
    """Per-point lattice shifts ``(M, 2)`` in [0, 1)^2 from a hash of the position (1 micrometre cells)."""
    q = np.floor(points / _HASH_QUANTUM).astype(np.int64).view(np.uint64)
    with np.errstate(over="ignore"):
        h = _splitmix64(q[:, 0])
        h = _splitmix64(h ^ q[:, 1])
        h = _splitmix64(h ^ q[:, 2])
    u = (h >> _U64(40)).astype(np.float64) / float(1 << 24)
    v = ((h >> _U64(16)) & _U64(0xFFFFFF)).astype(np.float64) / float(1 << 24)
    return np.stack([u, v], axis=1)


# How the AO lattice is placed at each shading point without an rng: name -> shifts (None: unshifted).
AO_PATTERNS = {
    "lattice": None,  # the same lattice everywhere: noise-free, structured where occluders are near
    "hashed": _hashed_shifts,  # a Cranley-Patterson rotation per point from a hash of its position
}


class SpecularSplit(tuple):
    """``(reflect_dir, reflect_weight, refract_rows, refract_dir, refract_weight)`` of specular hits."""

    __slots__ = ()


class WhittedShader:
    """Environment, IBL x AO and Fresnel-split shading of one scene.

    Parameters
    ----------
    scene : Scene
    packed : PackedScene, optional
        The scene's packed arrays (materials), when the caller has them.
    caster : Caster, optional
        A caster of all the scene's objects, reused for occlusion when the scene has no glass.
    ao_pattern : str
        Placement of the AO lattice when the render has no ``rng`` (one of :data:`AO_PATTERNS`):
        ``"lattice"`` (default) uses the same directions at every point, noise-free but with the
        structured "ghost" shadows a fixed lattice leaves near occluders; ``"hashed"`` rotates the
        lattice per point (Cranley-Patterson rotation) by a hash of the point's position:
        deterministic, unbiased over the scene, the structure turned into fine noise. With an ``rng``
        every point draws its own rotation either way.

    Examples
    --------
    >>> from vergence.render import Tracer, builtin_scene
    >>> scene = builtin_scene("tabletop", width=16, height=12)
    >>> tracer = Tracer(scene, shader=WhittedShader(scene, ao_pattern="hashed"))
    """

    def __init__(self, scene: Scene, packed: surfaces.PackedScene | None = None, caster: Caster | None = None,
                 *, ao_pattern: str = "lattice") -> None:  # fmt: skip
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vergence.render.Scene; got {type(scene).__name__}")
        if packed is not None and not isinstance(packed, surfaces.PackedScene):
            raise TypeError(f"packed must be a PackedScene or None; got {type(packed).__name__}")
        if caster is not None and not isinstance(caster, Caster):
            raise TypeError(f"caster must be a Caster or None; got {type(caster).__name__}")
        if ao_pattern not in AO_PATTERNS:
            raise ValueError(f"ao_pattern must be one of {', '.join(AO_PATTERNS)}; got {ao_pattern!r}")
        self.ao_pattern = ao_pattern
        self.packed = surfaces.pack_scene(scene) if packed is None else packed
        self.lighting = Lighting(scene.environment)
        glass = [isinstance(scene.materials[o.material], Glass) for o in scene.objects]
        # Glass does not occlude ambient occlusion (it transmits light).
        if caster is not None and not any(glass):
            self.occluders = caster
        else:
            self.occluders = Caster([s for s, g in zip(self.packed.shapes, glass) if not g])

    def background(self, directions: np.ndarray) -> np.ndarray:
        """Radiance ``(M, 3)`` of rays ``(M, 3)`` that escape the scene: the environment's."""
        return self.lighting.radiance(directions)

    def diffuse(
        self, points: np.ndarray, n_geo: np.ndarray, n_shade: np.ndarray, *, samples: int,
        rng: np.random.Generator | None, ao_distance: float | None,
    ) -> np.ndarray:  # fmt: skip
        """Radiance per unit albedo ``(M, 3)`` of diffuse points: ``E(n) AO / pi`` (S3 §3.1)."""
        ao = self.ambient_occlusion(points, n_geo, n_shade, samples=samples, rng=rng, ao_distance=ao_distance)
        return self.lighting.irradiance(n_shade) * (ao / np.pi)[:, None]

    def ambient_occlusion(self, points, n_geo, n_shade, *, samples, rng, ao_distance) -> np.ndarray:  # noqa: ANN001
        """Cosine-weighted unoccluded fraction of the hemisphere around ``n_shade`` at each point."""
        out = np.empty(len(points))
        lattice = ao_lattice(samples)
        step = max(1, AO_CHUNK // samples)
        for s in range(0, len(points), step):
            e = min(len(points), s + step)
            if rng is not None:
                shifts = rng.random((e - s, 2))
            elif AO_PATTERNS[self.ao_pattern] is not None:
                shifts = AO_PATTERNS[self.ao_pattern](points[s:e])
            else:
                shifts = np.empty((0, 2))
            orig, dirs = _kernels.ao_rays(points[s:e], n_geo[s:e], n_shade[s:e], lattice, shifts, EPS_REL)
            maxt = None if ao_distance is None else np.full(dirs.shape[1], ao_distance)
            blocked = self.occluders.occluded(orig, dirs, maxt).reshape(e - s, samples)
            out[s:e] = 1.0 - np.count_nonzero(blocked, axis=1) / samples  # the blocked fraction
        return out

    def specular(self, d: np.ndarray, n_shade: np.ndarray, entering: np.ndarray, mat: np.ndarray) -> SpecularSplit:
        """Children of specular hits (materials ``mat``, mirror or glass; ``n_shade`` faces the ray).

        Glass: reflected weight Schlick's ``R`` (Schlick 1994), refracted weight ``1 - R`` times the
        glass colour when entering; no refracted child under total internal reflection. Mirror:
        reflected weight its colour. Returns a :class:`SpecularSplit`; ``refract_rows`` index the
        rows of ``d`` that have a refracted child.
        """
        pk = self.packed
        is_glass = pk.mat_kind[mat] == surfaces.GLASS
        cos_i = np.clip(-np.einsum("ij,ij->i", d, n_shade), 0.0, 1.0)
        ior = pk.mat_ior[mat]
        n1 = np.where(entering, 1.0, ior)
        n2 = np.where(entering, ior, 1.0)
        R = np.where(is_glass, schlick(cos_i, n1, n2), 1.0)  # mirrors reflect all
        refl_w = np.where(is_glass[:, None], R[:, None], pk.mat_color[mat])
        g = np.flatnonzero(is_glass)
        tdir, tir = refract(d[g], n_shade[g], n1[g] / n2[g])
        ok = ~tir & (R[g] < 1.0)
        g, tdir = g[ok], tdir[ok]
        tint = np.where(entering[g][:, None], pk.mat_color[mat[g]], 1.0)
        return SpecularSplit((reflect(d, n_shade), refl_w, g, tdir, (1.0 - R[g])[:, None] * tint))
