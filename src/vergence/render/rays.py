"""Ray generation, the first stage of the renderer: a camera to the rays through its pixel centres.

Each camera model has one generator in :data:`RAY_GENERATORS` (type -> function); a generator returns
a :class:`RayBatch`: world origins and unit directions of the pixels that have a ray, with their flat
pixel indices (a fisheye has no ray outside its image circle). Frames and pixel conventions:
``docs/conventions.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array
from vergence.camera import Camera
from vergence.render.lenses import FisheyeCamera

__all__ = ["RAY_GENERATORS", "RayBatch", "SUBPIXEL_OFFSET_RANGE", "camera_rays", "subpixel_grid_rays", "subpixel_rays"]

#: Offsets of :func:`subpixel_rays` from a pixel centre, pixels, per axis: [-0.5, 0.5], the pixel's own
#: square (centres at integer coordinates). A ray farther out samples a neighbouring pixel, which a
#: supersampled pixel must not average; and a huge offset overflowed ``K^-1 (x, y, 1)``.
SUBPIXEL_OFFSET_RANGE = (-0.5, 0.5)


@dataclass(frozen=True, slots=True, eq=False)
class RayBatch:
    """Rays of one image: ``origins`` and unit ``directions`` ``(M, 3)`` float64, ``pixels`` ``(M,)``.

    ``pixels`` are flat (row-major) indices into an image of ``shape`` (H, W); pixels without a ray
    are absent.
    """

    origins: np.ndarray
    directions: np.ndarray
    pixels: np.ndarray
    shape: tuple[int, int]


def _grid_rays(camera: Camera | FisheyeCamera) -> RayBatch:
    dirs = camera.ray_directions().reshape(-1, 3)  # NaN where a pixel has no ray (fisheye)
    pix = np.flatnonzero(~np.isnan(dirs[:, 0]))
    origins = np.broadcast_to(camera.center, (len(pix), 3)).copy()
    return RayBatch(origins=origins, directions=dirs[pix], pixels=pix, shape=(camera.height, camera.width))


def _pinhole_rays(camera: Camera) -> RayBatch:
    from vergence.render import _kernels

    dirs = _kernels.pinhole_directions(np.linalg.inv(camera.K), np.ascontiguousarray(camera.R), camera.width,
                                       camera.height)  # fmt: skip
    n = camera.width * camera.height
    origins = np.broadcast_to(camera.center, (n, 3)).copy()
    return RayBatch(origins=origins, directions=dirs, pixels=np.arange(n), shape=(camera.height, camera.width))


RAY_GENERATORS: dict[type, Callable[..., RayBatch]] = {
    Camera: _pinhole_rays,  # pinhole: K^-1 (x, y, 1), rotated to the world
    FisheyeCamera: _grid_rays,  # equidistant r = f theta (S3 §3.2)
}


def camera_rays(camera: Camera | FisheyeCamera) -> RayBatch:
    """The rays through the pixel centres of ``camera`` (one per pixel that has a ray).

    Raises
    ------
    TypeError
        If ``camera`` is not one of the types in :data:`RAY_GENERATORS`.
    """
    generator = RAY_GENERATORS.get(type(camera))
    if generator is None:
        valid = ", ".join(t.__name__ for t in RAY_GENERATORS)
        raise TypeError(f"camera must be one of {valid}; got {type(camera).__name__}")
    return generator(camera)


def subpixel_rays(camera: Camera, offsets: np.ndarray) -> RayBatch:
    """Pinhole rays through ``(x + dx, y + dy)`` for every pixel ``(x, y)``: supersampling.

    Parameters
    ----------
    camera : Camera
        A pinhole camera (``K^-1 (x, y, 1)`` holds at any sub-pixel position).
    offsets : (H, W, 2) or (2,) array
        Offsets from the pixel centres in pixels, ``(dx, dy)``, per pixel or shared, each in
        :data:`SUBPIXEL_OFFSET_RANGE` ([-0.5, 0.5]).

    Raises
    ------
    TypeError
        If ``camera`` is not a pinhole :class:`~vergence.camera.Camera`, or ``offsets`` is not numeric.
    ValueError
        If ``offsets`` has another shape, or holds NaN, inf or a value outside the range.
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"sub-pixel rays need a pinhole Camera; got {type(camera).__name__}")
    if offsets is None or isinstance(offsets, str):
        raise TypeError(f"offsets must be a numeric array of shape (2,) or (H, W, 2); got {type(offsets).__name__}")
    off = as_float_array("offsets", offsets)
    if off.shape not in ((2,), (camera.height, camera.width, 2)):
        raise ValueError(f"offsets must have shape (2,) or ({camera.height}, {camera.width}, 2); got {off.shape}")
    low, high = SUBPIXEL_OFFSET_RANGE
    if off.size and not (low <= off.min() and off.max() <= high):
        raise ValueError(f"offsets must lie in [{low:g}, {high:g}] px (SUBPIXEL_OFFSET_RANGE); "
                         f"got [{off.min():g}, {off.max():g}]")  # fmt: skip
    ys, xs = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    off = np.broadcast_to(off, (camera.height, camera.width, 2))
    homog = np.stack([xs + off[..., 0], ys + off[..., 1], np.ones_like(xs)], axis=-1).reshape(-1, 3)
    d = (homog @ np.linalg.inv(camera.K).T) @ camera.R
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = len(d)
    return RayBatch(origins=np.broadcast_to(camera.center, (n, 3)).copy(), directions=d, pixels=np.arange(n),
                    shape=(camera.height, camera.width))  # fmt: skip


def subpixel_grid_rays(camera: Camera, k: int, rng: np.random.Generator | None = None) -> RayBatch:
    """The k x k sub-pixel rays of every pixel of ``camera``, as one batch (a Numba kernel; supersampling).

    Block ``j = iy k + ix`` (``pixels`` ``j H W + p``) holds the rays through the cell centres
    ``(ix + 1/2) / k - 1/2``, ``(iy + 1/2) / k - 1/2`` of every pixel ``p``; with an ``rng`` each ray
    moves by a uniform offset within its cell, drawn block by block as ``rng.random((H, W, 2))``.
    :func:`subpixel_rays` (numpy), one block at a time, is its reference.

    Raises
    ------
    TypeError
        If ``camera`` is not a pinhole :class:`~vergence.camera.Camera`.
    """
    from vergence.render import _kernels

    if not isinstance(camera, Camera):
        raise TypeError(f"sub-pixel rays need a pinhole Camera; got {type(camera).__name__}")
    h, w = camera.height, camera.width
    cells = (np.arange(k) + 0.5) / k - 0.5
    grid = np.array([[gx, gy] for gy in cells for gx in cells], dtype=np.float64)
    jitter = np.zeros((0, h, w, 2))
    if rng is not None:
        jitter = np.stack([(rng.random((h, w, 2)) - 0.5) / k for _ in range(k * k)])
    dirs = _kernels.subpixel_directions(np.linalg.inv(camera.K), np.ascontiguousarray(camera.R), w, h, grid, jitter)
    n = len(dirs)
    return RayBatch(origins=np.broadcast_to(camera.center, (n, 3)).copy(), directions=dirs, pixels=np.arange(n),
                    shape=(h, w))  # fmt: skip
