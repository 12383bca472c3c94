"""Screen disparity in pixels and arcminutes, and the stereoscopic comfort zone (S3 §3–4, S0 §2).

The disparity here is the **screen parallax** of a displayed pair, ``x_r - x_l`` in display pixels:
positive (uncrossed) behind the screen, the pixel form ``d · N`` of S0's normalised disparity ``d``
(fraction of the screen width ``W'``, see ``docs/conventions.md``). A stereo matcher's disparity map
(``x_left - x_right``) has the opposite sign: negate it before using these functions.

Angles follow the vergence of a viewer centred in front of the screen (S3 §3 measures disparities in
arcmin): a parallax ``s`` (metres) on a screen at distance ``D`` seen by eyes ``e`` apart changes the
vergence angle by

``theta = 2 atan(e / 2D) - 2 atan((e - s) / 2D)``  (exact), or ``theta ≈ s / D``  (small angle),

positive for uncrossed parallax (the eyes converge less). The usual comfort zone is ±1 degree of
vergence around the screen (±60 arcmin), :class:`ComfortZone`'s default.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from vergence._validate import check_finite, check_in_range
from vergence.viewing._shared import float_or_array, real_array
from vergence.viewing.geometry import MAX_ABS_DISPARITY, Display, check_display

__all__ = [
    "ARCMIN_PER_RADIAN",
    "COMFORT_TOLERANCE_PX",
    "MAX_VERGENCE_ARCMIN",
    "ComfortReport",
    "ComfortZone",
    "arcmin_from_pixels",
    "check_disparity_range",
    "pixels_from_arcmin",
]

ARCMIN_PER_RADIAN = 180.0 * 60.0 / math.pi

# Largest |vergence change| the small-angle form accepts, arcminutes: 180 degrees. The exact form is
# undefined past about that (its own domain, checked there, depends on the display), and the small-angle
# form has no viewing meaning past it either (it would overflow at 1e308).
MAX_VERGENCE_ARCMIN = 180.0 * 60.0

# Screen disparity, in display pixels, by which a range may pass an edge of the comfort zone and still
# count as inside it. A range planned to end on a limit reaches it through
# pixel <-> arcmin conversions whose float64 round-off is ~1e-13 px (a maximum of 59.99999999999999'
# against 60' was reported outside); a millionth of a pixel is far above that and far below anything
# a viewer or a quantised image can show.
COMFORT_TOLERANCE_PX = 1e-6

# A zone limit is a vergence change; beyond 90 degrees the exact inverse leaves its domain for
# ordinary displays and the figure has no viewing meaning.
_MAX_ZONE_ARCMIN = 90.0 * 60.0


def _screen_vergence(display: Display) -> float:
    """Vergence angle (radians) of a viewer fixating the screen centre: ``2 atan(e / 2D)``."""
    return 2.0 * math.atan(display.eye_separation / (2.0 * display.distance))


def _arcmin_from_parallax(s: np.ndarray, display: Display, exact: bool) -> np.ndarray:
    """Vergence change (arcmin) of a screen parallax ``s`` in metres (vergence geometry, module docstring)."""
    e, D = display.eye_separation, display.distance
    if exact:
        theta = _screen_vergence(display) - 2.0 * np.arctan((e - s) / (2.0 * D))
    else:
        theta = s / D
    return theta * ARCMIN_PER_RADIAN


def _parallax_from_arcmin(theta_arcmin: np.ndarray, display: Display, exact: bool) -> np.ndarray:
    """Screen parallax (metres) whose vergence change is ``theta_arcmin``; inverse of the above."""
    e, D = display.eye_separation, display.distance
    theta = theta_arcmin / ARCMIN_PER_RADIAN
    if not exact:
        return theta * D
    half = _screen_vergence(display) / 2.0 - theta / 2.0  # half the vergence angle after the change
    with np.errstate(invalid="ignore"):
        bad = np.abs(half) >= math.pi / 2.0
    if bad.any():
        lo = (_screen_vergence(display) - math.pi) * ARCMIN_PER_RADIAN
        hi = (_screen_vergence(display) + math.pi) * ARCMIN_PER_RADIAN
        worst = float(theta_arcmin[bad].flat[0])
        raise ValueError(
            f"disparity_arcmin must lie in ({lo:.6g}, {hi:.6g}) arcmin for this display "
            f"(a vergence between -180 and 180 degrees); got {worst:g}"
        )
    return e - 2.0 * D * np.tan(half)


def _check_exact(exact: object) -> None:
    if not isinstance(exact, bool | np.bool_):
        raise TypeError(f"exact must be True or False; got {type(exact).__name__}")


def _checked(name: str, values: object, display: object, exact: object) -> np.ndarray:
    """The common checks of the two conversions: real values, NaN only beside a valid one, the display
    with its resolution, ``exact`` a bool."""
    arr = real_array(name, values, allow_nan=True)
    if arr.size == 0 or np.isnan(arr).all():
        raise ValueError(f"{name} must hold at least one value that is not NaN (NaN marks an invalid pixel "
                         f"of a map); got {arr.size} value(s), none valid")
    check_display(display, resolution=True)
    _check_exact(exact)
    return arr


def arcmin_from_pixels(parallax_px: object, display: Display, *, exact: bool = True) -> float | np.ndarray:
    """Vergence change in arcminutes of a screen disparity in pixels (S3 §3 works in arcmin).

    Parameters
    ----------
    parallax_px : float or array_like
        Screen parallax ``x_r - x_l`` in display pixels, positive (uncrossed) behind the screen.
        NaN (an invalid pixel of a map) passes through as NaN, but at least one value must be valid;
        inf, and more than :data:`~vergence.viewing.geometry.MAX_ABS_DISPARITY` screen widths, are refused.
    display : Display
        The viewing set-up; its ``resolution`` must be known.
    exact : bool, keyword-only
        True (default): the exact vergence difference at the screen centre; False: the small-angle
        form ``s / D``.

    Returns
    -------
    float or numpy.ndarray
        Angle in arcminutes, positive for uncrossed disparity; a float for a scalar input.

    Raises
    ------
    ValueError
        If ``parallax_px`` holds inf or is all NaN, or the display resolution is unknown.
    TypeError
        If ``parallax_px`` is not numeric (text included), ``display`` is not a Display or ``exact``
        not a bool.

    Notes
    -----
    With pitch ``p = W'/N``, parallax ``s = parallax_px · p`` and (vergence geometry)
    ``theta = 2 atan(e/2D) - 2 atan((e - s)/2D)``, or ``theta ≈ s/D`` for small angles.
    The two agree within 0.3 % for a few pixels at 60 cm.

    Examples
    --------
    S3's study display, 1 px at 60 cm (S3 §4: 0.282 mm pitch, about 1.62′):

    >>> samsung = Display.preset("samsung-2233rz")
    >>> round(arcmin_from_pixels(1.0, samsung), 3), round(arcmin_from_pixels(1.0, samsung, exact=False), 3)
    (1.611, 1.616)
    """
    px = _checked("parallax_px", parallax_px, display, exact)
    limit = MAX_ABS_DISPARITY * display.resolution  # d = parallax_px / N screen widths
    with np.errstate(invalid="ignore"):
        too_far = np.abs(px) > limit
    if too_far.any():
        raise ValueError(f"parallax_px must lie in [-{limit:g}, {limit:g}] (MAX_ABS_DISPARITY screen widths); "
                         f"got {px[too_far].flat[0]:g}")
    s = px * display.pixel_pitch
    return float_or_array(_arcmin_from_parallax(s, display, exact))


def pixels_from_arcmin(disparity_arcmin: object, display: Display, *, exact: bool = True) -> float | np.ndarray:
    """Screen disparity in pixels whose vergence change is ``disparity_arcmin`` (inverse of the above).

    The inverse of :func:`arcmin_from_pixels` with the same ``exact`` choice.

    Parameters
    ----------
    disparity_arcmin : float or array_like
        Vergence change in arcminutes, positive (uncrossed) behind the screen, at most
        :data:`MAX_VERGENCE_ARCMIN` in magnitude. NaN passes through beside at least one valid value.
    display : Display
        The viewing set-up; its ``resolution`` must be known.
    exact : bool, keyword-only
        True (default): invert the exact vergence difference; False: the small-angle form.

    Returns
    -------
    float or numpy.ndarray
        Screen parallax ``x_r - x_l`` in pixels.

    Raises
    ------
    ValueError
        If an angle is inf, past :data:`MAX_VERGENCE_ARCMIN`, outside the exact form's domain (a
        vergence outside ±180°), if all are NaN, or if the display resolution is unknown.
    TypeError
        If ``disparity_arcmin`` is not numeric, ``display`` is not a Display or ``exact`` not a bool.

    Notes
    -----
    ``s = e - 2D tan(atan(e/2D) - theta/2)`` (exact) or ``s = theta D``, then ``parallax_px = s / p``.

    Examples
    --------
    >>> round(pixels_from_arcmin(60.0, Display.preset("samsung-2233rz"), exact=False), 2)
    37.13
    """
    theta = _checked("disparity_arcmin", disparity_arcmin, display, exact)
    with np.errstate(invalid="ignore"):
        too_wide = np.abs(theta) > MAX_VERGENCE_ARCMIN
    if too_wide.any() and not exact:  # the exact form checks its own (display-dependent) domain
        raise ValueError(f"disparity_arcmin must lie in [-{MAX_VERGENCE_ARCMIN:g}, {MAX_VERGENCE_ARCMIN:g}] arcmin "
                         f"(a vergence change of at most 180 degrees); got {theta[too_wide].flat[0]:g}")
    pitch = display.pixel_pitch
    return float_or_array(_parallax_from_arcmin(theta, display, exact) / pitch)


@dataclass(frozen=True, slots=True)
class ComfortZone:
    """Range of vergence change around the screen that viewers fuse comfortably.

    Parameters
    ----------
    crossed_arcmin : float
        Largest crossed disparity (in front of the screen), as a positive angle in arcminutes.
    uncrossed_arcmin : float
        Largest uncrossed disparity (behind the screen), in arcminutes.

    Both lie in (0, 5400] (at most 90 degrees). The default is the common ±1 degree (±60 arcmin).

    Examples
    --------
    >>> zone = ComfortZone()
    >>> zone.min_arcmin, zone.max_arcmin
    (-60.0, 60.0)
    >>> [round(v, 2) for v in zone.perceived_depths(Display(0.065, 3.0, 1.2))]
    [1.66, 15.43]
    """

    crossed_arcmin: float = 60.0
    uncrossed_arcmin: float = 60.0

    def __post_init__(self) -> None:
        for name in ("crossed_arcmin", "uncrossed_arcmin"):
            v = check_in_range(name, getattr(self, name), 0.0, _MAX_ZONE_ARCMIN)
            if v == 0.0:
                raise ValueError(f"{name} must be > 0; got 0")
            object.__setattr__(self, name, v)

    @property
    def min_arcmin(self) -> float:
        """Signed lower limit (crossed, in front of the screen): ``-crossed_arcmin``."""
        return -self.crossed_arcmin

    @property
    def max_arcmin(self) -> float:
        """Signed upper limit (uncrossed, behind the screen): ``uncrossed_arcmin``."""
        return self.uncrossed_arcmin

    def _parallax(self, display: Display, exact: bool) -> tuple[float, float]:
        check_display(display)
        _check_exact(exact)
        s = _parallax_from_arcmin(np.array([self.min_arcmin, self.max_arcmin]), display, exact)
        return float(s[0]), float(s[1])

    def pixels(self, display: Display, *, exact: bool = True) -> tuple[float, float]:
        """The zone as screen disparities in pixels ``(min_px, max_px)``; needs the resolution."""
        lo, hi = self._parallax(display, exact)
        return lo / display.pixel_pitch, hi / display.pixel_pitch

    def disparities(self, display: Display, *, exact: bool = True) -> tuple[float, float]:
        """The zone as S0 normalised disparities ``(d_min, d_max)``, fractions of the screen width."""
        lo, hi = self._parallax(display, exact)
        return lo / display.width, hi / display.width

    def perceived_depths(self, display: Display, *, exact: bool = True) -> tuple[float, float]:
        """Nearest and farthest perceived distances (metres from the viewer) inside the zone.

        By S0 Eq. (1b) with ``d = s / W'``: ``z' = b'H' / (b' - s)``. The far distance is ``inf``
        when the zone reaches the divergence limit ``s >= b'`` (then every depth behind the screen is
        inside it). With ``exact=True`` these are the fixation distances whose vergence is the
        screen's minus or plus the zone limits.
        """
        lo, hi = self._parallax(display, exact)
        e, D = display.eye_separation, display.distance
        near = e * D / (e - lo)  # Eq. (1b); lo < 0 so the denominator is > e
        far = e * D / (e - hi) if hi < e else math.inf  # Eq. (1b)
        return near, far


@dataclass(frozen=True, slots=True)
class ComfortReport:
    """Result of :func:`check_disparity_range`; all disparities are screen pixels ``x_r - x_l``.

    Attributes
    ----------
    min_px, max_px : float
        Extremes of the checked disparities.
    min_arcmin, max_arcmin : float
        The same as vergence changes.
    zone_min_px, zone_max_px : float
        The comfort zone on this display.
    near_margin_px, far_margin_px : float
        ``min_px - zone_min_px`` and ``zone_max_px - max_px``: room left in front of and behind the
        screen (negative when the range leaves the zone on that side).
    excess_px, excess_arcmin : float
        How far the range leaves the zone: the largest overshoot on either side, 0 when inside.
    divergence_px : float
        The divergence limit ``b'/W'`` of S0 Eq. (8) in pixels (``b' / pitch``).
    diverges : bool
        Whether ``max_px`` exceeds the divergence limit (the eyes would diverge; exact, no tolerance).
    inside : bool
        Both margins >= ``-COMFORT_TOLERANCE_PX`` and no divergence: a range that ends on a zone edge,
        to float round-off, is inside (``excess_px`` and ``excess_arcmin`` are then 0).
    """

    min_px: float
    max_px: float
    min_arcmin: float
    max_arcmin: float
    zone_min_px: float
    zone_max_px: float
    near_margin_px: float
    far_margin_px: float
    excess_px: float
    excess_arcmin: float
    divergence_px: float
    diverges: bool
    inside: bool

    def __post_init__(self) -> None:
        for name in (f.name for f in fields(self)):
            if name not in ("diverges", "inside"):
                object.__setattr__(self, name, check_finite(name, getattr(self, name)))
        if self.min_px > self.max_px:
            raise ValueError(f"min_px must be <= max_px; got {self.min_px:g} > {self.max_px:g}")
        if self.excess_px < 0 or self.excess_arcmin < 0:
            raise ValueError(
                f"excess_px and excess_arcmin must be >= 0; got {self.excess_px:g}, {self.excess_arcmin:g}"
            )

    def to_dict(self) -> dict[str, float | bool]:
        """Plain dict (JSON-ready) of every field."""
        return asdict(self)


def check_disparity_range(
    parallax_px: object, display: Display, *, zone: ComfortZone | None = None, exact: bool = True
) -> ComfortReport:
    """Check screen disparities against a comfort zone and the divergence limit.

    Parameters
    ----------
    parallax_px : float or array_like
        Screen disparities ``x_r - x_l`` in pixels: a ``(min, max)`` pair, or a whole disparity map.
        NaN (invalid) entries are ignored; at least one must be finite; inf is refused.
    display : Display
        The viewing set-up; its ``resolution`` must be known.
    zone : ComfortZone, keyword-only
        Default ``ComfortZone()``: ±60 arcmin.
    exact : bool, keyword-only
        Angle form used for the conversions (see :func:`arcmin_from_pixels`).

    Returns
    -------
    ComfortReport

    Raises
    ------
    ValueError
        If ``parallax_px`` has no finite value or holds inf, or the resolution is unknown.

    Notes
    -----
    The divergence limit is S0 Eq. (8), ``d <= b'/W'``, i.e. ``b'/W' · N`` pixels. On a large,
    distant screen (a cinema) it can lie inside the ±60′ zone: ``inside`` is then False for
    disparities past it even though they are within the zone.

    Examples
    --------
    >>> r = check_disparity_range([-10.0, 30.0], Display.preset("samsung-2233rz"))
    >>> r.inside, round(r.far_margin_px, 1), round(r.divergence_px, 1)
    (True, 7.2, 230.5)
    """
    values = real_array("parallax_px", parallax_px, allow_nan=True)
    check_display(display)
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        raise ValueError(f"parallax_px must hold at least one finite value; got {values.size} values, none finite")
    zone = ComfortZone() if zone is None else zone
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    lo, hi = float(finite.min()), float(finite.max())
    lo_arcmin, hi_arcmin = (float(v) for v in arcmin_from_pixels(np.array([lo, hi]), display, exact=exact))
    zone_lo, zone_hi = zone.pixels(display, exact=exact)
    near_margin, far_margin = lo - zone_lo, zone_hi - hi
    divergence_px = display.divergence_disparity * display.resolution  # Eq. (8) in pixels
    # within COMFORT_TOLERANCE_PX of a zone edge is on it: inside, no excess. The divergence limit
    # stays exact: past it by one float the eyes diverge (S0 Eq. 8 is a physical bound, not a budget).
    tol = COMFORT_TOLERANCE_PX
    diverges = hi > divergence_px
    excess_px = max(0.0, -near_margin, -far_margin)
    excess_arcmin = max(0.0, zone.min_arcmin - lo_arcmin, hi_arcmin - zone.max_arcmin)
    if excess_px <= tol:
        excess_px = excess_arcmin = 0.0
    return ComfortReport(
        min_px=lo,
        max_px=hi,
        min_arcmin=lo_arcmin,
        max_arcmin=hi_arcmin,
        zone_min_px=zone_lo,
        zone_max_px=zone_hi,
        near_margin_px=near_margin,
        far_margin_px=far_margin,
        excess_px=excess_px,
        excess_arcmin=excess_arcmin,
        divergence_px=divergence_px,
        diverges=bool(diverges),
        inside=bool(near_margin >= -tol and far_margin >= -tol and not diverges),
    )
