"""Depth pre- and post-processing for DIBR (S1 §IV.B): smoothing, edge handling, median refinement.

- :func:`smooth_depth`: ATTEST-style Gaussian pre-smoothing of the depth, which shrinks the
  disocclusions a warp opens (S1 §IV.B.1).
- :func:`dilate_foreground`: the near side of every depth discontinuity grows by a pixel or two, so
  the mixed colours along object contours travel with the foreground instead of being smeared on
  the background as a halo (contour artifacts, S1 §IV.B.3).
- :func:`contour_mask`: the unreliable pixels along depth discontinuities (Müller et al., S1
  §IV.B.3), to be taken from another reference when one sees them clearly.
- :func:`median_refine`: median filtering of a forward-warped disparity followed by inverse warping
  of the pixels it changed (Do et al., S1 §IV.B.1).
"""

from __future__ import annotations

import numpy as np

from vergence._validate import check_finite, check_positive, check_positive_int, check_same_hw
from vergence.synthesis import _stages
from vergence.synthesis._checks import (
    MAX_FILTER_RADIUS,
    MAX_SMOOTH_SIGMA,
    check_image,
    check_map,
    check_nonnegative,
    check_radius,
    check_sigma,
    within_float32,
)
from vergence.synthesis.view import WarpedView

__all__ = [
    "CONTOUR_SIDES",
    "MAX_FILTER_RADIUS",
    "MAX_SMOOTH_SIGMA",
    "contour_mask",
    "dilate_foreground",
    "median_refine",
    "smooth_depth",
]

# Sides of a depth edge that contour_mask can mark.
CONTOUR_SIDES = ("both", "near", "far")


def smooth_depth(depth: object, *, sigma: float, vertical_sigma: float | None = None) -> np.ndarray:
    """Gaussian pre-smoothing of a depth or disparity map, ignoring unknown (NaN) values (ATTEST).

    Parameters
    ----------
    depth : (H, W) array
        Depth, inverse depth or disparity; NaN = unknown (stays NaN).
    sigma : float
        Horizontal standard deviation in pixels, in (0, MAX_SMOOTH_SIGMA].
    vertical_sigma : float, optional
        Vertical standard deviation (same range); defaults to ``sigma``. ATTEST used a larger vertical one
        (asymmetric smoothing) to keep vertical edges straight.

    Returns
    -------
    (H, W) float32
        Normalised convolution ``G * (m d) / G * m`` with ``m`` the known mask.

    Notes
    -----
    S1 §IV.B.1: smoothing the depth so that no (or smaller) disocclusions appear, traded against
    geometric distortion of the smoothed edges.

    Examples
    --------
    >>> import numpy as np
    >>> smooth_depth(np.full((3, 3), 2.0), sigma=1.0).tolist()[1]
    [2.0, 2.0, 2.0]
    """
    d = check_map("depth", depth)
    sx = check_sigma("sigma", sigma)
    sy = sx if vertical_sigma is None else check_sigma("vertical_sigma", vertical_sigma)
    return _stages.smooth_depth(d, sx, sy)


def dilate_foreground(disparity: object, *, radius: int = 1, threshold: float = 1.0) -> np.ndarray:
    """Grow the near side of each depth discontinuity by ``radius`` pixels.

    A pixel takes the largest disparity of its ``(2 radius + 1)^2`` neighbourhood when that exceeds
    its own by more than ``threshold``; elsewhere (smooth or slanted surfaces) nothing changes.

    Parameters
    ----------
    disparity : (H, W) array
        Pixels, larger = nearer; NaN = unknown (ignored by the maximum, kept NaN).
    radius : int
        Pixels to grow, >= 0 (0 returns a copy).
    threshold : float
        Smallest disparity jump treated as a discontinuity, in pixels (the gap limit of the gradient rule, S1 Sec. IV.B.1).

    Returns
    -------
    (H, W) float32

    Notes
    -----
    Contour artifacts (S1 §IV.B.3) come from pixels that mix foreground and background colour at a
    depth discontinuity. Giving them the foreground depth makes them move with the object they
    outline; the background they uncover is then taken from the other reference, where it is seen
    clearly, and the remaining disocclusion is filled from the background side.

    Examples
    --------
    >>> import numpy as np
    >>> dilate_foreground(np.array([[0.0, 0, 5, 5, 0, 0]]), radius=1).tolist()
    [[0.0, 5.0, 5.0, 5.0, 5.0, 0.0]]
    """
    d = check_map("disparity", disparity)
    r = check_radius("radius", radius)
    thr = check_nonnegative("threshold", threshold)
    return _stages.dilate_foreground(d, r, thr)


def contour_mask(disparity: object, *, width: int = 1, threshold: float = 1.0, side: str = "both") -> np.ndarray:
    """Pixels within ``width`` of a depth discontinuity: the unreliable areas of S1 §IV.B.3.

    Parameters
    ----------
    disparity : (H, W) array
        Pixels, larger = nearer; NaN = unknown (an unknown neighbour is no discontinuity).
    width : int
        Band width in pixels on each marked side, >= 1.
    threshold : float
        Smallest jump between 4-neighbours that counts as a discontinuity, in pixels.
    side : {"both", "near", "far"}
        Mark the band on both sides of the edge, or only on the foreground or background side.

    Returns
    -------
    (H, W) bool

    Notes
    -----
    Müller et al. (cited in S1 §IV.B.3) split each reference into reliable and unreliable areas by
    edge detection in the depth image; unreliable pixels are taken from another reference where one
    sees them reliably (see :func:`vergence.synthesis.blend_views`).

    Examples
    --------
    >>> import numpy as np
    >>> contour_mask(np.array([[0.0, 0, 0, 5, 5, 5]]), side="far").astype(int).tolist()
    [[0, 0, 1, 0, 0, 0]]
    """
    d = check_map("disparity", disparity)
    w = check_positive_int("width", width)
    check_radius("width", w)
    thr = check_nonnegative("threshold", threshold)
    if side not in CONTOUR_SIDES:
        raise ValueError(f"side must be one of {', '.join(CONTOUR_SIDES)}; got {side!r}")
    return _stages.contour_mask(d, w, thr, side)


def median_refine(
    warped: WarpedView,
    source_image: object,
    source_disparity: object,
    *,
    scale: float,
    tolerance: float = 0.5,
    consistency: float = 1.0,
) -> WarpedView:
    """Median-filter a forward-warped disparity and inverse-warp the pixels it changed (Do et al.).

    Parameters
    ----------
    warped : WarpedView
        The output of :func:`vergence.synthesis.forward_warp` of ``source_image``.
    source_image : (H, W) or (H, W, C) array
        The reference view that was warped.
    source_disparity : (H, W) array
        Its disparity (the one that was warped), NaN = unknown.
    scale : float
        The ``scale`` of that forward warp.
    tolerance : float
        A pixel counts as changed when the 3x3 median (over known values, at least 5 of 9) differs
        from its warped disparity by more than this, in pixels; holes with a median are changed too.
    consistency : float
        A changed pixel is inverse-warped only when the reference's own disparity at the source
        position agrees with the median within this many pixels (otherwise the reference does not
        see that surface there, and the pixel is left as it was).

    Returns
    -------
    WarpedView
        Same layout, with the refined colours, disparities and the smaller hole mask.

    Notes
    -----
    S1 §IV.B.1 (Luat Do et al.): depth maps are smooth regions with sharp edges, so a median filter
    removes isolated warping errors and closes cracks without blurring edges; the pixels it changed
    get their colour by inverse warping ``x_src = x + scale d_med`` (S1 Eq. 7 read backwards).
    """
    if not isinstance(warped, WarpedView):
        raise TypeError(f"warped must be a WarpedView; got {type(warped).__name__}")
    if warped.nearness_unit != "px":
        raise ValueError(f"warped must come from a rectified warp (nearness in px); got nearness in {warped.nearness_unit}")
    img = check_image("source_image", source_image)
    check_same_hw("source_image", img, "warped image", warped.image)
    if img.shape[2:] != warped.image.shape[2:]:
        raise ValueError(f"source_image must have the channels of the warped image {warped.image.shape}; got {img.shape}")
    d_src = check_map("source_disparity", source_disparity, "source_image", img)
    s = check_finite("scale", scale)
    known = np.abs(d_src[np.isfinite(d_src)])
    shift = abs(s) * float(known.max()) if known.size else 0.0
    if not shift <= img.shape[1]:  # the inverse warp reads x + scale d: a shift past the width reads nothing
        raise ValueError(f"scale {s:g} times the largest source disparity moves pixels {shift:g} px, more than "
                         f"the image's {img.shape[1]} px width")
    tol = within_float32("tolerance", check_positive("tolerance", tolerance))
    cons = within_float32("consistency", check_positive("consistency", consistency))
    image, disparity, holes = _stages.median_refine(
        _stages.as_hwc(img), d_src, _stages.as_hwc(warped.image), warped.nearness, warped.holes, s, tol, cons
    )
    return WarpedView(image=_stages.like(image, img), holes=holes, nearness=disparity, nearness_unit="px")
