"""Shot cuts from the frames: a jump in the colour histogram between consecutive frames.

Rule (one pass, frame by frame, nothing kept but the previous frame's histogram):

1. Each frame is reduced to three normalised histograms of :data:`CUT_BINS` bins, one per RGB
   channel (a camera move changes where the colours are, hardly how much of each there is),
   counted on a grid of pixels at most :data:`CUT_SAMPLE_SIDE` wide or high (every pixel of a
   small frame, every 8th row and column of a 1080p one).
2. The change between frames ``k - 1`` and ``k`` is the histogram distance
   ``c_k = (1/3) sum_channels (1/2) sum_bins |h_k - h_(k-1)|``, in [0, 1] (0: same colours, 1: no
   colour in common).
3. A cut starts a shot at frame ``k`` when ``c_k >= CUT_THRESHOLD`` and the current shot is at least
   :data:`MIN_SHOT_FRAMES` long (a flash or a fast whip pan does not make a string of one-frame shots).

Dissolves and fades are not detected (no frame-to-frame jump); two shots of the same colours are
not separated.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

__all__ = ["CUT_BINS", "CUT_SAMPLE_SIDE", "CUT_THRESHOLD", "MIN_SHOT_FRAMES", "ShotCuts", "detect_cuts", "histogram_change"]

# Bins per channel: coarse enough that noise and compression do not move mass between bins.
CUT_BINS = 32
# Longest side of the pixel grid the histograms count (a histogram of 50k samples moves by well under
# 1 % between two samplings of one picture; decoding, not counting, then sets the pace).
CUT_SAMPLE_SIDE = 256
# Histogram distance of a cut. Measured on the rendered test clips (make_test_clips): within a
# moving shot 0.02-0.03, at the tabletop -> stadium cut 0.42.
CUT_THRESHOLD = 0.3
# Shortest shot, frames (a quarter of a second at 24 frames/s, except the last shot of a clip).
MIN_SHOT_FRAMES = 6


@dataclass(frozen=True, slots=True)
class ShotCuts:
    """Result of :func:`detect_cuts`.

    Attributes
    ----------
    shots : tuple of (int, int)
        ``(start, end)`` of each shot, ``end`` exclusive; they tile ``[0, frames)``.
    change : (frames,) float64
        ``c_k``, the histogram distance to the previous frame (0 for frame 0).
    """

    shots: tuple[tuple[int, int], ...]
    change: np.ndarray

    @property
    def cuts(self) -> tuple[int, ...]:
        """First frame of each shot after the first."""
        return tuple(start for start, _ in self.shots[1:])


def _histograms(frame: np.ndarray) -> np.ndarray:
    a = np.asarray(frame)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"frame must have shape (H, W, 3); got {a.shape}")
    step = max(1, -(-max(a.shape[:2]) // CUT_SAMPLE_SIDE))  # ceil: the grid is at most CUT_SAMPLE_SIDE long
    a = a[::step, ::step]
    levels = np.clip((a * CUT_BINS).astype(np.int64), 0, CUT_BINS - 1)
    counts = np.stack([np.bincount(levels[:, :, c].ravel(), minlength=CUT_BINS) for c in range(3)])
    return counts / float(levels.shape[0] * levels.shape[1])


def histogram_change(previous: object, frame: object) -> float:
    """The change ``c`` between two frames (rule 2 of the module): 0 same colours, 1 none in common.

    Examples
    --------
    >>> black, white = np.zeros((2, 2, 3)), np.ones((2, 2, 3))
    >>> histogram_change(black, white), histogram_change(black, black)
    (1.0, 0.0)
    """
    return float(0.5 * np.abs(_histograms(np.asarray(frame)) - _histograms(np.asarray(previous))).sum(axis=1).mean())


def detect_cuts(frames: Iterable[np.ndarray], *, threshold: float = CUT_THRESHOLD,
                min_shot: int = MIN_SHOT_FRAMES) -> ShotCuts:  # fmt: skip
    """Split a stream of frames into shots by the rule of the module.

    Parameters
    ----------
    frames : iterable of (H, W, 3) float arrays in [0, 1]
        Read once, in order (a generator of decoded frames).
    threshold : float
        ``CUT_THRESHOLD`` by default, in (0, 1].
    min_shot : int
        ``MIN_SHOT_FRAMES`` by default, >= 1.

    Returns
    -------
    ShotCuts

    Raises
    ------
    ValueError
        No frames, a frame that is not ``(H, W, 3)``, or bad options.

    Examples
    --------
    >>> grey = [np.full((4, 4, 3), 0.2)] * 8 + [np.full((4, 4, 3), 0.9)] * 8
    >>> detect_cuts(grey).shots
    ((0, 8), (8, 16))
    """
    if not (isinstance(threshold, int | float) and not isinstance(threshold, bool) and 0 < threshold <= 1):
        raise ValueError(f"threshold must be in (0, 1]; got {threshold!r}")
    if isinstance(min_shot, bool) or not isinstance(min_shot, int | np.integer) or min_shot < 1:
        raise ValueError(f"min_shot must be an integer >= 1; got {min_shot!r}")
    change: list[float] = []
    starts = [0]
    previous = None
    for k, frame in enumerate(frames):
        h = _histograms(frame)
        c = 0.0 if previous is None else float(0.5 * np.abs(h - previous).sum(axis=1).mean())
        change.append(c)
        if k > 0 and c >= threshold and k - starts[-1] >= min_shot:
            starts.append(k)
        previous = h
    if not change:
        raise ValueError("frames must hold at least one frame; got none")
    ends = [*starts[1:], len(change)]
    return ShotCuts(shots=tuple(zip(starts, ends)), change=np.array(change))
