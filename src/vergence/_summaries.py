"""Summaries of a set of registration distances (S1 Eq. (12)-(13)): internal API of :mod:`vergence.metrics`.

:func:`vergence.metrics.registration_error` and :func:`vergence.synthesis.assess_view` report the
same RMS, median and nearest-rank figures of their distances; both compute them here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["distance_summaries"]


def distance_summaries(values: np.ndarray, ranks: Sequence[float]) -> tuple[float, float, dict[float, float]]:
    """RMS, median and nearest-rank k-th ranked values (the ``ceil(k N)``-th smallest of the N
    values, k in (0, 1]; Eq. 13, k = 1 is Eq. 12) of a non-empty set of distances."""
    flat = np.sort(np.asarray(values, dtype=np.float64).ravel())
    ranked = {k: float(flat[max(math.ceil(k * flat.size), 1) - 1]) for k in ranks}
    peak = float(flat[-1])  # the RMS scaled by the largest distance: a subnormal radius's squares underflow to 0
    rms = peak * float(np.sqrt(np.mean((flat / peak) ** 2))) if peak > 0.0 else 0.0
    return rms, float(np.median(flat)), ranked
