"""Whitted ray tracing into the ray tree of S3 §3.1 (SPEC §5.1): one image layer per tree node.

Node numbering (heap order): node 1 is the first hit; the children of node ``i`` are ``2i``
(reflection) and ``2i + 1`` (refraction); with at most ``D`` specular bounces there are
``N = 2^(D+1) - 1`` nodes (7 for D = 2) and array index ``i - 1`` holds node ``i``.

What a node stores, per pixel (S3 §3.1: "the node L_i contains the diffuse radiance or the
background color when there is no local hit point"; P_i "the scene-space location of all surface
intersections"):

- ``radiance``: the path throughput (product of the Fresnel factors ``R`` or ``1 - R`` of glass,
  the colours of mirrors and of glass entered, SPEC §5.1) times the **local** contribution of the
  node's hit: the diffuse radiance ``albedo/pi E(n) AO`` if the surface is diffuse, 0 if it is a
  mirror or glass (their light is carried by the children), or the environment radiance along the
  ray if it escapes. So ``beauty = sum over nodes`` exactly, and no light is counted twice.
- ``position``: the world point where the node's ray hits (the surface seen in that layer: for node
  2 the object seen in the mirror, not the mirror); NaN where the ray escapes or the node does not
  exist (no parent specular hit, total internal reflection, or a pixel without a ray).
- ``normal``: the unit shading normal there, turned to face the arriving ray; NaN likewise.

Decisions where S3 is silent: a specular hit at the last level (depth D) is cut off and adds
nothing (a Whitted tree of depth D); mirrors have no refraction child; rectangles are two-sided;
glass sits in air (index 1) and is entered where the ray meets the outward normal; glass objects
do not occlude ambient occlusion (they transmit light); secondary rays start ``1e-4 (1 + |p|_inf)``
off the surface, on the side they leave from.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vergence._validate import check_positive, check_positive_int
from vergence.camera import Camera
from vergence.render import _kernels, surfaces
from vergence.render._mitsuba import Caster
from vergence.render.lenses import FisheyeCamera
from vergence.render.scene import Glass, Scene
from vergence.render.shading import Lighting, ao_lattice, reflect, refract, schlick

__all__ = ["MAX_DEPTH", "RenderResult", "RenderSettings", "layer_names", "render", "render_stereo"]

MAX_DEPTH = 6  # 127 layers; beyond that the arrays outgrow memory long before they help
# Offset of secondary ray origins, relative to the coordinates' magnitude: well above the float32
# error of Mitsuba's intersection (~1e-6 relative), well below any feature of the built-in scenes.
_EPS_REL = 1e-4
_AO_CHUNK = 1 << 21  # shadow rays per Mitsuba call

Progress = Callable[[float, str], None]


def layer_names(max_depth: int) -> list[str]:
    """Names of the nodes 1..N: ``"first hit"``, then the path, e.g. ``"R"``, ``"T"``, ``"RT"``."""
    names = []
    for i in range(1, 2 ** (max_depth + 1)):
        path = ""
        while i > 1:
            path = ("R" if i % 2 == 0 else "T") + path
            i //= 2
        names.append(path or "first hit")
    return names


@dataclass(frozen=True, slots=True)
class RenderSettings:
    """How a :class:`RenderResult` was made (JSON-ready through :meth:`to_dict`).

    ``tree_rays`` counts the rays of the tree (primary and specular), ``ao_rays`` the
    ambient-occlusion rays: together, all the rays Mitsuba cast.
    """

    scene: str
    max_depth: int
    samples: int
    deterministic: bool
    ao_distance: float | None
    variant: str
    environment: str
    tree_rays: int = 0
    ao_rays: int = 0

    def to_dict(self) -> dict:
        """Plain dictionary of the settings."""
        return {k: getattr(self, k) for k in self.__slots__}


@dataclass(frozen=True, slots=True, eq=False)
class RenderResult:
    """The ray tree of one view (S3 §3.1). Arrays are read-only.

    Attributes
    ----------
    radiance : (N, H, W, 3) float32
        Per node, linear HDR radiance already weighted by the path's Fresnel and colour factors.
    position : (N, H, W, 3) float32
        World position of each node's hit, metres; NaN where the path escapes or does not exist.
    normal : (N, H, W, 3) float32
        Unit shading normal at each node's hit, facing the arriving ray; NaN likewise.
    depth : (H, W) float32
        Camera-frame z of the first hit, metres; NaN where the primary ray escapes.
    beauty : (H, W, 3) float32
        The image: ``radiance.sum(axis=0)``.
    camera : Camera or FisheyeCamera
    settings : RenderSettings
    """

    radiance: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    beauty: np.ndarray
    camera: Camera | FisheyeCamera
    settings: RenderSettings

    def __post_init__(self) -> None:
        n = 2 ** (self.settings.max_depth + 1) - 1
        shape = (n, self.camera.height, self.camera.width, 3)
        for name in ("radiance", "position", "normal"):
            if getattr(self, name).shape != shape:
                raise ValueError(f"{name} must have shape {shape}; got {getattr(self, name).shape}")
        if self.depth.shape != shape[1:3] or self.beauty.shape != shape[1:]:
            raise ValueError(f"depth and beauty must have shapes {shape[1:3]} and {shape[1:]}; "
                             f"got {self.depth.shape} and {self.beauty.shape}")
        for name in ("radiance", "position", "normal", "depth", "beauty"):
            view = getattr(self, name).view()  # read-only view: the caller's array keeps its flags
            view.flags.writeable = False
            object.__setattr__(self, name, view)

    @property
    def n_layers(self) -> int:
        """Number of nodes ``N = 2^(D+1) - 1``."""
        return self.radiance.shape[0]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _offset(p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Move points off the surface along ``n`` (the side the new ray leaves on)."""
    return p + (_EPS_REL * (1.0 + np.abs(p).max(axis=1)))[:, None] * n


class _Tracer:
    """One scene prepared for tracing: Mitsuba scenes for hits and for occlusion, packed arrays."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.packed = surfaces.pack_scene(scene)
        self.caster = Caster(self.packed.shapes)
        glass = [isinstance(scene.materials[o.material], Glass) for o in scene.objects]
        self.occluders = Caster([s for s, g in zip(self.packed.shapes, glass) if not g]) if any(glass) else self.caster
        self.lighting = Lighting(scene.environment)

    def trace(self, camera, *, max_depth, samples, rng, ao_distance, progress) -> RenderResult:  # noqa: ANN001
        try:
            return self._trace(camera, max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                               progress=progress)  # fmt: skip
        except MemoryError:
            n = 2 ** (max_depth + 1) - 1
            gib = 3 * n * camera.height * camera.width * 3 * 4 / 2**30  # radiance, position, normal (float32)
            raise ValueError(f"width x height {camera.width}x{camera.height} with {n} layers does not fit in memory "
                             f"(the layer arrays alone need {gib:.3g} GiB); render a smaller image") from None

    def _trace(self, camera, *, max_depth, samples, rng, ao_distance, progress) -> RenderResult:  # noqa: ANN001
        h, w = camera.height, camera.width
        n_nodes = 2 ** (max_depth + 1) - 1
        dirs_all = camera.ray_directions().reshape(-1, 3)  # NaN where a pixel has no ray (fisheye)
        pix = np.flatnonzero(~np.isnan(dirs_all[:, 0]))
        rad = np.zeros((n_nodes, h * w, 3), dtype=np.float32)
        pos = np.full((n_nodes, h * w, 3), np.nan, dtype=np.float32)
        nrm = np.full((n_nodes, h * w, 3), np.nan, dtype=np.float32)
        depth = np.full(h * w, np.nan, dtype=np.float32)
        node = np.ones(len(pix), dtype=np.int64)
        o = np.broadcast_to(camera.center, (len(pix), 3)).copy()  # exact origins (float64 geometry)
        oc = o  # origins handed to Mitsuba: moved off the surface they leave
        d = dirs_all[pix]
        thr = np.ones((len(pix), 3))
        queue: list[tuple[np.ndarray, ...]] = []  # diffuse hits: node, pixel, p, n_geo, n_shade, albedo x throughput
        pk = self.packed
        tree_rays = 0
        for level in range(max_depth + 1):
            if progress is not None:
                progress(level / (max_depth + 2), f"level {level}: {len(pix):,} rays")
            if not len(pix):
                break
            obj, prim, t32 = self.caster.intersect(oc, d)
            tree_rays += len(d)
            esc = obj < 0
            rad[node[esc] - 1, pix[esc]] = thr[esc] * self.lighting.radiance(d[esc])
            hit = np.flatnonzero(~esc)
            node, pix, o, d, thr, obj = node[hit], pix[hit], o[hit], d[hit], thr[hit], obj[hit]
            p, ng, ns, uv = surfaces.refine_hits(pk, obj, prim[hit], o, d, t32[hit])
            dn = _dot(d, ng)
            entering = dn < 0.0
            side = np.where(entering, 1.0, -1.0)[:, None]
            ng, ns = ng * side, ns * side  # both face the arriving ray now
            pos[node - 1, pix] = p
            nrm[node - 1, pix] = ns
            if level == 0:
                depth[pix] = p @ camera.R[2] + camera.t[2]
            mat = pk.material[obj]
            kind = pk.mat_kind[mat]
            s = np.flatnonzero(kind == surfaces.DIFFUSE)
            queue.append((node[s], pix[s], p[s], ng[s], ns[s], thr[s] * surfaces.albedo(pk, mat[s], uv[s])))
            if level == max_depth:
                break  # specular hits at the last level are cut off
            children: list[tuple[np.ndarray, ...]] = []
            s = np.flatnonzero(kind != surfaces.DIFFUSE)
            is_glass = kind[s] == surfaces.GLASS
            cos_i = np.clip(-_dot(d[s], ns[s]), 0.0, 1.0)
            ior = pk.mat_ior[mat[s]]
            n1 = np.where(entering[s], 1.0, ior)
            n2 = np.where(entering[s], ior, 1.0)
            R = np.where(is_glass, schlick(cos_i, n1, n2), 1.0)  # SPEC §5.2; mirrors reflect all
            refl_w = np.where(is_glass[:, None], R[:, None], pk.mat_color[mat[s]])
            children.append((2 * node[s], pix[s], p[s], _offset(p[s], ng[s]), reflect(d[s], ns[s]), thr[s] * refl_w))
            g = s[is_glass]
            eta = n1[is_glass] / n2[is_glass]
            tdir, tir = refract(d[g], ns[g], eta)
            ok = ~tir & (R[is_glass] < 1.0)
            g, tdir = g[ok], tdir[ok]
            tint = np.where(entering[g][:, None], pk.mat_color[mat[g]], 1.0)
            t_w = (1.0 - R[is_glass][ok])[:, None] * tint
            children.append((2 * node[g] + 1, pix[g], p[g], _offset(p[g], -ng[g]), tdir, thr[g] * t_w))
            node, pix, o, oc, d, thr = (np.concatenate([c[k] for c in children]) for k in range(6))
        if progress is not None:
            progress((max_depth + 1) / (max_depth + 2), "shading: image-based lighting x ambient occlusion")
        n_shade = 0
        if queue:
            qn, qpix, qp, qng, qns, qalb = (np.concatenate([q[k] for q in queue]) for k in range(6))
            ao = self._ambient_occlusion(qp, qng, qns, samples, rng, ao_distance)
            rad[qn - 1, qpix] = qalb / np.pi * self.lighting.irradiance(qns) * ao[:, None]
            n_shade = len(qn)
        rad = rad.reshape(n_nodes, h, w, 3)
        settings = RenderSettings(
            scene=self.scene.name, max_depth=max_depth, samples=samples, deterministic=rng is None,
            ao_distance=ao_distance, variant=self.caster.variant, environment=self.scene.environment.describe(),
            tree_rays=tree_rays, ao_rays=n_shade * samples,
        )  # fmt: skip
        if progress is not None:
            progress(1.0, "done")
        return RenderResult(radiance=rad, position=pos.reshape(rad.shape), normal=nrm.reshape(rad.shape),
                            depth=depth.reshape(h, w), beauty=rad.sum(axis=0), camera=camera, settings=settings)  # fmt: skip

    def _ambient_occlusion(self, p, ng, ns, samples, rng, ao_distance) -> np.ndarray:  # noqa: ANN001
        """Cosine-weighted unoccluded fraction of the hemisphere around ``ns`` at each point."""
        out = np.empty(len(p))
        lattice = ao_lattice(samples)
        step = max(1, _AO_CHUNK // samples)
        for s in range(0, len(p), step):
            e = min(len(p), s + step)
            shifts = np.empty((0, 2)) if rng is None else rng.random((e - s, 2))
            orig, dirs = _kernels.ao_rays(p[s:e], ng[s:e], ns[s:e], lattice, shifts, _EPS_REL)  # as ao_directions
            maxt = None if ao_distance is None else np.full(dirs.shape[1], ao_distance)
            blocked = self.occluders.occluded(orig, dirs, maxt).reshape(e - s, samples)
            out[s:e] = 1.0 - blocked.mean(axis=1)
        return out


def _check_options(scene, camera, max_depth, samples, rng, ao_distance):  # noqa: ANN001, ANN202
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a vergence.render.Scene; got {type(scene).__name__}")
    if camera is not None and not isinstance(camera, Camera | FisheyeCamera):
        raise TypeError(f"camera must be a Camera, a FisheyeCamera or None; got {type(camera).__name__}")
    if isinstance(max_depth, bool) or not isinstance(max_depth, int | np.integer) or not 0 <= max_depth <= MAX_DEPTH:
        raise ValueError(f"max_depth must be an integer in [0, {MAX_DEPTH}]; got {max_depth!r}")
    samples = check_positive_int("samples", samples)
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator or None; got {type(rng).__name__}")
    if ao_distance is not None:
        ao_distance = check_positive("ao_distance", ao_distance)
    return int(max_depth), samples, ao_distance


def render(
    scene: Scene,
    *,
    camera: Camera | FisheyeCamera | None = None,
    max_depth: int = 2,
    samples: int = 16,
    rng: np.random.Generator | None = None,
    ao_distance: float | None = None,
    progress: Progress | None = None,
) -> RenderResult:
    """Ray-trace ``scene`` into its ray tree of ``2^(max_depth+1) - 1`` layers (S3 §3.1).

    Parameters
    ----------
    scene : Scene
        From :func:`~vergence.render.load_scene`, :func:`~vergence.render.builtin_scene` or built in code.
    camera : Camera or FisheyeCamera, optional
        Defaults to ``scene.camera.build()``.
    max_depth : int
        Largest number of specular bounces D, in [0, 6]; N = 2^(D+1) - 1 layers.
    samples : int
        Ambient-occlusion rays per diffuse shading point.
    rng : numpy.random.Generator, optional
        Randomises the AO directions per point (unbiased, noisy). Without it the same stratified
        directions serve every point: deterministic and noise-free (the mode for tests).
    ao_distance : float, optional
        Occluders farther than this (metres) are ignored; default: any distance.
    progress : callable(fraction, message), optional
        Called as the wavefronts advance.

    Returns
    -------
    RenderResult

    Notes
    -----
    Diffuse radiance is ``albedo / pi * E(n) * AO`` (image-based lighting times ambient occlusion,
    S3 §3.1); glass splits by Schlick's ``R`` (SPEC §5.2) with total internal reflection; an escaping
    ray takes the environment radiance. ``beauty == radiance.sum(axis=0)`` (SPEC §5.1).
    """
    max_depth, samples, ao_distance = _check_options(scene, camera, max_depth, samples, rng, ao_distance)
    cam = scene.camera.build() if camera is None else camera
    return _Tracer(scene).trace(cam, max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                                progress=progress)  # fmt: skip


def render_stereo(
    scene: Scene,
    *,
    baseline: float,
    convergence: float,
    camera: Camera | None = None,
    max_depth: int = 2,
    samples: int = 16,
    rng: np.random.Generator | None = None,
    ao_distance: float | None = None,
    progress: Progress | None = None,
) -> tuple[RenderResult, RenderResult]:
    """Render the left and right views of the shifted-sensor rig on ``camera`` (S0 §2).

    The rig is :func:`vergence.rig.stereo_pair` (``baseline`` b, convergence distance H, metres);
    ``camera`` defaults to the scene's (pinhole only). Other parameters as :func:`render`; with an
    ``rng``, the left view draws first. ``progress`` fractions run 0..0.5 (left), 0.5..1 (right).
    """
    from vergence.rig import stereo_pair

    max_depth, samples, ao_distance = _check_options(scene, camera, max_depth, samples, rng, ao_distance)
    cam = scene.camera.build() if camera is None else camera
    if not isinstance(cam, Camera):
        raise TypeError(f"render_stereo needs a pinhole Camera; got {type(cam).__name__}")
    left, right = stereo_pair(cam, baseline=baseline, convergence=convergence)
    tracer = _Tracer(scene)
    out = []
    for k, (eye, c) in enumerate((("left", left), ("right", right))):
        report = None
        if progress is not None:
            report = lambda f, m, k=k, eye=eye: progress((k + f) / 2.0, f"{eye}: {m}")  # noqa: E731
        out.append(tracer.trace(c, max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                                progress=report))  # fmt: skip
    return out[0], out[1]
