"""The unchecked stages of the general 3D warp between two pinhole cameras (validated inputs only).

Public entries: :func:`vergence.synthesis.warp_to_camera` and
:func:`vergence.synthesis.refine_camera_warp`; the 3D path of
:func:`vergence.synthesis.synthesize_view` composes the same stages.
"""

from __future__ import annotations

import numpy as np

from vergence.camera import Camera
from vergence.synthesis import _kernels
from vergence.synthesis._stages import as_hwc, like
from vergence.synthesis.view import WarpedView

# |e_w| below this fraction of |e| counts as an epipole at infinity (target beside the source plane).
EPIPOLE_AT_INFINITY = 1e-12
# A mesh facet whose target bounding box is wider or taller than this (pixels) is not drawn (its
# points are splatted): a source pixel magnified 64 times is far beyond what one image supports,
# and the cap bounds the cost of a facet stretched across the image near the target's centre plane.
MAX_FACET_PX = 64.0
# Median refinement of a 3D warp: a hole needs this many known target depths among its 3 x 3; the
# source depth must agree with the median's within this relative tolerance; at most this many passes
# (the defaults of refine_camera_warp and the 3D path of synthesize_view).
MEDIAN_MIN_KNOWN = 5
REFINE_CONSISTENCY = 0.01
REFINE_ITERATIONS = 3


def epipole(source: Camera, target: Camera) -> np.ndarray:
    """``e = K_s (R_s C_t + t_s)``, homogeneous."""
    return source.K @ (source.R @ target.center + source.t)


def mcmillan_order(source: Camera, target: Camera) -> np.ndarray:
    """Flat pixel indices in McMillan's occlusion-compatible order (McMillan 1997)."""
    e = epipole(source, target)
    xs, ys = source.pixel_grid().reshape(-1, 2).T
    if abs(e[2]) <= EPIPOLE_AT_INFINITY * np.linalg.norm(e):
        # Epipole at infinity in direction (e_x, e_y): travel toward it.
        key = xs * e[0] + ys * e[1]
        return np.argsort(key, kind="stable")
    dist = np.hypot(xs - e[0] / e[2], ys - e[1] / e[2])
    # Positive epipole: toward it (far pixels first); negative: away from it.
    return np.argsort(-dist if e[2] > 0 else dist, kind="stable")


def mesh_links(
    z: np.ndarray, u: np.ndarray, v: np.ndarray, zt: np.ndarray, source: Camera, target: Camera, limit: float
) -> tuple[np.ndarray, np.ndarray]:
    """Right and lower neighbour links of the mesh warp: both points drawable (in front of the
    target) and the neighbour, lifted with this pixel's depth, lands within ``limit`` pixels of
    where it lands with its own (the 2-D gradient rule of S1 Sec. IV.B.1)."""
    r_rel = target.R @ source.R.T
    A = target.K @ r_rel @ np.linalg.inv(source.K)  # Z_t m_t = Z_s A m_s + c (S1 Eq. 5)
    c = target.K @ (target.t - r_rel @ source.t)
    link_r = np.empty(z.shape, dtype=bool)
    link_d = np.empty(z.shape, dtype=bool)
    _kernels.mesh_links(np.ascontiguousarray(z), u, v, zt, np.ascontiguousarray(A), np.ascontiguousarray(c), float(limit), link_r, link_d)
    return link_r, link_d


def warp_to_camera(
    img: np.ndarray, z: np.ndarray, source: Camera, target: Camera, order: str, limit: float | None
) -> WarpedView:
    """3D warp of a validated image with metric depth ``z`` (float64) from ``source`` to ``target``."""
    # S1 Eq. (5), corrected sign: X from the source pixel and depth, then Z_t m_t = K_t (R_t X + t_t).
    points = source.backproject_depth(z).reshape(-1, 3)
    pix, zt = target.project(np.nan_to_num(points, nan=0.0))
    zt = np.where(np.isnan(points[:, 0]), np.nan, zt)
    u = np.ascontiguousarray(pix[:, 0])
    v = np.ascontiguousarray(pix[:, 1])
    zt = np.ascontiguousarray(zt)
    colours = np.ascontiguousarray(as_hwc(img).reshape(-1, img.shape[2] if img.ndim == 3 else 1))
    out = np.zeros((target.height, target.width, colours.shape[1]), dtype=np.float32)
    zbuf = np.full((target.height, target.width), np.inf)
    painted = np.zeros((target.height, target.width), dtype=bool)
    if limit is not None:
        link_r, link_d = mesh_links(z, u, v, zt, source, target, limit)
        ordering = np.arange(u.size, dtype=np.int64) if order == "zbuffer" else mcmillan_order(source, target).astype(np.int64)
        _kernels.splat_mesh(ordering, u, v, zt, link_r, link_d, colours, MAX_FACET_PX, order == "zbuffer", out, zbuf, painted)
    elif order == "zbuffer":
        _kernels.splat_zbuffer(u, v, zt, colours, out, zbuf, painted)
    else:
        _kernels.splat_ordered(mcmillan_order(source, target).astype(np.int64), u, v, zt, colours, out, zbuf, painted)
    depth_t = np.where(painted, zbuf, np.nan).astype(np.float32)
    return _metric_view(like(out, img), depth_t, ~painted)


def _metric_view(image: np.ndarray, depth: np.ndarray, holes: np.ndarray) -> WarpedView:
    with np.errstate(divide="ignore"):
        nearness = (1.0 / depth).astype(np.float32)
    return WarpedView(image=image, holes=holes, nearness=nearness, nearness_unit="1/m", depth=depth)


def refine_camera_warp(
    warped: WarpedView, img: np.ndarray, z: np.ndarray, source: Camera, target: Camera, tol: float, iterations: int
) -> WarpedView:
    """Up to ``iterations`` passes of median target depth + inverse warping (Do et al.)."""
    src = as_hwc(img)
    for _ in range(iterations):
        refined = _refine_pass(warped, src, z, source, target, tol, img)
        if refined is warped:
            break
        warped = refined
    return warped


def _refine_pass(
    warped: WarpedView,
    src: np.ndarray,
    z: np.ndarray,
    source: Camera,
    target: Camera,
    tol: float,
    template: np.ndarray,
) -> WarpedView:
    """One median + inverse-warp pass; ``warped`` itself if nothing changed."""
    med = np.empty(warped.depth.shape, dtype=np.float32)
    fill = np.empty(warped.depth.shape, dtype=bool)  # holes with a median
    _kernels.median3_changes(
        np.ascontiguousarray(warped.depth, dtype=np.float32), np.ascontiguousarray(warped.holes), np.inf, MEDIAN_MIN_KNOWN, med, fill
    )
    ys, xs = np.nonzero(fill)
    if ys.size == 0:
        return warped
    pts = target.backproject(np.stack([xs, ys], axis=-1).astype(np.float64), med[ys, xs].astype(np.float64))
    pix, zs = source.project(pts)
    ok = np.isfinite(pix).all(axis=1)
    us = np.rint(np.nan_to_num(pix[:, 0], nan=-1.0)).astype(np.intp)
    vs = np.rint(np.nan_to_num(pix[:, 1], nan=-1.0)).astype(np.intp)
    ok &= (us >= 0) & (us < source.width) & (vs >= 0) & (vs < source.height)
    us, vs = np.where(ok, us, 0), np.where(ok, vs, 0)
    with np.errstate(invalid="ignore"):
        ok &= np.abs(z[vs, us] - zs) <= tol * zs
    if not ok.any():
        return warped
    image_t = as_hwc(warped.image).copy()
    image_t[ys[ok], xs[ok]] = src[vs[ok], us[ok]]
    depth_t = warped.depth.copy()
    depth_t[ys[ok], xs[ok]] = med[ys[ok], xs[ok]]
    holes = warped.holes.copy()
    holes[ys[ok], xs[ok]] = False
    return _metric_view(like(image_t, template), depth_t, holes)
