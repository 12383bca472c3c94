"""What a render returns: the ray tree of S3 §3.1 as image layers (:class:`RenderResult`), over
any ray shape (:class:`RayTree`), and how it was made (:class:`RenderSettings`).

Node numbering (heap order): node 1 is the first hit; the children of node ``i`` are ``2i``
(reflection) and ``2i + 1`` (refraction); array index ``i - 1`` holds node ``i``
(see :mod:`vergence.render.raytree` for what each node stores).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.camera import Camera
from vergence.render.lenses import FisheyeCamera

__all__ = ["RayTree", "RenderResult", "RenderSettings", "layer_names"]


def layer_names(max_depth: int) -> list[str]:
    """Names of the nodes 1..N: ``"first hit"``, then the path, e.g. ``"R"``, ``"T"``, ``"RT"``.

    ``max_depth`` is an integer in [0, :data:`~vergence.render.limits.MAX_DEPTH`].
    """
    from vergence.render.limits import check_max_depth

    max_depth = check_max_depth(max_depth)
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
    ambient-occlusion rays: together, all the rays Mitsuba cast. ``supersample`` k: radiance is the
    mean of k x k sub-pixel rays per pixel (1: the pixel centre only).
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
    supersample: int = 1

    def to_dict(self) -> dict:
        """Plain dictionary of the settings."""
        return {k: getattr(self, k) for k in self.__slots__}


def _check_types(result: object, arrays: tuple[str, ...]) -> None:
    """The settings a RenderSettings and the named fields numpy arrays (TypeError otherwise)."""
    if not isinstance(result.settings, RenderSettings):
        raise TypeError(f"settings must be a RenderSettings; got {type(result.settings).__name__}")
    for name in arrays:
        if not isinstance(getattr(result, name), np.ndarray):
            raise TypeError(f"{name} must be a numpy array; got {type(getattr(result, name)).__name__}")


def _check_object_id(result: object, shape: tuple[int, ...]) -> None:
    """``result.object_id`` None or an integer array of ``shape`` (then stored as a read-only int32 view)."""
    oid = result.object_id
    if oid is None:
        return
    if not isinstance(oid, np.ndarray) or not np.issubdtype(oid.dtype, np.integer):
        raise TypeError(f"object_id must be an integer numpy array or None; got {type(oid).__name__}")
    if oid.shape != tuple(shape):
        raise ValueError(f"object_id must have shape {tuple(shape)}; got {oid.shape}")
    view = oid.astype(np.int32, copy=False).view()
    view.flags.writeable = False
    object.__setattr__(result, "object_id", view)


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
    object_id : (N, H, W) int32 or None
        Per node, the index into ``scene.objects`` of the surface the node's ray hit (for node 2, the
        object seen in the mirror), -1 where the node has no hit; None when not known (a result
        built by hand or by compositing).
    """

    radiance: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    beauty: np.ndarray
    camera: Camera | FisheyeCamera
    settings: RenderSettings
    object_id: np.ndarray | None = None

    def __post_init__(self) -> None:
        _check_types(self, ("radiance", "position", "normal", "depth", "beauty"))
        if not isinstance(self.camera, Camera | FisheyeCamera):
            raise TypeError(f"camera must be a Camera or a FisheyeCamera; got {type(self.camera).__name__}")
        n = 2 ** (self.settings.max_depth + 1) - 1
        shape = (n, self.camera.height, self.camera.width, 3)
        for name in ("radiance", "position", "normal"):
            if getattr(self, name).shape != shape:
                raise ValueError(f"{name} must have shape {shape}; got {getattr(self, name).shape}")
        if self.depth.shape != shape[1:3] or self.beauty.shape != shape[1:]:
            raise ValueError(f"depth and beauty must have shapes {shape[1:3]} and {shape[1:]}; "
                             f"got {self.depth.shape} and {self.beauty.shape}")
        _check_object_id(self, shape[:3])
        for name in ("radiance", "position", "normal", "depth", "beauty"):
            view = getattr(self, name).view()  # read-only view: the caller's array keeps its flags
            view.flags.writeable = False
            object.__setattr__(self, name, view)

    @property
    def n_layers(self) -> int:
        """Number of nodes ``N = 2^(D+1) - 1``."""
        return self.radiance.shape[0]


@dataclass(frozen=True, slots=True, eq=False)
class RayTree:
    """The ray tree of arbitrary rays (:meth:`Tracer.trace_rays`), laid out as ``shape``. Arrays are read-only.

    The same nodes as :class:`RenderResult` (heap order, ``N = 2^(D+1) - 1``), over the ray grid
    ``shape`` instead of a camera's pixels.

    Attributes
    ----------
    radiance, position, normal : (N, *shape, 3) float32
        As in :class:`RenderResult`.
    distance : shape float64
        Distance from the origin to the first hit along the unit direction, metres; NaN where the
        primary ray hits nothing within its ``tmax``.
    hit : shape bool
        Whether the primary ray hit a surface within ``tmax``. A ray with a finite ``tmax`` and no
        hit carries no radiance at all: the caller continues it from ``origin + tmax direction``
        (curved rays cut into segments). A ray with ``tmax = inf`` and no hit escapes and takes the
        environment radiance.
    beauty : (*shape, 3) float32
        ``radiance.sum(axis=0)``.
    settings : RenderSettings
    object_id : (N, *shape) int32 or None
        As in :class:`RenderResult`.
    """

    radiance: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    hit: np.ndarray
    beauty: np.ndarray
    settings: RenderSettings
    object_id: np.ndarray | None = None

    def __post_init__(self) -> None:
        _check_types(self, ("radiance", "position", "normal", "distance", "hit", "beauty"))
        n = self.radiance.shape[0] if self.radiance.ndim else 0
        shape = (n, *self.hit.shape, 3)
        if self.radiance.ndim < 2 or self.radiance.shape != shape:
            raise ValueError(f"radiance must have shape (N, *hit.shape, 3) = {shape}; got {self.radiance.shape}")
        for name, want in (("position", shape), ("normal", shape), ("distance", self.hit.shape),
                           ("beauty", shape[1:])):  # fmt: skip
            if getattr(self, name).shape != want:
                raise ValueError(f"{name} must have shape {want}; got {getattr(self, name).shape}")
        _check_object_id(self, shape[:-1])
        for name in ("radiance", "position", "normal", "distance", "hit", "beauty"):
            view = getattr(self, name).view()
            view.flags.writeable = False
            object.__setattr__(self, name, view)

    @property
    def shape(self) -> tuple[int, ...]:
        """The ray grid's shape."""
        return self.hit.shape

    @property
    def n_layers(self) -> int:
        """Number of nodes ``N = 2^(D+1) - 1``."""
        return self.radiance.shape[0]
