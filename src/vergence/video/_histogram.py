"""Pooled disparity percentiles of a shot: counts of ``D`` in bins of :data:`HISTOGRAM_STEP_PX` over ``[-W, W]``
(``vergence analyze`` reports them; ``vergence convert`` maps each shot's 1st-99th percentile range)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["HISTOGRAM_STEP_PX", "PERCENTILES", "MatchedPiece", "ShotHistogram"]

PERCENTILES = (1, 5, 50, 95, 99)
# Bin width of the per-shot histograms of D: shot percentiles are exact to this (px).
HISTOGRAM_STEP_PX = 1.0 / 16.0


class ShotHistogram:
    """Counts of D in bins of HISTOGRAM_STEP_PX over [-W, W] (a parallax of a whole width cannot be shown)."""

    def __init__(self, width: int) -> None:
        self.limit = float(width)
        self.bins = int(round(2 * self.limit / HISTOGRAM_STEP_PX))
        self.counts = np.zeros(self.bins, np.int64)
        self.lo, self.hi = np.inf, -np.inf  # exact extremes of the values added

    def add(self, d: np.ndarray) -> None:
        """Count the finite values ``d`` (a 1-D array)."""
        if d.size == 0:
            return
        self.lo, self.hi = min(self.lo, float(d.min())), max(self.hi, float(d.max()))
        idx = np.floor((np.clip(d, -self.limit, self.limit) + self.limit) / HISTOGRAM_STEP_PX).astype(np.int64)
        self.counts += np.bincount(np.minimum(idx, self.bins - 1), minlength=self.bins)

    def percentiles(self, lo: float, hi: float) -> np.ndarray:
        """The PERCENTILES, interpolated within their bins, kept within the exact extremes ``[lo, hi]``."""
        cum = np.cumsum(self.counts)
        total = cum[-1]
        out = []
        for p in PERCENTILES:
            rank = p / 100.0 * total
            k = int(np.searchsorted(cum, rank, side="left"))
            before = cum[k - 1] if k > 0 else 0
            inside = (rank - before) / self.counts[k] if self.counts[k] else 0.5
            out.append(-self.limit + (k + inside) * HISTOGRAM_STEP_PX)
        return np.clip(np.array(out), lo, hi)

    def merge(self, other: ShotHistogram) -> None:
        """Add the counts and extremes of ``other`` (a histogram of the same width)."""
        self.counts += other.counts
        self.lo, self.hi = min(self.lo, other.lo), max(self.hi, other.hi)

    def pooled(self) -> np.ndarray:
        """The :data:`PERCENTILES` of every value added (NaN when none was)."""
        if not self.counts.any():
            return np.full(len(PERCENTILES), np.nan)
        return self.percentiles(self.lo, self.hi)


@dataclass(frozen=True, slots=True, eq=False)
class MatchedPiece:
    """What matching one stereo piece found: the pooled histogram of its disparities (the shot's range is
    read from its pieces' merged histograms), the search range of its last frame, and how many frames were
    matched again in a widened range or stayed saturated (:mod:`vergence.video.search`)."""

    histogram: ShotHistogram
    search_px: tuple[int, int]
    widened_frames: int
    saturated_frames: int
    edges: tuple[float, float] = (math.nan, math.nan)  # the largest edge cue of its frames (edge_cues), left and right
