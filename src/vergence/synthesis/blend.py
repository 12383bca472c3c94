"""Blending of two or more warped references with a depth test (S1 §IV.B.2).

Each reference has been warped to the target view; where several see a pixel, the nearest surface
wins (their warped disparities disagree by more than ``depth_tolerance``); among the references
that agree on the nearest surface, the reliable ones (not along a depth contour in their own
view, S1 §IV.B.3) are preferred, and their colours are averaged with weights from the distance of
each reference to the target (S1 §IV.B.2, SPEC §6.3).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array, check_finite, check_positive
from vergence.synthesis.warp import _check_image, _check_maps

__all__ = ["BlendResult", "baseline_weights", "blend_views"]


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class BlendResult:
    """A blended view.

    Attributes
    ----------
    image : (H, W) or (H, W, C) float32
        Blended colours, 0 in holes.
    disparity : (H, W) float32
        Disparity of the winning surface, NaN in holes.
    holes : (H, W) bool
        Pixels no reference sees.
    """

    image: np.ndarray
    disparity: np.ndarray
    holes: np.ndarray

    def __post_init__(self) -> None:
        _check_maps("BlendResult", self.image, disparity=self.disparity, holes=self.holes)


def baseline_weights(positions: object, target: float) -> np.ndarray:
    """Blending weights from the distance of each reference to the target along the baseline.

    Parameters
    ----------
    positions : (N,) array
        Reference positions on the baseline (any unit), N >= 1, distinct.
    target : float
        Target position, same unit.

    Returns
    -------
    (N,) float64
        Non-negative weights summing to 1. For two references they are the linear ones of SPEC §6.3,
        ``w_L = |t - t_R| / |t_R - t_L|``, ``w_R = 1 - w_L`` (zero outside the segment). For more,
        only the nearest reference on each side of the target contributes, with those linear
        weights (one side only: the nearest reference alone). A reference at the target gets 1.

    Notes
    -----
    S1 §IV.B.2: weight the reference closer to the new viewpoint more.

    Examples
    --------
    >>> baseline_weights([0.0, 1.0], 0.25).tolist()
    [0.75, 0.25]
    """
    p = as_float_array("positions", positions)
    if p.ndim != 1 or p.size == 0:
        raise ValueError(f"positions must have shape (N,) with N >= 1; got {p.shape}")
    if np.unique(p).size != p.size:
        raise ValueError(f"positions must be distinct; got {p.tolist()}")
    t = check_finite("target", target)
    w = np.zeros(p.size)
    exact = np.flatnonzero(p == t)
    if exact.size:
        w[exact[0]] = 1.0
        return w
    left = np.flatnonzero(p < t)
    right = np.flatnonzero(p > t)
    if left.size and right.size:
        i = left[np.argmax(p[left])]
        j = right[np.argmin(p[right])]
        w[i] = (p[j] - t) / (p[j] - p[i])  # SPEC §6.3: w_L = |t_v - t_R| / |t_R - t_L|
        w[j] = 1.0 - w[i]
    else:
        side = left if left.size else right
        w[side[np.argmin(np.abs(p[side] - t))]] = 1.0
    return w


def blend_views(
    images: Sequence[object],
    disparities: Sequence[object],
    *,
    weights: object,
    reliable: Sequence[object] | None = None,
    depth_tolerance: float = 1.0,
) -> BlendResult:
    """Blend warped references: nearest surface first, reliable pixels next, weighted average last.

    Parameters
    ----------
    images : sequence of N arrays (H, W) or (H, W, C)
        Warped references (float in [0, 1], uint8 or uint16), one layout for all.
    disparities : sequence of N arrays (H, W)
        Their warped disparities in one common unit (the same baseline), NaN in holes.
    weights : (N,) array
        Non-negative weights, e.g. :func:`baseline_weights`; not all zero. A reference with weight
        0 only fills pixels that no weighted reference sees (so a target at a reference position
        reproduces that reference exactly where it is known).
    reliable : sequence of N (H, W) bool arrays, optional
        False where a reference's pixel is unreliable (e.g. warped from a depth contour,
        :func:`vergence.synthesis.contour_mask`); such a pixel is used only if no reliable
        reference sees the same surface.
    depth_tolerance : float
        Two warped disparities within this many pixels see the same surface; a larger difference
        is an occlusion and the larger disparity (nearer surface) wins.

    Returns
    -------
    BlendResult

    Raises
    ------
    ValueError
        Lengths or shapes differ, weights negative or all zero, disparity with inf.

    Notes
    -----
    S1 §IV.B.2: blending compensates for intensity differences and distortions of the two warps;
    the nearer reference weighs more; the depth test is the z-buffer rule applied across references.

    Examples
    --------
    >>> import numpy as np
    >>> a, b = np.zeros((1, 2), np.float32), np.ones((1, 2), np.float32)
    >>> res = blend_views([a, b], [np.array([[1.0, 1.0]]), np.array([[1.0, 9.0]])], weights=[0.75, 0.25])
    >>> res.image.tolist()
    [[0.25, 1.0]]
    """
    n = len(images)
    if n == 0 or len(disparities) != n:
        raise ValueError(f"images and disparities must be non-empty sequences of one length; got {n} and {len(disparities)}")
    imgs = [_check_image(f"images[{i}]", im) for i, im in enumerate(images)]
    for i, im in enumerate(imgs[1:], start=1):
        if im.shape != imgs[0].shape:
            raise ValueError(f"images[{i}] must have shape {imgs[0].shape} like images[0]; got {im.shape}")
    hw = imgs[0].shape[:2]
    ds = []
    for i, d in enumerate(disparities):
        arr = as_float_array(f"disparities[{i}]", d, allow_nan=True, dtype=np.float32)
        if arr.shape != hw:
            raise ValueError(f"disparities[{i}] must have shape {hw} matching the images; got {arr.shape}")
        ds.append(arr)
    w = as_float_array("weights", weights, shape=(n,))
    if (w < 0).any() or w.sum() <= 0:
        raise ValueError(f"weights must be >= 0 and not all zero; got {w.tolist()}")
    rel = None
    if reliable is not None:
        if len(reliable) != n:
            raise ValueError(f"reliable must hold {n} masks; got {len(reliable)}")
        rel = []
        for i, r in enumerate(reliable):
            r = np.asarray(r)
            if r.dtype != bool or r.shape != hw:
                raise ValueError(f"reliable[{i}] must be a bool array of shape {hw}; got {r.dtype} {r.shape}")
            rel.append(r)
    tol = check_positive("depth_tolerance", depth_tolerance)
    return _blend(imgs, ds, w, rel, tol)


def _blend(
    imgs: list[np.ndarray],
    ds: list[np.ndarray],
    w: np.ndarray,
    rel: list[np.ndarray] | None,
    tol: float,
) -> BlendResult:
    """Unchecked body of :func:`blend_views`."""
    d = np.stack(ds)  # (N, H, W)
    known = ~np.isnan(d)
    # Zero-weight references only count where no weighted reference sees the pixel.
    weighted = w > 0
    seen_weighted = known[weighted].any(axis=0)
    active = known & (weighted[:, None, None] | ~seen_weighted[None])
    nearest = np.where(active, d, -np.inf).max(axis=0)
    holes = ~active.any(axis=0)
    with np.errstate(invalid="ignore"):
        cand = active & (d >= nearest[None] - tol)
    if rel is not None:
        r = np.stack(rel) & cand
        cand = np.where(r.any(axis=0)[None], r, cand)
    # A zero weight in a pixel only zero-weight references see still counts: fall back to 1.
    ww = w[:, None, None] * cand
    ww = np.where(ww.sum(axis=0)[None] > 0, ww, cand.astype(np.float64))
    total = ww.sum(axis=0)
    norm = np.divide(ww, total[None], out=np.zeros_like(ww), where=total[None] > 0).astype(np.float32)
    stack = np.stack([im if im.ndim == 3 else im[:, :, None] for im in imgs])  # (N, H, W, C)
    image = np.einsum("nhw,nhwc->hwc", norm, stack)
    disparity = np.einsum("nhw,nhw->hw", norm, np.where(cand, d, np.float32(0.0)))
    disparity[holes] = np.nan
    image[holes] = 0.0
    if imgs[0].ndim == 2:
        image = image[:, :, 0]
    return BlendResult(image=image, disparity=disparity, holes=holes)
