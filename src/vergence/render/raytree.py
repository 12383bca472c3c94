"""Whitted ray tracing into the ray tree of S3 §3.1 (Whitted 1980): one image layer per tree node.

Node numbering (heap order): node 1 is the first hit; the children of node ``i`` are ``2i``
(reflection) and ``2i + 1`` (refraction); with at most ``D`` specular bounces there are
``N = 2^(D+1) - 1`` nodes (7 for D = 2) and array index ``i - 1`` holds node ``i``.

What a node stores, per pixel (S3 §3.1: "the node L_i contains the diffuse radiance or the
background color when there is no local hit point"; P_i "the scene-space location of all surface
intersections"):

- ``radiance``: the path throughput (product of the Fresnel factors ``R`` or ``1 - R`` of glass,
  the colours of mirrors and of glass entered, S3 §3.1) times the **local** contribution of the
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

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array, check_positive, check_positive_int
from vergence.camera import Camera
from vergence.render import surfaces
from vergence.render.intersect import Intersector
from vergence.render.lenses import FisheyeCamera
from vergence.render.limits import MAX_DEPTH, MAX_RENDER_SIDE, check_max_depth, render_cost
from vergence.render.rays import RayBatch, camera_rays, subpixel_grid_rays, subpixel_rays
from vergence.render.results import RayTree, RenderResult, RenderSettings, layer_names
from vergence.render.scene import MAX_SCENE_EXTENT, Scene
from vergence.render.shader import WhittedShader
from vergence.render.staged import trace_staged

__all__ = ["MAX_DEPTH", "Tracer", "WAVEFRONT_SLOTS", "check_render_options", "render", "render_stereo"]


Progress = Callable[[float, str], None]

#: Rays per tree level of one wavefront of :meth:`Tracer.render_many` (cameras beyond it start the next):
#: 512 Ki. Side by side pays while each camera's wavefront is small and stops paying as the arrays outgrow
#: the caches (8 cameras of glasses, 16 AO samples, joint / one per wavefront, medians of 5 interleaved
#: rounds on the 2 shared cores: 160x120 0.87, 320x240 1.07, 320x240 with 3x3 rays per pixel 1.22).
WAVEFRONT_SLOTS = 1 << 19


@dataclass(frozen=True, slots=True)
class _Flat:
    """The tree of ``n_slots`` ray slots, flat: what the stages produce before any reshaping."""

    radiance: np.ndarray  # (N, n_slots, 3) float32
    position: np.ndarray
    normal: np.ndarray
    first_point: np.ndarray  # (n_slots, 3) float64, NaN without a first hit
    first_t: np.ndarray  # (n_slots,) float64, NaN without a first hit
    tree_rays: np.ndarray  # (views,) rays of the tree per view
    ao_rays: np.ndarray  # (views,) AO rays per view
    object_id: np.ndarray  # (N, n_slots) int32: index into scene.objects of each node's hit, -1 without one


# What the tracer calls on its shading stage (see WhittedShader).
_SHADER_METHODS = ("background", "diffuse", "specular")


class Tracer:
    """A scene prepared once for tracing, reusable across cameras and ray sets (S3 §3.1).

    Three stages, each replaceable: ray generation (``rays``: camera -> :class:`~vergence.render.rays.RayBatch`,
    default :func:`~vergence.render.rays.camera_rays`), intersection (``intersector``: default
    :class:`~vergence.render.intersect.Intersector`, Mitsuba's cast refined in float64) and shading
    (``shader``: default :class:`~vergence.render.shader.WhittedShader`, IBL x AO and Schlick's
    Fresnel split). The Mitsuba scenes are built once, here.

    Parameters
    ----------
    scene : Scene
    rays : callable(camera) -> RayBatch, optional
    intersector : callable, optional
        Called as ``intersector(origins, directions, cast_from=..., tmax=...)``, returning
        :class:`~vergence.render.intersect.Hits`; needs a ``packed`` attribute and a ``variant``.
    shader : object, optional
        With the methods ``background``, ``diffuse`` and ``specular`` of :class:`WhittedShader`.
    staged : bool
        Run the stages one by one (numpy and small kernels between Mitsuba's casts): the readable
        reference. By default the default stages run fused (:mod:`vergence.render.wavefront`: a few
        kernels per tree level, ambient occlusion as shadow rays), to float rounding the same result;
        a tracer with a stage of its own always runs staged.

    Examples
    --------
    >>> from vergence.render import builtin_scene
    >>> tracer = Tracer(builtin_scene("tabletop", width=16, height=12))
    >>> tracer.render(samples=1).beauty.shape
    (12, 16, 3)
    >>> tree = tracer.trace_rays([[0.0, 0.3, 1.2]], [[0.0, 0.0, -1.0]], max_depth=0, samples=1)
    >>> tree.hit.tolist()
    [True]
    """

    def __init__(self, scene: Scene, *, rays: Callable[..., RayBatch] | None = None, intersector=None, shader=None,
                 staged: bool = False) -> None:  # noqa: ANN001  # fmt: skip
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vergence.render.Scene; got {type(scene).__name__}")
        if rays is not None and not callable(rays):
            raise TypeError(f"rays must be a callable (camera -> RayBatch) or None; got {type(rays).__name__}")
        if intersector is not None and not (callable(intersector)
                                            and isinstance(getattr(intersector, "packed", None), surfaces.PackedScene)
                                            and isinstance(getattr(intersector, "variant", None), str)):  # fmt: skip
            raise TypeError("intersector must be a callable with a PackedScene 'packed' and a str 'variant' "
                            f"(an Intersector) or None; got {type(intersector).__name__}")  # fmt: skip
        missing = [m for m in _SHADER_METHODS if not callable(getattr(shader, m, None))]
        if shader is not None and missing:
            raise TypeError(f"shader must have the methods {', '.join(_SHADER_METHODS)} (a WhittedShader) or be None; "
                            f"got {type(shader).__name__}")  # fmt: skip
        self.scene = scene
        self.rays = camera_rays if rays is None else rays
        self.intersector = Intersector(scene) if intersector is None else intersector
        self.packed = self.intersector.packed
        caster = getattr(self.intersector, "caster", None)
        self.shader = WhittedShader(scene, self.packed, caster) if shader is None else shader
        if not isinstance(staged, bool):
            raise TypeError(f"staged must be a bool; got {type(staged).__name__}")
        self.fused = (not staged and self.rays is camera_rays and type(self.intersector) is Intersector
                      and type(self.shader) is WhittedShader)  # fmt: skip
        self._pack = None

    def uv_objects(self) -> np.ndarray:
        """Per object: whether its material reads texture coordinates (a checker or a texture)."""
        from vergence.render.scene import Checker, Texture

        pk = self.packed
        return np.array([isinstance(pk.materials[m], Checker | Texture) for m in pk.material], dtype=np.bool_)

    def shading_pack(self):  # noqa: ANN201
        """The materials and environment as kernel arrays (:func:`~vergence.render.wavefront.pack_shading`), once."""
        if self._pack is None:
            from vergence.render.wavefront import pack_shading

            self._pack = pack_shading(self.packed, self.shader.lighting)
        return self._pack

    # ------------------------------------------------------------------ public entry points
    def render(self, camera: Camera | FisheyeCamera | None = None, *, max_depth: int = 2, samples: int = 16,
               rng: np.random.Generator | None = None, ao_distance: float | None = None,
               progress: Progress | None = None, supersample: int = 1) -> RenderResult:  # fmt: skip
        """Ray-trace one camera's view (default: the scene's camera); parameters as :func:`render`."""
        max_depth, samples, ao_distance = check_render_options(self.scene, camera, max_depth, samples, rng, ao_distance)
        cam = self.scene.camera.build() if camera is None else camera
        supersample = _check_supersample(supersample, [cam])
        return self._render_many([cam], max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                                 progress=progress, supersample=supersample)[0]  # fmt: skip

    def render_many(self, cameras: Sequence[Camera | FisheyeCamera], *, max_depth: int = 2, samples: int = 16,
                    rng: np.random.Generator | None = None, ao_distance: float | None = None,
                    progress: Progress | None = None, supersample: int = 1) -> list[RenderResult]:  # fmt: skip
        """Ray-trace several cameras' views, their rays side by side in one wavefront per tree level.

        A rig's cameras, S3's table of offsets: one Mitsuba cast and one set of kernels per level for
        all of them. Cameras are grouped into wavefronts of at most :data:`WAVEFRONT_SLOTS` rays per
        level (``(1 + k^2) H W`` a camera with ``supersample`` k), in order. Each result is
        :meth:`render`'s for that camera; with an ``rng`` the draws follow the joint order (a camera's
        pixels after the previous camera's within a wavefront), so they differ from separate renders.
        Parameters as :func:`render`; ``progress`` reports the wavefronts.

        Raises
        ------
        TypeError, ValueError
            As :meth:`render`, for any camera (before any ray is traced); an empty ``cameras``.
        """
        cams = list(cameras) if isinstance(cameras, list | tuple) else None
        if not cams:
            raise ValueError(f"cameras must be a non-empty list of Camera or FisheyeCamera; got {cameras!r:.80}")
        for cam in cams:
            max_depth, samples, ao_distance = check_render_options(self.scene, cam, max_depth, samples, rng, ao_distance)
        supersample = _check_supersample(supersample, cams)
        if progress is not None and not callable(progress):
            raise TypeError(f"progress must be a callable(fraction, message) or None; got {type(progress).__name__}")
        groups: list[list] = [[]]
        slots = 0
        for cam in cams:
            n = (1 + (supersample * supersample if supersample > 1 else 0)) * cam.width * cam.height
            if groups[-1] and slots + n > WAVEFRONT_SLOTS:
                groups.append([])
                slots = 0
            groups[-1].append(cam)
            slots += n
        out: list[RenderResult] = []
        for g, group in enumerate(groups):
            say = None
            if progress is not None:
                say = lambda f, m, g=g, c=len(out), k=len(group): progress(  # noqa: E731
                    (g + f) / len(groups), f"views {c + 1}-{c + k} of {len(cams)}: {m}")  # fmt: skip
            out += self._render_many(group, max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                                     progress=say, supersample=supersample)  # fmt: skip
        return out

    def trace_rays(
        self, origins: object, directions: object, *, shape: tuple[int, ...] | None = None, tmax: object = None,
        max_depth: int = 2, samples: int = 16, rng: np.random.Generator | None = None,
        ao_distance: float | None = None, progress: Progress | None = None,
    ) -> RayTree:  # fmt: skip
        """Trace arbitrary rays into their ray tree (per-pixel camera origins, segments of curved rays).

        Parameters
        ----------
        origins, directions : (..., 3) array
            Finite world origins and directions, metres; the directions must be finite and non-zero
            and are **normalised** here (distances and ``tmax`` are metres along the unit direction).
            The two broadcast together.
        shape : tuple of int, optional
            Layout of the result (its size must equal the number of rays); default: the leading
            shape of ``directions``.
        tmax : float or array broadcasting to the leading shape, optional
            Largest distance of each primary ray's hit (> 0, ``inf`` allowed); default: unbounded.
            Only the primary ray is bounded; the tree below a hit is traced in full.
        max_depth, samples, rng, ao_distance, progress
            As :func:`render`.

        Returns
        -------
        RayTree
            ``hit`` tells which rays hit within ``tmax``; rays with a finite ``tmax`` and no hit
            carry no radiance (continue them), rays with ``tmax = inf`` and no hit escape.

        Raises
        ------
        ValueError
            On a malformed, non-finite or zero input, a ``shape`` of another size or ``tmax <= 0``.
        """
        max_depth, samples, ao_distance = check_render_options(self.scene, None, max_depth, samples, rng, ao_distance)
        d = as_float_array("directions", directions)
        if d.ndim == 0 or d.shape[-1] != 3:
            raise ValueError(f"directions must have shape (..., 3); got {d.shape}")
        o = as_float_array("origins", origins)
        if o.ndim == 0 or o.shape[-1] != 3:
            raise ValueError(f"origins must have shape (..., 3); got {o.shape}")
        try:
            o, d = np.broadcast_arrays(o, d)
        except ValueError:
            raise ValueError(f"origins and directions must broadcast together; got {o.shape} and {d.shape}") from None
        lead = d.shape[:-1]
        norm = np.linalg.norm(d, axis=-1)
        if (norm == 0).any():
            raise ValueError(f"directions must be non-zero; got {int((norm == 0).sum())} zero rows")
        n = int(np.prod(lead, dtype=np.int64))
        out_shape = lead if shape is None else tuple(int(v) for v in shape)
        if int(np.prod(out_shape, dtype=np.int64)) != n or any(v < 0 for v in out_shape):
            raise ValueError(f"shape must hold the {n} rays; got {shape!r}")
        problem = render_cost(n, 1, max_depth=max_depth, samples=samples).problem()
        if problem is not None:
            raise ValueError(f"tracing {n:,} rays with max_depth {max_depth}, samples {samples} {problem}")
        bound = None
        if tmax is not None:
            try:
                tm = np.asarray(tmax, dtype=np.float64)
            except (TypeError, ValueError):
                raise TypeError(f"tmax must be numeric; got {type(tmax).__name__}") from None
            if np.isnan(tm).any() or (tm <= 0).any():
                raise ValueError("tmax must be > 0 (inf allowed) for every ray")
            try:
                bound = np.broadcast_to(tm, lead).reshape(n).astype(np.float64)
            except ValueError:
                raise ValueError(f"tmax must broadcast to the rays' shape {lead}; got {tm.shape}") from None
        rays = RayBatch(origins=o.reshape(n, 3).copy(), directions=(d / norm[..., None]).reshape(n, 3),
                        pixels=np.arange(n), shape=(n,))  # fmt: skip
        flat = self._trace([rays], np.array([0, n]), tmax=bound, max_depth=max_depth, samples=samples, rng=rng,
                           ao_distance=ao_distance, progress=progress)  # fmt: skip
        nodes = flat.radiance.shape[0]
        settings = self._settings(max_depth, samples, rng, ao_distance, int(flat.tree_rays[0]), int(flat.ao_rays[0]))
        rad = flat.radiance.reshape(nodes, *out_shape, 3)
        return RayTree(radiance=rad, position=flat.position.reshape(rad.shape), normal=flat.normal.reshape(rad.shape),
                       distance=flat.first_t.reshape(out_shape), hit=np.isfinite(flat.first_t).reshape(out_shape),
                       beauty=rad.sum(axis=0), settings=settings,
                       object_id=flat.object_id.reshape(nodes, *out_shape))  # fmt: skip

    # ------------------------------------------------------------------ internals
    def _settings(self, max_depth, samples, rng, ao_distance, tree_rays, ao_rays, supersample=1) -> RenderSettings:  # noqa: ANN001
        return RenderSettings(
            scene=self.scene.name, max_depth=max_depth, samples=samples, deterministic=rng is None,
            ao_distance=ao_distance, variant=self.intersector.variant, environment=self.scene.environment.describe(),
            tree_rays=tree_rays, ao_rays=ao_rays, supersample=supersample,
        )  # fmt: skip

    def _render_many(self, cameras, *, max_depth, samples, rng, ao_distance, progress,
                     supersample=1) -> list[RenderResult]:  # noqa: ANN001  # fmt: skip
        """Render several cameras' views with one wavefront per tree level (their rays side by side).

        With ``supersample`` k > 1, each camera also casts a k x k grid of sub-pixel rays per pixel
        (cell centres, or jittered within their cells by ``rng``); its radiance layers and beauty are
        their mean, while position, normal and depth stay those of the pixel-centre ray (a point of
        one surface, never an average across an edge).
        """
        if progress is not None and not callable(progress):
            raise TypeError(f"progress must be a callable(fraction, message) or None; got {type(progress).__name__}")
        n = 2 ** (max_depth + 1) - 1
        k2 = supersample * supersample
        _check_cost(cameras, max_depth=max_depth, samples=samples, supersample=supersample)
        try:
            batches = [self.rays(c) for c in cameras]
            sizes = [c.height * c.width for c in cameras]
            if supersample > 1 and self.fused:  # one kernel per camera for its k x k sub-pixel blocks
                for c in cameras:
                    batches.append(subpixel_grid_rays(c, supersample, rng))
                    sizes.extend([c.height * c.width] * k2)
            elif supersample > 1:
                grid = (np.arange(supersample) + 0.5) / supersample - 0.5
                for c in cameras:
                    for gy in grid:
                        for gx in grid:
                            off = np.array([gx, gy])
                            if rng is not None:
                                off = off + (rng.random((c.height, c.width, 2)) - 0.5) / supersample
                            batches.append(subpixel_rays(c, off))
                            sizes.append(c.height * c.width)
            starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
            offsets = starts[:len(cameras)].tolist() + [int(starts[len(cameras) + k * k2]) for k in range(len(cameras))] \
                if supersample > 1 and self.fused else starts  # fmt: skip
            shifted = [RayBatch(b.origins, b.directions, b.pixels + s, b.shape) for b, s in zip(batches, offsets)]
            flat = self._trace(shifted, starts, tmax=None, max_depth=max_depth, samples=samples, rng=rng,
                               ao_distance=ao_distance, progress=progress, geo_slots=int(starts[len(cameras)]))  # fmt: skip
        except MemoryError:
            c = cameras[0]
            gib = 3 * n * c.height * c.width * 3 * 4 / 2**30  # radiance, position, normal (float32)
            raise ValueError(f"width x height {c.width}x{c.height} with {n} layers does not fit in memory "
                             f"(the layer arrays alone need {gib:.3g} GiB); render a smaller image") from None
        out = []
        nc = len(cameras)
        for k, cam in enumerate(cameras):
            sl = slice(starts[k], starts[k + 1])
            h, w = cam.height, cam.width
            rad = flat.radiance[:, sl].reshape(n, h, w, 3)
            tree_rays, ao_rays = int(flat.tree_rays[k]), int(flat.ao_rays[k])
            if supersample > 1:
                subs = [nc + k * k2 + j for j in range(k2)]
                acc = np.zeros((n, h * w, 3), dtype=np.float64)
                for v in subs:
                    acc += flat.radiance[:, starts[v] : starts[v + 1]]
                rad = (acc / k2).astype(np.float32).reshape(n, h, w, 3)
                tree_rays += int(flat.tree_rays[subs].sum())
                ao_rays += int(flat.ao_rays[subs].sum())
            p0 = flat.first_point[sl]
            depth = (p0 @ cam.R[2] + cam.t[2]).astype(np.float32).reshape(h, w)
            settings = self._settings(max_depth, samples, rng, ao_distance, tree_rays, ao_rays, supersample)
            out.append(RenderResult(radiance=rad, position=flat.position[:, sl].reshape(rad.shape),
                                    normal=flat.normal[:, sl].reshape(rad.shape), depth=depth,
                                    beauty=rad.sum(axis=0), camera=cam, settings=settings,
                                    object_id=flat.object_id[:, sl].reshape(n, h, w)))  # fmt: skip
        return out

    def _trace(self, batches, starts, *, tmax, max_depth, samples, rng, ao_distance, progress,
               geo_slots=None) -> _Flat:  # noqa: ANN001  # fmt: skip
        """The tree of every ray of ``batches`` (slots ``pixels``); position and normal are kept for the
        first ``geo_slots`` slots at least (all by default; the fused path keeps only those)."""
        if self.fused:
            from vergence.render.wavefront import trace_wavefront

            cat = lambda name: (getattr(batches[0], name) if len(batches) == 1  # noqa: E731
                                else np.concatenate([getattr(b, name) for b in batches]))  # fmt: skip
            return _Flat(*trace_wavefront(self, cat("origins"), cat("directions"), cat("pixels"), starts, tmax=tmax,
                                          max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                                          progress=progress,
                                          geo_slots=int(starts[-1]) if geo_slots is None else geo_slots))  # fmt: skip
        return _Flat(*trace_staged(self, batches, starts, tmax=tmax, max_depth=max_depth, samples=samples, rng=rng,
                                   ao_distance=ao_distance, progress=progress))  # fmt: skip


def _check_cost(cameras, *, max_depth, samples, supersample) -> None:  # noqa: ANN001
    """Refuse a render past MAX_RENDER_SIDE, MAX_RENDER_BYTES or MAX_RENDER_RAYS before allocating."""
    c = cameras[0]
    side = max(max(cam.width, cam.height) for cam in cameras)
    if side > MAX_RENDER_SIDE:
        raise ValueError(f"camera width and height must be <= {MAX_RENDER_SIDE} pixels (MAX_RENDER_SIDE); "
                         f"got {c.width}x{c.height}")  # fmt: skip
    trees = sum(cam.width * cam.height for cam in cameras)
    problem = render_cost(trees, 1, max_depth=max_depth, samples=samples, supersample=supersample).problem()
    if problem is not None:
        raise ValueError(f"a render of {len(cameras)} view(s) of {c.width}x{c.height} pixels with max_depth "
                         f"{max_depth}, samples {samples}, supersample {supersample} {problem}")  # fmt: skip


def _check_supersample(supersample, cameras) -> int:  # noqa: ANN001
    k = check_positive_int("supersample", supersample)
    if k > 1 and not all(isinstance(c, Camera) for c in cameras):
        raise TypeError("supersample > 1 needs a pinhole Camera; got "
                        f"{next(type(c).__name__ for c in cameras if not isinstance(c, Camera))}")  # fmt: skip
    return k


# No occluder lies farther from a shading point than the diagonal of the cube of MAX_SCENE_EXTENT (all
# scene points lie inside it); a longer AO distance only overflowed the float32 cast of the ray ends.
_MAX_AO_DISTANCE = 2.0 * np.sqrt(3.0) * MAX_SCENE_EXTENT


def _camera_reach(camera: Camera | FisheyeCamera) -> float:
    """Largest |coordinate| of the camera centre, metres (compared with MAX_SCENE_EXTENT, as the scene's camera)."""
    return float(np.abs(camera.center).max())


def check_render_options(scene, camera, max_depth, samples, rng, ao_distance):  # noqa: ANN001, ANN202
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a vergence.render.Scene; got {type(scene).__name__}")
    if camera is not None and not isinstance(camera, Camera | FisheyeCamera):
        raise TypeError(f"camera must be a Camera, a FisheyeCamera or None; got {type(camera).__name__}")
    if camera is not None and _camera_reach(camera) > MAX_SCENE_EXTENT:
        raise ValueError(f"camera must lie within {MAX_SCENE_EXTENT:g} m of the origin (MAX_SCENE_EXTENT); "
                         f"its centre reaches {_camera_reach(camera):g} m")  # fmt: skip
    check_max_depth(max_depth)
    samples = check_positive_int("samples", samples)
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator or None; got {type(rng).__name__}")
    if ao_distance is not None:
        ao_distance = check_positive("ao_distance", ao_distance)
        if ao_distance > _MAX_AO_DISTANCE:
            raise ValueError(f"ao_distance must be <= {_MAX_AO_DISTANCE:.6g} m, the diagonal of the scene's cube "
                             f"(2 sqrt(3) MAX_SCENE_EXTENT); got {ao_distance:g}")  # fmt: skip
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
    supersample: int = 1,
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
    supersample : int
        k > 1 averages the radiance of a k x k grid of sub-pixel rays per pixel (anti-aliasing; the
        cell centres, jittered within the cells with an ``rng``); position, normal and depth stay
        those of the pixel-centre ray. Pinhole cameras only. Costs about ``1 + k^2`` times the rays.

    Returns
    -------
    RenderResult

    Notes
    -----
    Diffuse radiance is ``albedo / pi * E(n) * AO`` (image-based lighting times ambient occlusion,
    S3 §3.1); glass splits by Schlick's ``R`` (Schlick 1994) with total internal reflection; an escaping
    ray takes the environment radiance. ``beauty == radiance.sum(axis=0)`` (S3 §3.1: ``L = sum_i L_i``).
    """
    max_depth, samples, ao_distance = check_render_options(scene, camera, max_depth, samples, rng, ao_distance)
    return Tracer(scene).render(camera, max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                                progress=progress, supersample=supersample)  # fmt: skip


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
    supersample: int = 1,
) -> tuple[RenderResult, RenderResult]:
    """Render the left and right views of the shifted-sensor rig on ``camera`` (S0 §2).

    The rig is :func:`vergence.rigs.stereo_pair` (``baseline`` b, convergence distance H, metres);
    ``camera`` defaults to the scene's (pinhole only). Other parameters as :func:`render`. Both eyes
    are traced through one :class:`Tracer`, their rays side by side in one wavefront per tree level;
    with an ``rng`` the AO draws follow that joint order (left pixels before right ones within a
    level). ``progress`` reports the joint wavefronts.

    Raises
    ------
    ValueError
        If ``baseline`` or ``convergence`` lies outside :data:`vergence.viewing.LENGTH_RANGE`, or the
        eyes at ``-+ b/2`` lie farther than :data:`MAX_SCENE_EXTENT` from the origin; both before
        any ray is traced.
    """
    from vergence.rigs import stereo_pair

    max_depth, samples, ao_distance = check_render_options(scene, camera, max_depth, samples, rng, ao_distance)
    cam = scene.camera.build() if camera is None else camera
    if not isinstance(cam, Camera):
        raise TypeError(f"render_stereo needs a pinhole Camera; got {type(cam).__name__}")
    supersample = check_positive_int("supersample", supersample)
    left, right = stereo_pair(cam, baseline=baseline, convergence=convergence)
    reach = max(_camera_reach(left), _camera_reach(right))  # the eyes at -+ b/2 from the centre
    if reach > MAX_SCENE_EXTENT:
        raise ValueError(f"baseline must keep both eyes within {MAX_SCENE_EXTENT:g} m of the origin (MAX_SCENE_EXTENT); "
                         f"they reach {reach:g} m")  # fmt: skip
    return tuple(Tracer(scene)._render_many([left, right], max_depth=max_depth, samples=samples, rng=rng,
                                            ao_distance=ao_distance, progress=progress, supersample=supersample))  # fmt: skip
