"""Objective quality of a synthesized view against the real one (S1 §V.B.2).

One call gathers what S1 and the view-synthesis literature report: PSNR, SSIM and DSSIM, and the
registration error of S1 Eq. (11)-(13) with its generalised Hausdorff distances, all over an
optional mask (e.g. the pixels a method did not have to invent); the registration error only where
the view has enough contrast to be registered. The metrics themselves live in :mod:`vergence.metrics`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from vergence._summaries import distance_summaries
from vergence._validate import as_image_pair, check_finite, check_in_range, check_positive
from vergence.metrics import (
    MAX_REGISTRATION_RADIUS,
    MIN_CONTRAST,
    REGISTRATION_PATCH,
    SSIM_WINDOW,
    patch_contrast,
    psnr,
    registration_error,
    ssim,
)
from vergence.synthesis._checks import within_float32

__all__ = ["ViewQuality", "assess_view", "error_image"]

_RANKS = (0.5, 0.8, 0.95, 1.0)


@dataclass(frozen=True, slots=True)
class ViewQuality:
    """Quality figures of a view against its reference.

    Attributes
    ----------
    psnr_db : float
        PSNR in dB (``inf`` for identical images).
    ssim, dssim : float
        Mean SSIM and ``(1 - SSIM) / 2``.
    registration_rms_px, registration_median_px : float or None
        RMS and median of the registration error ``d(p, I')`` (S1 Eq. 11) over the
        ``registration_pixels`` evaluated pixels, pixels; None when no pixel was evaluated (a flat view).
    registration_ranked_px : read-only mapping of float to float
        ``k -> d^k(I, I')`` (Eq. 13) for k in 0.5, 0.8, 0.95 and 1 (the Hausdorff distance, Eq. 12),
        over the evaluated pixels; empty when none was evaluated.
    registration_radius_px : float
        Search radius of the registration error (its largest possible value).
    pixels : int
        Number of pixels compared (the mask's, or all).
    registration_pixels : int
        Number of those pixels where the registration error was evaluated: the view's patch
        contrast is at least ``registration_min_contrast`` (0 to ``pixels``; 0 for a flat view, which
        has no structure to register).
    registration_min_contrast : float
        The contrast threshold, [0, 1] intensity units (0: every pixel).
    """

    psnr_db: float
    ssim: float
    dssim: float
    registration_rms_px: float | None
    registration_median_px: float | None
    registration_ranked_px: Mapping[float, float]
    registration_radius_px: float
    pixels: int
    registration_pixels: int
    registration_min_contrast: float

    def __post_init__(self) -> None:
        if self.pixels < 1:
            raise ValueError(f"pixels must be >= 1; got {self.pixels}")
        object.__setattr__(self, "registration_ranked_px", MappingProxyType(dict(self.registration_ranked_px)))
        if not 0 <= self.registration_pixels <= self.pixels:
            raise ValueError(f"registration_pixels must lie in [0, pixels {self.pixels}]; got {self.registration_pixels}")
        figures = (self.registration_rms_px, self.registration_median_px)
        if (self.registration_pixels == 0) != (figures == (None, None)):
            raise ValueError("registration_rms_px and registration_median_px must be None exactly when "
                             f"registration_pixels is 0; got {figures} over {self.registration_pixels} pixels")
        if self.registration_pixels and not 0.0 <= self.registration_median_px <= self.registration_radius_px:
            raise ValueError(
                f"registration_median_px must lie in [0, radius {self.registration_radius_px:g}]; "
                f"got {self.registration_median_px:g}"
            )

    @property
    def identical(self) -> bool:
        """Whether the view equals its reference (over the mask): MSE 0, PSNR infinite."""
        return self.psnr_db == math.inf

    def to_dict(self) -> dict:
        """JSON-ready dictionary; an infinite PSNR (identical images) is ``None`` with ``identical: True``
        (JSON has no infinity); the registration figures are ``None`` when no pixel was evaluated."""
        return {
            "psnr_db": self.psnr_db if math.isfinite(self.psnr_db) else None,
            "identical": self.identical,
            "ssim": self.ssim,
            "dssim": self.dssim,
            "registration_rms_px": self.registration_rms_px,
            "registration_median_px": self.registration_median_px,
            "registration_ranked_px": {f"{k:g}": v for k, v in self.registration_ranked_px.items()},
            "registration_radius_px": self.registration_radius_px,
            "pixels": self.pixels,
            "registration_pixels": self.registration_pixels,
            "registration_fraction": self.registration_pixels / self.pixels,
            "registration_min_contrast": self.registration_min_contrast,
        }


def assess_view(
    image: object,
    reference: object,
    *,
    mask: object = None,
    radius: float = 10.0,
    min_contrast: float = MIN_CONTRAST,
) -> ViewQuality:
    """PSNR, SSIM, DSSIM and the registration error of ``image`` against ``reference``.

    Parameters
    ----------
    image, reference : (H, W) or (H, W, 3) arrays
        The synthesized view and the real one, float in [0, 1], uint8 or uint16, one shape.
    mask : (H, W) bool array, optional
        Compare these pixels only (at least one).
    radius : float
        Search radius of the registration error, pixels (S1 Eq. 11; the paper gives none, 10 px is our choice).
    min_contrast : float
        The registration error is evaluated only where the 5x5 patch of ``image`` has an RMS
        contrast of at least this ([0, 1] units; default 3/255, see
        :func:`vergence.metrics.registration_error`); 0 evaluates every pixel.

    Returns
    -------
    ViewQuality

    Raises
    ------
    ValueError, TypeError
        As the metrics in :mod:`vergence.metrics` (shapes, ranges, masks); also for images smaller
        than SSIM's window (``SSIM_WINDOW`` px on a side). A view with no pixel (inside the mask)
        of contrast ``min_contrast`` is not refused: PSNR and SSIM are defined, the registration
        figures are None (a flat view has nothing to register).

    Notes
    -----
    S1 §V.B.2: the registration error ``d(p, I') = |p - p*|`` with ``p*`` the most similar pixel of
    the reference within ``radius`` (Eq. 11), its maximum (Hausdorff, Eq. 12) and its k-th ranked
    values (Eq. 13), here ZNCC of 5x5 patches (our choice of the similarity S of S1 Eq. 11), over the pixels with enough contrast
    (in flat areas the matched pixel is arbitrary and the distance would measure noise).

    Examples
    --------
    >>> import numpy as np
    >>> ref = np.random.default_rng(0).random((16, 16))
    >>> q = assess_view(ref, ref)
    >>> q.psnr_db, q.ssim, q.registration_rms_px, q.registration_pixels
    (inf, 1.0, 0.0, 256)
    """
    a, _ = as_image_pair("image", image, "reference", reference)
    if min(a.shape[:2]) < SSIM_WINDOW:
        raise ValueError(f"image must be at least {SSIM_WINDOW} px on each side for SSIM's {SSIM_WINDOW} x "
                         f"{SSIM_WINDOW} window (SSIM_WINDOW); got {a.shape[1]} x {a.shape[0]} px")
    p = psnr(image, reference, mask=mask)
    s = ssim(image, reference, mask=mask)
    selected = np.ones(a.shape[:2], bool) if mask is None else np.asarray(mask)
    c_min = check_in_range("min_contrast", min_contrast, 0.0, 0.5)
    if (patch_contrast(a, patch_size=REGISTRATION_PATCH)[selected] >= c_min).any():
        reg = registration_error(image, reference, radius=radius, min_contrast=c_min)
        dist = reg.distance[selected]
        evaluated = dist[~np.isnan(dist)]
        # Eq. (13), nearest rank; k = 1 is the Hausdorff distance of Eq. (12).
        rms, median, ranked = distance_summaries(evaluated, _RANKS)
    else:  # a flat view (inside the mask): nothing to register, and the search would be wasted
        if not check_positive("radius", radius) <= MAX_REGISTRATION_RADIUS:
            raise ValueError(f"radius must be at most {MAX_REGISTRATION_RADIUS} px (MAX_REGISTRATION_RADIUS); got {radius:g}")
        evaluated, rms, median, ranked = np.empty(0), None, None, {}
    return ViewQuality(
        psnr_db=p,
        ssim=s,
        dssim=(1.0 - s) / 2.0,  # vergence.metrics.dssim, without computing the SSIM a second time
        registration_rms_px=rms,
        registration_median_px=median,
        registration_ranked_px=ranked,
        registration_radius_px=float(radius),
        pixels=int(np.count_nonzero(selected)),
        registration_pixels=int(evaluated.size),
        registration_min_contrast=c_min,
    )


def error_image(image: object, reference: object, *, gain: float = 4.0) -> np.ndarray:
    """The error image of a view: ``gain |image - reference|``, mean over the channels, clipped to [0, 1].

    Parameters
    ----------
    image, reference : (H, W) or (H, W, C) arrays
        One shape (float in [0, 1], uint8 or uint16).
    gain : float
        Finite, > 0 (4 makes an error of a quarter of the range white).

    Returns
    -------
    (H, W) float32

    Examples
    --------
    >>> import numpy as np
    >>> error_image(np.full((1, 2), 0.5), np.array([[0.5, 0.4]])).round(3).tolist()
    [[0.0, 0.4]]
    """
    a, b = as_image_pair("image", image, "reference", reference)
    g = within_float32("gain", check_finite("gain", gain))
    if g <= 0:
        raise ValueError(f"gain must be > 0; got {g:g}")
    err = np.abs(a - b)
    err = err.mean(axis=2) if err.ndim == 3 else err
    return np.clip(g * err, 0.0, 1.0).astype(np.float32)
