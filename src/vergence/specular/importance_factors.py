"""Importance of each layer's matches: proximity x distinctiveness x contrast (S3 §3.2, "Human limitations").

S3 §3.2: the position matching of :func:`~vergence.specular.layer_disparity` overestimates what the
eye fuses; a match counts as much as it is *proximal* (found in the fusion window, nearer than
epsilon), *distinctive* (the luminance structure is unique) and of sufficient *contrast*. The
importance ``w_i(x) = proximity x distinctiveness x contrast`` lies in [0, 1] per layer and pixel.
Each factor is a public function on the L* images of :func:`~vergence.specular.perceived_lightness`.
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np
import scipy.ndimage

from vergence._validate import check_positive, readonly_fields
from vergence.specular import _importance_kernels as _k
from vergence.specular.lightness import PerceivedLightness
from vergence.specular.matching import LayerDisparity

__all__ = [
    "CONTRAST_SATURATION_JND",
    "CONTRAST_WINDOW",
    "DISTINCTIVENESS_SCALE",
    "SSD_WINDOW",
    "Importance",
    "contrast_q",
    "distinctiveness",
    "importance",
    "peli_contrast",
]

# S3 §3.2: the SSD window, 3 x 3 pixels.
SSD_WINDOW = 3
# S3 §3.2: Peli's contrast in a 17 x 17 Gaussian-weighted window: sigma = (17 - 1) / 6, cut at 3 sigma.
CONTRAST_WINDOW = 17
# S3 §3.2: the contrast factor "smoothly blends into 1 for contrasts above 10 JND"; 1 JND = 1 ΔL*.
CONTRAST_SATURATION_JND = 10.0
# Scale kappa_0 of the distinctiveness 1 - exp(-lambda_min / kappa_0), in (ΔL*)^2 per px^2 (S3 gives
# none). For a smooth image alpha(y) ~ sum over the 9 window pixels of (grad L . y)^2, whose Hessian is
# 2 * 9 * grad L grad L^T: kappa_0 = 18 is the curvature of a texture changing by 1 JND (1 ΔL*) per
# pixel in every direction, which gets distinctiveness 1 - 1/e = 0.63.
DISTINCTIVENESS_SCALE = 2.0 * SSD_WINDOW**2


# The discrete curvature of the SSD landscape alpha(y) at the match y = 0, as weights on alpha over
# y in {-1, 0, 1}^2 (index [1 + y_row, 1 + y_col]): kappa_xx = alpha(-1, 0) - 2 alpha(0, 0) + alpha(1, 0),
# kappa_yy likewise, kappa_xy = [alpha(1, 1) - alpha(1, -1) - alpha(-1, 1) + alpha(-1, -1)] / 4.
_KAPPA_XX = np.array([[0.0, 0.0, 0.0], [1.0, -2.0, 1.0], [0.0, 0.0, 0.0]])
_KAPPA_YY = _KAPPA_XX.T.copy()
_KAPPA_XY = np.array([[0.25, 0.0, -0.25], [0.0, 0.0, 0.0], [-0.25, 0.0, 0.25]])


def checked_pair(lightness: object, matches: object) -> tuple[PerceivedLightness, LayerDisparity]:
    if not isinstance(lightness, PerceivedLightness):
        raise TypeError(f"lightness must be a PerceivedLightness; got {type(lightness).__name__}")
    if not isinstance(matches, LayerDisparity):
        raise TypeError(f"matches must be a LayerDisparity; got {type(matches).__name__}")
    if matches.distance.shape != lightness.left.shape:
        raise ValueError(f"matches must be of the lightness's layers {lightness.left.shape}; "
                         f"got {matches.distance.shape}")  # fmt: skip
    return lightness, matches


def distinctiveness(
    lightness: PerceivedLightness, matches: LayerDisparity, *, scale: float = DISTINCTIVENESS_SCALE
) -> tuple[np.ndarray, np.ndarray]:
    """How uniquely each left pixel's match is pinned by its luminance pattern (S3 §3.2).

    Parameters
    ----------
    lightness : PerceivedLightness
        L* of the layers of both eyes.
    matches : LayerDisparity
        The per-layer matches of the left eye in the right eye, of the same ``(N, H, W)``.
    scale : float, keyword-only
        ``kappa_0`` > 0 in (ΔL*)^2/px^2 (:data:`DISTINCTIVENESS_SCALE`).

    Returns
    -------
    factor : (N, H, W) float32
        ``1 - exp(-max(lambda_min, 0) / kappa_0)`` in [0, 1]; NaN where there is no match.
    curvature : (N, H, W) float64
        ``lambda_min``; NaN where there is no match.

    Notes
    -----
    S3 §3.2: ``alpha(y) = sum_u (L_l(x + u) - L_r(m(x) + y + u))^2`` over the 3 x 3 window ``u``, with
    ``m(x) = x - d_i(x)`` the match; "the discrete curvature of the energy landscape when varying y
    [in {-5..5}^2] is used to rate the match". S3 does not say which curvature. Here: the smaller
    eigenvalue of the discrete Hessian at ``y = 0``,
    ``lambda_min = (k_xx + k_yy)/2 - sqrt(((k_xx - k_yy)/2)^2 + k_xy^2)`` with
    ``k_xx = alpha(-1,0) - 2 alpha(0,0) + alpha(1,0)``, ``k_yy`` likewise and
    ``k_xy = [alpha(1,1) - alpha(1,-1) - alpha(-1,1) + alpha(-1,-1)] / 4``. Why the smaller eigenvalue:
    it is 0 on a straight edge, which can slide along itself (the aperture problem), where the
    Laplacian ``k_xx + k_yy`` is not; and it is large only for structure in two directions (corners,
    texture). Why at ``y = 0``: the curvature of the minimum is what pins the match (a white-noise
    patch has a sharp minimum and a flat landscape around it). We also tried the Hessian of a
    quadratic fitted to all 121 values of S3's ±5 landscape: it rates white noise as flat (the
    plateau dominates the fit), so it was dropped. The discrete curvature needs only ``alpha`` at
    ``y in {-1, 0, 1}^2``, the only values computed; a consequence is that a pattern repeating within
    5 px is not penalised for its ambiguity. A negative ``lambda_min`` (the match is no minimum)
    gives 0. S3 gives no mapping to [0, 1]; the exponential with the perceptual scale of
    :data:`DISTINCTIVENESS_SCALE` is ours. Pixels outside the image repeat the border pixel.
    """
    lightness, matches = checked_pair(lightness, matches)
    kappa0 = check_positive("scale", scale)
    left = lightness.left.astype(np.float64)  # float64 sums: the curvature is a small difference of large SSDs
    right = lightness.right.astype(np.float64)
    lam = _k.landscape_hessian(left, right, np.ascontiguousarray(matches.disparity_px),
                               SSD_WINDOW // 2, 1, _KAPPA_XX, _KAPPA_XY, _KAPPA_YY)  # fmt: skip
    with np.errstate(invalid="ignore"):
        factor = (1.0 - np.exp(-np.maximum(lam, 0.0) / kappa0)).astype(np.float32)
    return factor, lam


def _gaussian_taps(size: int) -> np.ndarray:
    """Normalised Gaussian of ``size`` taps, sigma = (size - 1) / 6 (cut at 3 sigma)."""
    r = size // 2
    u = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-0.5 * (u / (r / 3.0)) ** 2)
    return g / g.sum()


def peli_contrast(lightness: object) -> np.ndarray:
    """Local contrast: the standard deviation of L* in a 17 x 17 Gaussian window (S3 §3.2), in ΔL* (JND).

    Parameters
    ----------
    lightness : (..., H, W) array_like
        Finite L* images (e.g. :attr:`PerceivedLightness.left`).

    Returns
    -------
    (..., H, W) float64
        ``sqrt(G * L^2 - (G * L)^2)``, ``G`` the normalised 17-tap Gaussian (sigma = 16/6 px) in x and y;
        borders mirrored (``scipy.ndimage`` mode ``reflect``).

    Notes
    -----
    S3 §3.2: "contrast is computed as the standard deviation of luminance (Peli's contrast [Pel90]) in
    a 17 x 17-pixel, Gaussian-weighted window". Peli (1990) defines a band-limited contrast (band-pass
    over local mean) per frequency band; S3 uses one local standard deviation, and so do we. We take it
    of L* rather than of luminance Y: L* is close to perceptually uniform, so 1 ΔL* is about one JND
    and S3's "10 JND" threshold of :func:`contrast_q` reads directly. The CSF pre-filter of
    :func:`~vergence.specular.perceived_lightness` band-limits the input. Rounding can make the
    variance slightly negative on flat regions: it is clipped at 0 before the square root.

    >>> float(peli_contrast(np.full((20, 20), 50.0))[10, 10])
    0.0
    """
    arr = np.asarray(lightness, dtype=np.float64)
    if arr.ndim < 2 or 0 in arr.shape:
        raise ValueError(f"lightness must have shape (..., H, W) and not be empty; got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError("lightness must be finite (no NaN or inf)")
    g = _gaussian_taps(CONTRAST_WINDOW)

    def blur(a: np.ndarray) -> np.ndarray:
        a = scipy.ndimage.correlate1d(a, g, axis=-1, mode="reflect")
        return scipy.ndimage.correlate1d(a, g, axis=-2, mode="reflect")

    mean = blur(arr)
    return np.sqrt(np.maximum(blur(arr * arr) - mean * mean, 0.0))


def contrast_q(contrast_jnd: object) -> np.ndarray:
    """Contrast factor after Cormack, Stevenson & Schor (1991): ``3 t^2 - 2 t^3``, ``t = clip(c / 10, 0, 1)``.

    Notes
    -----
    S3 §3.2: "a function similar to Cormack's Q function, that equals 0 for a luminance contrast of 0,
    and smoothly blends into 1 for contrasts above 10 JND". Cormack et al. found stereo thresholds
    rising as 1/c^2 at low contrast and flat at high contrast; the smoothstep has the quadratic onset,
    is C^1 and is exactly 1 from 10 JND (:data:`CONTRAST_SATURATION_JND`).

    >>> contrast_q([0.0, 5.0, 10.0, 20.0]).tolist()
    [0.0, 0.5, 1.0, 1.0]
    """
    c = np.asarray(contrast_jnd, dtype=np.float64)
    if np.isnan(c).any() or (c < 0).any():
        raise ValueError("contrast_jnd must be >= 0 (no NaN)")
    t = np.clip(c / CONTRAST_SATURATION_JND, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


@dataclass(frozen=True, slots=True, eq=False)
class Importance:
    """Importance of each left-eye layer pixel and its three factors (S3 §3.2). Arrays are read-only.

    Attributes
    ----------
    weight : (N, H, W) float32
        ``w = proximity x distinctiveness x contrast`` in [0, 1]; 0 where there is no match.
    proximity : (N, H, W) bool
        Matched in the fusion window nearer than epsilon (S3: the factor is 1, else 0).
    distinctiveness : (N, H, W) float32
        In [0, 1]; NaN where there is no match (:func:`distinctiveness`).
    contrast : (N, H, W) float32
        ``Q`` of the left eye's Peli contrast, in [0, 1] (:func:`contrast_q`, :func:`peli_contrast`).
    """

    weight: np.ndarray
    proximity: np.ndarray
    distinctiveness: np.ndarray
    contrast: np.ndarray

    def __post_init__(self) -> None:
        shape = np.shape(self.weight)
        for name in ("weight", "proximity", "distinctiveness", "contrast"):
            arr = getattr(self, name)
            if not isinstance(arr, np.ndarray) or arr.ndim != 3 or arr.shape != shape:
                raise ValueError(f"{name} must be a numpy array of shape (N, H, W) {shape}; "
                                 f"got {getattr(arr, 'shape', type(arr).__name__)}")  # fmt: skip
        readonly_fields(self, "weight", "proximity", "distinctiveness", "contrast")


def importance(
    lightness: PerceivedLightness, matches: LayerDisparity, *, scale: float = DISTINCTIVENESS_SCALE
) -> Importance:
    """Importance ``w_i(x) = proximity x distinctiveness x contrast`` of every left-eye layer pixel (S3 §3.2).

    Parameters
    ----------
    lightness : PerceivedLightness
        L* of both eyes' layers (:func:`~vergence.specular.perceived_lightness`).
    matches : LayerDisparity
        The left eye's matches (:func:`~vergence.specular.layer_disparity`), same ``(N, H, W)``.
    scale : float, keyword-only
        The distinctiveness scale ``kappa_0`` (:func:`distinctiveness`).

    Returns
    -------
    Importance

    Raises
    ------
    TypeError
        If ``lightness`` or ``matches`` has the wrong type.
    ValueError
        If their layer shapes differ or ``scale`` is not finite and > 0.

    Notes
    -----
    Proximity (S3 §3.2): 1 when the pixel has a match, i.e. the nearest position of the same layer in
    the other eye within the 81 x 9 window lies nearer than epsilon, else 0 (a generalised
    disocclusion). S3 rates the pixels of the *left* image; contrast is measured there.
    """
    lightness, matches = checked_pair(lightness, matches)
    proximity = np.array(matches.matched)
    dist, _ = distinctiveness(lightness, matches, scale=scale)
    contrast = contrast_q(peli_contrast(lightness.left)).astype(np.float32)
    weight = np.where(proximity, np.nan_to_num(dist, nan=0.0) * contrast, np.float32(0.0)).astype(np.float32)
    return Importance(weight=weight, proximity=proximity, distinctiveness=dist, contrast=contrast)
