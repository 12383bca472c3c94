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


def auto_exposure(radiance: np.ndarray) -> float:
    """Exposure mapping the 99th percentile of luminance to 1 (1.0 for an all-black image)."""
    lum = np.asarray(radiance, dtype=np.float64) @ _LUMA
    lum = lum[np.isfinite(lum)]
    p99 = float(np.percentile(lum, 99.0)) if lum.size else 0.0
    return 1.0 / p99 if p99 > 0.0 else 1.0


def tonemap(radiance: np.ndarray, *, exposure: float | None = None) -> np.ndarray:
    """Linear HDR ``(H, W, 3)`` to display sRGB float32 in [0, 1]: ``srgb(clip(exposure * L))``."""
    arr = np.asarray(radiance, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"radiance must have shape (H, W, 3); got {arr.shape}")
    k = auto_exposure(arr) if exposure is None else check_positive("exposure", exposure)
    x = np.clip(np.nan_to_num(arr * k, nan=0.0), 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)  # IEC 61966-2-1
    return srgb.astype(np.float32)
