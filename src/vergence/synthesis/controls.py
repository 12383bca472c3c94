"""Depth controls of 2D + depth rendering (S1 §IV.C, Table I): from a depth map to screen parallax.

The parallax between the two eyes of the rendered pair is ``P = psi(p)`` where ``p = -q`` is the
input's own parallax and ``q`` its nearness (larger = nearer): ``1/Z`` for metric depth, the
value itself for inverse depth or for a disparity map. ``psi`` is an increasing disparity mapping
(``vergence.viewing.mapping``); ``P = x_r - x_l`` in image pixels, positive (uncrossed)
behind the screen, zero at the convergence (zero-parallax) distance.

Three ways to choose psi, one per call:

- **shift-sensor set-up** (S1 Sec. IV.C; Fehn 2004): interaxial ``t_c``, convergence ``Z_c`` and focal
  length ``alpha_u``: ``P = alpha_u t_c (1/Z_c - 1/Z)``, a linear psi of slope ``alpha_u t_c``
  through zero at ``Z_c``. Table I: a larger ``t_c`` or focal length increases the parallax, a
  larger ``Z_c`` moves the scene toward the viewer.
- **disparity budget**: the parallax range fits ``[-B, +B]`` (B in image pixels, or in
  arcminutes for a :class:`~vergence.viewing.geometry.Display`, converted by
  :func:`~vergence.viewing.comfort.pixels_from_arcmin`), linearly; with a convergence depth the
  zero stays there and the larger side reaches the budget.
- **any psi** given by the caller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vergence._validate import check_finite, check_positive, check_positive_int
from vergence.io.depth import DEPTH_KINDS
from vergence.synthesis._checks import check_map
from vergence.viewing.comfort import arcmin_from_pixels, pixels_from_arcmin
from vergence.viewing.geometry import Display, check_display
from vergence.viewing.mapping import DisparityMapping, LinearMapping

__all__ = [
    "DEPTH_KINDS",
    "INVERSE_DEPTH_RANGE",
    "MAX_PARALLAX_WIDTHS",
    "MAX_VIEWS",
    "MIN_METRIC_DEPTH",
    "MIN_PARALLAX_PX",
    "ParallaxPlan",
    "nearness_from_depth",
    "plan_parallax",
    "views_offsets",
]

# Inverse depth is MPEG's normalised 1/Z (Fehn 2004): 0 is the far clipping plane, 1 the near one;
# a value outside is not a depth between the two planes.
INVERSE_DEPTH_RANGE = (0.0, 1.0)
# Smallest metric depth: the nearness 1/Z is float32, and 1/Z must stay finite (1 / 1.18e-38 =
# 8.5e37 < 3.4e38, float32's largest value); a smaller depth is a unit mistake, not a scene.
MIN_METRIC_DEPTH = float(np.finfo(np.float32).tiny)
# Largest parallax between two views, in image widths: view k sees a pixel at x + o_k P (S1 Eq. 7),
# so a point whose parallax between two views is a whole width or more cannot lie inside both (its
# two images are W or more apart, and both must be in [0, W)); those views share nothing at that
# depth. One rule for every depth control and for interpolation: refused, not rendered black.
MAX_PARALLAX_WIDTHS = 1.0
# Smallest parallax range a depth control may ask for, pixels: below it every view is the source
# image (a subnormal budget or focal length gave a zero range and an error about psi's internals).
MIN_PARALLAX_PX = 1e-6
# Most views synthesize_stereo renders: a multi-view autostereoscopic screen takes 8 to 64, and
# each view is a full image in memory.
MAX_VIEWS = 128

def nearness_from_depth(depth: object, *, kind: str = "metric") -> np.ndarray:
    """Nearness ``q`` (larger = nearer) of a depth map, NaN where unknown.

    Parameters
    ----------
    depth : (H, W) array
        ``"metric"``: camera-frame z in metres, > 0 where known; ``"inverse"``: inverse depth,
        e.g. an 8-bit MPEG depth map read into [0, 1] (1 = nearest plane); ``"disparity"``: pixels,
        ``x_left - x_right``. NaN = unknown.
    kind : {"metric", "inverse", "disparity"}

    Returns
    -------
    (H, W) float32
        ``1/Z`` (metric) or the input itself (a new array).

    Raises
    ------
    ValueError
        Not 2-D, inf values, no known value, metric depth below ``MIN_METRIC_DEPTH`` (or <= 0),
        inverse depth outside ``INVERSE_DEPTH_RANGE`` [0, 1].

    Notes
    -----
    MPEG's 8-bit depth stores ``1/Z = (v/255)(1/Z_near - 1/Z_far) + 1/Z_far`` (Fehn 2004; S1 Sec. IV.C): ``v`` is
    an affine function of ``1/Z``, which any linear psi absorbs.

    Examples
    --------
    >>> nearness_from_depth([[2.0, 4.0]]).tolist()
    [[0.5, 0.25]]
    """
    if kind not in DEPTH_KINDS:
        raise ValueError(f"kind must be one of {', '.join(DEPTH_KINDS)}; got {kind!r}")
    d = check_map("depth", depth)
    lo = float(np.nanmin(d))
    if kind == "inverse":
        hi = float(np.nanmax(d))
        if lo < INVERSE_DEPTH_RANGE[0] or hi > INVERSE_DEPTH_RANGE[1]:
            raise ValueError(
                f"depth must lie in [0, 1] for inverse depth (0 = the far plane, 1 = the near one; Fehn 2004); "
                f"got [{lo:g}, {hi:g}]"
            )
    if kind != "metric":
        return d.copy() if d is depth else d
    if lo <= 0:
        raise ValueError(f"depth must be > 0 metres where known (metric depth; NaN = unknown); got min {lo:g}")
    if lo < MIN_METRIC_DEPTH:
        raise ValueError(
            f"depth must be >= {MIN_METRIC_DEPTH:.3g} (MIN_METRIC_DEPTH: 1/depth must be a finite float32); got min {lo:g}"
        )
    return np.float32(1.0) / d


@dataclass(frozen=True, slots=True, eq=False)  # holds an array: identity equality
class ParallaxPlan:
    """Screen parallax chosen for a 2D + depth image.

    Attributes
    ----------
    parallax_px : (H, W) float32
        ``P = x_r - x_l`` between the two eyes, image pixels, positive behind the screen; NaN
        where the depth is unknown.
    mapping : DisparityMapping
        The psi from input parallax ``-q`` to ``P``.
    range_px : (float, float)
        Smallest and largest ``P`` over the image.
    range_arcmin : (float, float) or None
        The same as vergence changes for the display (None without a display).
    """

    parallax_px: np.ndarray
    mapping: DisparityMapping
    range_px: tuple[float, float]
    range_arcmin: tuple[float, float] | None

    def __post_init__(self) -> None:
        if np.ndim(self.parallax_px) != 2:
            raise ValueError(f"parallax_px must have shape (H, W); got {np.shape(self.parallax_px)}")
        if not isinstance(self.mapping, DisparityMapping):
            raise TypeError(f"mapping must be a DisparityMapping; got {type(self.mapping).__name__}")
        for name in ("range_px", "range_arcmin"):
            value = getattr(self, name)
            if value is None and name == "range_arcmin":
                continue
            pair = _finite_pair(name, value)
            if not pair[0] <= pair[1]:
                raise ValueError(f"{name} must be (min, max) with min <= max; got {value}")
            object.__setattr__(self, name, pair)


def _finite_pair(name: str, value: object) -> tuple[float, float]:
    """``value`` as a pair of finite floats ``(a, b)``."""
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise ValueError(f"{name} must be a pair (min, max); got {value!r}")
    return check_finite(f"{name}[0]", value[0]), check_finite(f"{name}[1]", value[1])


def _display_px(display: Display, image_width: int) -> float:
    """Display pixels per image pixel when the image fills the screen width."""
    return check_display(display, resolution=True).resolution / image_width


def plan_parallax(
    depth: object,
    *,
    kind: str = "metric",
    budget_px: float | None = None,
    budget_arcmin: float | None = None,
    display: Display | None = None,
    convergence: float | None = None,
    focal_px: float | None = None,
    interaxial: float | None = None,
    mapping: DisparityMapping | None = None,
) -> ParallaxPlan:
    """Screen parallax of every pixel from its depth, by one of the three controls of the module.

    Parameters
    ----------
    depth : (H, W) array
        See :func:`nearness_from_depth`.
    kind : {"metric", "inverse", "disparity"}
    budget_px : float, optional
        Budget mode: ``|P| <= budget_px`` image pixels.
    budget_arcmin : float, optional
        Budget mode for ``display``: ``|P| <= budget_arcmin`` of vergence change, the image shown
        across the full screen width.
    display : Display, optional
        Needed with ``budget_arcmin``; with any mode it also gives ``range_arcmin``.
    convergence : float, optional
        Depth of the zero-parallax plane, in the unit of ``depth`` (metres for metric depth).
        Budget mode: default the middle of the nearness range. Shift-sensor mode: required.
    focal_px, interaxial : float, optional
        Shift-sensor mode: focal length ``alpha_u`` in pixels and interaxial ``t_c`` in metres
        (metric depth only).
    mapping : DisparityMapping, optional
        Caller's psi from input parallax ``-q`` to ``P``.

    Returns
    -------
    ParallaxPlan

    Raises
    ------
    ValueError
        Bad depth (see :func:`nearness_from_depth`), no or several modes, missing parameters, a
        budget arcmin without a display, shift-sensor mode on non-metric depth, a flat depth map
        in budget mode without a convergence depth, or a parallax that cannot fit the image:
        ``|P|`` must stay below ``MAX_PARALLAX_WIDTHS`` image widths (checked on the budget, or on
        the range a shift-sensor set-up or mapping gives, before the map is computed).

    Notes
    -----
    Shift-sensor parallax ``P = alpha_u t_c (1/Z_c - 1/Z)`` (Fehn 2004; S1 Table I); linear
    range-to-range psi (Lang et al. 2010).

    Examples
    --------
    >>> import numpy as np
    >>> plan = plan_parallax(np.tile([[1.0, 2.0, 4.0]], (1, 8)), budget_px=10.0)  # 24 px wide
    >>> [round(float(v), 3) for v in plan.parallax_px[0, :3]], plan.range_px
    ([-10.0, 3.333, 10.0], (-10.0, 10.0))
    """
    q = nearness_from_depth(depth, kind=kind)
    modes = [
        name
        for name, given in (
            ("budget", budget_px is not None or budget_arcmin is not None),
            ("shift-sensor", focal_px is not None or interaxial is not None),
            ("mapping", mapping is not None),
        )
        if given
    ]
    if len(modes) != 1:
        raise ValueError(
            "give exactly one control: budget_px or budget_arcmin, focal_px with interaxial, or mapping; "
            f"got {', '.join(modes) if modes else 'none'}"
        )
    if display is not None:
        check_display(display)
    q_min, q_max = float(np.nanmin(q)), float(np.nanmax(q))
    p_min, p_max = -q_max, -q_min  # input parallax p = -q: uncrossed positive, like P
    p_c = None
    if convergence is not None:
        c = check_finite("convergence", convergence)
        if kind == "metric":
            c = check_positive("convergence", c)
            if c < MIN_METRIC_DEPTH:
                raise ValueError(f"convergence must be at least {MIN_METRIC_DEPTH:g} m (MIN_METRIC_DEPTH); got {c:g}")
            p_c = -1.0 / c
        else:
            p_c = -c
    width = q.shape[1]
    limit = MAX_PARALLAX_WIDTHS * width
    if modes == ["budget"]:
        psi = _budget_mapping(p_min, p_max, p_c, budget_px, budget_arcmin, display, width)
    elif modes == ["shift-sensor"]:
        if kind != "metric":
            raise ValueError(f"focal_px and interaxial need metric depth (kind='metric'); got kind={kind!r}")
        if focal_px is None or interaxial is None or p_c is None:
            raise ValueError("the shift-sensor control needs focal_px, interaxial and convergence together")
        f, t = check_positive("focal_px", focal_px), check_positive("interaxial", interaxial)
        gain = f * t
        # P = alpha_u t_c (1/Z_c - 1/Z) = gain (p - p_c) (Fehn 2004), at the two ends of the range.
        ends = (gain * (p_min - p_c), gain * (p_max - p_c))
        if not all(math.isfinite(e) and abs(e) < limit for e in ends):
            raise ValueError(
                f"focal_px {f:g} with interaxial {t:g} and convergence {convergence:g} gives parallaxes of "
                f"{ends[0]:.4g} .. {ends[1]:.4g} px, which must stay within +-{limit:g} px, "
                f"{MAX_PARALLAX_WIDTHS:g} image width (MAX_PARALLAX_WIDTHS): a point with a parallax of a "
                "whole width cannot appear in both views; lower the focal length or the interaxial"
            )
        if not gain * max(p_max - p_c, p_c - p_min) >= MIN_PARALLAX_PX:
            raise ValueError(
                f"focal_px {f:g} with interaxial {t:g} and convergence {convergence:g} gives parallaxes of "
                f"{ends[0]:.4g} .. {ends[1]:.4g} px, less than {MIN_PARALLAX_PX:g} px (MIN_PARALLAX_PX): "
                "every view would be the source image; raise the focal length or the interaxial"
            )
        psi = LinearMapping(p_c, p_c + 1.0, 0.0, gain)
    else:
        if not isinstance(mapping, DisparityMapping):
            raise TypeError(f"mapping must be a DisparityMapping; got {type(mapping).__name__}")
        psi = mapping
    # psi(-q) in float64 (a steep psi on a narrow nearness range overflows float32 before the
    # offset brings it back), the fit checked, then stored as float32.
    with np.errstate(over="ignore", invalid="ignore"):
        if isinstance(psi, LinearMapping):
            parallax64 = q.astype(np.float64)
            parallax64 *= -psi.gain
            parallax64 += psi.target_min - psi.gain * psi.source_min
        else:
            parallax64 = np.asarray(psi(-q.astype(np.float64)), dtype=np.float64)
    if isinstance(psi, LinearMapping):
        lo, hi = float(psi(p_min)), float(psi(p_max))  # exact ends (the budget itself)
    else:
        lo, hi = float(np.nanmin(parallax64)), float(np.nanmax(parallax64))
    if not (math.isfinite(lo) and math.isfinite(hi) and max(-lo, hi) < limit):
        raise ValueError(
            f"mapping gives parallaxes of {lo:.4g} .. {hi:.4g} px, which must stay within +-{limit:g} px, "
            f"{MAX_PARALLAX_WIDTHS:g} image width (MAX_PARALLAX_WIDTHS): a point with a parallax of a whole "
            "width cannot appear in both views"
        )
    parallax = parallax64.astype(np.float32)
    arcmin = None
    if display is not None:
        scale = _display_px(display, width)
        arcmin = (float(arcmin_from_pixels(lo * scale, display)), float(arcmin_from_pixels(hi * scale, display)))
    return ParallaxPlan(parallax_px=parallax, mapping=psi, range_px=(lo, hi), range_arcmin=arcmin)


def _budget_mapping(
    p_min: float,
    p_max: float,
    p_c: float | None,
    budget_px: float | None,
    budget_arcmin: float | None,
    display: Display | None,
    width: int,
) -> LinearMapping:
    """Linear psi fitting ``[p_min, p_max]`` into ``[-B, B]`` (zero at ``p_c`` when given)."""
    if budget_px is not None and budget_arcmin is not None:
        raise ValueError("give budget_px or budget_arcmin, not both")
    limit = MAX_PARALLAX_WIDTHS * width
    fit = (
        f"{MAX_PARALLAX_WIDTHS:g} image width (MAX_PARALLAX_WIDTHS) of a {width}-px-wide image: a point "
        "with a parallax of a whole width cannot appear in both views"
    )
    if budget_arcmin is not None:
        if display is None:
            raise ValueError("budget_arcmin needs a display (pixels per arcminute depend on it)")
        a = check_positive("budget_arcmin", budget_arcmin)
        per_px = _display_px(display, width)
        # The budget is the smaller side of the exact conversion (below), so it fits while either
        # side's angle at the limit is larger than a.
        a_max = max(
            float(arcmin_from_pixels(limit * per_px, display)), -float(arcmin_from_pixels(-limit * per_px, display))
        )
        if a >= a_max:
            raise ValueError(
                f"budget_arcmin must be < {a_max:.4g} arcmin on this display, {limit:g} px, {fit}; got {a:g}"
            )
        b = float(pixels_from_arcmin(a, display)) / per_px
        # Crossed side: the exact conversion is not symmetric; keep the smaller magnitude.
        b = min(b, -float(pixels_from_arcmin(-a, display)) / per_px)
        if not b >= MIN_PARALLAX_PX:
            raise ValueError(f"budget_arcmin {a:g} is {b:g} px on this display, less than {MIN_PARALLAX_PX:g} px "
                             "(MIN_PARALLAX_PX): every view would be the source image")
    else:
        b = check_positive("budget_px", budget_px)
        if not b >= MIN_PARALLAX_PX:
            raise ValueError(f"budget_px must be at least {MIN_PARALLAX_PX:g} px (MIN_PARALLAX_PX): every view "
                             f"would be the source image; got {b:g}")
        if b >= limit:
            raise ValueError(f"budget_px must be < {limit:g} px, {fit}; got {b:g}")
    if p_c is None:
        if p_max == p_min:
            raise ValueError(
                "depth must vary for a disparity budget without a convergence depth; got a flat map "
                f"(nearness {-p_min:g} everywhere)"
            )
        return LinearMapping(p_min, p_max, -b, b)
    span = max(p_c - p_min, p_max - p_c)
    if span <= 0:
        raise ValueError("depth must not be flat at the convergence depth for a disparity budget")
    return LinearMapping(p_c - span, p_c + span, -b, b)


def views_offsets(views: int, *, origin: str = "center") -> tuple[float, ...]:
    """Positions of ``views`` views in units of the pair parallax: adjacent views differ by 1.

    ``"center"``: symmetric about the original image (which is the middle view for odd counts);
    ``"left"``: the original image is view 0.
    """
    if isinstance(views, int | np.integer) and not isinstance(views, bool) and not 2 <= views <= MAX_VIEWS:
        raise ValueError(f"views must lie in [2, {MAX_VIEWS}] (MAX_VIEWS); got {views}")
    n = check_positive_int("views", views)
    if origin == "center":
        return tuple(i - (n - 1) / 2.0 for i in range(n))
    if origin == "left":
        return tuple(float(i) for i in range(n))
    raise ValueError(f"origin must be one of center, left; got {origin!r}")

