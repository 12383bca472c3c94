"""Image quality of synthesized views: PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13).

All metrics compare an ``image`` (e.g. a synthesized view) with a ``reference`` (the real view),
both float32 in [0, 1] (``(H, W)`` or ``(H, W, 3)``; uint8/uint16 are scaled), of one shape.
Conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from skimage.metrics import structural_similarity

from vergence._metrics_kernels import SIMILARITY_SSD, SIMILARITY_ZNCC, patch_sums, registration_search
from vergence._summaries import distance_summaries
from vergence._validate import as_image_pair, check_bool, check_finite, check_in_range, check_positive, check_positive_int

__all__ = [
    "MAX_REGISTRATION_RADIUS",
    "MIN_CONTRAST",
    "REGISTRATION_PATCH",
    "RegistrationError",
    "SSIM_WINDOW",
    "dssim",
    "patch_contrast",
    "psnr",
    "registration_error",
    "ssim",
]

# A patch is flat (ZNCC undefined) when its sum of squared deviations over the k x k x C samples is
# at most this. One 16-bit level on one sample gives (1/65535)^2 (1 - 1/n) ~ 2e-10, 200 times more;
# float64 rounding of the box sums is ~1e-14, 100 times less.
FLAT_VARIANCE = 1e-12
# Similarities closer than this are ties (won by the nearer candidate); ZNCC rounding is ~1e-14.
TIE_TOLERANCE = 1e-9
# Default min_contrast: 3 grey levels of 8 bits, 2.5 times the noise of the Middlebury Dolls views
# (1.2 levels RMS, Immerkaer's estimate). Dolls view3 plus 1.2-level Gaussian noise against view3
# (no misregistration) gets d = r (ZNCC < 0.8) on 86 % of the pixels of patch contrast 1-2 levels,
# 5 % at 2-3 levels and none from 3 levels on; 3 levels keeps 76 % of view3's pixels.
MIN_CONTRAST = 3.0 / 255.0
# Largest registration search radius: (2 r + 1)^2 = 4.2 million candidate offsets, about 100 MB of
# offset tables, and already 3.3 million patch comparisons per pixel. A radius of 1e6 would need 58 TiB.
MAX_REGISTRATION_RADIUS = 1024
# Side of SSIM's uniform window, pixels: scikit-image's default (Wang et al. 2004 use an 11 x 11
# Gaussian of sigma 1.5, whose weights fall below 5 % outside the central 7 x 7). An image must be
# at least this large on each side to have an SSIM.
SSIM_WINDOW = 7
# Side of the registration error's patch, pixels (S1 leaves it open; 5 x 5 is our choice).
REGISTRATION_PATCH = 5
_SIMILARITIES = {"ssd": SIMILARITY_SSD, "zncc": SIMILARITY_ZNCC}
_DEFAULT_RANKS = (0.8, 0.95, 1.0)
# The largest RMS deviation of values in [0, 1]: half of them 0, half 1.
_MAX_CONTRAST = 0.5


def _pair(image: object, reference: object) -> tuple[np.ndarray, np.ndarray]:
    """Validate an image and its reference: [0, 1], same shape, grey or RGB (no alpha)."""
    a, b = as_image_pair("image", image, "reference", reference)
    return a.astype(np.float64), b.astype(np.float64)


def _mask(mask: object, hw: tuple[int, ...]) -> np.ndarray | None:
    """Validate an optional boolean (H, W) mask holding at least one True."""
    if mask is None:
        return None
    m = np.asarray(mask)
    if m.dtype != bool:
        raise TypeError(f"mask must be a boolean array; got dtype {m.dtype}")
    if m.shape != hw:
        raise ValueError(f"mask must have shape (H, W) matching image {hw}; got {m.shape}")
    if not m.any():
        raise ValueError("mask must select at least one pixel; got an all-False mask")
    return m


def psnr(image: object, reference: object, *, mask: object = None) -> float:
    """Peak signal-to-noise ratio in dB for images in [0, 1]: ``10 log10(1 / MSE)``.

    Parameters
    ----------
    image, reference : array_like
        ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape.
    mask : array_like of bool, optional
        ``(H, W)``: the MSE is averaged over the selected pixels (and all channels) only.

    Returns
    -------
    float
        PSNR in dB; ``inf`` when the images are identical (over the mask), since MSE = 0.

    Raises
    ------
    ValueError
        On mismatched shapes, values outside [0, 1], NaN, or a mask of the wrong shape or all False.
    TypeError
        If a mask is not boolean.

    Notes
    -----
    ``PSNR = 10 log10(MAX^2 / MSE)`` with the data range ``MAX = 1``; MSE is the mean of the squared
    differences over the pixels (and channels).

    Examples
    --------
    >>> round(psnr(np.full((2, 2), 0.5), np.zeros((2, 2))), 4)  # MSE = 0.25: 10 log10(4)
    6.0206
    """
    a, b = _pair(image, reference)
    m = _mask(mask, a.shape[:2])
    sq = (a - b) ** 2
    if sq.ndim == 3:
        sq = sq.mean(axis=2)
    mse = float(sq.mean() if m is None else sq[m].mean())
    if mse == 0.0:
        return math.inf
    return float(10.0 * np.log10(1.0 / mse))


def _check_window(name: str, value: object, hw: tuple[int, ...]) -> int:
    """An odd window side >= 3 that fits in the image (SSIM window, registration patch)."""
    w = check_positive_int(name, value)
    if w < 3 or w % 2 == 0:
        raise ValueError(f"{name} must be an odd integer >= 3; got {w}")
    if w > min(hw):
        raise ValueError(f"{name} must not exceed the image's smaller side {min(hw)}; got {w}")
    return w


def ssim(image: object, reference: object, *, mask: object = None, win_size: int = SSIM_WINDOW,
         whole_windows: bool = False) -> float:
    """Mean structural similarity (Wang et al. 2004) through scikit-image, data range 1.

    Parameters
    ----------
    image, reference : array_like
        ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape, each side >= ``win_size``.
    mask : array_like of bool, optional
        ``(H, W)``: average the SSIM map (mean over channels) over the selected pixels instead of
        over the whole image. As scikit-image does, a border of ``(win_size - 1) // 2`` pixels, where
        the window leaves the image, is left out in both cases; so an all-True mask gives the
        unmasked value.
    win_size : int, optional
        Side of the uniform window (odd, >= 3); default ``SSIM_WINDOW`` (7, scikit-image's default).
    whole_windows : bool, optional
        With a mask: average only the pixels whose whole window lies in the mask (the mask eroded by
        the window), so pixels outside it (holes of a synthesised view) never enter a window's
        statistics. Default False: every selected pixel, its window wherever it reaches.

    Returns
    -------
    float
        SSIM in [-1, 1]; 1 for identical images.

    Raises
    ------
    ValueError
        On mismatched shapes, bad values, a bad ``win_size``, or a mask that selects no pixel
        inside the border (with ``whole_windows``: no whole window inside the mask).
    TypeError
        If a mask is not boolean.

    Notes
    -----
    ``skimage.metrics.structural_similarity(..., data_range=1, channel_axis=2)`` for colour images
    (the mean of the per-channel SSIM maps).

    Examples
    --------
    >>> ramp = np.linspace(0, 1, 64).reshape(8, 8)
    >>> ssim(ramp, ramp)
    1.0
    """
    a, b = _pair(image, reference)
    m = _mask(mask, a.shape[:2])
    w = _check_window("win_size", win_size, a.shape[:2])
    whole_windows = check_bool("whole_windows", whole_windows)
    channel_axis = 2 if a.ndim == 3 else None
    mean, smap = structural_similarity(a, b, data_range=1.0, channel_axis=channel_axis, win_size=w, full=True)
    if m is None:
        return float(mean)
    if smap.ndim == 3:
        smap = smap.mean(axis=2)
    pad = (w - 1) // 2
    inner = np.zeros_like(m)
    inner[pad : m.shape[0] - pad, pad : m.shape[1] - pad] = True
    sel = m & inner
    if whole_windows:
        from scipy.ndimage import minimum_filter

        sel &= minimum_filter(m.astype(np.uint8), size=w, mode="constant", cval=0).astype(bool)
        if not sel.any():
            raise ValueError(f"mask must hold at least one whole {w}x{w} window inside the image; got none")
    if not sel.any():
        raise ValueError(f"mask must select at least one pixel at least {pad} pixels from the border; got none")
    return float(smap[sel].mean())


def dssim(image: object, reference: object, *, mask: object = None, win_size: int = SSIM_WINDOW,
          whole_windows: bool = False) -> float:
    """Structural dissimilarity ``(1 - SSIM) / 2``, in [0, 1]; 0 for identical images.

    Parameters
    ----------
    image, reference : array_like
        ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape, each side >= ``win_size``.
    mask : array_like of bool, optional
        ``(H, W)`` pixels to average over, as in :func:`ssim`.
    win_size : int, optional
        Side of the SSIM window (odd, >= 3).
    whole_windows : bool, optional
        As :func:`ssim`: only windows wholly inside the mask.

    Returns
    -------
    float
        DSSIM in [0, 1].

    Raises
    ------
    ValueError, TypeError
        As :func:`ssim`.

    Examples
    --------
    >>> dssim(np.zeros((8, 8)), np.zeros((8, 8)))
    0.0
    """
    return (1.0 - ssim(image, reference, mask=mask, win_size=win_size, whole_windows=whole_windows)) / 2.0


@dataclass(frozen=True, slots=True)
class RegistrationError:
    """Per-pixel registration distances and their summaries (S1 Eq. (11)-(13)).

    Attributes
    ----------
    distance : numpy.ndarray
        float64 ``(H, W)``, read-only: ``d(p, I')`` in pixels for each pixel of the image (Eq. 11);
        ``radius`` where no candidate reached the similarity threshold; NaN where the image's patch
        has less contrast than ``min_contrast`` (not evaluated).
    rms : float
        Root mean square of ``distance`` over the evaluated pixels.
    median : float
        Median of ``distance`` over the evaluated pixels.
    ranked : Mapping[float, float]
        ``k -> d^k(I, I')``, the k-th ranked distance over the evaluated pixels (Eq. 13),
        read-only; ``k = 1`` is the Hausdorff distance (Eq. 12).
    radius : float
        Search radius in pixels.
    patch_size : int
        Side of the square patch.
    similarity : str
        ``"zncc"`` or ``"ssd"``.
    threshold : float
        Similarity below which a pixel gets ``radius`` (``-inf``: none).
    min_contrast : float
        Patch contrast (RMS deviation, [0, 1] units) below which a pixel is not evaluated.
    """

    distance: np.ndarray
    rms: float
    median: float
    ranked: Mapping[float, float]
    radius: float
    patch_size: int
    similarity: str
    threshold: float
    min_contrast: float

    def __post_init__(self) -> None:
        d = np.asarray(self.distance, dtype=np.float64)
        if d.ndim != 2 or d.size == 0:
            raise ValueError(f"distance must be a non-empty (H, W) array; got shape {d.shape}")
        values = d[~np.isnan(d)]
        if values.size == 0:
            raise ValueError("distance must hold at least one evaluated (non-NaN) pixel; got none")
        if not np.isfinite(values).all() or values.min() < 0:
            raise ValueError("distance must be finite and >= 0 where evaluated (NaN elsewhere)")
        d = d.copy()
        d.flags.writeable = False
        object.__setattr__(self, "distance", d)
        for name in ("rms", "median"):
            check_finite(name, getattr(self, name))
        ranks = {check_in_range("rank", float(k), 0.0, 1.0): check_finite("ranked value", float(v))
                 for k, v in dict(self.ranked).items()}
        object.__setattr__(self, "ranked", MappingProxyType(ranks))
        if self.similarity not in _SIMILARITIES:
            raise ValueError(
                f"similarity must be one of {', '.join(sorted(_SIMILARITIES))}; got {self.similarity!r}"
            )
        check_in_range("min_contrast", self.min_contrast, 0.0, _MAX_CONTRAST)

    @property
    def evaluated(self) -> int:
        """Number of evaluated pixels (patch contrast >= ``min_contrast``; non-NaN ``distance``)."""
        return int(np.count_nonzero(~np.isnan(self.distance)))

    @property
    def evaluated_fraction(self) -> float:
        """Fraction of the image's pixels that were evaluated, in (0, 1]."""
        return self.evaluated / self.distance.size

    @property
    def hausdorff(self) -> float:
        """Hausdorff distance ``max_p d(p, I')`` over the evaluated pixels (S1 Eq. (12))."""
        return float(np.nanmax(self.distance))

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summaries (no per-pixel ``distance``): distances in pixels, ranks as ``"0.95"`` keys.

        ``threshold`` is None when it is ``-inf`` (no threshold; JSON has no infinity).

        Examples
        --------
        >>> img = np.tile(np.linspace(0.0, 1.0, 16), (16, 1))
        >>> d = registration_error(img, img, radius=2.0).to_dict()
        >>> d["rms"], d["hausdorff"], d["ranked"]["0.95"], d["evaluated"]
        (0.0, 0.0, 0.0, 256)
        """
        return {
            "rms": float(self.rms),
            "median": float(self.median),
            "hausdorff": self.hausdorff,
            "ranked": {f"{k:g}": float(v) for k, v in self.ranked.items()},
            "evaluated": self.evaluated,
            "evaluated_fraction": self.evaluated_fraction,
            "radius": float(self.radius),
            "patch_size": int(self.patch_size),
            "similarity": self.similarity,
            "threshold": None if self.threshold == -np.inf else float(self.threshold),
            "min_contrast": float(self.min_contrast),
        }


def _offsets(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Integer offsets (dy, dx) with dy^2 + dx^2 <= radius^2, by distance, then dy, then dx."""
    r = int(math.floor(radius))
    dy, dx = np.mgrid[-r : r + 1, -r : r + 1]
    dy, dx = dy.ravel(), dx.ravel()
    keep = dy * dy + dx * dx <= radius * radius
    dy, dx = dy[keep], dx[keep]
    dist = np.sqrt(dy * dy + dx * dx)
    order = np.lexsort((dx, dy, dist))
    return np.stack([dy[order], dx[order]], axis=1).astype(np.int64), dist[order]


def _patch_contrast(sums: np.ndarray, squares: np.ndarray, k: int) -> np.ndarray:
    """RMS deviation of each k x k patch about its per-channel means, pooled over the C channels.

    ``sqrt((sum_c sum_q (I_c(q) - mean_c)^2) / (k^2 C))`` from the patch sums ``(H, W, C)`` and the
    sums of squares ``(H, W)``; the variance is clipped at 0 (rounding of a flat patch only).
    """
    n, nc = k * k, sums.shape[2]
    deviation = squares - np.einsum("ijc,ijc->ij", sums, sums) / n
    return np.sqrt(np.maximum(deviation, 0.0) / (n * nc))


def patch_contrast(image: object, *, patch_size: int = REGISTRATION_PATCH) -> np.ndarray:
    """RMS contrast of the ``patch_size`` x ``patch_size`` patch around each pixel, channels pooled.

    The quantity the registration error's ``min_contrast`` gate compares (:func:`registration_error`).

    Parameters
    ----------
    image : array_like
        ``(H, W)`` or ``(H, W, 3)`` in [0, 1], each side >= ``patch_size``.
    patch_size : int, optional
        Odd patch side k >= 3 (default ``REGISTRATION_PATCH``); patches that leave the image read it
        mirrored (reflect-101).

    Returns
    -------
    (H, W) float64
        ``sqrt(sum_c sum_q (I_c(q) - mean_c)^2 / (k^2 C))``, [0, 1] intensity units, in [0, 0.5].

    Raises
    ------
    ValueError
        On an invalid image, or an even, too small or too large ``patch_size``.

    Examples
    --------
    >>> float(patch_contrast(np.full((5, 5), 0.5)).max())
    0.0
    >>> stripes = np.tile([0.0, 1.0], (5, 3))[:, :5]  # columns 0 1 0 1 0: 2 of 5 are 1
    >>> round(float(patch_contrast(stripes)[2, 2]), 6)  # sqrt(0.4 * 0.6)
    0.489898
    """
    a, _ = _pair(image, image)
    k = _check_window("patch_size", patch_size, a.shape[:2])
    h = k // 2
    a3 = a[:, :, None] if a.ndim == 2 else a
    sums, squares = patch_sums(np.ascontiguousarray(np.pad(a3, ((h, h), (h, h), (0, 0)), mode="reflect")), k)
    return _patch_contrast(sums, squares, k)


def registration_error(
    image: object,
    reference: object,
    *,
    radius: float = 10.0,
    patch_size: int = REGISTRATION_PATCH,
    similarity: str = "zncc",
    threshold: float | None = None,
    ranks: Sequence[float] = _DEFAULT_RANKS,
    min_contrast: float = MIN_CONTRAST,
) -> RegistrationError:
    """Registration error of ``image`` against ``reference`` and its generalised Hausdorff distances.

    For each pixel ``p`` of the image, the best-matching pixel ``p*`` of the reference within
    ``radius`` is the one whose ``patch_size`` x ``patch_size`` patch is most similar to the patch
    at ``p``; the error is ``|p - p*|`` (Eq. 11). Ties go to the nearest candidate; if the best
    similarity is below ``threshold``, the error is ``radius``. Registration is undefined where the
    image has no structure: pixels whose patch in ``image`` has less contrast than
    ``min_contrast`` are not evaluated (NaN). The summaries over the evaluated pixels are the RMS,
    the median and the k-th ranked values (Eq. 13; k = 1 is the Hausdorff distance of Eq. 12).

    Parameters
    ----------
    image, reference : array_like
        ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape, each side >= ``patch_size``.
    radius : float, optional
        Search radius r in pixels (> 0): candidates ``p'`` inside the reference with
        ``|p' - p| <= r``.
    patch_size : int, optional
        Odd patch side k >= 3. Patches that leave the image read it mirrored (reflect-101).
    similarity : {"zncc", "ssd"}, optional
        ``"zncc"``: zero-mean normalised cross-correlation over the patch (each channel's own mean
        removed, channels pooled); two flat patches score 1 (no structure to misregister), a flat
        against a textured patch 0. ``"ssd"``: minus the mean squared difference over the patch.
    threshold : float, optional
        tau: a best similarity below it gives ``d = r``. Default: 0.8 for ZNCC, none for SSD.
    ranks : sequence of float, optional
        The k in (0, 1] of Eq. (13), nearest rank (the ``ceil(k N)``-th smallest of the N
        evaluated distances).
    min_contrast : float, optional
        In [0, 0.5], [0, 1] intensity units: a pixel is evaluated only if the RMS deviation of its
        patch in ``image`` about the patch mean (each channel's own mean, pooled over channels) is
        at least this. Default ``MIN_CONTRAST`` = 3/255, about 2.5 times the noise of 8-bit
        camera images such as Middlebury's: below it, the ZNCC of two noisy copies of one patch
        often falls under 0.8 and the pixel would get ``d = r`` for noise, not misregistration.
        0 evaluates every pixel (the plain Eq. 11).

    Returns
    -------
    RegistrationError
        The distance map (float64, pixels; NaN where not evaluated), its summaries, and the number
        and fraction of evaluated pixels (``evaluated``, ``evaluated_fraction``).

    Raises
    ------
    ValueError
        On mismatched shapes, bad values, ``radius <= 0``, an even or too large ``patch_size``, an
        unknown similarity (the valid ones are listed), a ZNCC threshold outside [-1, 1], ranks
        outside (0, 1], ``min_contrast`` outside [0, 0.5], or a ``min_contrast`` that no patch of
        ``image`` reaches.

    Notes
    -----
    S1 §V.B.2, Eq. (11) ``d(p, I') = |p - p*|``, ``p* = argmax_{|p' - p| <= r} S(I(p), I'(p'))``;
    Eq. (12) ``d(I, I') = max_p d(p, I')``; Eq. (13) ``d^k(I, I') = K^th_p d(p, I')`` (Starck et al.).
    Design choices (S1 and Starck et al. 2008 leave them open): ZNCC of 5 x 5 patches, r = 10,
    tau = 0.8, ties to the smallest
    distance. A ZNCC flat patch has a sum of squared deviations <= ``FLAT_VARIANCE``; similarities
    within ``TIE_TOLERANCE`` are ties. The search is a Numba kernel using box sums per offset; the
    contrast ``sqrt(sum_c sum_q (I_c(q) - mean_c)^2 / (k^2 C))`` comes from the same box sums.
    The contrast gate is ours, not S1's: S1 notes that a plain mean hides errors in structured
    regions; in flat regions the matched pixel is arbitrary, so the distance there measures noise.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ref = rng.random((24, 24))
    >>> shifted = np.roll(ref, (-1, -2), axis=(0, 1))  # a (2, 1)-px misregistration
    >>> result = registration_error(shifted, ref, radius=4)
    >>> round(float(result.distance[10, 10]) ** 2, 6)
    5.0
    >>> registration_error(ref, ref).rms
    0.0
    >>> flat = np.full((8, 8), 0.5)  # no structure: nothing to register
    >>> registration_error(flat, flat, min_contrast=0).rms
    0.0
    >>> registration_error(flat, flat)
    Traceback (most recent call last):
    ...
    ValueError: min_contrast must be at most the largest patch contrast of image (0) to leave a pixel; got 0.0117647
    """
    a, b = _pair(image, reference)
    r = check_positive("radius", radius)
    if r > MAX_REGISTRATION_RADIUS:
        raise ValueError(
            f"radius must be at most {MAX_REGISTRATION_RADIUS} px (MAX_REGISTRATION_RADIUS: the search "
            f"tables grow as radius^2); got {r:g}"
        )
    k = _check_window("patch_size", patch_size, a.shape[:2])
    if similarity not in _SIMILARITIES:
        raise ValueError(f"similarity must be one of {', '.join(sorted(_SIMILARITIES))}; got {similarity!r}")
    if threshold is None:
        tau = 0.8 if similarity == "zncc" else -math.inf
    elif similarity == "zncc":
        tau = check_in_range("threshold", threshold, -1.0, 1.0)
    else:
        tau = check_finite("threshold", threshold)
    if isinstance(ranks, str | bytes) or not isinstance(ranks, Sequence) or len(ranks) == 0:
        raise TypeError(f"ranks must be a non-empty sequence of numbers in (0, 1]; got {ranks!r}")
    ks = [check_in_range("ranks", k_, 0.0, 1.0) for k_ in ranks]
    if min(ks) <= 0.0:
        raise ValueError(f"ranks must lie in (0, 1]; got {min(ks):g}")
    c_min = check_in_range("min_contrast", min_contrast, 0.0, _MAX_CONTRAST)

    h = k // 2
    a3 = a[:, :, None] if a.ndim == 2 else a
    b3 = b[:, :, None] if b.ndim == 2 else b
    a_pad = np.ascontiguousarray(np.pad(a3, ((h, h), (h, h), (0, 0)), mode="reflect"))
    b_pad = np.ascontiguousarray(np.pad(b3, ((h, h), (h, h), (0, 0)), mode="reflect"))
    sums_a, squares_a = patch_sums(a_pad, k)
    contrast = _patch_contrast(sums_a, squares_a, k)
    evaluated = contrast >= c_min
    if not evaluated.any():
        raise ValueError(
            f"min_contrast must be at most the largest patch contrast of image ({contrast.max():.3g}) "
            f"to leave a pixel; got {c_min:g}"
        )
    sums_b, squares_b = patch_sums(b_pad, k)
    offsets, dists = _offsets(r)
    best, distance = registration_search(  # Eq. (11)
        a_pad, b_pad, sums_a, squares_a, sums_b, squares_b, offsets, dists, k,
        _SIMILARITIES[similarity], FLAT_VARIANCE, TIE_TOLERANCE,
    )
    distance[best < tau] = r
    distance[~evaluated] = np.nan
    rms, median, ranked = distance_summaries(distance[evaluated], ks)  # Eq. (12)-(13)
    return RegistrationError(
        distance=distance,
        rms=rms,
        median=median,
        ranked=ranked,
        radius=r,
        patch_size=k,
        similarity=similarity,
        threshold=tau,
        min_contrast=c_min,
    )
