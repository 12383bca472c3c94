"""General 3D warping between two pinhole cameras with depth in metres (S1 §IV.A, SPEC §6.1–6.2).

Each source pixel is lifted to 3D with its depth and projected into the target camera,
``Z_t m_t = K_t (R_t X + t_t)`` with ``X = R_s^T (Z_s K_s^{-1} m_s - t_s)`` (the corrected form of
S1 Eq. (5), SPEC §6.1). Visibility is resolved either by a z-buffer (the smaller target depth wins)
or by McMillan's occlusion-compatible order (SPEC §6.2): pixels are painted in an order that makes
nearer surfaces arrive last, so no depth test is needed.

Sampling: where the target magnifies the surface (moving toward it, turning to face it), point
splats leave cracks that grow with the magnification m (a share 1 - 1/m^2 of the pixels: about 30 %
at 1.2x, 75 % at 2x).
By default neighbouring source pixels that are one surface (the gradient rule of SPEC §6.3 in two
dimensions: moving one of them to the other's depth shifts its target position by at most
``gradient_limit`` pixels) are rasterized as triangles, so a surface stays closed at any
magnification; a larger shift is an occlusion boundary and stays a hole (disocclusion).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence._validate import check_finite, check_positive, check_positive_int
from vergence.camera import Camera
from vergence.synthesis import _kernels
from vergence.synthesis.warp import _as_hwc, _check_image, _check_maps, _like

__all__ = ["CameraWarpResult", "WARP_ORDERS", "epipole", "refine_camera_warp", "warp_to_camera"]

WARP_ORDERS = ("mcmillan", "zbuffer")

# |e_w| below this fraction of |e| counts as an epipole at infinity (target beside the source plane).
_EPIPOLE_AT_INFINITY = 1e-12
# A mesh facet whose target bounding box is wider or taller than this (pixels) is not drawn (its
# points are splatted): a source pixel magnified 64 times is far beyond what one image supports,
# and the cap bounds the cost of a facet stretched across the image near the target's centre plane.
_MAX_FACET_PX = 64.0


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class CameraWarpResult:
    """A view warped into another camera.

    Attributes
    ----------
    image : (H_t, W_t) or (H_t, W_t, C) float32
        Warped colours, 0 in holes.
    depth : (H_t, W_t) float32
        Target camera-frame z of the surface seen, metres; NaN in holes.
    holes : (H_t, W_t) bool
        Target pixels no source point reached.
    """

    image: np.ndarray
    depth: np.ndarray
    holes: np.ndarray

    def __post_init__(self) -> None:
        _check_maps("CameraWarpResult", self.image, depth=self.depth, holes=self.holes)


def _check_camera(name: str, cam: object) -> Camera:
    if not isinstance(cam, Camera):
        raise TypeError(f"{name} must be a Camera; got {type(cam).__name__}")
    return cam


def _check_source_image(image: object, source: Camera) -> np.ndarray:
    img = _check_image("image", image)
    if img.shape[:2] != (source.height, source.width):
        raise ValueError(f"image must have shape {(source.height, source.width)} matching the source camera; got {img.shape[:2]}")
    return img


def _check_depth(depth: object, source: Camera) -> np.ndarray:
    z = np.asarray(depth, dtype=np.float64)
    if z.shape != (source.height, source.width):
        raise ValueError(f"depth must have shape {(source.height, source.width)} matching the source camera; got {z.shape}")
    if np.isinf(z).any():
        raise ValueError("depth must not contain inf (use NaN for unknown)")
    known = ~np.isnan(z)
    if not known.any():
        raise ValueError("depth must have at least one known value; got all unknown (NaN)")
    if (z[known] <= 0).any():
        raise ValueError(f"depth must be > 0 metres where known; got min {z[known].min():g}")
    return z


def epipole(source: Camera, target: Camera) -> np.ndarray:
    """The target centre projected into the source image, homogeneous ``(e_x, e_y, e_w)``.

    ``e = K_s (R_s C_t + t_s)``. ``e_w > 0``: the target centre lies in front of the source camera
    (the epipole ``(e_x/e_w, e_y/e_w)`` is a point); ``e_w < 0``: behind it; ``e_w = 0``: at infinity
    in the direction ``(e_x, e_y)`` (a sideways move, as in a rectified pair).

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=3)
    >>> b = look_at([0.1, 0, 0], [0.1, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=3)
    >>> epipole(a, b).round(3).tolist()
    [0.15, 0.0, 0.0]
    """
    _check_camera("source", source)
    _check_camera("target", target)
    return source.K @ (source.R @ target.center + source.t)


def _mcmillan_order(source: Camera, target: Camera) -> np.ndarray:
    """Flat pixel indices in McMillan's occlusion-compatible order (SPEC §6.2)."""
    e = epipole(source, target)
    xs, ys = source.pixel_grid().reshape(-1, 2).T
    if abs(e[2]) <= _EPIPOLE_AT_INFINITY * np.linalg.norm(e):
        # Epipole at infinity in direction (e_x, e_y): travel toward it.
        key = xs * e[0] + ys * e[1]
        return np.argsort(key, kind="stable")
    dist = np.hypot(xs - e[0] / e[2], ys - e[1] / e[2])
    # Positive epipole: toward it (far pixels first); negative: away from it.
    return np.argsort(-dist if e[2] > 0 else dist, kind="stable")


def warp_to_camera(
    image: object,
    depth: object,
    source: Camera,
    target: Camera,
    *,
    order: str = "zbuffer",
    gradient_limit: float | None = 1.0,
) -> CameraWarpResult:
    """Warp a view with metric depth from the ``source`` camera into the ``target`` camera.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        Source view (float in [0, 1], uint8 or uint16), the size of ``source``.
    depth : (H, W) array
        Source camera-frame z in metres, > 0 where known, NaN = unknown.
    source, target : Camera
        The two cameras (``vergence.camera``); the output has the target's size.
    order : {"zbuffer", "mcmillan"}
        Visibility by z-buffer (smaller target depth wins) or by McMillan's occlusion-compatible
        painter's order (no depth test; mesh facets are painted with their top-left pixel).
    gradient_limit : float or None
        Mesh warp (default): two 4-neighbours are one surface when moving one of them to the
        other's depth shifts its target position by at most this many pixels; each source quad
        whose legs are all linked becomes two triangles, rasterized with perspective-correct
        colours, so magnified surfaces have no cracks (facets over 64 pixels across in the target
        are left to point splats). ``None``: nearest-pixel point splats only
        (sampling gaps where the target magnifies the surface stay holes, see
        :func:`refine_camera_warp`).

    Returns
    -------
    CameraWarpResult

    Raises
    ------
    ValueError
        Sizes differ from the source camera, depth <= 0 or inf, all unknown, an unknown order,
        a negative or non-finite gradient limit.

    Notes
    -----
    ``Z_t m_t = Z_s K_t R K_s^{-1} m_s + K_t t`` for the relative pose (R, t) (S1 Eq. (5) with the
    sign of SPEC §6.1). McMillan (SPEC §6.2): with the epipole ``e = K_s (R_s C_t + t_s)``, paint
    toward it when ``e_w > 0`` and away from it when ``e_w < 0``; later writes win. The mesh link
    is the gradient rule of SPEC §6.3 (S1 §IV.B.1) generalised to 3D: on a rectified pair it is
    ``|d_1 - d_0| <= gradient_limit`` exactly, the rule of :func:`~vergence.synthesis.forward_warp`.

    Examples
    --------
    >>> import numpy as np
    >>> from vergence.camera import look_at
    >>> a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=4, height=1)
    >>> b = look_at([1, 0, 0], [1, 0, 1], [0, -1, 0], fov_deg=90, width=4, height=1)
    >>> res = warp_to_camera(np.arange(4, dtype=np.float32)[None] / 4, np.full((1, 4), 2.0), a, b)
    >>> res.image.tolist(), res.holes.tolist()
    ([[0.25, 0.5, 0.75, 0.0]], [[False, False, False, True]])
    """
    source = _check_camera("source", source)
    target = _check_camera("target", target)
    img = _check_source_image(image, source)
    z = _check_depth(depth, source)
    if order not in WARP_ORDERS:
        raise ValueError(f"order must be one of {', '.join(WARP_ORDERS)}; got {order!r}")
    limit = None
    if gradient_limit is not None:
        limit = check_finite("gradient_limit", gradient_limit)
        if limit < 0:
            raise ValueError(f"gradient_limit must be >= 0 or None; got {limit:g}")
    # S1 Eq. (5) with the sign of SPEC §6.1: X from the source pixel and depth, then Z_t m_t = K_t (R_t X + t_t).
    points = source.backproject_depth(z).reshape(-1, 3)
    pix, zt = target.project(np.nan_to_num(points, nan=0.0))
    zt = np.where(np.isnan(points[:, 0]), np.nan, zt)
    u = np.ascontiguousarray(pix[:, 0])
    v = np.ascontiguousarray(pix[:, 1])
    zt = np.ascontiguousarray(zt)
    colours = np.ascontiguousarray(_as_hwc(img).reshape(-1, img.shape[2] if img.ndim == 3 else 1))
    out = np.zeros((target.height, target.width, colours.shape[1]), dtype=np.float32)
    zbuf = np.full((target.height, target.width), np.inf)
    painted = np.zeros((target.height, target.width), dtype=bool)
    if limit is not None:
        link_r, link_d = _mesh_links(z, u, v, zt, source, target, limit)
        ordering = np.arange(u.size, dtype=np.int64) if order == "zbuffer" else _mcmillan_order(source, target).astype(np.int64)
        _kernels.splat_mesh(ordering, u, v, zt, link_r, link_d, colours, _MAX_FACET_PX, order == "zbuffer", out, zbuf, painted)
    elif order == "zbuffer":
        _kernels.splat_zbuffer(u, v, zt, colours, out, zbuf, painted)
    else:
        _kernels.splat_ordered(_mcmillan_order(source, target).astype(np.int64), u, v, zt, colours, out, zbuf, painted)
    depth_t = np.where(painted, zbuf, np.nan).astype(np.float32)
    return CameraWarpResult(image=_like(out, img), depth=depth_t, holes=~painted)


def _mesh_links(
    z: np.ndarray, u: np.ndarray, v: np.ndarray, zt: np.ndarray, source: Camera, target: Camera, limit: float
) -> tuple[np.ndarray, np.ndarray]:
    """Right and lower neighbour links of the mesh warp: both points drawable (in front of the
    target) and the neighbour, lifted with this pixel's depth, lands within ``limit`` pixels of
    where it lands with its own (the 2-D gradient rule, SPEC §6.3)."""
    r_rel = target.R @ source.R.T
    A = target.K @ r_rel @ np.linalg.inv(source.K)  # Z_t m_t = Z_s A m_s + c (S1 Eq. 5, SPEC §6.1)
    c = target.K @ (target.t - r_rel @ source.t)
    link_r = np.empty(z.shape, dtype=bool)
    link_d = np.empty(z.shape, dtype=bool)
    _kernels.mesh_links(np.ascontiguousarray(z), u, v, zt, np.ascontiguousarray(A), np.ascontiguousarray(c), float(limit), link_r, link_d)
    return link_r, link_d


def refine_camera_warp(
    warped: CameraWarpResult,
    image: object,
    depth: object,
    source: Camera,
    target: Camera,
    *,
    consistency: float = 0.01,
    iterations: int = 3,
) -> CameraWarpResult:
    """Close the sampling gaps of a 3D warp: median target depth, then inverse warping (Do et al.).

    Each hole whose 3x3 neighbourhood holds at least 5 known target depths takes their median
    depth; the pixel is lifted to 3D with it, projected into the source, and its colour sampled
    there (nearest pixel) when the source depth at that pixel agrees within ``consistency`` (a
    relative tolerance on depth); otherwise it stays a hole (a true disocclusion). The pass repeats
    (crossing cracks need their neighbours first) until nothing changes or ``iterations`` passes.

    Parameters
    ----------
    warped : CameraWarpResult
        Output of :func:`warp_to_camera` for the same image, depth and cameras.
    image, depth, source, target
        As in :func:`warp_to_camera`.
    consistency : float
        Relative depth agreement, > 0 (0.01 = 1 %).
    iterations : int
        Most passes, >= 1.

    Returns
    -------
    CameraWarpResult

    Notes
    -----
    S1 §IV.B.1: median filtering of the warped depth, then inverse warping of the changed pixels.
    """
    if not isinstance(warped, CameraWarpResult):
        raise TypeError(f"warped must be a CameraWarpResult; got {type(warped).__name__}")
    source = _check_camera("source", source)
    target = _check_camera("target", target)
    img = _check_source_image(image, source)
    z = _check_depth(depth, source)
    tol = check_positive("consistency", consistency)
    n = check_positive_int("iterations", iterations)
    src = _as_hwc(img)
    for _ in range(n):
        refined = _refine_pass(warped, src, z, source, target, tol, img)
        if refined is warped:
            break
        warped = refined
    return warped


def _refine_pass(
    warped: CameraWarpResult,
    src: np.ndarray,
    z: np.ndarray,
    source: Camera,
    target: Camera,
    tol: float,
    template: np.ndarray,
) -> CameraWarpResult:
    """One median + inverse-warp pass of :func:`refine_camera_warp`; ``warped`` itself if nothing changed."""
    med = np.empty(warped.depth.shape, dtype=np.float32)
    fill = np.empty(warped.depth.shape, dtype=bool)  # holes with a median
    _kernels.median3_changes(
        np.ascontiguousarray(warped.depth, dtype=np.float32), np.ascontiguousarray(warped.holes), np.inf, 5, med, fill
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
    image_t = _as_hwc(warped.image).copy()
    image_t[ys[ok], xs[ok]] = src[vs[ok], us[ok]]
    depth_t = warped.depth.copy()
    depth_t[ys[ok], xs[ok]] = med[ys[ok], xs[ok]]
    holes = warped.holes.copy()
    holes[ys[ok], xs[ok]] = False
    return CameraWarpResult(image=_like(image_t, template), depth=depth_t, holes=holes)
