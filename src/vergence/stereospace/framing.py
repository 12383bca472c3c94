"""Framing and convergence of a stereospace pair: fit to the frame, and a horizontal image shift
that brings the pair's disparities into the display's comfort zone.

Fusiello's rectification (Fusiello et al. 2000, restated in S2 §3.2) gives each rectified view an
extent of its own size: turned by the rectifying rotation, a 640 x 480 photo can need 500 x 700
pixels (dino's photos are rolled 90 degrees, so its rectified views stand upright). :func:`frame_cameras`
places both extents in the output frame with one scale and one vertical offset (rows stay aligned):

- ``"fit"`` (the default): the largest scale at which both whole extents fit the frame, centred;
  nothing of the views is cut off (bars where the aspect ratios differ);
- ``"crop"``: the collection's scale (an image width of the collection maps onto the frame's
  width), centred; a wider or taller extent is cut off at the frame's edges (the tree before issue 27).

A horizontal image translation (HIT) shifts the left view by ``-h/2`` and the right view by ``+h/2``
image pixels: every screen parallax ``x_r - x_l`` grows by ``h``, and the depth order is kept.
:func:`convergence_shift` chooses ``h`` so that the range of the pair's point disparities (its 1st
to 99th percentiles, :data:`~vergence.stereospace.DISPARITY_TRIM`) is centred in the comfort zone
(:class:`vergence.viewing.ComfortZone`), in screen pixels of a display that the view fills in
width. A range wider than the zone does not fit whatever the shift (S0 §2; the range is what
:func:`~vergence.stereospace.pair_quality` calls ``fits_with_shift``): it is centred all the same,
overshooting both bounds alike, and ``fits`` is False. The shift moves the principal points of the
rectified cameras (``cx_l - h/2``, ``cx_r + h/2``), so the views are rendered shifted in one
resampling; a shifted view has a bar of ``|h|/2`` pixels without content at one side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.camera import Camera
from vergence._validate import as_float_array
from vergence.viewing import (ComfortZone, Display, arcmin_from_pixels, check_disparity_range, check_display,
                              pixels_from_arcmin)

__all__ = ["FRAMINGS", "ConvergenceShift", "convergence_shift", "frame_cameras"]

# The shift is found again from the points the shifted views show, until it moves by less than
# this (view pixels) or after this many rounds (a point entering or leaving at an edge changes the
# 1st/99th percentiles a little; two or three rounds settle on the synthetic and shared collections).
_SHIFT_TOLERANCE_PX = 0.01
_SHIFT_ROUNDS = 6

FRAMINGS = ("fit", "crop")
"""How :func:`frame_cameras` places the rectified views in the frame (see the module notes)."""


def _scaled(cam: Camera, s: float, ox: float, oy: float, width: int, height: int) -> Camera:
    """``cam`` with its image scaled by ``s`` about pixel centres and offset by ``(ox, oy)``.

    Pixel centres sit at integer coordinates, so pixel ``u`` of ``cam`` is ``s (u + 1/2) - 1/2 + o``
    in the new image: ``K' = [[s, 0, (s - 1)/2 + ox], [0, s, (s - 1)/2 + oy], [0, 0, 1]] K``.
    """
    M = np.array([[s, 0.0, (s - 1.0) / 2.0 + ox], [0.0, s, (s - 1.0) / 2.0 + oy], [0.0, 0.0, 1.0]])
    return Camera(K=M @ cam.K, R=cam.R, t=cam.t, width=width, height=height)


def frame_cameras(left: Camera, right: Camera, size: tuple[int, int], *, framing: str = "fit",
                  reference_width: int | None = None) -> tuple[Camera, Camera]:  # fmt: skip
    """The rectified cameras ``(left, right)`` placed in a ``size = (width, height)`` frame.

    ``left`` and ``right`` are Fusiello's rectified cameras (same ``R`` and focal lengths, the same
    vertical principal point, each of the size of its extent, :func:`vergence.depth.rectify_cameras`).
    Both get one scale ``s`` and one vertical offset, so rows stay aligned: ``"fit"``
    ``s = min(width / w_rect, height / h_rect)`` (``w_rect x h_rect`` the rectified size), ``"crop"``
    ``s = width / reference_width`` (the collection's image width; default the rectified width);
    each extent is centred in the frame.

    Raises
    ------
    ValueError
        An unknown ``framing``, a size that is not two positive whole numbers.
    TypeError
        Cameras that are not Camera.
    """
    if not isinstance(left, Camera) or not isinstance(right, Camera):
        raise TypeError("left and right must be Camera instances")
    if framing not in FRAMINGS:
        raise ValueError(f"framing must be one of {', '.join(FRAMINGS)}; got {framing!r}")
    if (not isinstance(size, tuple | list) or len(size) != 2
            or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= 1 for v in size)):  # fmt: skip
        raise ValueError(f"size must be (width, height), two positive whole numbers of pixels; got {size!r}")
    if reference_width is not None and (isinstance(reference_width, bool) or not isinstance(reference_width, int | np.integer)
                                        or reference_width < 1):  # fmt: skip
        raise ValueError(f"reference_width must be a positive whole number of pixels; got {reference_width!r}")
    width, height = int(size[0]), int(size[1])
    w_rect, h_rect = left.width, left.height
    if framing == "fit":
        s = min(width / w_rect, height / h_rect)
    else:
        s = width / (w_rect if reference_width is None else reference_width)
    ox, oy = (width - s * w_rect) / 2.0, (height - s * h_rect) / 2.0
    return (_scaled(left, s, ox, oy, width, height), _scaled(right, s, ox, oy, width, height))


@dataclass(frozen=True, slots=True)
class ConvergenceShift:
    """The horizontal image shift of a pair (see the module notes).

    Attributes
    ----------
    shift_px : float
        ``h``: the growth of every disparity ``x_r - x_l``, pixels of the views (the left view moves
        by ``-h/2``, the right one by ``+h/2``); 0 when not applied.
    shift_arcmin : float
        The vergence change of a screen parallax of ``h`` at the screen centre.
    before_arcmin, after_arcmin : (float, float) or None
        The disparity range (1st to 99th percentile of the points seen by both views) on the display
        before and after the shift; None without such points.
    zone_arcmin : (float, float)
        The comfort zone.
    fits : bool
        The range after the shift lies inside the zone (and short of divergence).
    applied : bool
        The shift moved the views (False: no shift asked, or no point seen by both views).
    points : int
        Points seen by both views.
    note : str
        Why nothing was applied, or the range does not fit; else ``""``.
    """

    shift_px: float
    shift_arcmin: float
    before_arcmin: tuple[float, float] | None
    after_arcmin: tuple[float, float] | None
    zone_arcmin: tuple[float, float]
    fits: bool
    applied: bool
    points: int
    note: str = ""

    def to_dict(self) -> dict:
        """JSON-ready fields."""
        out = {k: getattr(self, k) for k in self.__slots__}
        for k in ("before_arcmin", "after_arcmin", "zone_arcmin"):
            out[k] = None if out[k] is None else list(out[k])
        return out


def _seen_disparities(left: Camera, right: Camera, points: np.ndarray, trim: float) -> np.ndarray:
    """``x_r - x_l`` (pixels) of the points in front of both cameras and inside both images, trimmed."""
    xl, zl = left.project(points)
    xr, zr = right.project(points)
    seen = (zl > 0) & (zr > 0)
    for xy, cam in ((xl, left), (xr, right)):
        seen &= (xy[:, 0] >= -0.5) & (xy[:, 0] <= cam.width - 0.5) & (xy[:, 1] >= -0.5) & (xy[:, 1] <= cam.height - 0.5)
    d = xr[seen, 0] - xl[seen, 0]
    if trim > 0.0 and d.size:
        low, high = np.quantile(d, [trim, 1.0 - trim])
        d = d[(d >= low) & (d <= high)]
    return d


def convergence_shift(left: Camera, right: Camera, points: object, display: Display, *,
                      zone: ComfortZone | None = None, trim: float = 0.0,
                      apply: bool = True) -> tuple[Camera, Camera, ConvergenceShift]:  # fmt: skip
    """Shift a rectified pair horizontally so that its disparity range is centred in the comfort zone.

    Parameters
    ----------
    left, right : Camera
        Rectified cameras of the output views (rows aligned, same width).
    points : (P, 3) array
        The collection's sparse points (metres); those in front of both cameras and inside both
        images give the disparities.
    display : Display
        With a resolution; the views fill its width (a view pixel is ``resolution / width`` screen
        pixels).
    zone : ComfortZone, optional
        Default ``ComfortZone()`` (±60 arcmin).
    trim : float
        Fraction of the disparities dropped at each end (sparse SfM points hold outliers).
    apply : bool
        False: measure only (``shift_px`` 0, ``after`` = ``before``).

    Returns
    -------
    (Camera, Camera, ConvergenceShift)
        The shifted cameras (``cx`` moved by ``-h/2`` and ``+h/2``) and what was done.

    Raises
    ------
    ValueError
        Non-finite points or not ``(P, 3)``, a display without resolution, ``trim`` outside [0, 0.5).
    TypeError
        Cameras that are not Camera, a zone that is not a ComfortZone.

    Notes
    -----
    In screen pixels, with the range ``[p_min, p_max]`` and the zone ``[z_min, z_max]``
    (:func:`vergence.viewing.pixels_from_arcmin`), ``h_screen = (z_min + z_max)/2 - (p_min + p_max)/2``
    and ``h = h_screen width / resolution``, found again on the points the shifted views show (a
    shift moves points across the views' edges) until it changes by under 0.01 px (at most 6
    rounds). Parallax is ``x_r - x_l`` (positive behind the screen).
    """
    if not isinstance(left, Camera) or not isinstance(right, Camera):
        raise TypeError("left and right must be Camera instances")
    check_display(display, resolution=True)
    zone = ComfortZone() if zone is None else zone
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    if isinstance(trim, bool) or not isinstance(trim, int | float) or not 0.0 <= trim < 0.5:
        raise ValueError(f"trim must be a fraction in [0, 0.5); got {trim!r}")
    if not isinstance(apply, bool):
        raise TypeError(f"apply must be a bool; got {type(apply).__name__}")
    pts = as_float_array("points", points, shape=(None, 3))
    zone_arcmin = (zone.min_arcmin, zone.max_arcmin)
    d = _seen_disparities(left, right, pts, trim) if len(pts) else np.zeros(0)
    if d.size == 0:
        return left, right, ConvergenceShift(0.0, 0.0, None, None, zone_arcmin, False, False, 0,
                                             "no point seen by both views: no shift")  # fmt: skip
    scale = display.resolution / left.width  # screen pixels per view pixel
    before = check_disparity_range(np.array([d.min(), d.max()]) * scale, display, zone=zone)
    h, shifted = 0.0, (left, right)
    if apply:  # the shift moves points into and out of the views: centre what the shifted views show
        z_low, z_high = (float(pixels_from_arcmin(a, display)) for a in zone_arcmin)
        for _ in range(_SHIFT_ROUNDS):
            step = ((z_low + z_high) / 2.0 - (d.min() + d.max()) * scale / 2.0) / scale
            h += step
            shifted = (_scaled(left, 1.0, -h / 2.0, 0.0, left.width, left.height),
                       _scaled(right, 1.0, h / 2.0, 0.0, right.width, right.height))  # fmt: skip
            d_new = _seen_disparities(*shifted, pts, trim)
            if d_new.size == 0:  # shifted out of view altogether: keep the first shift's points
                break
            d = d_new
            if abs(step) <= _SHIFT_TOLERANCE_PX:
                break
    after = check_disparity_range(np.array([d.min(), d.max()]) * scale, display, zone=zone)
    note = "" if after.inside else "the disparities leave the comfort zone (not shifted)" if not apply else (
        f"the disparity range ({after.max_arcmin - after.min_arcmin:.0f} arcmin) is wider than the comfort zone "
        f"({zone_arcmin[1] - zone_arcmin[0]:.0f} arcmin): no shift brings it inside"
        if (before.max_arcmin - before.min_arcmin) > zone_arcmin[1] - zone_arcmin[0]
        else "the disparities pass the divergence limit of the display")  # fmt: skip
    left, right = shifted
    shift = ConvergenceShift(shift_px=float(h), shift_arcmin=float(arcmin_from_pixels(h * scale, display)),
                             before_arcmin=(before.min_arcmin, before.max_arcmin),
                             after_arcmin=(after.min_arcmin, after.max_arcmin), zone_arcmin=zone_arcmin,
                             fits=bool(after.inside), applied=bool(apply), points=int(d.size), note=note)  # fmt: skip
    return left, right, shift
