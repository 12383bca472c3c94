"""PatchMatch Stereo: slanted support windows found by random search and propagation.

Bleyer, Rhemann & Rother, "PatchMatch Stereo - Stereo Matching with Slanted Support Windows", BMVC 2011
(hereafter PMS). Every pixel of both views carries a plane ``d = a x + b y + c``; random planes
(§3.1) are improved by spatial propagation, view propagation and plane refinement (§3.2-3.3), and
the left map is post-processed by a left-right check, plane-based filling and a weighted median of
the filled pixels (§3.4). Disparity is ``x_left - x_right`` in pixels, NaN = unknown
(``docs/conventions.md``).

Parallel scan order: PMS visits the pixels one after another (even iterations from the top left,
odd ones from the bottom right), so that a good plane crosses the image in one sweep. Here each
iteration sweeps every row in parallel (left to right, or right to left), refining each pixel as
it is reached, then every column (down, or up); the planes still cross the image in one sweep,
on as many cores as there are rows.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from vergence._validate import check_in_range, check_positive, check_positive_int, readonly_fields
from vergence.depth import _kernels
from vergence.depth._pair import MAX_BLOCK_SIZE, check_block_size, check_disparity_range, stereo_pair_u8

__all__ = ["PatchMatchParameters", "PatchMatchResult", "match_patchmatch", "patchmatch_stereo"]

# Plane refinement stops when the disparity move falls below this (PMS §3.3: 0.1 px).
_REFINE_STOP_PX = 0.1
# Left-right check tolerance, pixels (PMS §3.4: "differ by more than 1").
_LR_TOLERANCE_PX = 1.0
# The matched view is sampled every 1/_UPSAMPLE pixel along the rows (cubic), and the cost interpolates linearly
# between those samples. 1: plain linear interpolation, as PMS (§3.1). 2 kept more contrast of fine textures
# at half-pixel disparities (a 3-px texture shifted by 9.5 px: 93 % of the pixels passed the left-right check,
# against 45 %) but scored worse on the training scenes (training mean 13.85 -> 13.97 % bad with the central
# x-difference; with the Sobel gradient tsukuba 4.19 % at 1 against 4.67 % at 2, venus 1.10 against 1.01).
_UPSAMPLE = 1
# Disparity resolution of the weighted median of the filled pixels, pixels.
_MEDIAN_BIN_PX = 0.1


@dataclass(frozen=True, slots=True)
class PatchMatchParameters:
    """Settings of :func:`patchmatch_stereo`: PMS §4 (window 35 x 35, gamma 10, alpha 0.9, tau_col 10,
    tau_grad 2, 3 iterations), except ``step``, chosen on the training scenes of
    ``benchmarks/stereo_split.json`` (``benchmarks/stereo_table.py --tune``).

    Attributes
    ----------
    window : int
        Side of the square support window, pixels (odd, 3 to ``MAX_BLOCK_SIZE``; PMS: 35).
    step : int
        The window is sampled every ``step`` pixels (1: every pixel, as in PMS); at most half the window.
        Training mean 13.70 % bad at 2, 13.36 % at 1 (tsukuba 4.19 -> 3.88, venus 1.10 -> 0.79) in 4.2 times
        the time (252 -> 1060 s for the seven scenes on 2 shared cores).
    gamma : float
        Colour scale of the support weights ``w = exp(-|I_p - I_q|_1 / gamma)``, 8-bit levels (PMS Eq. 4).
    alpha : float
        Weight of the gradient term against the colour term, in [0, 1] (PMS Eq. 5).
    tau_color, tau_gradient : float
        Truncations of the colour (L1 over the channels, 8-bit levels) and gradient costs (PMS Eq. 5).
    iterations : int
        Propagation iterations (PMS §3.2).
    """

    window: int = 35
    step: int = 2
    gamma: float = 10.0
    alpha: float = 0.9
    tau_color: float = 10.0
    tau_gradient: float = 2.0
    iterations: int = 3

    def __post_init__(self) -> None:
        win = check_positive_int("window", self.window)
        if win % 2 == 0 or win < 3 or win > MAX_BLOCK_SIZE:
            raise ValueError(f"window must be an odd number of pixels in [3, {MAX_BLOCK_SIZE}]; got {win}")
        stp = check_positive_int("step", self.step)
        if stp > win // 2:
            raise ValueError(f"step must be at most half the window ({win // 2} px); got {stp}")
        check_positive("gamma", self.gamma)
        check_in_range("alpha", self.alpha, 0.0, 1.0)
        check_positive("tau_color", self.tau_color)
        check_positive("tau_gradient", self.tau_gradient)
        check_positive_int("iterations", self.iterations)


@dataclass(frozen=True, slots=True, eq=False)
class PatchMatchResult:
    """Result of :func:`patchmatch_stereo`.

    Attributes
    ----------
    disparity : (H, W) float32
        Left disparity after the left-right check, plane-based filling and the weighted median of the
        filled pixels (PMS §3.4), pixels; every pixel known.
    filled : (H, W) float32
        The same before the weighted median: the left-right checked map with its holes filled from the planes.
    raw : (H, W) float32
        Left disparity of the planes, NaN where the left-right check failed (occlusions, mismatches).
    planes : (H, W, 3) float32
        The left view's plane per pixel, ``d = a x + b y + c`` (columns a, b, c; x, y in pixels).
    """

    disparity: np.ndarray
    filled: np.ndarray
    raw: np.ndarray
    planes: np.ndarray

    def __post_init__(self) -> None:
        readonly_fields(self, "disparity", "filled", "raw", "planes")


def _gradient_x(img: np.ndarray) -> np.ndarray:
    """x-gradient of the grey value (mean of the channels): Sobel / 8 (8-bit levels per pixel, edges replicated),
    as ``(H, W, 1)``.

    PMS Eq. (5) compares "grey-value gradients" without saying which. The Sobel derivative (the central
    difference smoothed 1-2-1 across the rows) scored better than the plain central difference on the
    training scenes (linear interpolation, window step 2: tsukuba 4.60 -> 4.20 %, venus 1.84 -> 1.13 % bad;
    the x and y components summed: 5.11 %, 1.89 %), with the same scale, so ``tau_gradient`` keeps its meaning.
    """
    grey = img.mean(axis=2).astype(np.float32)
    return (cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE) / 8.0)[:, :, None]


def _upsampled(img: np.ndarray) -> np.ndarray:
    """``img`` (H, W[, C]) resampled along the rows at ``x = i / _UPSAMPLE``, ``i = 0 .. _UPSAMPLE (W - 1)`` (cubic)."""
    if _UPSAMPLE == 1:  # the samples are the pixels
        return img
    h, w = img.shape[:2]
    xs = np.arange(_UPSAMPLE * (w - 1) + 1, dtype=np.float32) / _UPSAMPLE
    map_x = np.broadcast_to(xs, (h, xs.size)).copy()
    map_y = np.broadcast_to(np.arange(h, dtype=np.float32)[:, None], (h, xs.size)).copy()
    out = cv2.remap(img, map_x, map_y, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(h, xs.size, *img.shape[2:])


def patchmatch_stereo(
    left: object,
    right: object,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    parameters: PatchMatchParameters | None = None,
    rng: np.random.Generator | None = None,
) -> PatchMatchResult:
    """PatchMatch Stereo (Bleyer, Rhemann & Rother 2011) of a rectified pair.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) images
        Rectified pair in [0, 1] (or 8/16-bit), same size, both grey or both colour.
    max_disparity, min_disparity : int
        Disparity range, pixels: every plane's disparity at its own pixel stays inside it.
    parameters : PatchMatchParameters, optional
        Window, sampling step, weights and iterations; default ``PatchMatchParameters()``.
    rng : numpy.random.Generator, optional
        Source of the random planes and moves; default ``numpy.random.default_rng(0)`` (reproducible).

    Returns
    -------
    PatchMatchResult

    Raises
    ------
    ValueError
        On a pair of different sizes or channel counts, a disparity range wider than the image, or a
        window wider than the image's smaller side (:class:`PatchMatchParameters` checks the rest).
    TypeError
        When ``parameters`` is not a :class:`PatchMatchParameters` or ``rng`` not a Generator.

    Notes
    -----
    Matching cost of plane ``f`` at pixel p (PMS Eq. 2-5): ``m(p, f) = sum_{q in W_p} w(p, q) rho(q, q')``,
    ``q' = q_x - (a q_x + b q_y + c)`` in the right image, interpolated linearly along the row as in PMS,
    ``rho = (1 - alpha) min(|I_q - I_q'|_1, tau_col) + alpha min(|dI_q/dx - dI_q'/dx|, tau_grad)`` (x-gradient:
    Sobel / 8 of the grey value). Only planes seen from the front in both views compete: the disparity
    slope ``a`` stays below 1 - 0.1 in the left view (above -(1 - 0.1) in the right one), since a plane
    with ``a >= 1`` maps the left window onto a single right column or mirrors it (a surface the right
    camera sees edge-on or from behind); PMS states no such limit.
    Refinement (§3.3): the disparity at p moves by up to ``(max - min) / 2`` and the normal by up to 1
    per component, both halved until the disparity move is below 0.1 px. Post-processing (§3.4):
    pixels whose left and right disparities differ by more than 1 px are invalid; each takes the lower
    of the disparities the planes of its nearest valid row neighbours give at it, and those filled
    pixels get the weighted median of the window (weights of Eq. 4 with the colour distance taken as
    the Euclidean one).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> right = rng.random((30, 60)).astype(np.float32)
    >>> left = np.roll(right, 4, axis=1)  # a left pixel x sees the right pixel x - 4
    >>> res = patchmatch_stereo(left, right, max_disparity=8, parameters=PatchMatchParameters(window=9, step=1))
    >>> round(float(np.median(res.disparity[:, 10:])), 2)
    4.0
    """
    a8, b8 = stereo_pair_u8(left, right)
    lo, hi, _ = check_disparity_range(max_disparity, min_disparity, a8.shape[1])
    if parameters is None:
        parameters = PatchMatchParameters()
    elif not isinstance(parameters, PatchMatchParameters):
        raise TypeError(f"parameters must be a PatchMatchParameters; got {type(parameters).__name__}")
    if parameters.window > min(a8.shape[:2]):
        raise ValueError(f"window must not exceed the image's smaller side ({min(a8.shape[:2])} px); "
                         f"got {parameters.window}")
    prm = {"radius": parameters.window // 2, "step": parameters.step, "gamma": float(parameters.gamma),
           "alpha": float(parameters.alpha), "tau_color": float(parameters.tau_color),
           "tau_gradient": float(parameters.tau_gradient), "iterations": parameters.iterations}
    if rng is None:
        rng = np.random.default_rng(0)
    elif not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator; got {type(rng).__name__}")
    img_l = (a8 if a8.ndim == 3 else a8[:, :, None]).astype(np.float32)
    img_r = (b8 if b8.ndim == 3 else b8[:, :, None]).astype(np.float32)
    grad_l, grad_r = _gradient_x(img_l), _gradient_x(img_r)
    h, w, ch = img_l.shape
    lut = np.exp(-np.arange(255 * ch + 1, dtype=np.float64) / prm["gamma"])  # PMS Eq. (4)
    d_min, d_max = float(lo), float(hi)
    seeds = [np.uint64(s) for s in rng.integers(0, 2**63, size=2 + 2 * prm["iterations"], dtype=np.int64)]
    views = {
        "left": (img_l, grad_l, _upsampled(img_r), _upsampled(grad_r), -1.0),
        "right": (img_r, grad_r, _upsampled(img_l), _upsampled(grad_l), 1.0),
    }
    fixed = (prm["radius"], prm["step"])
    weights = (prm["alpha"], prm["tau_color"], prm["tau_gradient"], d_min, d_max)
    planes, costs = {}, {}
    for k, (name, (img, grad, other, ograd, sgn)) in enumerate(views.items()):
        planes[name] = _kernels.random_planes(h, w, d_min, d_max, seeds[k])  # PMS §3.1
        costs[name] = _kernels.all_costs(planes[name], img, grad, other, ograd, lut, *fixed, sgn, *weights)
    for it in range(prm["iterations"]):
        forward = it % 2 == 0  # PMS §3.2: odd iterations scan the other way
        for k, (name, (img, grad, other, ograd, sgn)) in enumerate(views.items()):
            args = (img, grad, other, ograd, lut, *fixed, sgn, *weights)
            _kernels.view_propagation(planes[name], costs[name], planes["right" if k == 0 else "left"], *args)
            _kernels.sweep_rows(planes[name], costs[name], *args, forward, (d_max - d_min) / 2.0, _REFINE_STOP_PX,
                                seeds[2 + 2 * it + k])
            _kernels.sweep_columns(planes[name], costs[name], *args, forward)
    return _post_process(planes["left"], planes["right"], a8, prm, d_min, d_max)


def _plane_disparity(planes: np.ndarray) -> np.ndarray:
    h, w = planes.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w]
    return planes[:, :, 0] * xs + planes[:, :, 1] * ys + planes[:, :, 2]


def _post_process(planes_l: np.ndarray, planes_r: np.ndarray, guide_u8: np.ndarray, prm: dict, d_min: float,
                  d_max: float) -> PatchMatchResult:
    """PMS §3.4: left-right check, plane-based filling, weighted median of the filled pixels."""
    d_l, d_r = _plane_disparity(planes_l), _plane_disparity(planes_r)
    h, w = d_l.shape
    xr = np.rint(np.arange(w)[None, :] - d_l).astype(np.int64)
    inside = (xr >= 0) & (xr < w)
    back = np.take_along_axis(d_r, np.clip(xr, 0, w - 1), axis=1)
    consistent = inside & (np.abs(d_l - back) <= _LR_TOLERANCE_PX)
    raw = np.where(consistent, d_l, np.nan)
    if consistent.any():
        filled = np.clip(_kernels.plane_fill(raw, planes_l), d_min, d_max)
    else:
        filled = d_l.copy()
    guide = guide_u8 if guide_u8.ndim == 3 else guide_u8[:, :, None]
    lut = np.exp(-np.sqrt(np.arange(guide.shape[2] * 255 * 255 + 1, dtype=np.float64)) / prm["gamma"])
    nbins = int((d_max - d_min) / _MEDIAN_BIN_PX) + 1
    n = 2 * (prm["radius"] // prm["step"]) + 1
    final = _kernels.weighted_median(np.ascontiguousarray(filled, np.float32), np.ascontiguousarray(guide),
                                     ~consistent, np.ones((h, w), bool), lut.astype(np.float32), prm["radius"],
                                     prm["step"], d_min, _MEDIAN_BIN_PX, nbins, np.ones((n, n), np.float32))
    return PatchMatchResult(disparity=final.astype(np.float32), filled=filled.astype(np.float32),
                            raw=raw.astype(np.float32),
                            planes=planes_l.astype(np.float32))


def match_patchmatch(
    left: object,
    right: object,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    block_size: int | None = None,
    parameters: PatchMatchParameters | None = None,
) -> np.ndarray:
    """:func:`patchmatch_stereo` as a :data:`~vergence.depth.MATCHERS` entry: its left-right checked disparity
    (``raw``: NaN where the check failed), for a refinement to fill.

    ``block_size``, when given, replaces the window of ``parameters`` (default ``PatchMatchParameters()``),
    and the sampling step shrinks to at most half of it.
    """
    res = patchmatch_stereo(left, right, max_disparity=max_disparity, min_disparity=min_disparity,
                            parameters=_with_window(left, right, block_size, parameters))
    return res.raw.copy()


def _with_window(left: object, right: object, block_size: int | None,
                 parameters: PatchMatchParameters | None) -> PatchMatchParameters:
    """``parameters`` (default ``PatchMatchParameters()``) with ``block_size``, when given, as the window;
    the sampling step shrinks to at most half of it."""
    if parameters is None:
        parameters = PatchMatchParameters()
    elif not isinstance(parameters, PatchMatchParameters):
        raise TypeError(f"parameters must be a PatchMatchParameters; got {type(parameters).__name__}")
    if block_size is None:
        return parameters
    a, _ = stereo_pair_u8(left, right)
    window = check_block_size(block_size, parameters.window, shape=a.shape, minimum=3, matcher="patchmatch")
    return replace(parameters, window=window, step=min(parameters.step, window // 2))
