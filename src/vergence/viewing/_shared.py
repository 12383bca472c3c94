"""The ranges, argument checks and formulas the viewing modules share: internal API of :mod:`vergence.viewing`.

Users meet the ranges as :data:`vergence.viewing.LENGTH_RANGE` and friends (re-exported by
:mod:`~vergence.viewing.geometry`) and the checks through the messages of the public functions. The
formulas here take arrays already checked: each public function validates once, then calls them
(``docs/conventions.md``; lengths in metres, disparities in image widths).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from vergence._validate import as_float_array, check_positive

if TYPE_CHECKING:
    from vergence.viewing.geometry import Display, Shooting

__all__ = [
    "IN_FRONT_OF_VIEWER",
    "LENGTH_RANGE",
    "MAX_ABS_DISPARITY",
    "MAX_SCENE_DEPTH",
    "ROUNDNESS_RANGE",
    "check_depths",
    "check_disparities",
    "check_length",
    "check_length_or_inf",
    "check_roundness",
    "check_scene_depths",
    "check_type",
    "depth_ratio",
    "disparity_array",
    "float_or_array",
    "perceived_depth_array",
    "real_array",
]

# Rig and display lengths (b, H, W, b', H', W'), metres: a micrometre to a thousand kilometres. Every
# figure of Eq. (1)-(6) is a product or ratio of at most four lengths and one depth, so inside these
# ranges each stays between 1e-50 and 1e50: finite and normal in float64 (no overflow to inf, no
# underflow to 0, no numpy warnings). Lengths outside are refused, never clamped.
LENGTH_RANGE = (1e-6, 1e6)

# Scene depths run from LENGTH_RANGE[0] to MAX_SCENE_DEPTH (1e20 m, far beyond any scene; the budget of a
# point at infinity is its limit, b/W).
MAX_SCENE_DEPTH = 1e20

# Largest |d| accepted as an input disparity, in image widths (S0's normalised disparity). A rig inside
# LENGTH_RANGE gives |d(z)| = (b/W)|1 - H/z| <= 1e24 at the depths allowed, so 1e30 refuses no real
# disparity, and it keeps 1 - d/(b/W) and Eq. (1b) finite (|d| W/b <= 1e42): no overflow warnings.
MAX_ABS_DISPARITY = 1e30

# Roundness factors rho (S0 Eq. 4 and 9) a user may ask for: 1 is round, CARDBOARD_ROUNDNESS flat. A
# thousandth to a thousand times round covers every look a director wants (S0 §6 uses 0.5 to 2); past
# it, psi' = rho z b'/(b_r z') sends the mapped disparities to thousands of image widths (issue 9:
# roundness 1e9 gave crossed disparities of -3e8 widths). Outside is refused, never clamped.
ROUNDNESS_RANGE = (1e-3, 1e3)


# ------------------------------------------------------------------------------- argument checks
def check_length(name: str, value: object, bounds: tuple[float, float] = LENGTH_RANGE, unit: str = "m") -> float:
    """``value`` as a float in ``bounds`` (default :data:`LENGTH_RANGE`, metres), else ValueError."""
    v = check_positive(name, value)
    if not bounds[0] <= v <= bounds[1]:
        raise ValueError(f"{name} must lie in [{bounds[0]:g}, {bounds[1]:g}]{' ' + unit if unit else ''}; got {v:g}")
    return v


def check_roundness(name: str, value: object) -> float:
    """``value`` as a float in :data:`ROUNDNESS_RANGE`, else ValueError (TypeError for a non-number)."""
    return check_length(name, value, ROUNDNESS_RANGE, "")


def check_type(name: str, value: object, cls: type) -> None:
    """TypeError naming the argument unless ``value`` is a ``cls`` (never an AttributeError later)."""
    if not isinstance(value, cls):
        raise TypeError(f"{name} must be a {cls.__name__}; got {type(value).__name__}")


def real_array(name: str, value: object, *, allow_nan: bool = False, allow_inf: bool = False) -> np.ndarray:
    """:func:`~vergence._validate.as_float_array` that also refuses text (numpy would read ``'30'`` as 30.0): TypeError.

    ``allow_inf`` lets +-inf (and NaN) through unchecked, for callers that check them themselves."""
    try:
        kind = np.asarray(value).dtype.kind
    except (TypeError, ValueError):  # ragged nesting and the like
        kind = "O"
    if isinstance(value, str | bytes) or kind in "USO":
        raise TypeError(f"{name} must be numeric; got {type(value).__name__}")
    if allow_inf:
        return np.asarray(value, dtype=np.float64)
    return as_float_array(name, value, allow_nan=allow_nan)


def check_disparities(name: str, d: object, unit: str = " image widths") -> np.ndarray:
    """Finite disparities (image widths) with ``|d| <=`` :data:`MAX_ABS_DISPARITY`."""
    arr = real_array(name, d)
    if arr.size and np.abs(arr).max() > MAX_ABS_DISPARITY:
        raise ValueError(f"{name} must lie in [-{MAX_ABS_DISPARITY:g}, {MAX_ABS_DISPARITY:g}]{unit}; "
                         f"got {arr.flat[np.abs(arr).argmax()]:g}")
    return arr


def check_depths(name: str, z: object) -> np.ndarray:
    """Finite scene depths in ``[LENGTH_RANGE[0], MAX_SCENE_DEPTH]`` metres."""
    arr = real_array(name, z)
    if (arr <= 0).any():
        raise ValueError(f"{name} must be > 0 (in front of the cameras); got min {arr.min():g}")
    if arr.size and (arr.min() < LENGTH_RANGE[0] or arr.max() > MAX_SCENE_DEPTH):
        bad = arr.min() if arr.min() < LENGTH_RANGE[0] else arr.max()
        raise ValueError(f"{name} must lie in [{LENGTH_RANGE[0]:g}, {MAX_SCENE_DEPTH:g}] m; got {bad:g}")
    return arr


def check_length_or_inf(name: str, value: object, *, where: str = "in front of the camera") -> float:
    """A length > 0 in ``[LENGTH_RANGE[0], MAX_SCENE_DEPTH]`` metres, or +inf (an infinitely far point)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number; got {type(value).__name__}")
    v = float(value)
    if math.isnan(v) or v <= 0:
        raise ValueError(f"{name} must be > 0 ({where}); got {v:g}")
    if math.isfinite(v) and not LENGTH_RANGE[0] <= v <= MAX_SCENE_DEPTH:
        raise ValueError(f"{name} must lie in [{LENGTH_RANGE[0]:g}, {MAX_SCENE_DEPTH:g}] m or be inf; got {v:g}")
    return v


def check_scene_depths(name: str, z: object) -> np.ndarray:
    """Scene depths >= ``LENGTH_RANGE[0]`` metres, +inf allowed (an infinitely far point)."""
    arr = real_array(name, z, allow_nan=True, allow_inf=True)
    if np.isnan(arr).any() or (arr <= 0).any():
        bad = arr[np.isnan(arr) | (arr <= 0)].flat[0]
        raise ValueError(f"{name} must be > 0 (in front of the camera; inf allowed); got {bad:g}")
    if (arr < LENGTH_RANGE[0]).any():  # 1/z of Eq. (9) would overflow near 5e-324
        raise ValueError(f"{name} must be >= {LENGTH_RANGE[0]:g} m (LENGTH_RANGE; inf allowed); "
                         f"got {arr[arr < LENGTH_RANGE[0]].flat[0]:g}")
    return arr


# A perceived depth <= 0 would need psi > b'/W': the eyes would diverge (S0 Eq. 8).
IN_FRONT_OF_VIEWER = "in front of the viewer; a negative one is past the divergence limit b'/W'"


# ---------------------------------------------------------- formulas on checked arrays, results
def float_or_array(arr: np.ndarray) -> float | np.ndarray:
    """A 0-d result as a Python float; arrays as they are (scalar in, float out)."""
    return float(arr) if arr.ndim == 0 else arr


def depth_ratio(numerator: float | np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """``numerator / denominator`` where the denominator is > 0, ``inf`` where it is exactly 0 (parallel
    rays: a point at infinity) and NaN where it is negative (the rays meet behind: no such depth).

    The callers write their denominators so that the sign, and an exact 0 at the limit, are exact.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = numerator / denominator
    return np.where(denominator > 0, ratio, np.where(denominator == 0, np.inf, np.nan))


def perceived_depth_array(d: np.ndarray, display: Display) -> np.ndarray:
    """S0 Eq. (1b) on a validated array (see :func:`~vergence.viewing.geometry.perceived_depth`)."""
    # Written as H' / (1 - d/(b'/W')): the gap is exactly 0 at d == b'/W' (Display.divergence_disparity),
    # so parallel eyes give inf, not a huge finite depth (b' - W'(b'/W') need not round to 0).
    return depth_ratio(display.distance, 1.0 - d / display.divergence_disparity)


def disparity_array(z: np.ndarray, reference: Shooting) -> np.ndarray:
    """S0 Eq. (1a) on a validated array, with ``d(inf) = b/W``."""
    finite = np.isfinite(z)
    d = np.full(z.shape, reference.baseline / reference.window)
    # Eq. (1a) as b/W (1 - H/z)-like ratio (z - H)/z: finite for every z > 0, including the depths past
    # MAX_SCENE_DEPTH that inverting a grid of disparities near b/W produces (no range check here).
    d[finite] = (reference.baseline / reference.window) * ((z[finite] - reference.convergence) / z[finite])
    return d
