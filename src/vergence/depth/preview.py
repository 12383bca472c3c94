"""A colour picture of a disparity map, for a person to look at (not for measurement)."""

from __future__ import annotations

import cv2
import numpy as np

from vergence._validate import as_float_array, check_bool

__all__ = ["disparity_preview"]


# The colour bar under a preview: its height as a fraction of the image height (at least
# _BAR_MIN_PX), and the label strip below it, whose Hershey text is _LABEL_PX tall at scale 1.
_BAR_FRACTION = 0.05
_BAR_MIN_PX = 8
_LABEL_PX = 22


def _turbo(scaled: np.ndarray) -> np.ndarray:
    """Turbo RGB in [0, 1] of values in [0, 1]."""
    rgb = cv2.applyColorMap(np.rint(np.clip(scaled, 0.0, 1.0) * 255).astype(np.uint8), cv2.COLORMAP_TURBO)
    return rgb[..., ::-1].astype(np.float32) / 255.0


def _colour_bar(width: int, height: int, lo: float, hi: float) -> np.ndarray:
    """A ``lo`` -> ``hi`` turbo ramp ``width`` wide, then a black strip with the labels lo, mid, hi (px)."""
    bar_h = max(_BAR_MIN_PX, round(_BAR_FRACTION * height))
    ramp = np.broadcast_to(np.linspace(0.0, 1.0, width, dtype=np.float32)[None, :], (bar_h, width))
    scale = max(0.4, min(1.0, width / 800.0))
    label_h = round(_LABEL_PX * scale) + 6
    labels = np.zeros((label_h, width, 3), np.uint8)
    texts = [f"{lo:g}", f"{(lo + hi) / 2:g}", f"{hi:g} px"]
    font = cv2.FONT_HERSHEY_SIMPLEX
    for k, text in enumerate(texts):
        (tw, _), _ = cv2.getTextSize(text, font, scale, 1)
        x = (0, (width - tw) // 2, width - tw)[k]
        cv2.putText(labels, text, (max(0, x), label_h - 4), font, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return np.concatenate([_turbo(ramp), labels.astype(np.float32) / 255.0], axis=0)


def disparity_preview(disparity: object, *, lo: float, hi: float, colour_bar: bool = False) -> np.ndarray:
    """Turbo colour map of ``disparity`` over ``[lo, hi]`` (clipped), black where unknown (NaN).

    Parameters
    ----------
    disparity : (H, W) array
        Disparity, pixels; NaN = unknown.
    lo, hi : float
        The disparities shown as the two ends of the colour map; ``hi > lo``.
    colour_bar : bool
        Add a colour bar under the map: the ``lo`` -> ``hi`` ramp across the full width (about 5 % of
        the height), then the values of its two ends and middle in pixels.

    Returns
    -------
    (H, W, 3) float32, or (H + bar, W, 3) with the colour bar
        RGB in [0, 1].

    Raises
    ------
    ValueError
        A disparity of another shape or without any finite value (nothing to show), ``hi <= lo``.
    TypeError
        ``lo``/``hi`` not real numbers, ``colour_bar`` not a bool.

    Examples
    --------
    >>> disparity_preview(np.array([[np.nan, 1.0]]), lo=0.0, hi=1.0)[0, 0].tolist()
    [0.0, 0.0, 0.0]
    >>> disparity_preview(np.zeros((100, 200)), lo=0.0, hi=16.0, colour_bar=True).shape
    (123, 200, 3)
    """
    d = as_float_array("disparity", disparity, allow_nan=True, dtype=np.float32)
    if d.ndim != 2 or 0 in d.shape:
        raise ValueError(f"disparity must have shape (H, W); got {d.shape}")
    if not np.isfinite(d).any():
        raise ValueError("disparity has no finite value")
    for name, v in (("lo", lo), ("hi", hi)):
        if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
            raise TypeError(f"{name} must be a real number of pixels; got {type(v).__name__}")
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo and np.isfinite(float(hi) - float(lo))):
        raise ValueError(f"hi must be finite and greater than lo, hi - lo finite; got lo={lo}, hi={hi}")
    colour_bar = check_bool("colour_bar", colour_bar)
    with np.errstate(over="ignore"):  # a tiny hi - lo: values past the float range are clipped to the ends anyway
        rgb = _turbo((np.nan_to_num(d.astype(np.float64), nan=lo) - lo) / (hi - lo))
    rgb[~np.isfinite(d)] = 0.0
    if colour_bar:
        rgb = np.concatenate([rgb, _colour_bar(d.shape[1], d.shape[0], float(lo), float(hi))], axis=0)
    return rgb
