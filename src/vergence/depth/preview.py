"""A colour picture of a disparity map, for a person to look at (not for measurement)."""

from __future__ import annotations

import cv2
import numpy as np

from vergence._validate import as_float_array

__all__ = ["disparity_preview"]


def disparity_preview(disparity: object, *, lo: float, hi: float) -> np.ndarray:
    """Turbo colour map of ``disparity`` over ``[lo, hi]`` (clipped), black where unknown (NaN).

    Parameters
    ----------
    disparity : (H, W) array
        Disparity, pixels; NaN = unknown.
    lo, hi : float
        The disparities shown as the two ends of the colour map; ``hi > lo``.

    Returns
    -------
    (H, W, 3) float32
        RGB in [0, 1].

    Examples
    --------
    >>> disparity_preview(np.array([[np.nan]]), lo=0.0, hi=1.0).tolist()
    [[[0.0, 0.0, 0.0]]]
    """
    d = as_float_array("disparity", disparity, allow_nan=True, dtype=np.float32)
    if d.ndim != 2 or 0 in d.shape:
        raise ValueError(f"disparity must have shape (H, W); got {d.shape}")
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"hi must be finite and greater than lo; got lo={lo}, hi={hi}")
    scaled = np.clip((np.nan_to_num(d, nan=lo) - lo) / (hi - lo), 0.0, 1.0)
    rgb = cv2.applyColorMap(np.rint(scaled * 255).astype(np.uint8), cv2.COLORMAP_TURBO)[:, :, ::-1]
    rgb = rgb.astype(np.float32) / 255.0
    rgb[~np.isfinite(d)] = 0.0
    return rgb
