"""The unchecked stages of :func:`vergence.synthesis.render_ibr` (validated inputs only).

Proxy (sources forward-warped into the target, mesh z-buffer), back-projection, per-source sampling
with the visibility test, undistorted desired rays, normalised blend. The Numba kernels are in
``_ibr_kernels.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
from numba import typed
import numpy as np

from vergence.camera import Camera
from vergence.synthesis import _ibr_fused_kernels, _ibr_kernels, _kernels, _stages3d
from vergence.synthesis.ibr_source import IBRSource

# Field of view: a proxy point must project within the source's pixel rectangle, the hull of its pixel
# centres widened by this many pixels (half a pixel: the edge of the border pixels; the sample there is
# clamped to the hull, the border pixel's colour, as a GPU's clamp-to-edge). ULR's field-of-view penalty
# (``_ibr_kernels.fov_penalty``) grows without bound towards that edge, so a source leaving its image
# fades out continuously instead of being cut at its border pixels' centres.
FOV_MARGIN_PX = 0.5
# The visibility test's slope on one side of a source pixel is at most this multiple of the other
# side's (:func:`surface_slopes`): ground at a grazing angle changes its slope by 1.5-3x per pixel near
# the horizon; a silhouette's jump is many times its surface's slope.
SLOPE_RATIO = 2.0


def forward_proxy(target: Camera, sources: list[IBRSource], distortion: object, limit: float | None) -> np.ndarray:
    """Target depth of the nearest source surface: every source's pixels lifted with their depth
    (distorted under a distortion), projected into the target and z-buffered; linked pixel quads
    are rasterised as two triangles (the mesh warp of :func:`~vergence.synthesis.warp_to_camera`).
    Sources are drawn in parallel (``_kernels.splat_mesh`` releases the GIL), each into its own
    z-buffer, as many at a time as Numba has threads; the nearest depth wins."""
    h, w = target.height, target.width
    zbuf = np.full((h, w), np.inf)
    if limit is None:
        painted = np.zeros((h, w), dtype=bool)
        for src in sources:
            u, v, zt = (np.empty(src.depth.size) for _ in range(3))
            source_in_target(src, target, distortion, u, v, zt)
            _kernels.splat_zbuffer(u, v, zt, np.zeros((u.size, 0), dtype=np.float32), np.zeros((h, w, 0), dtype=np.float32), zbuf, painted)
        return np.where(painted, zbuf, np.nan)
    batch = max(1, numba.get_num_threads())
    with ThreadPoolExecutor(max_workers=batch) as pool:
        for first in range(0, len(sources), batch):
            # The meshes in this thread (their kernels are parallel), the serial splats in the pool.
            meshes = [source_mesh(src, target, distortion, limit) for src in sources[first : first + batch]]
            for drawn in pool.map(lambda mesh: splat_alone(mesh, h, w), meshes):
                np.minimum(zbuf, drawn, out=zbuf)
    return np.where(np.isfinite(zbuf), zbuf, np.nan)


def source_mesh(src: IBRSource, target: Camera, distortion: object, limit: float) -> tuple[np.ndarray, ...]:
    """Flat target ``u, v, zt`` of a source's pixels and its right and lower mesh links."""
    u, v, zt = (np.empty(src.depth.size) for _ in range(3))
    source_in_target(src, target, distortion, u, v, zt)
    if distortion is None:
        link_r, link_d = _stages3d.mesh_links(src.depth, u, v, zt, src.camera, target, limit)
    else:
        link_r, link_d = links_distorted(src, u, v, zt, target, distortion, limit)
    return u, v, zt, link_r, link_d


def splat_alone(mesh: tuple[np.ndarray, ...], h: int, w: int) -> np.ndarray:
    """The ``(h, w)`` z-buffer (+inf where nothing is drawn) of one source's mesh."""
    u, v, zt, link_r, link_d = mesh
    zbuf = np.full((h, w), np.inf)
    _kernels.splat_mesh(np.arange(u.size), u, v, zt, link_r, link_d, np.zeros((u.size, 0), dtype=np.float32),
                        _stages3d.MAX_FACET_PX, True, np.zeros((h, w, 0), dtype=np.float32), zbuf, np.zeros((h, w), dtype=bool))
    return zbuf


def source_in_target(
    src: IBRSource, target: Camera, distortion: object, u: np.ndarray, v: np.ndarray, zt: np.ndarray
) -> None:
    """Write the flat target columns, rows and depths of a source's pixels (through ``phi`` if given)."""
    if distortion is not None:
        u[:], v[:], zt[:] = project(target, call_distortion(distortion.forward, "forward", backproject(src.camera, src.depth)))
        return
    cam = src.camera
    _ibr_kernels.project_depth(src.depth, np.linalg.inv(cam.K), cam.R, cam.t, target.K, target.R, target.t, u, v, zt)


def backproject(camera: Camera, depth: np.ndarray) -> np.ndarray:
    """``camera.backproject_depth(depth)`` in one parallel pass (NaN depth, NaN point)."""
    out = np.empty(depth.shape + (3,))
    _ibr_kernels.backproject(depth, np.linalg.inv(camera.K), camera.R, camera.t, out)
    return out


def project(camera: Camera, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flat C-contiguous pixel columns, rows and depths of world points in ``camera`` (NaN stays NaN)."""
    flat = points.reshape(-1, 3)
    pix, z = camera.project(np.nan_to_num(flat, nan=0.0))
    z = np.where(np.isnan(flat).any(axis=1), np.nan, z)
    return np.ascontiguousarray(pix[:, 0]), np.ascontiguousarray(pix[:, 1]), np.ascontiguousarray(z)


def links_distorted(
    src: IBRSource, u: np.ndarray, v: np.ndarray, zt: np.ndarray, target: Camera, distortion: object, limit: float
) -> tuple[np.ndarray, np.ndarray]:
    """Right and lower mesh links through a distortion: the rule of ``_stages3d.mesh_links`` (the
    neighbour lifted with this pixel's depth lands within ``limit`` pixels of where it lands with
    its own), with ``phi`` applied before the target projection."""
    hs, ws = src.depth.shape
    uv = np.stack([u, v], axis=-1).reshape(hs, ws, 2)
    drawable = (zt > 0) & np.isfinite(u) & np.isfinite(v)
    drawable = drawable.reshape(hs, ws)
    grid = src.camera.pixel_grid()
    links = []
    for dy, dx in ((0, 1), (1, 0)):
        link = np.zeros((hs, ws), dtype=bool)
        za = src.depth[: hs - dy, : ws - dx]
        lifted = src.camera.backproject(grid[dy:, dx:], za)
        lu, lv, lz = project(target, call_distortion(distortion.forward, "forward", lifted))
        shift = np.hypot(lu - uv[dy:, dx:, 0].ravel(), lv - uv[dy:, dx:, 1].ravel())
        with np.errstate(invalid="ignore"):
            ok = (lz > 0) & (shift <= limit)
        link[: hs - dy, : ws - dx] = ok.reshape(za.shape) & drawable[: hs - dy, : ws - dx] & drawable[dy:, dx:]
        links.append(link)
    return links[0], links[1]


def surface_slopes(depth: np.ndarray, cap: float, ratio: float = SLOPE_RATIO) -> np.ndarray:
    """One-sided depth slopes of a depth map, metres per pixel, for the visibility test: ``(4, H, W)``,
    towards -x, +x, -y and +y.

    Each is ``|z(neighbour) - z|`` on that side, at most ``ratio`` times the opposite side's: a surface
    bends gently (ground seen at a grazing angle: 1.5-3x from one pixel to the next) while at a
    silhouette one side jumps to another surface and the other side does not, so the jump never
    widens the test. Where that neighbour is unknown (NaN, the image's border), the opposite side's
    (the surface goes on); neither: 0. Each is at most ``cap`` times the pixel's depth: a surface seen
    more edge-on than that widens the test no further.

    >>> z = np.array([[1.0, 1.25, 2.0, 9.0]])
    >>> surface_slopes(z, 0.5)[:2].tolist()
    [[[0.25, 0.25, 0.75, 4.5]], [[0.25, 0.5, 1.0, 4.5]]]
    """
    out = np.empty((4,) + depth.shape)
    _ibr_kernels.surface_slopes(np.ascontiguousarray(depth, dtype=np.float64), float(cap), float(ratio), out)
    return out


def _source_arrays(sources: list[IBRSource]) -> tuple[typed.List, typed.List]:
    """The sources' images (float32) and depths (float64) as two Numba typed lists: one kernel type for any
    number of sources (a tuple's length is part of its type, so each source count compiled anew: ~40 s)."""
    images, depths = typed.List(), typed.List()
    for src in sources:
        images.append(np.ascontiguousarray(src.image, dtype=np.float32))
        depths.append(np.ascontiguousarray(src.depth, dtype=np.float64))
    return images, depths


def sample_sources(
    points: np.ndarray, sources: list[IBRSource], tol: float, slope_cap: float, store_pixels: bool, cubic: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per source: proxy pixel ``(S, h, w, 2)`` (empty unless ``store_pixels``), visibility
    ``(S, h, w)`` and colour ``(S, h, w, 3)``, in one pass over the target's rows
    (``_ibr_fused_kernels.sample_all``). The visibility test follows each source's surface slopes
    (:func:`surface_slopes`' rule, capped at ``slope_cap``; 0: the relative tolerance alone)."""
    h, w = points.shape[:2]
    n = len(sources)
    pixels = np.empty((n, h, w, 2) if store_pixels else (n, 0, 0, 2))
    visible = np.empty((n, h, w), dtype=bool)
    colours = np.empty((n, h, w, 3), dtype=np.float32)
    cams = [s.camera for s in sources]
    _ibr_fused_kernels.sample_all(
        np.ascontiguousarray(points), np.stack([c.K for c in cams]), np.stack([c.R for c in cams]),
        np.stack([c.t for c in cams]), *_source_arrays(sources), tol, slope_cap,
        SLOPE_RATIO, FOV_MARGIN_PX, cubic, pixels, visible, colours)
    return pixels, visible, colours


def sample_sources_staged(
    points: np.ndarray, sources: list[IBRSource], tol: float, slope_cap: float, store_pixels: bool, cubic: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sample_sources` one source at a time, each with its full-frame slope maps
    (:func:`surface_slopes`, ``_ibr_kernels.sample_source``): the slow reference."""
    h, w = points.shape[:2]
    n = len(sources)
    pixels = np.empty((n, h, w, 2) if store_pixels else (n, 0, 0, 2))
    visible = np.empty((n, h, w), dtype=bool)
    colours = np.empty((n, h, w, 3), dtype=np.float32)
    pts = np.ascontiguousarray(points)
    for i, src in enumerate(sources):
        cam = src.camera
        slopes = surface_slopes(src.depth, slope_cap)
        _ibr_kernels.sample_source(pts, np.ascontiguousarray(cam.K), np.ascontiguousarray(cam.R), np.ascontiguousarray(cam.t),
                                   src.image, src.depth, slopes, tol, FOV_MARGIN_PX, cubic, pixels[i], visible[i], colours[i])
    return pixels, visible, colours


@dataclass(frozen=True, slots=True)
class ULRSettings:
    """The validated options of ULR rendering (see ``render_ibr``): visibility test (``tol``,
    ``slope_cap``), sampling (``cubic``), penalties and threshold (``k``, ``alpha``, ``beta``, ``gamma``,
    ``relative``), the field-of-view band as a fraction of a source's smaller side (``band``),
    SIBR's penalty floor (``floor``) and threshold scale (``scale``)."""

    tol: float
    slope_cap: float
    cubic: bool
    k: int
    alpha: float
    beta: float
    gamma: float
    relative: float
    band: float
    floor: float
    scale: float


def ulr_fused(
    points: np.ndarray, rays: np.ndarray, centre: np.ndarray, sources: list[IBRSource], settings: ULRSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ULR rendering in one pass (``_ibr_fused_kernels.ulr_render``): normalised weights ``(S, h, w)``,
    image ``(h, w, 3)`` and coverage ``(h, w)``. ``rays`` ``(0, 0, 3)``: the desired ray is ``p - centre``."""
    h, w = points.shape[:2]
    cams = [s.camera for s in sources]
    sizes = np.array([[c.width, c.height] for c in cams], dtype=np.float64)
    weights = np.empty((len(sources), h, w), dtype=np.float32)
    image = np.empty((h, w, 3), dtype=np.float32)
    coverage = np.empty((h, w), dtype=bool)
    o = settings
    _ibr_fused_kernels.ulr_render(
        np.ascontiguousarray(points), rays, np.ascontiguousarray(centre, dtype=np.float64),
        np.stack([c.K for c in cams]), np.stack([c.R for c in cams]), np.stack([c.t for c in cams]),
        np.array([c.center for c in cams], dtype=np.float64), sizes, o.band * sizes.min(axis=1),
        *_source_arrays(sources), o.tol, o.slope_cap, SLOPE_RATIO,
        FOV_MARGIN_PX, o.cubic, o.k, o.alpha, o.beta, o.gamma, o.relative, o.floor, o.scale, weights, image, coverage)
    return weights, image, coverage


def ulr_staged(
    points: np.ndarray, rays: np.ndarray, centre: np.ndarray, sources: list[IBRSource], settings: ULRSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`ulr_fused` by stages, with full-frame per-source maps (:func:`sample_sources`, then
    ``_ibr_kernels.ulr_weights``, then :func:`blend`): the slow reference of the fused kernel.
    The staged path of ``render_ibr`` before the kernels were fused (issue 31)."""
    o = settings
    pixels, visible, colours = sample_sources_staged(points, sources, o.tol, o.slope_cap, True, o.cubic)
    w = np.empty(visible.shape, dtype=np.float32)
    centres = np.ascontiguousarray([s.camera.center for s in sources], dtype=np.float64)
    sizes = np.array([[s.camera.width, s.camera.height] for s in sources], dtype=np.float64)
    _ibr_kernels.ulr_weights(np.ascontiguousarray(points), rays, np.ascontiguousarray(centre, dtype=np.float64),
                             centres, visible, pixels, sizes, o.k, o.alpha, o.beta, o.gamma, o.band * sizes.min(axis=1),
                             o.relative, o.floor, o.scale, w)
    image, coverage = blend(w, visible, colours)
    return w, image, coverage


def desired_rays(distortion: object, points: np.ndarray, points_t: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Undistorted desired rays ``r = D phi(p)^-1 (p' - c)`` (S0 §6, Fig. 10), NaN where undefined."""
    rays = np.full(points.shape, np.nan)
    ok = np.isfinite(points).all(axis=-1) & np.isfinite(points_t).all(axis=-1)
    if ok.any():
        jac = call_distortion(distortion.jacobian, "jacobian", points[ok], shape=points[ok].shape + (3,))
        with np.errstate(invalid="ignore"):
            good = np.isfinite(jac).all(axis=(-2, -1)) & (np.abs(np.linalg.det(np.nan_to_num(jac))) > 0)
        idx = np.flatnonzero(ok)[good]
        d = (points_t[ok][good] - centre)[..., None]
        rays.reshape(-1, 3)[idx] = np.linalg.solve(jac[good], d)[..., 0]
    return rays


def blend(w: np.ndarray, visible: np.ndarray, colours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalise ``w`` in place over the visible sources and blend: image and coverage."""
    h, wd = visible.shape[1:]
    image = np.empty((h, wd, 3), dtype=np.float32)
    coverage = np.empty((h, wd), dtype=bool)
    _ibr_kernels.normalise_blend(w, visible, colours, image, coverage)
    return image, coverage


def call_distortion(fn: Callable, name: str, points: np.ndarray, *, shape: tuple | None = None) -> np.ndarray:
    """``fn(points)`` as float64, checked to have ``shape`` (default: the points' shape)."""
    out = np.asarray(fn(points), dtype=np.float64)
    want = points.shape if shape is None else shape
    if out.shape != want:
        raise ValueError(f"distortion.{name} must return shape {want} for points of shape {points.shape}; got {out.shape}")
    return out
