"""Per-layer camera offsets for a whole image: low-resolution solve, edge-aware upsampling (S3 §3.4).

S3 §3.4 optimises the offsets "in parallel, independently for every pixel", then "the resulting
optimal camera offset is blurred using an edge-aware filter ... The solution is found at lower
resolution and later up-sampled [Kopf et al. 2007]. In this step, the contribution of each pixel is
weighted by its importance". :class:`OffsetPlanner` does that on an
:class:`~vergence.specular.OffsetAnalysis`:

1. once: the table reduced ``factor`` times in each direction, each block's disparity and rivalry
   at every offset averaged with the *physical* importance as weight
   (:func:`~vergence.specular.weighted_block_mean`): the same pixels make a block's disparity at
   every offset, so that a block cannot change its disparity by changing which of its pixels are
   important; the block's importance is its plain mean of the physical importance;
2. per :meth:`OffsetPlanner.solve` (a weight changed, a map painted): the per-pixel descent on the
   reduced table (:func:`~vergence.specular.optimise_offsets`); blocks without importance take the
   push-pull interpolation of their neighbours' offsets (:func:`~vergence.specular.push_pull_fill`),
   not a constant (a constant 1 drew vertical stripes of physical stereo across a surface wherever
   a block of it had no feature); S3's edge-aware blur of the offsets, at the solve's resolution
   (:func:`~vergence.specular.joint_bilateral_upsample` at equal size, ``blur_radius``,
   ``blur_sigma``); then the joint bilateral upsampling to full resolution (same function,
   ``radius``, ``sigma_space``). Both are weighted by each block's physical importance (plus
   :data:`FILL_WEIGHT`, so that a filled block counts only where no important one is near) and
   guided by the layer's physical horizontal disparity, so that an offset does not leak across a
   depth edge of its layer (a mirror's frame, a sphere's rim) while neighbouring pixels of one
   surface, solved independently and sometimes landing in different local minima, agree.

Re-solving reuses the reduced table: at 512 x 512, factor 4, it is interactive
(``benchmarks/specular_optimise.py --planner``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from numbers import Integral

import numpy as np

from vergence._validate import check_positive, readonly_fields
from vergence.specular.cost import (
    COMFORT_MARGIN_ARCMIN,
    COST_TERMS,
    COST_WEIGHTS,
    RELATIVE_LAMBDA_ARCMIN,
    RIVALRY_TOLERANCE,
    VERTICAL_TOLERANCE_ARCMIN,
)
from vergence.specular.optimise import DESCENT_STEPS, RESTARTS, optimise_offsets
from vergence.specular.resample import joint_bilateral_upsample, push_pull_fill, weighted_block_mean
from vergence.specular.tabulated import OffsetAnalysis

__all__ = ["FILL_WEIGHT", "IMPORTANCE_FLOOR", "PLAN_FACTOR", "PLAN_SIGMA_RANGE", "OffsetPlan", "OffsetPlanner"]

#: Default reduction of the solve (S3 §3.4 "lower resolution"; ours): 4 x 4 pixels per solved pixel.
PLAN_FACTOR = 4
#: Default range sigma of the upsampling, arcmin of the layer's physical disparity (ours: twice
#: S3's relative target lambda_x = 3'; a disparity step of 12' or more keeps its sides apart).
PLAN_SIGMA_RANGE = 6.0
#: The least importance of a matched layer pixel in the plan (ours): S3 weights every term by
#: importance, so an unimportant pixel's offset is left to chance (to its neighbours, or to the
#: fill); but the importance model is an estimate, and a viewer or an independent matcher that
#: matches the pixel finds it wherever it was left. With a floor every matched pixel is solved (each
#: term of a pixel scales with w^2 alike, so a lone pixel's minimum does not depend on w), while
#: important pixels still dominate the blur and the upsampling twenty to one.
IMPORTANCE_FLOOR = 0.05
#: The weight of a block's filled offset in the blur and the upsampling (ours): a thousandth of a
#: fully important block, so that filled offsets only speak where no important block is in reach.
FILL_WEIGHT = 1e-3


@dataclass(frozen=True, slots=True, eq=False)
class OffsetPlan:
    """The offsets of every layer and pixel (S3 §3.4). Arrays are read-only.

    Attributes
    ----------
    y : (N, H, W) float32
        Offsets in [0, 1] at full resolution (1: the physical left eye; fixed layers are 1).
    y_low, cost_low : (N, h, w), (h, w) float64
        The per-pixel descent's result (before the blur) and cost on the reduced table.
    factor : int
        The reduction.
    seconds : float
        Wall time of :meth:`OffsetPlanner.solve`.
    """

    y: np.ndarray
    y_low: np.ndarray
    cost_low: np.ndarray
    factor: int
    seconds: float

    def __post_init__(self) -> None:
        readonly_fields(self, "y", "y_low", "cost_low")


def check_factor(factor: object) -> int:
    if isinstance(factor, bool) or not isinstance(factor, Integral) or not 1 <= factor <= 64:
        raise ValueError(f"factor must be an integer in [1, 64]; got {factor!r}")
    return int(factor)


class OffsetPlanner:
    """S3 §3.4's optimisation for whole images: reduce the table once, solve many times.

    Parameters
    ----------
    analysis : OffsetAnalysis
        :func:`~vergence.specular.analyse_table`'s ``g(y)``.
    factor : int, keyword-only
        Solve on ``ceil(H / factor) x ceil(W / factor)`` pixels (1: every pixel, then the upsampling
        is an edge-aware blur at full resolution).
    sigma_space, sigma_range : float, keyword-only
        The upsampling's spatial sigma (low-resolution pixels) and range sigma (arcmin of the layer's
        physical horizontal disparity).
    radius : int, keyword-only
        The upsampling's reach in low-resolution pixels.
    blur_sigma, blur_radius : float, int, keyword-only
        The edge-aware blur's spatial sigma and reach, low-resolution pixels (``blur_radius = 0``: no blur).

    Examples
    --------
    >>> planner = OffsetPlanner(analysis)                       # doctest: +SKIP
    >>> plan = planner.solve(variant="comfort", zone=(-60, 60))  # doctest: +SKIP
    >>> plan = planner.solve(alpha=(1, 1, 10, 1), variant="comfort", zone=(-60, 60))  # doctest: +SKIP
    """

    def __init__(
        self,
        analysis: OffsetAnalysis,
        *,
        factor: int = PLAN_FACTOR,
        sigma_space: float = 1.0,
        sigma_range: float = PLAN_SIGMA_RANGE,
        radius: int = 2,
        blur_sigma: float = 2.0,
        blur_radius: int = 4,
    ) -> None:
        if not isinstance(analysis, OffsetAnalysis):
            raise TypeError(f"analysis must be a vergence.specular.OffsetAnalysis; got {type(analysis).__name__}")
        factor = check_factor(factor)
        self.sigma_space = check_positive("sigma_space", sigma_space)
        self.sigma_range = check_positive("sigma_range", sigma_range)
        for name, value in (("radius", radius), ("blur_radius", blur_radius)):
            if isinstance(value, bool) or not isinstance(value, Integral) or not 0 <= value <= 16:
                raise ValueError(f"{name} must be an integer in [0, 16]; got {value!r}")
        self.blur_sigma = check_positive("blur_sigma", blur_sigma)
        # the analysis itself is not kept: a planner kept for re-solving holds only the reduced table
        self.factor, self.radius, self.blur_radius = int(factor), int(radius), int(blur_radius)
        self._shape = analysis.importance.shape[1:]
        t0 = time.perf_counter()
        # S3 §3.2: importance of the physical pair, for every offset; a matched pixel counts at least
        # IMPORTANCE_FLOOR (ours: a viewer may fuse what the importance model calls unimportant)
        matched = np.isfinite(analysis.original[..., 0])
        physical = np.where(matched, np.maximum(analysis.importance[-1], IMPORTANCE_FLOOR), 0.0).astype(np.float32)
        weight = np.broadcast_to(physical, analysis.importance.shape)
        self._disparity, _ = weighted_block_mean(analysis.disparity, weight, self.factor)
        self._rivalry, _ = weighted_block_mean(analysis.rivalry, weight, self.factor)
        # the importance of a block is its plain mean: NaN-free, in [0, 1]
        _, self._importance = weighted_block_mean(np.zeros(physical.shape, np.float32), physical, self.factor)
        self._guide_high = np.array(analysis.original[..., 0])
        self._guide_low = np.array(self._disparity[-1, ..., 0])
        self.seconds_reduce = time.perf_counter() - t0

    @property
    def low_shape(self) -> tuple[int, int]:
        """``(h, w)`` of the reduced table."""
        return self._importance.shape[2:]

    def _reduced_maps(self, maps: Mapping[str, object] | None) -> dict[str, np.ndarray]:
        shape = self._shape
        if maps is None:
            return {}
        if not isinstance(maps, Mapping):
            raise TypeError(f"maps must be a mapping of term name to (N, H, W) weights; got {type(maps).__name__}")
        unknown = set(maps) - set(COST_TERMS)
        if unknown:
            raise ValueError(f"maps has unknown terms {sorted(unknown)}; the terms are {', '.join(COST_TERMS)}")
        out = {}
        for name, value in maps.items():
            arr = np.asarray(value, dtype=np.float32)
            if arr.shape != shape:
                raise ValueError(f"the {name} weight map must have shape {shape}; got {arr.shape}")
            if not np.isfinite(arr).all() or (arr < 0).any():
                raise ValueError(f"the {name} weight map must be finite and >= 0")
            out[name], _ = weighted_block_mean(arr, np.ones(shape, np.float32), self.factor)
        return out

    def solve(
        self,
        *,
        alpha: object = COST_WEIGHTS,
        variant: str = "screen",
        zone: tuple[float, float] | None = None,
        maps: Mapping[str, object] | None = None,
        lam: tuple[float, float] = RELATIVE_LAMBDA_ARCMIN,
        margin: float = COMFORT_MARGIN_ARCMIN,
        vertical: float = VERTICAL_TOLERANCE_ARCMIN,
        rivalry_tolerance: float = RIVALRY_TOLERANCE,
        fixed: object = (0,),
        steps: int = DESCENT_STEPS,
        restarts: int = RESTARTS,
    ) -> OffsetPlan:
        """The offsets minimising S3 Eq. 2 for these weights (arguments as :func:`~vergence.specular.optimise_offsets`).

        ``maps`` are full-resolution ``(N, H, W)`` painted weights by term; they are block-averaged
        to the solve's resolution. A layer whose four maps are 0 at a pixel keeps ``y = 1`` there.
        """
        t0 = time.perf_counter()
        low_maps = self._reduced_maps(maps)
        sol = optimise_offsets(self._disparity, self._rivalry, self._importance, self._disparity[-1], alpha=alpha,
                               variant=variant, zone=zone, maps=low_maps, lam=lam, margin=margin, vertical=vertical,
                               rivalry_tolerance=rivalry_tolerance, fixed=fixed, steps=steps,
                               restarts=restarts)  # fmt: skip
        weight = self._importance
        y_low = push_pull_fill(sol.y, weight)
        weight = weight + FILL_WEIGHT
        if self.blur_radius:  # S3's edge-aware blur, at the solve's resolution
            y_low = joint_bilateral_upsample(y_low, weight, self._guide_low, self._guide_low,
                                             sigma_space=self.blur_sigma, sigma_range=self.sigma_range,
                                             radius=self.blur_radius, fill=1.0)  # fmt: skip
        y = joint_bilateral_upsample(y_low, weight, self._guide_low, self._guide_high,
                                     sigma_space=self.sigma_space, sigma_range=self.sigma_range, radius=self.radius,
                                     fill=1.0)  # fmt: skip
        y = np.clip(y, 0.0, 1.0).astype(np.float32)
        for i in fixed:
            y[i] = 1.0
        if maps:  # frozen where every painted map of the layer is 0
            full = [np.asarray(maps[t], dtype=np.float32) if maps.get(t) is not None else None for t in COST_TERMS]
            if all(f is not None for f in full):
                y[sum(full) == 0] = 1.0
        return OffsetPlan(y=y, y_low=np.array(sol.y), cost_low=np.array(sol.cost), factor=self.factor,
                          seconds=time.perf_counter() - t0)  # fmt: skip
