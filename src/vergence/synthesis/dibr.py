"""Depth-image-based rendering pipelines (S1 §IV): colour + depth in, the views a display needs out.

- :func:`interpolate_view`: a view between two rectified references with their disparities
  (view interpolation, S1 §II.C and §IV.B).
- :func:`synthesize_views` / :func:`synthesize_stereo`: 2D + depth to a stereo pair or N views,
  the parallax chosen by the depth controls of S1 §IV.C (``controls.py``).
- :func:`synthesize_view`: one image with metric depth from one camera to another
  (``vergence.camera``), the rectified fast path when the two cameras form a rectified pair.

Each pipeline validates its arguments once, then composes the same unchecked stages the
primitives call (``_stages``, ``_stages3d``), in this order (S1 §IV.B): unknown reference depth filled from
the background side, contour handling (the near side of depth edges, jumps above the gradient
limit, grown by ``edge_dilation`` pixels), forward warp with the gap/hole rule, median refinement
with inverse warping (view interpolation and camera-to-camera rendering, where depth comes from a
measurement), depth-tested blending weighted by distance (two references), and
background-directed hole filling steered by the original, undilated disparity (see
``_stages.fill_guide``; it travels through the blending as the ``"fill_guide"`` payload of each
:class:`~vergence.synthesis.WarpedView`, the contour reliability as its ``reliability``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vergence._validate import check_bool, check_finite, check_in_range, check_positive
from vergence.camera import Camera
from vergence.synthesis import _stages, _stages3d
from vergence.synthesis._checks import (
    FLOAT32_MAX,
    check_camera,
    check_depth,
    check_image,
    check_map,
    check_method,
    check_nonnegative,
    check_radius,
    check_sigma,
    check_source_image,
    within_float32,
)
from vergence.synthesis.advice import holes_warnings, stereo_warnings
from vergence.synthesis.blend import baseline_weights
from vergence.synthesis.controls import MAX_PARALLAX_WIDTHS, ParallaxPlan, plan_parallax, views_offsets
from vergence.synthesis.view import WarpedView
from vergence.viewing.geometry import Display
from vergence.viewing.mapping import DisparityMapping

__all__ = [
    "MAX_SYNTHESIS_BYTES",
    "StereoResult",
    "interpolate_view",
    "synthesize_stereo",
    "synthesize_view",
    "synthesize_views",
]

# Most memory synthesize_stereo's results may take (the views as float32 and their hole masks),
# checked before any work: 4 GiB holds 128 views of a 1080p RGB image (3.5 GB), while 128 views of
# the largest image read_image decodes (80 Mpx) would need 120 GB.
MAX_SYNTHESIS_BYTES = 4 * 2**30
# Median refinement: a warped disparity that differs from its 3x3 median by more than this (pixels)
# is re-sampled by inverse warping, if the reference agrees within the consistency tolerance.
_MEDIAN_TOLERANCE_PX = 0.5
_MEDIAN_CONSISTENCY_PX = 1.0
# Rectified-pair detection for synthesize_view: rotations, intrinsics (except cx) and the off-axis
# part of the baseline must agree to this relative precision.
_RECTIFIED_RTOL = 1e-9
# blend's metric depth test is not used on the rectified path (no metric depth there).
_UNUSED_RTOL = 0.0


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class StereoResult:
    """Views rendered from 2D + depth.

    Attributes
    ----------
    views : tuple of (H, W) or (H, W, C) float32
        Left to right; ``views[0]`` and ``views[-1]`` are the outer eyes (the stereo pair for two).
    holes : tuple of (H, W) bool
        The disoccluded pixels each view had filled.
    offsets : tuple of float
        Position of each view in units of the pair parallax (adjacent views differ by 1).
    plan : ParallaxPlan
        The parallax map, psi and the parallax range between adjacent views in pixels and arcmin.
    warnings : tuple of str
        What may not look right (:func:`~vergence.synthesis.stereo_warnings`,
        :func:`~vergence.synthesis.holes_warnings`), one line each; empty when all is well.
    """

    views: tuple[np.ndarray, ...]
    holes: tuple[np.ndarray, ...]
    offsets: tuple[float, ...]
    plan: ParallaxPlan
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not len(self.views) == len(self.holes) == len(self.offsets):
            raise ValueError(
                f"views, holes and offsets must have one length; got {len(self.views)}, {len(self.holes)}, {len(self.offsets)}"
            )
        if not isinstance(self.warnings, tuple) or not all(isinstance(w, str) for w in self.warnings):
            raise TypeError(f"warnings must be a tuple of str; got {self.warnings!r}")

    def to_dict(self) -> dict:
        """JSON-ready summary: view offsets, size, parallax range between adjacent views (pixels,
        arcmin when a display was given; ``x_r - x_l``, positive behind the screen), the share of
        each view that hole filling made up (percent, 4 decimals) and the warnings."""
        h, w = self.views[0].shape[:2]
        return {
            "offsets": list(self.offsets),
            "size": [int(w), int(h)],
            "parallax_range_px": list(self.plan.range_px),
            "parallax_range_arcmin": None if self.plan.range_arcmin is None else list(self.plan.range_arcmin),
            "holes_percent": [round(100.0 * float(m.mean()), 4) for m in self.holes],
            "warnings": list(self.warnings),
        }

    @property
    def left(self) -> np.ndarray:
        """The leftmost view."""
        return self.views[0]

    @property
    def right(self) -> np.ndarray:
        """The rightmost view."""
        return self.views[-1]


def _check_options(gradient_limit: float, edge_dilation: int, fill: str) -> tuple[float, int]:
    limit = check_nonnegative("gradient_limit", gradient_limit)
    r = check_radius("edge_dilation", edge_dilation)
    check_method("fill", fill, _stages.FILL_METHODS)
    return limit, r


def _check_fits(name: str, d: np.ndarray) -> None:
    """Refuse a disparity map with a value of ``MAX_PARALLAX_WIDTHS`` image widths or more."""
    limit = MAX_PARALLAX_WIDTHS * d.shape[1]
    widest = float(np.nanmax(np.abs(d)))
    if widest >= limit:
        raise ValueError(
            f"{name} must lie within +-{limit:g} px, {MAX_PARALLAX_WIDTHS:g} image width (MAX_PARALLAX_WIDTHS): "
            f"a point cannot be seen by both references that far apart; got |d| up to {widest:g} "
            "(a disparity file's scale?)"
        )


def _warp_reference(
    img_hwc: np.ndarray, d: np.ndarray, scale: float, limit: float, median: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward warp (and median refinement): ``(H, W, C)`` image, warped disparity, holes."""
    out, zbuf, holes = _stages.forward_warp(img_hwc, d, scale, limit)
    if median and scale != 0.0:
        out, zbuf, holes = _stages.median_refine(
            img_hwc, d, out, zbuf, holes, scale, _MEDIAN_TOLERANCE_PX, _MEDIAN_CONSISTENCY_PX
        )
    return out, zbuf, holes


def _fill(image_hwc: np.ndarray, guide: np.ndarray, holes: np.ndarray, fill: str) -> tuple[np.ndarray, np.ndarray]:
    """Fill holes in place on arrays this module owns (the values in the holes are ignored)."""
    return _stages.fill_holes(_stages.as_hwc(image_hwc), np.ascontiguousarray(guide, dtype=np.float32), holes, fill)


def interpolate_view(
    left: object,
    left_disparity: object,
    right: object,
    right_disparity: object,
    position: float,
    *,
    gradient_limit: float = 1.0,
    edge_dilation: int = 1,
    median: bool = True,
    contour_width: int = 0,
    depth_tolerance: float = 1.0,
    fill: str = "background",
) -> WarpedView:
    """The view at ``position`` between two rectified references on one horizontal line.

    A pixel at x in ``left`` with disparity d appears at ``x - T d`` in the target; a pixel at x in
    ``right`` with disparity d at ``x + (1 - T) d`` (T = ``position``).

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) arrays
        The references (float in [0, 1], uint8 or uint16), one shape.
    left_disparity, right_disparity : (H, W) arrays
        Pixels on the left-right baseline, positive in front; NaN = unknown (filled from the
        background side before warping).
    position : float
        T in [0, 1]: 0 is the left view, 1 the right one.
    gradient_limit : float
        Gap/hole rule of :func:`~vergence.synthesis.forward_warp`, target pixels.
    edge_dilation : int
        Contour handling: pixels to grow the near side of depth edges (jumps above
        ``gradient_limit`` in the reference disparity; 0 = off), see
        :func:`~vergence.synthesis.dilate_foreground`.
    median : bool
        Median refinement with inverse warping of each warped reference.
    contour_width : int
        Reliability-based contour removal (Müller et al., S1 §IV.B.3): source pixels within this
        many pixels of the far side of a depth edge are unreliable and replaced by the other
        reference where it sees the same surface reliably (0 = off; on Dolls it adds nothing once
        ``edge_dilation`` is on, see ``benchmarks/dolls.py``).
    depth_tolerance : float
        Depth test of the blending, pixels of disparity.
    fill : {"background", "mirror", "inpaint"}
        Hole filling of what neither reference sees.

    Returns
    -------
    WarpedView
        The view (holes filled), ``holes`` (the pixels neither reference saw), ``nearness`` (unit
        ``"px"``): the disparity on the left-right baseline of the surface seen, holes filled from
        the background (NaN only where a whole row had nothing to fill from); ``depth`` None;
        ``reliability`` with ``contour_width`` > 0 (True where a reliable source pixel was used).

    Raises
    ------
    ValueError
        Shapes differ, disparity with inf or all unknown, position outside [0, 1], bad options, or
        a disparity of ``MAX_PARALLAX_WIDTHS`` image widths or more (no point can be seen by both
        references that far apart: the view would be all holes).
    TypeError
        ``median`` is not a bool (a string such as ``"no"`` would be true).

    Notes
    -----
    S1 §IV.A–B: rectified warping (Eq. 7), sampling gaps vs holes, median + inverse warping, contour
    artifacts, blending with weights ``w_L = 1 - T``, ``w_R = T`` (S1 Sec. IV.B.2) and the nearer surface
    winning, background-only hole filling. At T = 0 the result is ``left`` wherever its disparity
    is known (the right reference only fills the rest), at T = 1 likewise ``right``.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.tile(np.linspace(0, 1, 6, dtype=np.float32), (2, 1))
    >>> d = np.full((2, 6), 2.0)
    >>> res = interpolate_view(img, d, img, d, 0.0)
    >>> bool(np.array_equal(res.image, img))
    True
    """
    lft = check_image("left", left)
    rgt = check_image("right", right)
    if rgt.shape != lft.shape:
        raise ValueError(f"right must have shape {lft.shape} like left; got {rgt.shape}")
    dl = check_map("left_disparity", left_disparity, "left", lft)
    dr = check_map("right_disparity", right_disparity, "right", rgt)
    for name, d in (("left_disparity", dl), ("right_disparity", dr)):
        _check_fits(name, d)
    t = check_in_range("position", position, 0.0, 1.0)
    limit, radius = _check_options(gradient_limit, edge_dilation, fill)
    tol = within_float32("depth_tolerance", check_positive("depth_tolerance", depth_tolerance))
    contour = check_radius("contour_width", contour_width)
    refine = check_bool("median", median)
    nc = lft.shape[2] if lft.ndim == 3 else 1
    views = []
    for img, d, scale in ((lft, dl, t), (rgt, dr, -(1.0 - t))):
        prepared, original = _stages.prepare_disparity(d, radius, limit)
        hwc = _stages.as_hwc(img)
        if contour:
            # The kernel warps the unreliable band as one more channel (1 = unreliable), split off
            # right after the warp (see _stages.reliable_from_warped).
            band = _stages.contour_mask(prepared, contour, limit, "far")
            hwc = np.concatenate([hwc, band[:, :, None].astype(np.float32)], axis=2)
        image, near, holes = _warp_reference(hwc, prepared, scale, limit, refine)
        reliability = _stages.reliable_from_warped(image[:, :, nc], holes) if contour else None
        payload = {}
        if radius:  # 0, not NaN, where unknown: the guide is blended like the colours
            payload["fill_guide"] = np.nan_to_num(_stages.fill_guide(near, prepared, original, scale, limit), nan=0.0)
        views.append(
            WarpedView(image=image[:, :, :nc], holes=holes, nearness=near, reliability=reliability, payload=payload)
        )
    weights = baseline_weights([0.0, 1.0], t)
    w = np.broadcast_to(weights[:, None, None], (2, *lft.shape[:2]))
    blended = _stages.blend(views, w, tol, _UNUSED_RTOL)
    disparity = _stages.fill_disparity(blended.nearness)  # NaN in the holes: the background rule of the fill
    guide = blended.payload["fill_guide"] if radius else blended.nearness
    image, _ = _fill(blended.image, guide, blended.holes, fill)
    return WarpedView(
        image=_stages.like(image, lft), holes=blended.holes, nearness=disparity, reliability=blended.reliability
    )


def synthesize_views(
    image: object,
    parallax_px: object,
    *,
    offsets: tuple[float, ...] = (-0.5, 0.5),
    gradient_limit: float = 1.0,
    edge_dilation: int = 1,
    fill: str = "background",
) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
    """Render views of a 2D + parallax image: view k sees pixel x at ``x + offsets[k] P(x)``.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        The original view (float in [0, 1], uint8 or uint16).
    parallax_px : (H, W) array
        Screen parallax ``P = x_r - x_l`` between adjacent views, pixels, positive behind the screen;
        NaN = unknown (filled from the background side).
    offsets : tuple of float
        View positions in units of P: ``(-0.5, 0.5)`` is a stereo pair around the original,
        ``(0, 1)`` keeps the original as the left view.
    gradient_limit, edge_dilation, fill
        As in :func:`interpolate_view`.

    Returns
    -------
    views : tuple of float32 images
    holes : tuple of (H, W) bool
        The disoccluded pixels of each view (filled in ``views``).

    Notes
    -----
    Shift-sensor DIBR (Fehn 2004): ``x_l = x_c - P/2``, ``x_r = x_c + P/2``. With
    ``d = -P`` this is :func:`~vergence.synthesis.forward_warp` with ``scale = offset``.
    """
    img = check_image("image", image)
    p = check_map("parallax_px", parallax_px, "image", img)
    if len(offsets) == 0:
        raise ValueError("offsets must hold at least one view position; got none")
    offs = tuple(check_finite(f"offsets[{k}]", o) for k, o in enumerate(offsets))
    limit, radius = _check_options(gradient_limit, edge_dilation, fill)
    return _render(_stages.as_hwc(img), -p, offs, limit, radius, fill, img)


def _render(
    img_hwc: np.ndarray,
    d: np.ndarray,
    offsets: tuple[float, ...],
    limit: float,
    radius: int,
    fill: str,
    template: np.ndarray,
) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
    prepared, original = _stages.prepare_disparity(d, radius, limit)
    views, holes = [], []
    for o in offsets:
        out, zbuf, hole = _stages.forward_warp(img_hwc, prepared, o, limit)
        filled, _ = _fill(out, _stages.fill_guide(zbuf, prepared, original, o, limit), hole, fill)
        views.append(_stages.like(filled, template))
        holes.append(hole)
    return tuple(views), tuple(holes)


def synthesize_stereo(
    image: object,
    depth: object,
    *,
    kind: str = "metric",
    display: Display | None = None,
    budget_arcmin: float | None = None,
    budget_px: float | None = None,
    convergence: float | None = None,
    focal_px: float | None = None,
    interaxial: float | None = None,
    mapping: DisparityMapping | None = None,
    views: int = 2,
    origin: str = "center",
    smooth_sigma: float | None = None,
    gradient_limit: float = 1.0,
    edge_dilation: int = 1,
    fill: str = "background",
) -> StereoResult:
    """2D + depth to a stereo pair (or N views): one call from a depth map to the display's views.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        The original view (float in [0, 1], uint8 or uint16).
    depth : (H, W) array
        Depth of ``kind`` (see :func:`~vergence.synthesis.nearness_from_depth`), NaN = unknown.
    kind, display, budget_arcmin, budget_px, convergence, focal_px, interaxial, mapping
        The depth control, see :func:`~vergence.synthesis.plan_parallax` (exactly one of a budget,
        the shift-sensor focal length + interaxial, or a mapping).
    views : int
        Number of views, >= 2; adjacent views are a stereo pair with the planned parallax.
    origin : {"center", "left"}
        The original image is the centre of the views (the middle view for odd counts) or the
        leftmost view.
    smooth_sigma : float, optional
        ATTEST Gaussian pre-smoothing of the parallax map (pixels); None = off.
    gradient_limit, edge_dilation, fill
        As in :func:`interpolate_view`.

    Returns
    -------
    StereoResult
        ``.left`` and ``.right`` are the outer views; ``.plan.range_px`` / ``.range_arcmin`` the
        parallax range between adjacent views; ``.warnings`` the comfort and divergence findings on
        ``display`` (when given) and the views that are mostly filled-in holes.

    Raises
    ------
    ValueError
        Bad arguments (see :func:`~vergence.synthesis.plan_parallax`), results larger than
        ``MAX_SYNTHESIS_BYTES`` (checked first), or views that cannot fit the
        image: the outer views lie ``(views - 1)`` adjacent parallaxes apart, and that span must
        stay below ``MAX_PARALLAX_WIDTHS`` image widths (checked before any view is rendered).

    Examples
    --------
    >>> import numpy as np
    >>> img = np.random.default_rng(0).random((4, 16), dtype=np.float32)
    >>> depth = np.full((4, 16), 2.0); depth[:, 6:10] = 1.0
    >>> res = synthesize_stereo(img, depth, budget_px=4.0)
    >>> res.plan.range_px, len(res.views), res.left.shape
    ((-4.0, 4.0), 2, (4, 16))
    """
    offsets = views_offsets(views, origin=origin)
    image_shape = np.shape(image)
    if len(image_shape) in (2, 3):  # from the shape alone, before any copy (check_image follows)
        per_view = math.prod(image_shape) * 4 + math.prod(image_shape[:2])  # float32 view + bool holes
        if len(offsets) * per_view > MAX_SYNTHESIS_BYTES:
            raise ValueError(
                f"views {len(offsets)} of a {image_shape[1]}x{image_shape[0]} image would take "
                f"{len(offsets) * per_view / 2**30:.3g} GiB, more than MAX_SYNTHESIS_BYTES "
                f"{MAX_SYNTHESIS_BYTES / 2**30:g} GiB: use fewer views or a smaller image"
            )
    img = check_image("image", image)
    shape = np.shape(depth)
    if len(shape) != 2 or shape != img.shape[:2]:
        raise ValueError(f"depth must have shape (H, W) matching image {img.shape[:2]}; got {shape}")
    plan = plan_parallax(
        depth,
        kind=kind,
        budget_px=budget_px,
        budget_arcmin=budget_arcmin,
        display=display,
        convergence=convergence,
        focal_px=focal_px,
        interaxial=interaxial,
        mapping=mapping,
    )
    limit, radius = _check_options(gradient_limit, edge_dilation, fill)
    sigma = None if smooth_sigma is None else check_sigma("smooth_sigma", smooth_sigma)
    widest = max(-plan.range_px[0], plan.range_px[1])
    span = (max(offsets) - min(offsets)) * widest
    width = img.shape[1]
    if span >= MAX_PARALLAX_WIDTHS * width:
        raise ValueError(
            f"views {len(offsets)} at up to {widest:.4g} px of parallax between neighbours span {span:.4g} px "
            f"between the outer views, which must stay below {MAX_PARALLAX_WIDTHS * width:g} px, "
            f"{MAX_PARALLAX_WIDTHS:g} image width (MAX_PARALLAX_WIDTHS): use fewer views or less parallax"
        )
    p = plan.parallax_px
    if sigma is not None:
        p = _stages.smooth_depth(p, sigma, sigma)
    rendered, holes = _render(_stages.as_hwc(img), np.negative(p, dtype=np.float32), offsets, limit, radius, fill, img)
    found = (() if display is None else stereo_warnings(plan, display)) + holes_warnings(holes)
    return StereoResult(views=rendered, holes=holes, offsets=offsets, plan=plan, warnings=found)


def _rectified_pair(source: Camera, target: Camera) -> tuple[float, float, float] | None:
    """``(f b, cx_s, cx_t)`` if the cameras form a rectified pair, else None (b: baseline along x_s)."""
    ks, kt = source.K, target.K
    same_k = np.allclose(np.delete(ks.ravel(), 2), np.delete(kt.ravel(), 2), rtol=_RECTIFIED_RTOL, atol=0.0)
    same_r = np.allclose(source.R, target.R, rtol=0.0, atol=_RECTIFIED_RTOL)
    base = source.R @ (target.center - source.center)  # baseline in the source camera frame
    sideways = abs(base[1]) + abs(base[2]) <= _RECTIFIED_RTOL * abs(base[0])
    if not (same_k and same_r and sideways and (source.width, source.height) == (target.width, target.height)):
        return None
    return float(ks[0, 0] * base[0]), float(ks[0, 2]), float(kt[0, 2])


def synthesize_view(
    image: object,
    depth: object,
    source: Camera,
    target: Camera,
    *,
    gradient_limit: float = 1.0,
    edge_dilation: int = 1,
    fill: str = "background",
) -> WarpedView:
    """Render the view of ``target`` from an image with metric depth taken by ``source``.

    When the cameras form a rectified pair (same rotation and intrinsics up to the principal
    point's x, centres on the camera x axis, one size) the disparity ``d = f b / Z + cx_s - cx_t``
    goes through the rectified pipeline (gap/hole rule, contour handling, median refinement);
    otherwise the 3D mesh warp with z-buffer and median refinement
    (:func:`~vergence.synthesis.warp_to_camera`), which has no cracks where the target magnifies
    the surface. Holes are then filled from the background side.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        Source view (float in [0, 1], uint8 or uint16), the size of ``source``.
    depth : (H, W) array
        Source camera-frame z in metres, > 0 where known, NaN = unknown.
    source, target : Camera
    gradient_limit, edge_dilation, fill
        As in :func:`interpolate_view`; ``gradient_limit`` also links the 3D mesh (pixels),
        ``edge_dilation`` applies to the rectified path.

    Returns
    -------
    WarpedView
        ``depth``: target camera-frame z in metres (holes filled from the background); None on
        the rectified path when the cameras share their centre (a principal-point shift). ``nearness``: on the rectified path (``nearness_unit == "px"``) the warped
        source disparity ``f b / Z + cx_s - cx_t`` in pixels, on the 3D path (``"1/m"``) ``1 / depth``.

    Notes
    -----
    S1 §IV.A: rectified pairs need one-dimensional resampling only (Eq. 7, ``Z = f b / d``);
    the general case is the 3D warp of S1 Eq. (5) (sign of the translation corrected).
    """
    source = check_camera("source", source)
    target = check_camera("target", target)
    img = check_source_image(image, source)
    z = check_depth(depth, source)
    limit, radius = _check_options(gradient_limit, edge_dilation, fill)
    pair = _rectified_pair(source, target)
    if pair is not None:
        fb, cx_s, cx_t = pair
        d64 = fb / z + cx_s - cx_t  # S1 Eq. (7): d = f b / Z
        if np.nanmax(np.abs(d64)) > FLOAT32_MAX:
            raise ValueError(
                f"depth must be >= {abs(fb) / FLOAT32_MAX:.3g} m for these cameras (its disparity f b / Z must be a float32); "
                f"got min {np.nanmin(z):g}"
            )
        d = d64.astype(np.float32)
        prepared, original = _stages.prepare_disparity(d, radius, limit)
        image_w, near, holes = _warp_reference(_stages.as_hwc(img), prepared, 1.0, limit, True)
        guide = _stages.fill_guide(near, prepared, original, 1.0, limit)
        disparity = _stages.fill_disparity(near)
        image_t, _ = _fill(image_w, guide, holes, fill)
        depth_t = None  # a pure principal-point shift (b = 0) keeps no depth in its disparity
        if fb != 0.0:
            with np.errstate(divide="ignore"):  # d = cx_s - cx_t: a point at infinity
                depth_t = (fb / (disparity.astype(np.float64) - cx_s + cx_t)).astype(np.float32)  # Z = f b / d
        return WarpedView(image=_stages.like(image_t, img), holes=holes, nearness=disparity, depth=depth_t)
    warped = _stages3d.warp_to_camera(img, z, source, target, "zbuffer", limit)
    warped = _stages3d.refine_camera_warp(
        warped, img, z, source, target, _stages3d.REFINE_CONSISTENCY, _stages3d.REFINE_ITERATIONS
    )
    # Hole filling wants "larger = nearer": inverse depth, then depth from the filled inverse depth.
    inv = np.where(warped.holes, np.nan, warped.nearness)
    image_t, inv_filled = _fill(_stages.as_hwc(warped.image), inv, warped.holes, fill)
    with np.errstate(divide="ignore"):
        depth_t = (1.0 / inv_filled).astype(np.float32)
    return WarpedView(
        image=_stages.like(image_t, img), holes=warped.holes, nearness=inv_filled, nearness_unit="1/m", depth=depth_t
    )
