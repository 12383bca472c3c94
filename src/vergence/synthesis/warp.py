"""Rectified forward and backward warping with a z-buffer and the gap/hole rule (S1 §IV.A–B).

Two rectified views on one horizontal line: a pixel at column x with disparity d (pixels,
``x_left - x_right``, positive in front; see ``docs/conventions.md``) moves to ``x - scale d`` in
the target view, ``scale`` being the target's position along the baseline in units of the
baseline the disparity was measured on (S1 Eq. 7; SPEC §6.1). Resampling is one-dimensional along
the rows (S1 §IV.A).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence._validate import as_image, check_finite, check_same_hw
from vergence.synthesis import _kernels

__all__ = ["WarpResult", "backward_warp", "forward_warp"]


def _check_maps(owner: str, image: np.ndarray, **maps: np.ndarray) -> None:
    """Result validation: every (H, W) map matches the image's (H, W)."""
    for name, m in maps.items():
        if np.shape(m) != np.shape(image)[:2]:
            raise ValueError(f"{owner}.{name} must have shape {np.shape(image)[:2]} matching image; got {np.shape(m)}")


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class WarpResult:
    """A warped view.

    Attributes
    ----------
    image : (H, W) or (H, W, C) float32
        Warped colours, 0 in holes.
    disparity : (H, W) float32
        The source disparity of the surface seen at each target pixel (not scaled), NaN in holes.
    holes : (H, W) bool
        Target pixels no source pixel reached (disocclusions, unknown source disparity, borders).
    """

    image: np.ndarray
    disparity: np.ndarray
    holes: np.ndarray

    def __post_init__(self) -> None:
        _check_maps("WarpResult", self.image, disparity=self.disparity, holes=self.holes)


def _rows(arr: np.ndarray) -> np.ndarray:
    """A C-contiguous 2-D view (rows x everything else) of an array, for the counting kernels."""
    a = np.ascontiguousarray(arr)
    return a.reshape(a.shape[0], -1) if a.ndim >= 2 else a.reshape(1, -1)


def _count_nonfinite(arr: np.ndarray) -> tuple[int, int]:
    """NaN and inf counts of a float array, in one parallel pass."""
    a = _rows(arr)
    n_nan = np.empty(a.shape[0], dtype=np.int64)
    n_inf = np.empty(a.shape[0], dtype=np.int64)
    _kernels.count_nonfinite(a, n_nan, n_inf)
    return int(n_nan.sum()), int(n_inf.sum())


def _check_image(name: str, image: object) -> np.ndarray:
    """:func:`vergence._validate.as_image` without copying a valid float32 image (one Numba pass).

    The kernels never write to their inputs, so a float32 image is used in place; anything else
    (and any invalid image, for its error message) goes through ``as_image``.
    """
    arr = np.asarray(image)
    if arr.dtype != np.float32 or arr.ndim not in (2, 3) or arr.size == 0 or (arr.ndim == 3 and arr.shape[2] not in (1, 3, 4)):
        return as_image(name, image)  # converts, or raises its own message
    arr = np.ascontiguousarray(arr)
    a = _rows(arr)
    bad = np.empty(a.shape[0], dtype=np.int64)
    _kernels.count_outside(a, np.float32(0.0), np.float32(1.0), bad)
    if bad.any():
        return as_image(name, image)  # raises the non-finite or range message
    return arr


def _as_hwc(image: np.ndarray) -> np.ndarray:
    """View a validated image as C-contiguous float32 ``(H, W, C)``."""
    return np.ascontiguousarray(image if image.ndim == 3 else image[:, :, None], dtype=np.float32)


def _like(hwc: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Return ``hwc`` with the channel layout of ``template`` (grey images lose the channel axis)."""
    return hwc[:, :, 0] if template.ndim == 2 else hwc


def _check_nonnegative(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise if it is not finite and >= 0."""
    v = check_finite(name, value)
    if v < 0:
        raise ValueError(f"{name} must be >= 0; got {v:g}")
    return v


def _check_map(name: str, value: object, ref_name: str | None = None, ref: np.ndarray | None = None) -> np.ndarray:
    """Validate a depth or disparity map as C-contiguous float32: ``(H, W)`` (like ``ref`` when
    given), not empty, NaN for unknown, no inf, not all unknown (one Numba pass)."""
    try:
        d = np.ascontiguousarray(value, dtype=np.float32)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric; got {type(value).__name__}") from exc
    if d.ndim != 2 or d.size == 0:
        raise ValueError(f"{name} must have shape (H, W); got {d.shape}")
    if ref is not None:
        check_same_hw(name, d, ref_name, ref)
    n_nan, n_inf = _count_nonfinite(d)
    if n_inf:
        raise ValueError(f"{name} must not contain inf (use NaN for unknown)")
    if n_nan == d.size:
        raise ValueError(f"{name} must have at least one known value; got all unknown (NaN)")
    return d


def _forward_warp_unchecked(
    image_hwc: np.ndarray, disparity: np.ndarray, scale: float, gradient_limit: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kernel call without validation: ``(H, W, C)`` float32 image of any channel count."""
    h, w, c = image_hwc.shape
    out = np.empty((h, w, c), dtype=np.float32)
    zbuf = np.empty((h, w), dtype=np.float32)
    holes = np.empty((h, w), dtype=bool)
    _kernels.forward_warp_rows(image_hwc, disparity, float(scale), float(gradient_limit), out, zbuf, holes)
    return out, zbuf, holes


def forward_warp(
    image: object, disparity: object, *, scale: float = 1.0, gradient_limit: float = 1.0
) -> WarpResult:
    """Forward-warp a rectified view: the pixel at x with disparity d moves to ``x - scale d``.

    The nearest surface (larger disparity) wins where several pixels land on one target pixel
    (z-buffer). Two horizontal neighbours whose target positions spread apart by at most
    ``gradient_limit`` pixels more than their source spacing (``|scale (d1 - d0)| <= limit``) are
    one surface: every target pixel centre between them receives the linear interpolation of the
    pair (sub-pixel splatting, which closes the sampling gaps). A larger jump is an occlusion
    boundary and the target interval stays a hole (disocclusion).

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        Float in [0, 1], uint8 or uint16.
    disparity : (H, W) array
        Pixels, ``x_left - x_right`` on the reference baseline; NaN = unknown (the pixel is skipped).
        Negative values are allowed (points behind the zero-parallax plane of a shifted set-up).
    scale : float
        Target position in baselines: 1 is the right view of a left reference, 0.5 the middle,
        negative values move the other way (a right reference toward the left).
    gradient_limit : float
        Largest gap, in target pixels, that is still a sampling gap (SPEC §6.3; S1 §IV.B.1).

    Returns
    -------
    WarpResult
        Warped image (0 in holes), warped source disparity (NaN in holes) and the hole mask.

    Raises
    ------
    ValueError
        Shapes differ, disparity holds inf or is all unknown, a non-finite scale, a negative limit.

    Notes
    -----
    Rectified warping ``x' = x - scale d``, S1 Eq. (7) with ``Z = f b / d``; gap vs hole by the
    disparity-gradient rule of S1 §IV.B.1 (SPEC §6.3): near on the left with a 10-px jump leaves a
    10-px hole. Rows run in parallel (Numba); within a row the z-test keeps the larger disparity.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.linspace(0, 1, 8, dtype=np.float32)[None, :]
    >>> res = forward_warp(img, np.full((1, 8), 2.0), scale=1.0)
    >>> res.holes.astype(int).tolist()
    [[0, 0, 0, 0, 0, 0, 1, 1]]
    """
    img = _check_image("image", image)
    d = _check_map("disparity", disparity, "image", img)
    s = check_finite("scale", scale)
    limit = _check_nonnegative("gradient_limit", gradient_limit)
    out, zbuf, holes = _forward_warp_unchecked(_as_hwc(img), d, s, limit)
    return WarpResult(image=_like(out, img), disparity=zbuf, holes=holes)


def backward_warp(image: object, disparity: object, *, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Inverse (backward) warp: the target pixel at x takes the source colour at ``x + scale d(x)``.

    ``disparity`` lives on the target grid (e.g. a forward-warped, median-filtered disparity);
    colours are interpolated linearly along the row.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        The source view (float in [0, 1], uint8 or uint16).
    disparity : (H, W) array
        Target-grid disparity in pixels, NaN = unknown.
    scale : float
        As in :func:`forward_warp`: the same ``scale`` undoes that forward warp.

    Returns
    -------
    image : float32, shape of ``image``
        Sampled colours, 0 where not valid.
    valid : (H, W) bool
        Known disparity and a source position within the row.

    Notes
    -----
    The inverse of S1 Eq. (7) on rectified rows; used after median filtering of the warped depth
    (Do et al., S1 §IV.B.1).

    Examples
    --------
    >>> import numpy as np
    >>> img = np.linspace(0, 1, 5, dtype=np.float32)[None, :]
    >>> out, ok = backward_warp(img, np.full((1, 5), 0.5))
    >>> np.round(out, 3).tolist(), ok.tolist()
    ([[0.125, 0.375, 0.625, 0.875, 1.0]], [[True, True, True, True, True]])
    """
    img = _check_image("image", image)
    d = _check_map("disparity", disparity, "image", img)
    s = check_finite("scale", scale)
    out, valid = _backward_warp_unchecked(_as_hwc(img), d, s)
    return _like(out, img), valid


def _backward_warp_unchecked(image_hwc: np.ndarray, disparity: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Kernel call without validation (see :func:`backward_warp`)."""
    h, w, c = image_hwc.shape
    out = np.zeros((h, w, c), dtype=np.float32)
    valid = np.zeros((h, w), dtype=bool)
    _kernels.backward_warp_rows(image_hwc, disparity, float(scale), out, valid)
    return out, valid
