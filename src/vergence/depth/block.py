"""Local window matching with SAD, SSD or NCC costs (S1 §III.B "local algorithms").

For each disparity the per-pixel cost is aggregated over a square window with a box filter and the
lowest cost wins (winner takes all); the disparity is refined to sub-pixel by a parabola through
the costs at d - 1, d, d + 1, and kept only when the right image's own winner agrees (left-right
check). Images are processed whole, one disparity at a time: memory stays at a few images.
"""

from __future__ import annotations

from collections.abc import Callable
from types import MappingProxyType

import cv2
import numpy as np

from vergence.depth._pair import check_block_size, check_disparity_range, stereo_pair_u8

__all__ = ["COSTS", "match_blocks"]

# NCC denominators below this (8-bit levels squared) mean a flat window: no correlation is defined.
_FLAT_VARIANCE = 1e-6


def _cost_sad(left: np.ndarray, right_shift: np.ndarray, block: int, cache: dict) -> np.ndarray:
    """Sum of absolute differences over the window (summed over channels)."""
    return cv2.blur(np.abs(left - right_shift).sum(axis=2), (block, block))


def _cost_ssd(left: np.ndarray, right_shift: np.ndarray, block: int, cache: dict) -> np.ndarray:
    """Sum of squared differences over the window (summed over channels)."""
    return cv2.blur(((left - right_shift) ** 2).sum(axis=2), (block, block))


def _cost_ncc(left: np.ndarray, right_shift: np.ndarray, block: int, cache: dict) -> np.ndarray:
    """One minus the normalised cross-correlation (averaged over channels); ``cache`` keeps the left
    window means and variances across disparities."""
    box = (block, block)
    if not cache:
        mean_l = cv2.blur(left, box).reshape(left.shape)
        cache["left"] = (mean_l, cv2.blur(left * left, box).reshape(left.shape) - mean_l * mean_l)
    mean_l, var_l = cache["left"]
    mean_r = cv2.blur(right_shift, box).reshape(left.shape)
    var_r = cv2.blur(right_shift * right_shift, box).reshape(left.shape) - mean_r * mean_r
    cross = cv2.blur(left * right_shift, box).reshape(left.shape) - mean_l * mean_r
    denom = np.sqrt(np.maximum(var_l, 0.0) * np.maximum(var_r, 0.0))
    ncc = np.where(denom > _FLAT_VARIANCE, cross / np.maximum(denom, _FLAT_VARIANCE), 0.0)
    return 1.0 - ncc.mean(axis=2)  # 0 for a perfect correlation, 2 for an inverted one


COSTS: MappingProxyType[str, Callable[[np.ndarray, np.ndarray, int, dict], np.ndarray]] = MappingProxyType({
    "ncc": _cost_ncc,
    "sad": _cost_sad,
    "ssd": _cost_ssd,
})
"""Window cost name -> ``cost(left, right_shifted, block, cache)`` (lower is better); read-only."""


def match_blocks(
    left: object,
    right: object,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    cost: str = "sad",
    block_size: int | None = None,
) -> np.ndarray:
    """Winner-takes-all window matching with a SAD, SSD or NCC cost; sub-pixel, left-right checked.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) images
        Rectified pair in [0, 1], same size, both grey or both colour.
    max_disparity, min_disparity : int
        Disparity search range, pixels.
    cost : str
        A name of :data:`COSTS`: sum of absolute or squared differences over the window (summed over channels), or one
        minus the normalised cross-correlation (averaged over channels).
    block_size : int, optional
        Odd window size; default 7 px up to 1000 px, 11 beyond.

    Returns
    -------
    (H, W) float32
        Disparity, NaN where the left-right check fails or no disparity fits in the image.

    Notes
    -----
    Sub-pixel: ``d + (c_- - c_+) / (2 (c_- - 2 c_0 + c_+))`` when the parabola opens upwards.
    """
    if not isinstance(cost, str) or cost not in COSTS:
        raise ValueError(f"cost must be one of {', '.join(COSTS)}; got {cost!r}")
    a, b = stereo_pair_u8(left, right)
    lo, hi, _ = check_disparity_range(max_disparity, min_disparity, a.shape[1])
    bs = check_block_size(block_size, 7 if max(a.shape[:2]) <= 1000 else 11, shape=a.shape)
    L = a.astype(np.float32).reshape(a.shape[0], a.shape[1], -1)
    R = b.astype(np.float32).reshape(L.shape)
    h, w, _ = L.shape
    cost_of, cache = COSTS[cost], {}
    inf = np.float32(np.inf)
    best = np.full((h, w), inf, np.float32)
    best_d = np.full((h, w), np.nan, np.float32)
    c_minus = np.full((h, w), inf, np.float32)
    c_plus = np.full((h, w), inf, np.float32)
    prev = np.full((h, w), inf, np.float32)
    just_won = np.zeros((h, w), bool)
    best_r = np.full((h, w), inf, np.float32)  # winner seen from each right pixel
    best_rd = np.full((h, w), np.nan, np.float32)
    for d in range(lo, hi + 1):
        shifted = np.zeros_like(R)  # shifted[:, x] = R[:, x - d]
        x0, x1 = max(0, d), min(w, w + d)
        if x1 <= x0:
            continue
        shifted[:, x0:x1] = R[:, x0 - d:x1 - d]
        c = cost_of(L, shifted, bs, cache).astype(np.float32)
        c[:, :x0] = inf
        c[:, x1:] = inf
        c_plus[just_won] = c[just_won]
        win = c < best
        c_minus[win] = prev[win]
        best[win] = c[win]
        best_d[win] = d
        c_plus[win] = inf
        just_won = win
        prev = c
        # right view: right pixel xr = x - d sees cost c[:, xr + d]
        cr = np.full((h, w), inf, np.float32)
        cr[:, x0 - d:x1 - d] = c[:, x0:x1]
        rwin = cr < best_r
        best_r[rwin] = cr[rwin]
        best_rd[rwin] = d
    denom = c_minus - 2.0 * best + c_plus
    with np.errstate(invalid="ignore", divide="ignore"):
        offset = np.where(np.isfinite(denom) & (denom > 0), (c_minus - c_plus) / (2.0 * denom), 0.0)
    disp = (best_d + offset).astype(np.float32)  # |offset| <= 1/2 since c_0 is the minimum
    xs = np.arange(w)[None, :] - np.nan_to_num(best_d, nan=-1e6).astype(np.int64)
    ok = np.isfinite(best_d) & (xs >= 0) & (xs < w)
    rows = np.broadcast_to(np.arange(h)[:, None], (h, w))
    back = best_rd[rows, np.clip(xs, 0, w - 1)]
    ok &= np.abs(back - best_d) <= 1.0
    disp[~ok] = np.nan
    return disp
