"""Shooting and viewing geometry of a stereoscopic pair (S0 §2, Eq. (1)–(6); Devernay & Beardsley 2010; S1 §IV.C).

The model is the parallel-camera, shifted-sensor rig of Devernay & Beardsley: two cameras a
baseline ``b`` apart whose frusta meet the convergence plane at distance ``H`` in the same window
of width ``W``; the pair is shown to eyes ``b'`` apart at distance ``H'`` from a screen of width
``W'``. Disparity ``d = x_r - x_l`` is a fraction of the image width, positive (uncrossed) behind
the convergence plane. All lengths are in metres.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from vergence._validate import check_positive, check_positive_int
from vergence.viewing._shared import (  # the ranges are public here, in __all__
    LENGTH_RANGE,
    MAX_ABS_DISPARITY,
    MAX_SCENE_DEPTH,
    ROUNDNESS_RANGE,
    check_depths,
    check_disparities,
    check_length,
    check_roundness,
    check_type,
    depth_ratio,
    float_or_array,
    perceived_depth_array,
    real_array,
)

__all__ = [
    "CARDBOARD_ROUNDNESS",
    "CONTROL_EFFECTS",
    "DISPLAY_PRESETS",
    "Display",
    "LENGTH_RANGE",
    "MAX_ABS_DISPARITY",
    "MAX_SCENE_DEPTH",
    "ROUNDNESS_RANGE",
    "Shooting",
    "check_display",
    "disparity",
    "divergence_baseline",
    "divergence_depth",
    "focal_ratio",
    "perceived_depth",
    "perceived_depth_from_depth",
    "roundness",
    "roundness_baseline",
    "scene_depth_from_disparity",
    "shift_sensor_parallax",
    "shift_sensor_positions",
]

# focal_mm and sensor_mm of Shooting.from_focal, millimetres: LENGTH_RANGE in millimetres.
_MM_RANGE = (1e-3, 1e9)

# The paper's cardboard criterion (S0 §2): roundness below this looks like a flat cut-out.
CARDBOARD_ROUNDNESS = 0.3


@dataclass(frozen=True, slots=True)
class Shooting:
    """Acquisition geometry (S0 Fig. 1): baseline ``b``, convergence distance ``H``, window width ``W``.

    Examples
    --------
    >>> Shooting.from_focal(baseline=0.1, convergence=30.0, focal_mm=350.0, sensor_mm=35.0).window
    3.0
    """

    baseline: float
    convergence: float
    window: float

    def __post_init__(self) -> None:
        for name in ("baseline", "convergence", "window"):
            object.__setattr__(self, name, check_length(name, getattr(self, name)))

    @classmethod
    def from_focal(cls, *, baseline: float, convergence: float, focal_mm: float, sensor_mm: float) -> Shooting:
        """Build from a physical focal length F and sensor width S: ``f = F/S = H/W`` (S0 §2)."""
        f = check_length("focal_mm", focal_mm, _MM_RANGE, "mm") / check_length("sensor_mm", sensor_mm, _MM_RANGE, "mm")
        return cls(baseline=baseline, convergence=convergence, window=check_length("convergence", convergence) / f)

    @property
    def focal(self) -> float:
        """Normalised focal length ``f = H / W``."""
        return self.convergence / self.window


@dataclass(frozen=True, slots=True)
class Display:
    """Viewing geometry (S0 Fig. 1): eye separation ``b'``, viewing distance ``H'``, screen width ``W'``.

    ``resolution`` is the horizontal pixel count, needed for conversions to pixels and arcminutes.

    Examples
    --------
    >>> Display(eye_separation=0.065, distance=3.0, width=1.2).focal
    2.5
    """

    eye_separation: float
    distance: float
    width: float
    resolution: int | None = None

    def __post_init__(self) -> None:
        for name in ("eye_separation", "distance", "width"):
            object.__setattr__(self, name, check_length(name, getattr(self, name)))
        if self.resolution is not None:
            object.__setattr__(self, "resolution", check_positive_int("resolution", self.resolution))

    @classmethod
    def preset(cls, name: str) -> Display:
        """A named display from :data:`DISPLAY_PRESETS`; the error lists the valid names."""
        try:
            return DISPLAY_PRESETS[name]
        except (KeyError, TypeError):
            valid = ", ".join(sorted(DISPLAY_PRESETS))
            raise ValueError(f"unknown display preset {name!r}; valid presets: {valid}") from None

    @property
    def focal(self) -> float:
        """Normalised projection focal length ``f' = H' / W'``."""
        return self.distance / self.width

    @property
    def divergence_disparity(self) -> float:
        """Largest disparity (fraction of W') before the eyes diverge: ``b'/W'`` (S0 Eq. 8)."""
        return self.eye_separation / self.width

    @property
    def pixel_pitch(self) -> float:
        """Width of one pixel in metres; needs ``resolution``."""
        return self.width / check_display(self, resolution=True).resolution


def check_display(display: object, *, name: str = "display", resolution: bool = False) -> Display:
    """``display`` itself if it is a :class:`Display` (with a known ``resolution`` when asked), else an error.

    The one check of a display argument that every public function of the package runs, so that all
    speak alike.

    Parameters
    ----------
    display : object
        The argument to check.
    name : str, optional
        The argument's name in the message (default ``"display"``; e.g. ``"target_display"``).
    resolution : bool, optional
        Whether the horizontal pixel count must be known (conversions to pixels and arcminutes).

    Returns
    -------
    Display
        ``display``, unchanged.

    Raises
    ------
    TypeError
        If ``display`` is not a :class:`Display`: ``"NAME must be a vergence.viewing.Display; got TYPE"``.
    ValueError
        If ``resolution`` is true and ``display.resolution`` is None:
        ``"NAME resolution is unknown: give the screen width in pixels"``.

    Examples
    --------
    >>> check_display(Display(0.065, 3.0, 1.2, resolution=1920), resolution=True).resolution
    1920
    >>> check_display("tv-55", name="target_display")
    Traceback (most recent call last):
        ...
    TypeError: target_display must be a vergence.viewing.Display; got str
    >>> check_display(Display(0.065, 3.0, 1.2), resolution=True)
    Traceback (most recent call last):
        ...
    ValueError: display resolution is unknown: give the screen width in pixels
    """
    if not isinstance(display, Display):
        raise TypeError(f"{name} must be a vergence.viewing.Display; got {type(display).__name__}")
    if resolution and display.resolution is None:
        raise ValueError(f"{name} resolution is unknown: give the screen width in pixels")
    return display


# Typical viewing set-ups; eye separation 65 mm (adult mean). Screen widths are the diagonal times
# a / sqrt(a^2 + b^2) for an a:b aspect ratio, to 0.1 mm; distances as commonly recommended for each screen.
# Read-only (a mapping proxy of frozen Displays): no caller can change a preset for everyone else.
DISPLAY_PRESETS: Mapping[str, Display] = MappingProxyType({
    # A 10 m wide cinema screen seen from 15 m (f' = 1.5), projected in 2K DCI (2048 px).
    "cinema": Display(eye_separation=0.065, distance=15.0, width=10.0, resolution=2048),
    # 24" 16:9 monitor, 1920 x 1080, at 60 cm: 24 x 25.4 mm x 16/sqrt(337) = 0.5313 m.
    "desktop-24": Display(eye_separation=0.065, distance=0.6, width=0.5313, resolution=1920),
    # 15.6" 16:9 laptop, 1920 x 1080, at 50 cm: 15.6 x 25.4 mm x 16/sqrt(337) = 0.3454 m.
    "laptop-15": Display(eye_separation=0.065, distance=0.5, width=0.3454, resolution=1920),
    # 6.1" 20:9 phone held in landscape, 2400 x 1080 (e.g. Pixel 6a), at 30 cm:
    # 6.1 x 25.4 mm x 20/sqrt(481) = 0.1413 m.
    "phone": Display(eye_separation=0.065, distance=0.3, width=0.1413, resolution=2400),
    # S3's study display: Samsung 2233RZ, 22" 16:10, 1680 px at 0.282 mm pitch, viewed from 60 cm.
    "samsung-2233rz": Display(eye_separation=0.065, distance=0.6, width=0.47376, resolution=1680),
    # A 55" 16:9 television, 1920 x 1080, at 3 m: 55 x 25.4 mm x 16/sqrt(337) = 1.2176 m; f' = 2.46,
    # S0's living-room example.
    "tv-55": Display(eye_separation=0.065, distance=3.0, width=1.2176, resolution=1920),
})


def disparity(z: object, shooting: Shooting) -> float | np.ndarray:
    """Disparity of a point at depth ``z``, as a fraction of the window width (S0 Eq. 1a).

    ``d(z) = (b / W) (z - H) / z``: zero on the convergence plane, ``b/W`` at infinity.

    Examples
    --------
    >>> disparity(60.0, Shooting(baseline=0.2, convergence=30.0, window=2.0))
    0.05
    """
    z_ = check_depths("z", z)
    check_type("shooting", shooting, Shooting)
    return float_or_array((shooting.baseline / shooting.window) * (z_ - shooting.convergence) / z_)


def scene_depth_from_disparity(d: object, shooting: Shooting) -> float | np.ndarray:
    """Depth whose disparity is ``d``: ``z = bH / (b - W d)`` (S0 Eq. (1a) solved for z); inf at ``d = b/W``.

    Disparities at or beyond ``b/W`` have no depth in front of the cameras: NaN there (inf at equality).
    """
    d_ = check_disparities("d", d)
    check_type("shooting", shooting, Shooting)
    # Eq. (1c) as H / (1 - d/(b/W)): the gap is exactly 0 at d == b/W, so z = inf there
    # (b - W(b/W) need not round to 0).
    gap = 1.0 - d_ / (shooting.baseline / shooting.window)
    return float_or_array(depth_ratio(shooting.convergence, gap))


def perceived_depth(d: object, display: Display) -> float | np.ndarray:
    """Perceived depth of a disparity ``d`` (fraction of W') on a display (S0 Eq. 1b).

    ``z' = b'H' / (b' - W' d)``. At ``d = b'/W'`` the eyes are parallel (``z' = inf``); beyond it
    they diverge and nothing is perceived: NaN.

    Examples
    --------
    >>> perceived_depth(0.0, Display(eye_separation=0.065, distance=3.0, width=1.2))
    3.0
    """
    d_ = check_disparities("d", d)
    check_display(display)
    return float_or_array(perceived_depth_array(d_, display))


def perceived_depth_from_depth(z: object, shooting: Shooting, display: Display) -> float | np.ndarray:
    """Perceived depth of a scene point at depth ``z`` (S0 Eq. 2); NaN where the eyes diverge.

    ``z'(z) = z b'H'W / (z (b'W - bW') + bHW')``.
    """
    z_ = check_depths("z", z)
    _check_rig(shooting, display)
    den = _eq2_denominator(z_, shooting, display)
    return float_or_array(depth_ratio(z_ * display.eye_separation * display.distance * shooting.window, den))


def roundness(z: object, shooting: Shooting, display: Display) -> float | np.ndarray:
    """Roundness factor at depth ``z``: depth over width magnification (S0 Eq. 4).

    ``rho(z) = b H' W / (z (b'W - bW') + bHW')``; 1 everywhere in the orthostereoscopic set-up
    (b = b', H = H', W = W'). Below :data:`CARDBOARD_ROUNDNESS` objects look like cut-outs.
    Where the eyes diverge the denominator is negative and so is the returned value (Eq. 4 as is).

    Examples
    --------
    >>> round(roundness(30.0, Shooting(0.65, 30.0, 3.0), Display(0.065, 3.0, 1.2)), 12)
    1.0
    """
    z_ = check_depths("z", z)
    _check_rig(shooting, display)
    den = _eq2_denominator(z_, shooting, display)  # Eq. (4) shares Eq. (2)'s denominator
    with np.errstate(divide="ignore"):
        rho = shooting.baseline * display.distance * shooting.window / den
    return float_or_array(rho)


def divergence_baseline(window: float, display: Display) -> float:
    """Largest baseline with no ocular divergence at any depth: ``b_div = b'W / W'`` (S0 Eq. 3)."""
    w = check_length("window", window)
    check_display(display)
    return display.eye_separation * w / display.width


def roundness_baseline(convergence: float, display: Display, *, roundness: float = 1.0) -> float:
    """Baseline giving roundness ``rho`` on the convergence plane: ``b = rho b' H / H'`` (S0 Eq. 5)."""
    rho = check_roundness("roundness", roundness)
    h = check_length("convergence", convergence)
    check_display(display)
    return rho * display.eye_separation * h / display.distance


def focal_ratio(shooting: Shooting, display: Display) -> float:
    """``f / f' = (H/W) / (H'/W')``, which equals ``b_round / b_div`` (S0 Eq. 6)."""
    _check_rig(shooting, display)
    return shooting.focal / display.focal


def _excess(shooting: Shooting, display: Display) -> float:
    """``bW' - b'W`` where the eyes can diverge (S0 Eq. 3), else 0.

    The rig can make the eyes diverge when ``b > b_div`` with ``b_div`` as :func:`divergence_baseline`
    computes it (so that ``b`` equal to the reported ``b_div`` never diverges) and ``bW' - b'W``
    is positive in floating point; otherwise 0 (within an ulp of ``b_div``, or below it).
    """
    b, W = shooting.baseline, shooting.window
    excess = b * display.width - display.eye_separation * W
    return excess if excess > 0 and b > divergence_baseline(W, display) else 0.0


def divergence_depth(shooting: Shooting, display: Display) -> float:
    """Depth beyond which the eyes diverge: ``bHW' / (bW' - b'W)``, or inf if ``b <= b_div`` (S0 §2, Eq. 3).

    ``b`` equal to :func:`divergence_baseline` gives exactly inf. At the returned depth
    :func:`perceived_depth_from_depth` is exactly inf (parallel eyes); it is finite before it and
    NaN (divergence) after it.

    Examples
    --------
    >>> round(divergence_depth(Shooting(0.26, 30.0, 3.0), Display(0.065, 3.0, 1.2)), 9)
    80.0
    """
    _check_rig(shooting, display)
    excess = _excess(shooting, display)
    return math.inf if excess == 0 else shooting.baseline * shooting.convergence * display.width / excess


def _check_rig(shooting: object, display: object) -> None:
    check_type("shooting", shooting, Shooting)
    check_display(display)


def _eq2_denominator(z: np.ndarray, shooting: Shooting, display: Display) -> np.ndarray:
    """``z (b'W - bW') + bHW'`` of S0 Eq. (2) and (4), written so that its sign is exact.

    Without divergence (:func:`_excess` is 0) it is ``bHW' + z (b'W - bW')`` with both terms >= 0
    (``b'W - bW'`` is kept only where it is >= 0; within an ulp of ``b_div`` it is taken as 0).
    With divergence it is ``(bW' - b'W)(z_div - z)``, ``z_div`` from :func:`divergence_depth`: exactly
    0 at that depth, negative beyond it.
    """
    b, H, Wp = shooting.baseline, shooting.convergence, display.width
    excess = _excess(shooting, display)
    if excess == 0:
        return b * H * Wp + z * max(display.eye_separation * shooting.window - b * Wp, 0.0)
    return excess * (divergence_depth(shooting, display) - z)


# ---------------------------------------------------------------------------------------------
# Shift-sensor DIBR geometry (Fehn 2004; S1 §IV.C, Table I)

# S1 Table I: the effect of increasing (+1) each control on screen parallax, perceived depth and
# object size. "fore" = the scene shifts toward the viewer.
CONTROL_EFFECTS: dict[str, dict[str, str]] = {
    "interaxial": {"parallax": "increase", "perceived_depth": "increase", "object_size": "constant"},
    "focal_length": {"parallax": "increase", "perceived_depth": "increase", "object_size": "increase"},
    "convergence": {"parallax": "decrease", "perceived_depth": "shift toward viewer", "object_size": "constant"},
}


def shift_sensor_parallax(
    depth: object, *, focal_px: float, interaxial: float, convergence: float
) -> float | np.ndarray:
    """Screen parallax in pixels of the shift-sensor pair (Fehn 2004; S1 §IV.C, Table I).

    ``P = x_r - x_l = alpha_u t_c (1/Z_c - 1/Z)``: zero at the convergence distance ``Z_c``,
    positive behind it. ``focal_px`` is alpha_u, ``interaxial`` t_c (> 0) and ``convergence`` Z_c
    (metres).

    Examples
    --------
    >>> shift_sensor_parallax(4.0, focal_px=1000.0, interaxial=0.06, convergence=2.0)
    15.0
    """
    z = check_depths("depth", depth)
    a = check_positive("focal_px", focal_px)
    tc = check_length("interaxial", interaxial)
    zc = check_length("convergence", convergence)
    if not math.isfinite(a * tc / LENGTH_RANGE[0] ** 2):  # |P| <= alpha t_c (1/Z_c + 1/Z): keep it finite
        raise ValueError(f"focal_px must be <= {sys.float_info.max * LENGTH_RANGE[0] ** 2 / tc:g} with interaxial "
                         f"{tc:g} m (the parallax would overflow); got {a:g}")
    return float_or_array(a * tc * (1.0 / zc - 1.0 / z))


def shift_sensor_positions(
    x_center: object, depth: object, *, focal_px: float, interaxial: float, convergence: float
) -> tuple[np.ndarray, np.ndarray]:
    """Left and right abscissae of centre-view pixels ``x_c`` with depth ``Z`` (Fehn 2004; S1 §IV.C).

    ``x_l = x_c + (alpha_u t_c / 2)(1/Z - 1/Z_c)``, ``x_r = x_c - (alpha_u t_c / 2)(1/Z - 1/Z_c)``.
    """
    xc = real_array("x_center", x_center)
    p = np.asarray(shift_sensor_parallax(depth, focal_px=focal_px, interaxial=interaxial, convergence=convergence))
    if p.shape != xc.shape and p.ndim and xc.ndim:
        raise ValueError(f"depth must have shape {xc.shape} matching x_center; got {p.shape}")
    return xc - p / 2.0, xc + p / 2.0
