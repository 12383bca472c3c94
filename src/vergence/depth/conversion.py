"""Depth from disparity and back for a rectified pair (S1 Eq. 7).

For rectified cameras with focal length f (pixels) and baseline b, a point at depth Z (camera-frame
z) has disparity ``d = f b / Z - doffs`` where ``doffs = cx_right - cx_left`` (0 when both cameras
share their principal point). Depth in the units of b (metres), disparity in pixels
(``docs/conventions.md``); NaN marks invalid values in both directions.
"""

from __future__ import annotations

import math

import numpy as np

from vergence._validate import as_float_array, check_finite, check_positive

__all__ = ["depth_from_disparity", "disparity_from_depth"]


def depth_from_disparity(disparity: object, *, focal_px: float, baseline: float, doffs_px: float = 0.0) -> np.ndarray:
    """Depth ``Z = f b / (d + doffs)`` of each pixel of a disparity map (S1 Eq. 7).

    Parameters
    ----------
    disparity : array
        Disparity ``x_left - x_right``, pixels; NaN = unknown.
    focal_px : float
        Focal length of the rectified pair, pixels (> 0).
    baseline : float
        Distance between the camera centres, metres (> 0).
    doffs_px : float
        ``cx_right - cx_left`` of the rectified cameras (``Rectification.doffs_px``).

    Returns
    -------
    float64 array
        Depth in metres; NaN where the disparity is unknown or ``d + doffs <= 0`` (at or beyond infinity),
        and where ``d + doffs`` is so small that ``f b / (d + doffs)`` passes the largest float (as far as infinity).

    Raises
    ------
    ValueError
        A disparity with no finite value (nothing to convert), or ``focal_px * baseline`` past the float range.

    Examples
    --------
    >>> depth_from_disparity(np.array([10.0, 0.0, np.nan]), focal_px=1000.0, baseline=0.1).tolist()
    [10.0, nan, nan]
    """
    d = as_float_array("disparity", disparity, allow_nan=True)
    fb = _focal_baseline(focal_px, baseline)
    off = check_finite("doffs_px", doffs_px)
    if not np.isfinite(d).any():
        raise ValueError("disparity has no finite value")
    shifted = d + off
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        z = np.where(shifted > 0, fb / shifted, np.nan)  # Eq. (7): Z = K C / (m1 - m2)
    z[np.isinf(z)] = np.nan  # beyond the largest float: as far as infinity (d + doffs -> 0+)
    return z


def disparity_from_depth(depth: object, *, focal_px: float, baseline: float, doffs_px: float = 0.0) -> np.ndarray:
    """Disparity ``d = f b / Z - doffs`` of each pixel of a depth map (inverse of :func:`depth_from_disparity`).

    Depth must be > 0 where known (NaN = unknown, and stays NaN); ``inf`` is refused.

    Raises
    ------
    ValueError
        A depth with no finite value, a depth <= 0, a depth so small that ``f b / Z`` passes the largest
        float, or ``focal_px * baseline`` past the float range.

    Examples
    --------
    >>> disparity_from_depth(np.array([10.0, np.nan]), focal_px=1000.0, baseline=0.1).tolist()
    [10.0, nan]
    """
    z = as_float_array("depth", depth, allow_nan=True)
    fb = _focal_baseline(focal_px, baseline)
    off = check_finite("doffs_px", doffs_px)
    if not np.isfinite(z).any():
        raise ValueError("depth has no finite value")
    with np.errstate(invalid="ignore"):
        if (z <= 0).any():
            raise ValueError("depth must be > 0 where known; use NaN for unknown")
    with np.errstate(over="ignore"):
        d = fb / z - off  # Eq. (7) solved for m1 - m2
    if np.isinf(d).any():
        raise ValueError(f"depth must be large enough for a finite disparity focal_px * baseline / depth; "
                         f"got {float(np.nanmin(z)):g} m")
    return d


def _focal_baseline(focal_px: object, baseline: object) -> float:
    """``f b`` of Eq. (7), checked: both > 0 and their product a finite float."""
    f = check_positive("focal_px", focal_px)
    b = check_positive("baseline", baseline)
    if not math.isfinite(f * b):
        raise ValueError(f"baseline times focal_px must be a finite number; got {b:g} m x {f:g} px")
    return f * b
