"""Binocular rivalry of each layer's matches (S3 §3.2, "Rivalry").

S3 §3.2: matching by scene position never pairs wrong points, so rivalry has two other causes.
Missing matches (occlusions, matches too far): they are extrapolated from nearby pixels by hole
filling, "inspired by the filling-in mechanism performed by the HVS", and the luminance at the
extrapolated match is compared. Image structure: even with equal centre colours, the patches around
the two matched points may differ (rotated, scaled, brighter), measured by a 7 x 7 SSD of luminance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence._validate import readonly_fields
from vergence.specular import _importance_kernels as _k
from vergence.specular.importance_factors import checked_pair
from vergence.specular.lightness import PerceivedLightness
from vergence.specular.matching import LayerDisparity

__all__ = ["RIVALRY_WINDOW", "Rivalry", "fill_matches", "rivalry"]

# S3 §3.2: "a 7 x 7 SSD of the luminance of the stereo match".
RIVALRY_WINDOW = 7


def fill_matches(disparity_px: object) -> np.ndarray:
    """Fill the missing matches of each layer from the matched pixels around them, by push-pull.

    Parameters
    ----------
    disparity_px : (N, H, W, 2) array_like
        Per-layer disparity (:attr:`LayerDisparity.disparity_px`), NaN (both components) where a
        pixel has no match; finite values are kept as they are.

    Returns
    -------
    (N, H, W, 2) float32
        The disparity with every hole filled by the nearby matches, rounded to whole pixels; a layer
        with no match at all stays NaN.

    Notes
    -----
    S3 §3.2 extrapolates "matches of nearby pixels, using hole filling" without naming the method.
    Push-pull (Gortler et al. 1996): *push* halves the resolution level by level, each coarse pixel the
    mean of the matched pixels below it (weighted by their counts); *pull* fills each hole at a level
    with its coarse parent. A hole thus takes the mean of the matches in the smallest dyadic block around
    it that has any. Filled values are rounded to whole pixels (the matches are whole pixels).

    >>> d = np.full((1, 1, 4, 2), np.nan, np.float32); d[0, 0, 0] = (2.0, 0.0)
    >>> fill_matches(d)[0, 0, :, 0].tolist()
    [2.0, 2.0, 2.0, 2.0]
    """
    arr = np.asarray(disparity_px, dtype=np.float64)
    if arr.ndim != 4 or arr.shape[-1] != 2 or 0 in arr.shape:
        raise ValueError(f"disparity_px must have shape (N, H, W, 2) with N, H, W >= 1; got {arr.shape}")
    if np.isinf(arr).any():
        raise ValueError("disparity_px must not contain inf (NaN marks a pixel with no match)")
    valid = ~np.isnan(arr).any(axis=-1)
    values = [np.where(valid[..., None], arr, 0.0)]
    weights = [valid.astype(np.float64)]
    while values[-1].shape[1] > 1 or values[-1].shape[2] > 1:  # push: one level per halving
        v, w = values[-1], weights[-1]
        ph, pw = v.shape[1] % 2, v.shape[2] % 2
        v = np.pad(v * w[..., None], ((0, 0), (0, ph), (0, pw), (0, 0)))
        w = np.pad(w, ((0, 0), (0, ph), (0, pw)))
        wsum = w[:, 0::2, 0::2] + w[:, 1::2, 0::2] + w[:, 0::2, 1::2] + w[:, 1::2, 1::2]
        vsum = v[:, 0::2, 0::2] + v[:, 1::2, 0::2] + v[:, 0::2, 1::2] + v[:, 1::2, 1::2]
        with np.errstate(invalid="ignore", divide="ignore"):
            values.append(np.where(wsum[..., None] > 0, vsum / wsum[..., None], 0.0))
        weights.append(wsum)
    filled = np.where(weights[-1][..., None] > 0, values[-1], np.nan)
    for v, w in zip(values[-2::-1], weights[-2::-1]):  # pull: coarse to fine
        h, wd = w.shape[1], w.shape[2]
        parent = filled.repeat(2, axis=1).repeat(2, axis=2)[:, :h, :wd]
        filled = np.where(w[..., None] > 0, v, parent)
    out = np.where(valid[..., None], arr, np.round(filled))
    return out.astype(np.float32)


@dataclass(frozen=True, slots=True, eq=False)
class Rivalry:
    """Rivalry of each left-eye layer pixel with its (possibly filled) match (S3 §3.2). Arrays are read-only.

    Attributes
    ----------
    rivalry : (N, H, W) float32
        Mean over the 7 x 7 window of the squared L* difference between the left patch and the right
        patch at the match, in (ΔL*)^2; NaN in a layer with no match at all.
    point_difference : (N, H, W) float32
        ``|L*_l(x) - L*_r(m(x))|`` of the two centre pixels, in ΔL*; NaN likewise.
    disparity_px : (N, H, W, 2) float32
        The disparity compared: the matches, holes filled (:func:`fill_matches`).
    filled : (N, H, W) bool
        Where the match was extrapolated (no match of its own).
    """

    rivalry: np.ndarray
    point_difference: np.ndarray
    disparity_px: np.ndarray
    filled: np.ndarray

    def __post_init__(self) -> None:
        shape = np.shape(self.rivalry)
        for name, want in (("rivalry", shape), ("point_difference", shape), ("filled", shape),
                           ("disparity_px", (*shape, 2))):  # fmt: skip
            arr = getattr(self, name)
            if not isinstance(arr, np.ndarray) or arr.shape != want or len(shape) != 3:
                raise ValueError(f"{name} must be a numpy array of shape {want} with (N, H, W); "
                                 f"got {getattr(arr, 'shape', type(arr).__name__)}")  # fmt: skip
        readonly_fields(self, "rivalry", "point_difference", "disparity_px", "filled")


def rivalry(lightness: PerceivedLightness, matches: LayerDisparity) -> Rivalry:
    """Rivalry ``r_i(x)`` of every left-eye layer pixel: 7 x 7 SSD of L* at its match (S3 §3.2).

    Parameters
    ----------
    lightness : PerceivedLightness
        L* of both eyes' layers (:func:`~vergence.specular.perceived_lightness`).
    matches : LayerDisparity
        The left eye's matches (:func:`~vergence.specular.layer_disparity`), same ``(N, H, W)``.

    Returns
    -------
    Rivalry

    Raises
    ------
    TypeError
        If ``lightness`` or ``matches`` has the wrong type.
    ValueError
        If their layer shapes differ.

    Notes
    -----
    First the missing matches are filled (:func:`fill_matches`), then, with ``m(x) = x - d_i(x)``,
    ``r_i(x) = (1/49) sum_u (L_l(x + u) - L_r(m(x) + u))^2`` over the 7 x 7 window ``u`` (S3 §3.2 says
    "7 x 7 SSD"; the mean keeps the unit independent of the window). Pixels outside the image repeat
    the border pixel. S3 compares "luminance"; here L* after tone mapping and the CSF, as for importance.
    A constant shift between the eyes matched exactly gives 0.
    """
    lightness, matches = checked_pair(lightness, matches)
    disparity = fill_matches(matches.disparity_px)
    mean_sq, point = _k.patch_difference(lightness.left, lightness.right, disparity, RIVALRY_WINDOW // 2)
    return Rivalry(rivalry=mean_sq.astype(np.float32), point_difference=point.astype(np.float32),
                   disparity_px=disparity,
                   filled=~np.array(matches.matched) & ~np.isnan(disparity[..., 0]))  # fmt: skip
