"""The disparity search range of a stereo clip, found from its content per shot, and the check that it held.

A matcher only finds disparities inside its search range ``[lo, hi]``; content beyond it is matched
to something inside, and piles up at the bound. So:

1. **Estimate** (:func:`shot_search_ranges`): SIFT features of up to :data:`SAMPLES_PER_SHOT` frames of
   each shot (its first, middle and last), matched with Lowe's ratio test and cleaned by a RANSAC
   fundamental matrix (:func:`vergence.depth.measure_row_alignment`, on views at most
   :data:`FEATURE_MAX_WIDTH` px wide), give the disparities ``x_left - x_right`` of the shot's
   textured content. The range is their :data:`SEARCH_TAIL` and ``100 - SEARCH_TAIL`` percentiles,
   widened on each side by :data:`SEARCH_MARGIN_SHARE` of that spread (at least
   :data:`SEARCH_MARGIN_MIN_PX`), kept within ``+-width / 2``. Fewer than 8 consistent features in
   every sample: the default ``+-width/8`` (:func:`vergence.video._matching.default_search_px`),
   said so (``source = "default"``).
2. **Check** (:func:`match_searched`): a frame is *saturated* at a bound when more than
   :data:`SATURATION_SHARE` of its matched pixels lie within :data:`SATURATION_PX` of it (pixels of the
   columns where the whole range can be searched: near the edges the matcher sees padding). A bound that
   was estimated (not given by the user) is then moved out by the range's width (at least 16 px) and
   the frame matched again, once; a frame still saturated is reported as such. A shot is saturated too
   when more than :data:`SATURATION_SHARE` of its features lie beyond a bound the caller gave (content far beyond a
   bound is mostly left unmatched rather than piled up at it, so the pixels alone can miss it).
3. **Report** (:func:`on_bound`): a percentile within :data:`SATURATION_PX` of the range it was
   searched in is named, so that no figure sitting on a bound goes out without saying so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vergence.depth.matching import BOUND_PX, BOUND_SHARE, bound_shares
from vergence.video._matching import default_search_px, match_padded

__all__ = [
    "FEATURE_MAX_WIDTH",
    "SAMPLES_PER_SHOT",
    "SATURATION_PX",
    "SATURATION_SHARE",
    "SEARCH_MARGIN_MIN_PX",
    "SEARCH_MARGIN_SHARE",
    "SEARCH_TAIL",
    "SearchRange",
    "SearchedFrame",
    "feature_alignment",
    "match_searched",
    "on_bound",
    "search_from_disparities",
    "shot_search_ranges",
]

# Frames of a shot whose features set its range (first, middle, last).
SAMPLES_PER_SHOT = 3
# Features are matched on views reduced to at most this width (SIFT on a 1080p pair costs ~2 s on 2 cores).
FEATURE_MAX_WIDTH = 960
# Percent of the features' disparities left out at each end (stray matches that passed RANSAC).
SEARCH_TAIL = 1.0
# Margin added on each side of the features' range: this share of its spread, and at least this many px
# (content without features, such as a flat wall, can lie a little beyond the textured content).
SEARCH_MARGIN_SHARE = 0.25
SEARCH_MARGIN_MIN_PX = 16
# A matched pixel within this of a bound is at the bound (px): the matcher's rule (vergence.depth.BOUND_PX).
SATURATION_PX = BOUND_PX
# A frame is saturated at a bound when more than this share of its matched pixels are at it; a shot, also when
# more than this share of its features lie outside the range. With the margin, content does not reach a bound
# that holds it: on the clips of tests/video/test_search.py a range that holds the content puts 0.0 % at each
# bound, ranges 10-30 px short of it 0.3-12 % (content far beyond a bound is mostly left unmatched, not piled
# up: hence the features' share too).
SATURATION_SHARE = BOUND_SHARE


@dataclass(frozen=True, slots=True)
class SearchRange:
    """A shot's search range ``[lo, hi]`` (px of the views) and where it came from: ``"content"`` (its
    features, ``features`` of them), ``"given"`` (both bounds by the caller) or ``"default"`` (too few
    features: ``+-width/8``). ``fixed`` says which bounds the caller gave (those are never widened);
    ``features_outside`` is the share of the features whose disparity lies beyond a bound the caller gave."""

    lo: int
    hi: int
    source: str
    features: int = 0
    fixed: tuple[bool, bool] = (False, False)
    features_outside: float = 0.0

    @property
    def saturated(self) -> bool:
        """More than :data:`SATURATION_SHARE` of the shot's features lie beyond a given bound (a range given too narrow)."""
        return self.features_outside > SATURATION_SHARE

    def to_dict(self) -> dict:
        return {"search_px": [self.lo, self.hi], "search_source": self.source, "search_features": self.features,
                "features_outside": self.features_outside}


@dataclass(frozen=True, slots=True, eq=False)
class SearchedFrame:
    """One frame matched by :func:`match_searched`: its disparity (float64, NaN where unmatched), the range of
    the last pass, whether it was widened, and the share of matched pixels at each bound of that pass."""

    disparity: np.ndarray
    lo: int
    hi: int
    widened: bool
    at_bounds: tuple[float, float]

    @property
    def saturated(self) -> bool:
        """More than :data:`SATURATION_SHARE` of the matched pixels at a bound of the last pass."""
        return max(self.at_bounds) > SATURATION_SHARE


def feature_alignment(left: np.ndarray, right: np.ndarray):
    """:func:`vergence.depth.measure_row_alignment` of the pair reduced to at most :data:`FEATURE_MAX_WIDTH` px
    wide, its offsets scaled back to full-resolution px; None when too few features match."""
    import cv2

    from vergence.depth import measure_row_alignment
    from vergence.depth.rectify import RowAlignment

    height, width = left.shape[:2]
    f = max(1.0, width / FEATURE_MAX_WIDTH)
    small = [v if f == 1.0 else cv2.resize(v, (round(width / f), round(height / f)), interpolation=cv2.INTER_AREA)
             for v in (left, right)]  # fmt: skip
    try:
        found = measure_row_alignment(*small)
    except (ValueError, cv2.error):  # too few features, or RANSAC found no model
        return None
    return RowAlignment(f * found.abs_dy_px, f * found.disparity_px)


def search_from_disparities(disparity_px: np.ndarray, width: int) -> tuple[int, int]:
    """The search range of content whose features have the disparities ``disparity_px`` (module docstring, 1).

    Examples
    --------
    >>> search_from_disparities(np.linspace(36.0, 95.0, 200), 480)
    (20, 111)
    """
    values = np.asarray(disparity_px, dtype=np.float64)
    values = values[np.isfinite(values)]
    if values.size == 0:
        raise ValueError("disparity_px holds no finite value")
    d_lo, d_hi = np.percentile(values, [SEARCH_TAIL, 100.0 - SEARCH_TAIL])
    margin = max(SEARCH_MARGIN_MIN_PX, SEARCH_MARGIN_SHARE * (d_hi - d_lo))
    limit = width // 2
    lo = max(-limit, int(np.floor(d_lo - margin)))
    hi = min(limit, int(np.ceil(d_hi + margin)))
    return (lo, hi) if hi > lo else (min(lo, hi - 1), hi)


def _samples(start: int, end: int) -> list[int]:
    return sorted({start, (start + end - 1) // 2, end - 1})[:SAMPLES_PER_SHOT]


def shot_search_ranges(clip, shots: Sequence[tuple[int, int]], *, min_disparity: int | None = None,
                       max_disparity: int | None = None) -> list[SearchRange]:  # fmt: skip
    """The search range of each shot ``[start, end)`` of the stereo ``clip`` (module docstring, 1); a bound given
    by the caller is kept as given (both given: no frame is read)."""
    width = clip.width
    fixed = (min_disparity is not None, max_disparity is not None)
    ranges = []
    for start, end in shots:
        found = []
        for k in _samples(start, end):
            left, right = next(iter(clip.pairs(k, k + 1)))
            alignment = feature_alignment(left, right)
            if alignment is not None:
                found.append(alignment.disparity_px)
        values = np.concatenate(found) if found else np.zeros(0)
        if all(fixed):
            lo, hi = int(min_disparity), int(max_disparity)
            ranges.append(SearchRange(lo, hi, "given", int(values.size), fixed, _outside(values, lo, hi, fixed)))
            continue
        if values.size:
            lo, hi, source = *search_from_disparities(values, width), "content"
        else:
            search = default_search_px(width)
            lo, hi, source = -search, search, "default"
        lo = int(min_disparity) if fixed[0] else lo
        hi = int(max_disparity) if fixed[1] else hi
        if hi <= lo:  # one bound given on the far side of the content
            lo, hi = (lo, lo + 2 * SEARCH_MARGIN_MIN_PX) if fixed[0] else (hi - 2 * SEARCH_MARGIN_MIN_PX, hi)
        ranges.append(SearchRange(lo, hi, source, int(values.size), fixed, _outside(values, lo, hi, fixed)))
    return ranges


def _outside(values: np.ndarray, lo: int, hi: int, fixed: tuple[bool, bool]) -> float:
    """Share of the features beyond a bound the caller gave (an estimated bound leaves out the tails on purpose)."""
    if values.size == 0:
        return 0.0
    return float(np.mean((fixed[0] & (values < lo)) | (fixed[1] & (values > hi))))


def match_searched(left: np.ndarray, right: np.ndarray, search: SearchRange, method: str, *,
                   lo: int | None = None, hi: int | None = None) -> SearchedFrame:  # fmt: skip
    """Match a frame in ``[lo, hi]`` (default the shot's ``search``), and once more with each saturated bound that
    the caller did not give moved out by the range's width (module docstring, 2)."""
    width = left.shape[1]
    lo = search.lo if lo is None else lo
    hi = search.hi if hi is None else hi
    d = match_padded(left, right, lo, hi, method)
    shares = bound_shares(d, lo, hi)
    step = max(16, hi - lo)
    limit = width // 2
    new_lo = max(-limit, lo - step) if shares[0] > SATURATION_SHARE and not search.fixed[0] else lo
    new_hi = min(limit, hi + step) if shares[1] > SATURATION_SHARE and not search.fixed[1] else hi
    if (new_lo, new_hi) == (lo, hi):
        return SearchedFrame(d, lo, hi, False, shares)
    d = match_padded(left, right, new_lo, new_hi, method)
    return SearchedFrame(d, new_lo, new_hi, True, bound_shares(d, new_lo, new_hi))


def on_bound(percentiles: dict[str, float], lo: float, hi: float) -> list[str]:
    """The keys of ``percentiles`` within :data:`SATURATION_PX` of ``lo`` or ``hi``.

    Examples
    --------
    >>> on_bound({"p1": -63.5, "p50": 10.0, "p99": 63.9}, -64, 64)
    ['p1', 'p99']
    """
    return [k for k, v in percentiles.items() if abs(v - lo) <= SATURATION_PX or abs(v - hi) <= SATURATION_PX]
