"""Per-layer camera offsets of the left eye (S3 §3.4): the shading camera, its tabulation, the final render.

S3 §3.4 moves "the camera used for shading of the left image ... along a line, connecting the left
and right eye position independently for each pixel and each layer": with offset ``y`` the centre
is ``c(y) = c_R + y (c_L - c_R)``, so ``y = 1`` is the original stereo and ``y = 0`` puts the left
camera on the right eye (the layer is mono). The convergence (zero-parallax) plane stays where it
is: the rigs of :func:`vergence.rigs.stereo_pair` are shifted-sensor rigs (S0 §2), whose two
cameras differ only in the centre and the principal point ``cx``; the camera at ``y`` interpolates
both, ``cx(y) = cx_R + y (cx_L - cx_R)``, and a point of the convergence plane keeps its pixel for
every ``y`` (:func:`offset_camera`, Notes). At ``y = 0`` it *is* the right camera.

- :func:`offset_camera`: that camera, for one offset.
- :func:`offset_rays`: per-pixel origins and directions for a map of offsets (each pixel's ray
  through the same pixel of its own camera).
- :func:`tabulate_offsets`: S3's table of ``g`` at ``y_m = m / k``, ``m = 0..k`` (k = 32: 33
  renders of the left eye): per offset the left eye's ray tree and its per-layer disparity against
  the right eye (:func:`~vergence.specular.layer_disparity`).
- :func:`render_offsets`: the final render of S3 §3.4, every layer of every pixel shaded from its
  own camera, through :meth:`vergence.render.Tracer.trace_rays` with per-pixel origins.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from numbers import Integral, Real
from typing import TYPE_CHECKING

import numpy as np

from vergence._validate import readonly_fields
from vergence.camera import Camera
from vergence.specular.matching import MATCH_WINDOW, layer_disparity

if TYPE_CHECKING:  # importing vergence.render imports Mitsuba: only when a render is asked for
    from vergence.render import RenderResult, Scene, Tracer

__all__ = [
    "MAX_OFFSET_STEPS",
    "OffsetTable",
    "offset_camera",
    "offset_rays",
    "render_offsets",
    "tabulate_offsets",
]

#: Largest number of steps k of :func:`tabulate_offsets` (k + 1 renders): 256, eight times S3's k = 32;
#: the table grows linearly with k (see :func:`tabulate_offsets`, Notes, for its size).
MAX_OFFSET_STEPS = 256
# A rig is shifted-sensor when the rotations, focal lengths, skew and cy agree and the baseline lies
# along the camera x axis to this relative tolerance (rounding of look_at and of the centres' sums).
_RIG_TOL = 1e-9
# Offsets handed to Tracer.render_many at once by tabulate_offsets (side by side up to its WAVEFRONT_SLOTS
# rays a level); their ray trees are held until matched (at 512 x 512, D = 2, about 70 MB each).
_RENDER_BATCH = 8

Progress = Callable[[float, str], None]


def check_rig(left: object, right: object) -> tuple[Camera, Camera]:
    """``left`` and ``right`` as the two cameras of a shifted-sensor rig (S0 §2), or a one-line error."""
    for name, cam in (("left", left), ("right", right)):
        if not isinstance(cam, Camera):
            raise TypeError(f"{name} must be a pinhole vergence.camera.Camera; got {type(cam).__name__}")
    if (left.width, left.height) != (right.width, right.height):
        raise ValueError(f"left and right must share an image size; got {left.width}x{left.height} and "
                         f"{right.width}x{right.height}")  # fmt: skip
    k_diff = np.abs(left.K - right.K)
    k_diff[0, 2] = 0.0  # the sensor shift
    base = right.center - left.center
    b = float(np.linalg.norm(base))
    scale = max(1.0, float(np.abs(left.K).max()))
    along = left.R @ base  # the baseline in the camera frame: (b, 0, 0) for a shifted-sensor rig
    if (not np.allclose(left.R, right.R, rtol=0.0, atol=_RIG_TOL) or k_diff.max() > _RIG_TOL * scale
            or b == 0.0 or along[0] <= 0.0 or abs(along[1]) + abs(along[2]) > _RIG_TOL * max(b, 1.0)):  # fmt: skip
        raise ValueError("left and right must form a shifted-sensor rig (vergence.rigs.stereo_pair: same R, size "
                         "and K but cx, the right eye along the left camera's +x axis)")  # fmt: skip
    return left, right


def _check_offset(y: object) -> float:
    if isinstance(y, bool) or not isinstance(y, Real):
        raise TypeError(f"y must be a real number; got {type(y).__name__}")
    y = float(y)
    if not 0.0 <= y <= 1.0:  # NaN fails too
        raise ValueError(f"y must lie in [0, 1] (1: the left eye, 0: the right eye's centre); got {y!r}")
    return y


def offset_camera(left: Camera, right: Camera, y: float) -> Camera:
    """The left eye's shading camera at offset ``y`` along the baseline (S3 §3.4).

    Parameters
    ----------
    left, right : Camera
        A shifted-sensor rig, as :func:`vergence.rigs.stereo_pair` returns (same ``R``, size and
        ``K`` but ``cx``; the right centre on the left camera's +x axis).
    y : float
        Offset in [0, 1]: 1 is the left eye, 0 the right eye (the layer becomes mono).

    Returns
    -------
    Camera
        Centre ``c(y) = c_R + y (c_L - c_R)``, principal point ``cx(y) = cx_R + y (cx_L - cx_R)``,
        everything else the left camera's. ``y = 1`` returns ``left`` and ``y = 0`` returns
        ``right`` themselves.

    Raises
    ------
    TypeError
        If a camera is not a pinhole :class:`~vergence.camera.Camera` or ``y`` is not a real number.
    ValueError
        If the cameras do not form a shifted-sensor rig or ``y`` is outside [0, 1].

    Notes
    -----
    The convergence plane is fixed: in the left camera frame a point ``(X, Y, H)`` of the plane
    ``z = H`` (``H = fx b / (cx_R - cx_L)``, :func:`vergence.rigs.stereo_pair`) is at
    ``X - (1 - y) b`` from the camera at ``y``, so its column is
    ``fx (X - (1 - y) b) / H + cx_L + (1 - y)(cx_R - cx_L) = fx X / H + cx_L``: the left eye's, for
    every ``y``; its row does not change (the baseline has no y or z component). A parallel rig
    (``cx_R = cx_L``, H infinite) keeps ``cx``.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> from vergence.rigs import stereo_pair
    >>> cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=101, height=51)
    >>> left, right = stereo_pair(cam, baseline=0.1, convergence=2.0)
    >>> mid = offset_camera(left, right, 0.5)
    >>> mid.center.tolist(), mid.principal_point
    ([0.0, 0.0, 0.0], (50.0, 25.0))
    """
    left, right = check_rig(left, right)
    y = _check_offset(y)
    if y == 1.0:
        return left
    if y == 0.0:
        return right
    center = right.center + y * (left.center - right.center)
    K = np.array(left.K, copy=True)
    K[0, 2] = right.K[0, 2] + y * (left.K[0, 2] - right.K[0, 2])
    return Camera(K=K, R=left.R, t=-left.R @ center, width=left.width, height=left.height)


def offset_map(y: object, shape: tuple[int, ...], name: str = "y") -> np.ndarray:
    if y is None or isinstance(y, str):
        raise TypeError(f"{name} must be a numeric array; got {type(y).__name__}")
    arr = np.asarray(y)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must be a real numeric array; got dtype {arr.dtype}")
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}; got {arr.shape}")
    arr = arr.astype(np.float64)
    if arr.size and not np.isfinite(arr).all():
        raise ValueError(f"{name} must hold offsets in [0, 1]; got {int((~np.isfinite(arr)).sum())} NaN or inf")
    if arr.size and not (arr.min() >= 0.0 and arr.max() <= 1.0):
        raise ValueError(f"{name} must hold offsets in [0, 1]; got [{arr.min():g}, {arr.max():g}]")
    return arr


def offset_rays(left: Camera, right: Camera, y: object) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel rays of the left eye's shading cameras for an offset map ``y`` (S3 §3.4).

    Parameters
    ----------
    left, right : Camera
        A shifted-sensor rig (see :func:`offset_camera`).
    y : (H, W) array_like
        Offset of each pixel's camera, in [0, 1].

    Returns
    -------
    origins : (H, W, 3) float64
        ``c(y)`` per pixel, world metres.
    directions : (H, W, 3) float64
        Unit world direction through pixel ``(u, v)`` of the camera at ``y``:
        ``R^T K_L^-1 (u - (cx(y) - cx_L), v, 1)``, normalised (only ``cx`` differs from ``K_L``).

    Raises
    ------
    TypeError, ValueError
        As :func:`offset_camera`; ``y`` of another shape or outside [0, 1].
    """
    left, right = check_rig(left, right)
    y = offset_map(y, (left.height, left.width))
    s = 1.0 - y  # distance from the left eye, as a fraction of the baseline
    origins = left.center + s[..., None] * (right.center - left.center)
    shift = s * (right.K[0, 2] - left.K[0, 2])  # cx(y) - cx_L, pixels
    vs, us = np.mgrid[0 : left.height, 0 : left.width].astype(np.float64)
    homog = np.stack([us - shift, vs, np.ones_like(us)], axis=-1)
    d = (homog @ np.linalg.inv(left.K).T) @ left.R
    return origins, d / np.linalg.norm(d, axis=-1, keepdims=True)


def check_steps(k: object) -> int:
    if isinstance(k, bool) or not isinstance(k, Integral):
        raise TypeError(f"k must be an integer; got {type(k).__name__}")
    if not 2 <= int(k) <= MAX_OFFSET_STEPS:
        raise ValueError(f"k must be an integer in [2, {MAX_OFFSET_STEPS}] (offsets m/k, m = 0..k); got {k}")
    return int(k)


@dataclass(frozen=True, slots=True, eq=False)
class OffsetTable:
    """S3's table of the left eye at the offsets ``y_m = m / k`` (S3 §3.4). Arrays are read-only.

    Attributes
    ----------
    offsets : (k + 1,) float64
        ``m / k`` for ``m = 0..k``: ``offsets[0] = 0`` (the right eye's camera), ``offsets[-1] = 1``
        (the left eye).
    radiance : (k + 1, N, H, W, 3) float32
        Per offset, the left eye's ray-tree layers (:attr:`vergence.render.RenderResult.radiance`).
    position : (k + 1, N, H, W, 3) float32 or None
        Per offset, the layers' world positions; None unless asked for (``keep_position``).
    disparity_px : (k + 1, N, H, W, 2) float32
        Per offset, :attr:`~vergence.specular.LayerDisparity.disparity_px` against the right eye.
    distance : (k + 1, N, H, W) float32
        Per offset, the matched distance in metres (NaN: no match).
    epsilon : float
        The match cutoff, metres, the same at every offset.
    window : tuple of int
        The match window ``(width, height)``, pixels.
    left, right : RenderResult
        The two physical renders (``y = 1`` and the right eye); ``radiance[-1]`` is ``left.radiance``.
    seconds_render, seconds_match : float
        Wall time spent rendering and matching.
    """

    offsets: np.ndarray
    radiance: np.ndarray
    position: np.ndarray | None
    disparity_px: np.ndarray
    distance: np.ndarray
    epsilon: float
    window: tuple[int, int]
    left: RenderResult
    right: RenderResult
    seconds_render: float
    seconds_match: float

    def __post_init__(self) -> None:
        k1 = len(self.offsets)
        n, h, w = self.distance.shape[1:]
        shapes = {"radiance": (k1, n, h, w, 3), "disparity_px": (k1, n, h, w, 2), "distance": (k1, n, h, w)}
        if self.position is not None:
            shapes["position"] = (k1, n, h, w, 3)
        for name, want in shapes.items():
            if getattr(self, name).shape != want:
                raise ValueError(f"{name} must have shape {want}; got {getattr(self, name).shape}")
        readonly_fields(self, "offsets", *shapes)

    @property
    def k(self) -> int:
        """The number of steps k (k + 1 offsets)."""
        return len(self.offsets) - 1

    @property
    def n_layers(self) -> int:
        """Number of layers N."""
        return self.distance.shape[1]


def _check_progress(progress: object) -> None:
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable(fraction, message) or None; got {type(progress).__name__}")


def tracer_of(scene: object) -> Tracer:
    from vergence.render import Scene, Tracer

    if isinstance(scene, Tracer):
        return scene
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a vergence.render.Scene or Tracer; got {type(scene).__name__}")
    return Tracer(scene)


def tabulate_offsets(
    scene: Scene | Tracer,
    left: Camera,
    right: Camera,
    *,
    k: int = 32,
    max_depth: int = 2,
    samples: int = 16,
    rng: np.random.Generator | None = None,
    ao_distance: float | None = None,
    window: tuple[int, int] = MATCH_WINDOW,
    epsilon: float | None = None,
    keep_position: bool = False,
    progress: Progress | None = None,
) -> OffsetTable:
    """Render the left eye's ray tree at ``y_m = m / k`` and match each against the right eye (S3 §3.4).

    Parameters
    ----------
    scene : vergence.render.Scene or vergence.render.Tracer
        A prepared :class:`~vergence.render.Tracer` is reused (its Mitsuba scene is built once).
    left, right : Camera
        A shifted-sensor rig (:func:`vergence.rigs.stereo_pair`), see :func:`offset_camera`.
    k : int
        Steps: ``k + 1`` offsets ``0/k .. k/k``, in [2, :data:`MAX_OFFSET_STEPS`]; S3 uses 32.
    max_depth, samples, rng, ao_distance
        As :func:`vergence.render.render`, the same for every render.
    window, epsilon
        As :func:`~vergence.specular.layer_disparity`; ``epsilon`` defaults to
        :data:`~vergence.specular.EPSILON_FRACTION` x the :func:`~vergence.specular.scene_diameter`
        of the physical pair, then serves every offset (the cutoff must not move with ``y``).
    keep_position : bool
        Also keep the per-offset positions (another ``(k + 1) N H W 3`` float32 array).
    progress : callable(fraction, message), optional
        Called before each render and once at the end.

    Returns
    -------
    OffsetTable

    Raises
    ------
    TypeError, ValueError
        On a bad scene, rig, ``k`` (not an integer in [2, 256]), ``max_depth`` or ``keep_position``
        before any render; the other render options at the first render, ``window`` and ``epsilon``
        at the first match (after the physical pair is rendered).

    Notes
    -----
    ``k + 1`` renders are needed, yet only ``k`` are traced besides the right eye: the camera at
    ``y = 0`` is the right camera itself (:func:`offset_camera`), so its row is the right render
    and its disparity is zero wherever a layer exists. S3 §3.4 reports "up to one minute" on a GPU.
    The renders go :data:`_RENDER_BATCH` at a time side by side, one wavefront per tree level
    (:meth:`~vergence.render.Tracer.render_many`); with an ``rng`` the AO draws follow that joint order.

    *Memory.* Radiance and disparity take ``(k + 1) N H W (3 + 2 + 1) x 4`` bytes (float32); at S3's
    512 x 512, D = 2 (N = 7), k = 32 that is 33 x 7 x 262144 x 24 B = 1.45 GB (2.18 GB with
    ``keep_position``); the process peaked at 2.27 GiB (``benchmarks/specular_offsets.py``). Normals
    are not kept. Measured there (one run, 2 shared CPU cores, 16 AO samples): 32.2 s, of which
    25.7 s for the 33 renders and 3.7 s for the 33 matches.
    """
    from vergence.render.limits import check_max_depth

    tracer = tracer_of(scene)
    left, right = check_rig(left, right)
    k = check_steps(k)
    max_depth = check_max_depth(max_depth)
    _check_progress(progress)
    if not isinstance(keep_position, bool):
        raise TypeError(f"keep_position must be a bool; got {type(keep_position).__name__}")
    opts = {"max_depth": max_depth, "samples": samples, "rng": rng, "ao_distance": ao_distance}
    offsets = np.arange(k + 1, dtype=np.float64) / k
    seconds_render = seconds_match = 0.0
    right_res = left_res = pos = None
    # The physical pair first (its match fixes epsilon), then y = 0 (the right render itself), then 1/k ...
    order = [k, 0, *range(1, k)]
    rendered: dict = {}
    for done, m in enumerate(order):
        if progress is not None:
            progress(done / (k + 1), f"offset {m}/{k} ({done + 1} of {k + 1})")
        if m not in rendered:  # the next offsets side by side in one wavefront (Tracer.render_many)
            t0 = time.perf_counter()
            batch = [j for j in order[done : done + _RENDER_BATCH] if j != 0]
            cams = ([right] if right_res is None else []) + [offset_camera(left, right, offsets[j]) for j in batch]
            results = tracer.render_many(cams, **opts)
            if right_res is None:
                right_res, results = results[0], results[1:]
            rendered = {0: right_res, **dict(zip(batch, results))}
            seconds_render += time.perf_counter() - t0
        res = rendered.pop(m)
        t0 = time.perf_counter()
        match = layer_disparity(res.position, right_res.position, window=window, epsilon=epsilon)
        seconds_match += time.perf_counter() - t0
        if m == k:
            left_res, epsilon, window = res, match.epsilon, match.window
            n, h, w = res.n_layers, left.height, left.width
            rad = np.empty((k + 1, n, h, w, 3), np.float32)
            pos = np.empty((k + 1, n, h, w, 3), np.float32) if keep_position else None
            disp = np.empty((k + 1, n, h, w, 2), np.float32)
            dist = np.empty((k + 1, n, h, w), np.float32)
        rad[m] = res.radiance
        if pos is not None:
            pos[m] = res.position
        disp[m] = match.disparity_px
        dist[m] = match.distance
    if progress is not None:
        progress(1.0, "done")
    return OffsetTable(offsets=offsets, radiance=rad, position=pos, disparity_px=disp, distance=dist,
                       epsilon=float(epsilon), window=window, left=left_res, right=right_res, seconds_render=seconds_render,
                       seconds_match=seconds_match)  # fmt: skip


def tree_level(node: int) -> int:
    """Tree level of heap node ``node`` (1-based): its number of specular bounces."""
    return node.bit_length() - 1


def render_offsets(
    scene: Scene | Tracer,
    left: Camera,
    right: Camera,
    y: object,
    *,
    samples: int = 16,
    rng: np.random.Generator | None = None,
    ao_distance: float | None = None,
    progress: Progress | None = None,
) -> RenderResult:
    """The left eye with every layer of every pixel shaded from its own camera (S3 §3.4, the final render).

    Parameters
    ----------
    scene : vergence.render.Scene or vergence.render.Tracer
    left, right : Camera
        A shifted-sensor rig (:func:`vergence.rigs.stereo_pair`), see :func:`offset_camera`.
    y : (N, H, W) array_like
        Offset per layer (heap order, ``N = 2^(D+1) - 1``: the depth D follows from N) and pixel,
        in [0, 1]. S3 keeps the diffuse layer at 1; this function renders whatever it is given.
    samples, rng, ao_distance
        As :func:`vergence.render.render`.
    progress : callable(fraction, message), optional
        Called before each pass and once at the end.

    Returns
    -------
    RenderResult
        On the left camera's pixel grid (``camera`` is ``left``): layer ``i`` at pixel ``x`` is
        layer ``i`` at ``x`` of the camera :func:`offset_camera` ``(left, right, y[i, x])``.
        ``depth`` is the z of the first layer's hit in the left camera frame (every offset camera
        shares that frame's z axis: the baseline is along x). ``settings`` counts the rays of all passes.
        Without ``rng``, a map of ones gives :meth:`vergence.render.Tracer.render` of ``left`` and a
        layer of zeros that layer of ``right``, to float rounding (the ray directions are computed
        by another route than the renderer's pinhole kernel).

    Raises
    ------
    TypeError, ValueError
        On a bad scene or rig, ``y`` not ``(N, H, W)`` with N = 2^(D+1) - 1 or outside [0, 1].

    Notes
    -----
    Rays with per-pixel origins and directions (:func:`offset_rays`) go through
    :meth:`vergence.render.Tracer.trace_rays`: no table, no interpolation. One pass per distinct
    offset map: layers whose maps are equal share a pass (all ones is one pass, the left eye), and
    the pass stops at the deepest level among its layers (node i needs levels 0..floor(log2 i);
    a node's own radiance, position and normal do not depend on deeper levels). Each pass traces
    whole trees, not only its layers' paths, so N distinct maps cost up to N tree traces (a
    path-restricted trace would cut that; the tracer has none).
    """
    from vergence.render import RenderResult
    from vergence.render.limits import MAX_DEPTH

    tracer = tracer_of(scene)
    left, right = check_rig(left, right)
    _check_progress(progress)
    if y is None or isinstance(y, str):
        raise TypeError(f"y must be a numeric array of shape (N, H, W); got {type(y).__name__}")
    arr = np.asarray(y)
    n = arr.shape[0] if arr.ndim == 3 else 0
    depth = int(math.log2(n + 1)) - 1 if n > 0 else -1
    if arr.ndim != 3 or n != 2 ** (depth + 1) - 1 or not 0 <= depth <= MAX_DEPTH:
        raise ValueError(f"y must have shape (N, {left.height}, {left.width}) with N = 2^(D+1) - 1 layers, "
                         f"D in [0, {MAX_DEPTH}]; got {arr.shape}")  # fmt: skip
    ymap = offset_map(arr, (n, left.height, left.width))
    groups: list[tuple[np.ndarray, list[int]]] = []  # distinct maps and their layers (0-based)
    for i in range(n):
        for gmap, layers in groups:
            if np.array_equal(gmap, ymap[i]):
                layers.append(i)
                break
        else:
            groups.append((ymap[i], [i]))
    h, w = left.height, left.width
    rad = np.zeros((n, h, w, 3), np.float32)
    pos = np.full((n, h, w, 3), np.nan, np.float32)
    nrm = np.full((n, h, w, 3), np.nan, np.float32)
    first = None
    tree_rays = ao_rays = 0
    settings = None
    for g, (gmap, layers) in enumerate(groups):
        if progress is not None:
            progress(g / len(groups), f"pass {g + 1} of {len(groups)}: layers {', '.join(str(i + 1) for i in layers)}")
        level = max(tree_level(i + 1) for i in layers)
        origins, directions = offset_rays(left, right, gmap)
        tree = tracer.trace_rays(origins, directions, max_depth=level, samples=samples, rng=rng,
                                 ao_distance=ao_distance)  # fmt: skip
        for i in layers:
            rad[i], pos[i], nrm[i] = tree.radiance[i], tree.position[i], tree.normal[i]
        if 0 in layers:  # the first hit in float64, as the renderer's depth
            first = origins + tree.distance[..., None] * directions
        tree_rays += tree.settings.tree_rays
        ao_rays += tree.settings.ao_rays
        settings = tree.settings
    if progress is not None:
        progress(1.0, "done")
    z = (first @ left.R[2] + left.t[2]).astype(np.float32)  # NaN where the first ray escapes
    settings = replace(settings, max_depth=depth, tree_rays=tree_rays, ao_rays=ao_rays)
    return RenderResult(radiance=rad, position=pos, normal=nrm, depth=z, beauty=rad.sum(axis=0), camera=left,
                        settings=settings)  # fmt: skip
