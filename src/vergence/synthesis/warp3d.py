"""General 3D warping between two pinhole cameras with depth in metres (S1 Sec. IV.A; McMillan 1997).

Each source pixel is lifted to 3D with its depth and projected into the target camera,
``Z_t m_t = K_t (R_t X + t_t)`` with ``X = R_s^T (Z_s K_s^{-1} m_s - t_s)`` (the corrected form of
S1 Eq. (5) with the sign of the translation corrected). Visibility is resolved either by a z-buffer (the smaller target depth wins)
or by McMillan's occlusion-compatible order (McMillan 1997): pixels are painted in an order that makes
nearer surfaces arrive last, so no depth test is needed.

Sampling: where the target magnifies the surface (moving toward it, turning to face it), point
splats leave cracks that grow with the magnification m (a share 1 - 1/m^2 of the pixels: about 30 %
at 1.2x, 75 % at 2x).
By default neighbouring source pixels that are one surface (the gradient rule of S1 Sec. IV.B.1 in two
dimensions: moving one of them to the other's depth shifts its target position by at most
``gradient_limit`` pixels) are rasterized as triangles, so a surface stays closed at any
magnification; a larger shift is an occlusion boundary and stays a hole (disocclusion).
"""

from __future__ import annotations

import numpy as np

from vergence._validate import check_finite, check_positive, check_positive_int
from vergence.camera import Camera
from vergence.synthesis import _stages3d
from vergence.synthesis._checks import check_camera, check_depth, check_source_image, within_float32
from vergence.synthesis.view import WarpedView

__all__ = ["WARP_ORDERS", "epipole", "refine_camera_warp", "warp_to_camera"]

WARP_ORDERS = ("mcmillan", "zbuffer")
# Two camera centres closer than this, relative to their distance from the origin (at least 1 m),
# are one centre: float64 round-off of a camera pose stays below 1e-12.
_SAME_CENTRE_RTOL = 1e-12


def epipole(source: Camera, target: Camera) -> np.ndarray:
    """The target centre projected into the source image, homogeneous ``(e_x, e_y, e_w)``.

    ``e = K_s (R_s C_t + t_s)``. ``e_w > 0``: the target centre lies in front of the source camera
    (the epipole ``(e_x/e_w, e_y/e_w)`` is a point); ``e_w < 0``: behind it; ``e_w = 0``: at infinity
    in the direction ``(e_x, e_y)`` (a sideways move, as in a rectified pair).

    Raises
    ------
    TypeError
        If a camera is not a :class:`~vergence.camera.Camera`.
    ValueError
        If the two centres coincide (a pure rotation): every ray through the source centre is then
        an epipolar line and ``e`` is the zero vector, no point.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=3)
    >>> b = look_at([0.1, 0, 0], [0.1, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=3)
    >>> epipole(a, b).round(3).tolist()
    [0.15, 0.0, 0.0]
    """
    check_camera("source", source)
    check_camera("target", target)
    baseline = float(np.linalg.norm(target.center - source.center))
    if baseline <= _SAME_CENTRE_RTOL * max(1.0, float(np.linalg.norm(source.center))):
        raise ValueError(f"target must not share the source's centre {source.center.tolist()}: the epipole of a pure rotation is undefined")
    return _stages3d.epipole(source, target)


def warp_to_camera(
    image: object,
    depth: object,
    source: Camera,
    target: Camera,
    *,
    order: str = "zbuffer",
    gradient_limit: float | None = 1.0,
) -> WarpedView:
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
    WarpedView
        ``depth``: target camera-frame z in metres (NaN in holes); ``nearness``: ``1 / depth``
        (unit ``"1/m"``).

    Raises
    ------
    ValueError
        Sizes differ from the source camera, depth <= 0 or inf, all unknown, an unknown order,
        a negative or non-finite gradient limit.

    Notes
    -----
    ``Z_t m_t = Z_s K_t R K_s^{-1} m_s + K_t t`` for the relative pose (R, t) (S1 Eq. (5) with the
    translation's sign corrected: ``+ K_t t``, not ``+ K_t C``). McMillan 1997: with the epipole ``e = K_s (R_s C_t + t_s)``, paint
    toward it when ``e_w > 0`` and away from it when ``e_w < 0``; later writes win. The mesh link
    is the gradient rule of S1 Sec. IV.B.1 generalised to 3D: on a rectified pair it is
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
    source = check_camera("source", source)
    target = check_camera("target", target)
    img = check_source_image(image, source)
    z = check_depth(depth, source)
    if order not in WARP_ORDERS:
        raise ValueError(f"order must be one of {', '.join(WARP_ORDERS)}; got {order!r}")
    limit = None
    if gradient_limit is not None:
        limit = check_finite("gradient_limit", gradient_limit)
        if limit < 0:
            raise ValueError(f"gradient_limit must be >= 0 or None; got {limit:g}")
    return _stages3d.warp_to_camera(img, z, source, target, order, limit)


def refine_camera_warp(
    warped: WarpedView,
    image: object,
    depth: object,
    source: Camera,
    target: Camera,
    *,
    consistency: float = _stages3d.REFINE_CONSISTENCY,
    iterations: int = _stages3d.REFINE_ITERATIONS,
) -> WarpedView:
    """Close the sampling gaps of a 3D warp: median target depth, then inverse warping (Do et al.).

    Each hole whose 3x3 neighbourhood holds at least 5 known target depths takes their median
    depth; the pixel is lifted to 3D with it, projected into the source, and its colour sampled
    there (nearest pixel) when the source depth at that pixel agrees within ``consistency`` (a
    relative tolerance on depth); otherwise it stays a hole (a true disocclusion). The pass repeats
    (crossing cracks need their neighbours first) until nothing changes or ``iterations`` passes.

    Parameters
    ----------
    warped : WarpedView
        Output of :func:`warp_to_camera` for the same image, depth and cameras.
    image, depth, source, target
        As in :func:`warp_to_camera`.
    consistency : float
        Relative depth agreement, > 0 (0.01 = 1 %).
    iterations : int
        Most passes, >= 1.

    Returns
    -------
    WarpedView

    Notes
    -----
    S1 §IV.B.1: median filtering of the warped depth, then inverse warping of the changed pixels.
    """
    if not isinstance(warped, WarpedView):
        raise TypeError(f"warped must be a WarpedView; got {type(warped).__name__}")
    if warped.depth is None:
        raise ValueError("warped must carry metric depth (the output of warp_to_camera); got depth None")
    source = check_camera("source", source)
    target = check_camera("target", target)
    img = check_source_image(image, source)
    z = check_depth(depth, source)
    if warped.image.shape[:2] != (target.height, target.width) or warped.image.shape[2:] != img.shape[2:]:
        raise ValueError(
            f"warped.image must have shape {(target.height, target.width) + img.shape[2:]} (target size, image channels); got {warped.image.shape}"
        )
    tol = within_float32("consistency", check_positive("consistency", consistency))
    n = check_positive_int("iterations", iterations)
    return _stages3d.refine_camera_warp(warped, img, z, source, target, tol, n)
