"""Linear tone mapping of HDR renders, as in S3 §3.2 ("a linear tone mapper").

``exposure`` times radiance, clipped to [0, 1], then sRGB-encoded (IEC 61966-2-1). The automatic
exposure maps the 99th percentile of the luminance (Rec. 709 weights) to 1, so the brightest 1 %
(sun, highlights) clips. numpy only (figures with matplotlib live in ``vergence.report.preview``).
"""

from __future__ import annotations

import numpy as np

from vergence._validate import check_positive

__all__ = ["auto_exposure", "tonemap"]

_LUMA = np.array([0.2126, 0.7152, 0.0722])


def _radiance(radiance: object, *, image: bool = False) -> np.ndarray:
    """``radiance`` as float64 ``(..., 3)``, finite and >= 0 (radiance is a non-negative quantity)."""
    try:
        arr = np.asarray(radiance, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"radiance must be a real-valued array; got {type(radiance).__name__}") from None
    if (arr.ndim != 3 if image else arr.ndim < 1) or arr.shape[-1] != 3 or arr.size == 0:
        raise ValueError(f"radiance must have shape {'(H, W, 3)' if image else '(..., 3)'} and not be empty; "
                         f"got {arr.shape}")  # fmt: skip
    bad = int((~np.isfinite(arr)).sum())
    if bad:
        raise ValueError(f"radiance must be finite; got {bad} NaN or inf value(s)")
    if arr.size and arr.min() < 0.0:
        raise ValueError(f"radiance must be >= 0; got min {arr.min():g}")
    return arr


def auto_exposure(radiance: np.ndarray) -> float:
    """Exposure mapping the 99th percentile of luminance to 1 (1.0 for an all-black image).

    Raises ``ValueError`` for radiance that is not finite and >= 0, or not of shape ``(..., 3)``.
    """
    lum = _radiance(radiance) @ _LUMA
    p99 = float(np.percentile(lum, 99.0)) if lum.size else 0.0
    return 1.0 / p99 if p99 > 0.0 else 1.0


def tonemap(radiance: np.ndarray, *, exposure: float | None = None) -> np.ndarray:
    """Linear HDR ``(H, W, 3)`` to display sRGB float32 in [0, 1]: ``srgb(clip(exposure * L))``.

    Raises ``ValueError`` for radiance with NaN, inf or negative values (no HDR image has them:
    they would be mapped silently to black), or an ``exposure`` that is not finite and > 0.
    """
    arr = _radiance(radiance, image=True)
    k = auto_exposure(arr) if exposure is None else check_positive("exposure", exposure)
    x = np.clip(arr * k, 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)  # IEC 61966-2-1
    return srgb.astype(np.float32)
