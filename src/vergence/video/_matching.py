"""Matching of a stereo frame for :mod:`vergence.video` (analysis and conversion share it)."""

from __future__ import annotations

import numpy as np


def match_padded(left: np.ndarray, right: np.ndarray, lo: int, hi: int, method: str) -> np.ndarray:
    """Disparity of the left view, float64, NaN where unmatched; both views padded by the search range.

    OpenCV's matchers leave the first ``max_disparity`` and the last ``-min_disparity`` columns
    unmatched (their candidates fall outside the other image): padding both views with their edge
    columns moves that blind band into the padding, so pixels near the edges whose match lies
    inside the other view are measured. A pixel matched into the padding (``x - D`` outside the other
    view: it matched a replicated edge column) is left unmatched (NaN).
    """
    import cv2

    from vergence.depth import compute_disparity

    pad = hi - lo
    a, b = (cv2.copyMakeBorder(v, 0, 0, pad, pad, cv2.BORDER_REPLICATE) for v in (left, right))
    d = compute_disparity(a, b, min_disparity=lo, max_disparity=hi, method=method, keep_invalid=True).disparity
    d = d[:, pad:pad + left.shape[1]].astype(np.float64)
    # A match inside the padding (x - D outside the other view) is a match with a replicated edge column.
    x = np.arange(left.shape[1], dtype=np.float64)[None, :]
    with np.errstate(invalid="ignore"):
        d[(x - d < 0) | (x - d > left.shape[1] - 1)] = np.nan
    return d


# Default matching range of a stereo clip: +- this share of the view width, rounded up to 16 px.
SEARCH_SHARE = 1.0 / 8.0


def default_search_px(width: int) -> int:
    """The default half-range of the disparity search for views ``width`` px wide (a multiple of 16)."""
    import math

    return int(math.ceil(width * SEARCH_SHARE / 16.0) * 16)
