"""What the viewer sees of each layer: tone mapping, CSF pre-filter and CIELAB L* (S3 §3.2).

S3 §3.2 ("Tone mapping / luminance adaptation") matches luminance patterns only after the HDR ray
tree pair has been tone-mapped to the display's range "using a linear tone mapper" and filtered "by
the human CSF [Robson 1966]", so that details the screen cannot show or the eye cannot see take no
part. The stages, each public:

1. :func:`vergence.render.tonemap` on every layer, with one exposure for all layers of both eyes:
   ``srgb(clip(exposure * L_i, 0, 1))`` (a linear tone map is additive, so the layers of one eye still
   sum to the clipped beauty image wherever it does not clip);
2. :func:`csf_lowpass`: the Mannos–Sakrison CSF (1974) as a low-pass filter in cycles per degree of
   the display (:func:`pixels_per_degree`);
3. :func:`lightness_from_srgb`: CIE 1976 L* (D65 white; 1 ΔL* is about one just-noticeable difference).

:func:`perceived_lightness` runs all three on the layers of both eyes; :func:`layer_lightness` on
those of one eye with a given exposure (S3 §3.4's table re-renders only the left eye: the right
eye's L* is computed once).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
import scipy.fft
import scipy.optimize

from vergence._validate import check_positive, readonly_fields
from vergence.render.tonemap import auto_exposure, tonemap
from vergence.viewing.geometry import Display, check_display

__all__ = [
    "PerceivedLightness",
    "csf_lowpass",
    "csf_mannos_sakrison",
    "layer_lightness",
    "lightness_from_srgb",
    "perceived_lightness",
    "pixels_per_degree",
]

# Rec. 709 / sRGB primaries, D65: the Y row of the RGB -> XYZ matrix (IEC 61966-2-1).
_LUMA = np.array([0.2126, 0.7152, 0.0722])
# CIE 1976: L* = 116 f(Y / Yn) - 16, f(t) = t^(1/3) above (6/29)^3, linear below.
_DELTA = 6.0 / 29.0


def csf_mannos_sakrison(frequency_cpd: object) -> np.ndarray:
    """Mannos–Sakrison (1974) contrast sensitivity ``A(f) = 2.6 (0.0192 + 0.114 f) exp(-(0.114 f)^1.1)``.

    ``frequency_cpd``: spatial frequency in cycles per degree (>= 0). The peak is about 0.98 near 8 cpd.

    >>> round(float(csf_mannos_sakrison(8.0)), 3)
    0.981
    """
    f = np.asarray(frequency_cpd, dtype=np.float64)
    return 2.6 * (0.0192 + 0.114 * f) * np.exp(-((0.114 * f) ** 1.1))


@cache
def _csf_peak() -> float:
    """Frequency (cpd) of the Mannos–Sakrison maximum: the root of d log A / df."""
    dlog = lambda f: 0.114 / (0.0192 + 0.114 * f) - 1.1 * 0.114 * (0.114 * f) ** 0.1  # noqa: E731
    return float(scipy.optimize.brentq(dlog, 1.0, 30.0, xtol=1e-12))


def pixels_per_degree(display: Display, width_px: int) -> float:
    """Image pixels per degree of visual angle at the screen centre for an image ``width_px`` wide
    filling the width of ``display``: ``1 / (2 atan(p / 2D))`` in degrees, ``p = display.width / width_px``.

    >>> from vergence.viewing import Display
    >>> round(pixels_per_degree(Display.preset("samsung-2233rz"), 1680), 1)
    37.1
    """
    check_display(display)
    if isinstance(width_px, bool) or not isinstance(width_px, int | np.integer) or width_px < 1:
        raise ValueError(f"width_px must be an integer >= 1; got {width_px!r}")
    pitch = display.width / int(width_px)
    return 1.0 / math.degrees(2.0 * math.atan(pitch / (2.0 * display.distance)))


def csf_lowpass(images: object, display: Display) -> np.ndarray:
    """Low-pass ``(..., H, W, C)`` images by the Mannos–Sakrison CSF as seen on ``display`` (S3 §3.2).

    Parameters
    ----------
    images : (..., H, W, C) array_like
        Finite images (here, display-encoded sRGB) filling the display's width.
    display : vergence.viewing.Display
        Its width and viewing distance set the scale (:func:`pixels_per_degree`).

    Returns
    -------
    (..., H, W, C) float64
        The filtered images (not clipped).

    Notes
    -----
    Gain ``H(f) = 1`` for ``f <= f_peak`` and ``A(f) / A(f_peak)`` above, with ``A`` from
    :func:`csf_mannos_sakrison` and ``f`` the radial frequency in cycles per degree. S3 §3.2 only says
    "filter by the human CSF" (citing Robson 1966); a band-pass CSF would also remove the mean and the
    coarse shading that matching relies on, so below the peak the filter passes everything (a
    low-pass CSF): it only removes detail finer than the eye resolves at that distance. Applied as a
    product in the DCT-II domain (``scipy.fft.dctn``, orthonormal), which is the zero-phase filter on the
    mirror-extended image: no wrap-around at the borders. DCT index ``k`` of an axis of ``n`` pixels
    is ``k / 2n`` cycles per pixel. Nothing changes when even the highest frequency of the grid (the
    diagonal, sqrt(2) x 0.5 cycles per pixel) lies below ``f_peak``; with 512 px across S3's 22" display
    at 60 cm (11.3 px per degree) only the diagonal corner above 7.9 cpd (up to 8.0) is attenuated, by
    less than 0.01 %.
    """
    arr = np.asarray(images, dtype=np.float64)
    if arr.ndim < 3 or 0 in arr.shape:
        raise ValueError(f"images must have shape (..., H, W, C) and not be empty; got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError("images must be finite (no NaN or inf)")
    gain = _csf_gain(arr.shape[-3], arr.shape[-2], display)
    return arr.copy() if gain is None else _csf_apply(arr, gain)


def _csf_gain(h: int, w: int, display: Display) -> np.ndarray | None:
    """The ``(H, W)`` gain of :func:`csf_lowpass` on the DCT-II grid; None when it is 1 everywhere."""
    ppd = pixels_per_degree(display, w)
    fy = np.arange(h)[:, None] / (2.0 * h)
    fx = np.arange(w)[None, :] / (2.0 * w)
    f_cpd = np.hypot(fx, fy) * ppd
    peak = _csf_peak()
    gain = np.where(f_cpd <= peak, 1.0, csf_mannos_sakrison(f_cpd) / csf_mannos_sakrison(peak))
    return None if gain.min() == 1.0 else gain


def _csf_apply(arr: np.ndarray, gain: np.ndarray) -> np.ndarray:
    """``arr`` ``(..., H, W, C)`` filtered by ``gain`` ``(H, W)`` in the DCT-II domain."""
    coeff = scipy.fft.dctn(arr, type=2, axes=(-3, -2), norm="ortho")
    coeff *= gain[:, :, None]
    return scipy.fft.idctn(coeff, type=2, axes=(-3, -2), norm="ortho")


def lightness_from_srgb(srgb: object) -> np.ndarray:
    """CIE 1976 L* in [0, 100] of ``(..., 3)`` sRGB values in [0, 1] (IEC 61966-2-1 decoding, D65 white).

    ``Y = 0.2126 R + 0.7152 G + 0.0722 B`` (linear), ``L* = 116 f(Y) - 16``; the L channel of
    ``skimage.color.rgb2lab``.

    >>> float(lightness_from_srgb([1.0, 1.0, 1.0])), float(lightness_from_srgb([0.0, 0.0, 0.0]))
    (100.0, 0.0)
    """
    c = np.asarray(srgb, dtype=np.float64)
    if c.ndim < 1 or c.shape[-1] != 3:
        raise ValueError(f"srgb must have shape (..., 3); got {c.shape}")
    if not np.isfinite(c).all() or c.min(initial=0.0) < 0.0 or c.max(initial=0.0) > 1.0:
        raise ValueError("srgb must be finite and lie in [0, 1]")
    return _lstar(c)


def _lstar(c: np.ndarray) -> np.ndarray:
    """:func:`lightness_from_srgb` of checked values, in their float dtype."""
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    y = linear @ _LUMA.astype(c.dtype)
    f = np.where(y > _DELTA**3, np.cbrt(y), y / (3.0 * _DELTA**2) + 4.0 / 29.0)
    return 116.0 * f - 16.0


@dataclass(frozen=True, slots=True, eq=False)
class PerceivedLightness:
    """CIELAB L* of every layer of a stereo ray tree as shown on a display (S3 §3.2). Arrays are read-only.

    Attributes
    ----------
    left, right : (N, H, W) float32
        L* in [0, 100] per layer and pixel (a layer with no light there is 0, black).
    exposure : float
        The radiance multiplier of the linear tone map, shared by all layers of both eyes.
    pixels_per_degree : float
        Image pixels per degree on the display (the scale of the CSF filter).
    """

    left: np.ndarray
    right: np.ndarray
    exposure: float
    pixels_per_degree: float

    def __post_init__(self) -> None:
        for name in ("left", "right"):
            arr = getattr(self, name)
            if not isinstance(arr, np.ndarray) or arr.ndim != 3:
                raise ValueError(f"{name} must be a (N, H, W) numpy array; got {getattr(arr, 'shape', type(arr))}")
        if self.left.shape != self.right.shape:
            raise ValueError(f"right must have the shape of left {self.left.shape}; got {self.right.shape}")
        readonly_fields(self, "left", "right")


def _numeric(name: str, value: object) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must be a real numeric array; got dtype {arr.dtype}")
    if arr.ndim != 4 or arr.shape[-1] != 3 or 0 in arr.shape:
        raise ValueError(f"{name} must have shape (N, H, W, 3) with N, H, W >= 1; got {arr.shape}")
    return arr.astype(np.float64)


def _checked_radiance(eye: str, radiance: object, position: object) -> np.ndarray:
    """Radiance of one eye with NaN (allowed only where the layer has no surface) replaced by 0.

    ``eye`` prefixes the argument names in messages (``left`` names ``left_radiance``; "" names ``radiance``).
    """
    rname, pname = (f"{eye}_radiance", f"{eye}_position") if eye else ("radiance", "position")
    rad = _numeric(rname, radiance)
    pos = _numeric(pname, position)
    if pos.shape != rad.shape:
        raise ValueError(f"{pname} must have the shape of {rname} {rad.shape}; got {pos.shape}")
    if np.isinf(rad).any():
        raise ValueError(f"{rname} must not contain inf")
    nan = np.isnan(rad)
    surface = np.isfinite(pos).all(axis=-1)
    bad = int((nan.any(axis=-1) & surface).sum())
    if bad:
        raise ValueError(f"{rname} must be finite where the layer has a surface (finite {pname}); "
                         f"got NaN at {bad} such pixel(s)")  # fmt: skip
    rad = np.where(nan, 0.0, rad)
    if rad.min() < 0.0:
        raise ValueError(f"{rname} must be >= 0; got min {rad.min():g}")
    return rad


def perceived_lightness(
    left_radiance: object,
    right_radiance: object,
    left_position: object,
    right_position: object,
    display: Display,
    *,
    exposure: float | None = None,
) -> PerceivedLightness:
    """L* of every layer of both eyes after tone mapping and CSF filtering for ``display`` (S3 §3.2).

    Parameters
    ----------
    left_radiance, right_radiance : (N, H, W, 3) array_like
        Per-layer linear HDR radiance (:attr:`vergence.render.RenderResult.radiance`), >= 0. NaN is
        allowed only where the layer has no surface (its position is NaN) and counts as no light (0).
    left_position, right_position : (N, H, W, 3) array_like
        Per-layer world positions, NaN where there is no surface (only used to check the radiance).
    display : vergence.viewing.Display
        The viewing set-up; the image fills its width.
    exposure : float, optional, keyword-only
        Radiance multiplier (> 0); default :func:`vergence.render.auto_exposure` of the left eye's
        beauty image (the sum of its layers), as :func:`vergence.render.stereo_preview`.

    Returns
    -------
    PerceivedLightness

    Raises
    ------
    TypeError
        If an array is not numeric or ``display`` is not a Display.
    ValueError
        On shapes that are not ``(N, H, W, 3)`` and equal, inf or negative radiance, NaN radiance
        where a surface exists, or an exposure that is not finite and > 0.

    Notes
    -----
    Per layer: ``srgb(clip(exposure * L_i, 0, 1))`` (:func:`vergence.render.tonemap`), then
    :func:`csf_lowpass`, clipped to [0, 1] (the filter's overshoot at edges is at most a few
    percent), then :func:`lightness_from_srgb`. S3 §3.2 names a linear tone mapper and a CSF filter
    but not their order with the display encoding; the filter acts on the displayed (sRGB) values.

    Examples
    --------
    >>> from vergence.viewing import Display
    >>> rad = np.full((1, 2, 2, 3), 0.5); pos = np.zeros((1, 2, 2, 3))
    >>> out = perceived_lightness(rad, rad, pos, pos, Display.preset("samsung-2233rz"))
    >>> out.exposure, float(out.left[0, 0, 0])
    (2.0, 100.0)
    """
    left = _checked_radiance("left", left_radiance, left_position)
    right = _checked_radiance("right", right_radiance, right_position)
    if right.shape != left.shape:
        raise ValueError(f"right_radiance must have the shape of left_radiance {left.shape}; got {right.shape}")
    check_display(display)
    k = auto_exposure(left.sum(axis=0)) if exposure is None else check_positive("exposure", exposure)
    gain = _csf_gain(left.shape[1], left.shape[2], display)
    return PerceivedLightness(left=_lightness(left, k, gain), right=_lightness(right, k, gain), exposure=float(k),
                              pixels_per_degree=pixels_per_degree(display, left.shape[2]))  # fmt: skip


def _lightness(rad: np.ndarray, exposure: float, gain: np.ndarray | None) -> np.ndarray:
    """L* ``(N, H, W)`` float32 of checked radiance ``(N, H, W, 3)``: tone map, CSF, L*."""
    srgb = np.stack([tonemap(layer, exposure=exposure) for layer in rad])  # float32
    if gain is not None:
        srgb = np.clip(_csf_apply(srgb, gain), 0.0, 1.0).astype(np.float32)
    return _lstar(srgb).astype(np.float32)


def layer_lightness(radiance: object, position: object, display: Display, *, exposure: float) -> np.ndarray:
    """L* of every layer of one eye, as :func:`perceived_lightness` computes it for each eye (S3 §3.2).

    Parameters
    ----------
    radiance : (N, H, W, 3) array_like
        One eye's layers (:class:`vergence.render.RenderResult`), as in :func:`perceived_lightness`.
    position : (N, H, W, 3) array_like or None
        Their positions (NaN radiance is allowed where a layer has no surface); None: the radiance
        must be finite everywhere (the renderer writes 0 where a layer has no surface).
    display : vergence.viewing.Display
    exposure : float, keyword-only
        The radiance multiplier (> 0) shared with the other eye: ``perceived_lightness(...).exposure``.

    Returns
    -------
    (N, H, W) float32
        Equal to the ``left`` (or ``right``) of :func:`perceived_lightness` with that exposure.

    Raises
    ------
    TypeError, ValueError
        As :func:`perceived_lightness`.
    """
    rad = _checked_radiance("", radiance, radiance if position is None else position)
    check_display(display)
    k = check_positive("exposure", exposure)
    return _lightness(rad, k, _csf_gain(rad.shape[1], rad.shape[2], display))
