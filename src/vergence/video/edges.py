"""The frame's edges of a converted shot: its stereo window, the floating window that masks it, and the band at
the left edge that the right view does not see.

**Stereo window.** Content in front of the screen (``D > 0``) that the frame's edge cuts breaks the window:
the edge, at the screen's depth, hides something nearer than itself. :func:`edge_cues` gives each frame's
depth cue (disparity, or nearness: larger is nearer) in its edge bands (:data:`EDGE_BAND` of the width, their
:data:`EDGE_PERCENTILE`-th percentile); a shot keeps the largest of its frames, which its linear psi maps to
the output's disparity at each edge (:func:`floating_window_of`).

**Floating window** (``vergence convert --floating-window``): :func:`masked_window` blacks out, for the whole
shot, that many columns at the left edge of the left view and at the right edge of the right one. The
window's edge then stands in front of the screen by as much as the content it cuts, the practice of
stereoscopic cinema (Devernay & Beardsley 2010).

**The left band** (:func:`fill_left_band`): a point near the left edge of the left view, in front of the
screen, lies left of the right view's frame (``x - D < 0``); nothing matches it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["EDGE_BAND", "EDGE_PERCENTILE", "FILL_FROM", "edge_cues", "fill_left_band", "floating_window_of",
           "masked_window"]

# Share of the width whose depth cue decides a floating window (as vergence analyze's window band), and the
# percentile of each frame's band taken (a few stray matches do not widen the window).
EDGE_BAND = 0.02
EDGE_PERCENTILE = 95


def edge_cues(cue: np.ndarray) -> tuple[float, float]:
    """The ``EDGE_PERCENTILE``-th percentile of a frame's depth cue (disparity or nearness: larger is nearer) in
    its left and right edge bands (``EDGE_BAND`` of the width, at least 2 columns); NaN where a band has none."""
    w = cue.shape[1]
    band = min(w, max(2, int(round(EDGE_BAND * w))))
    out = []
    for values in (cue[:, :band], cue[:, w - band:]):
        known = values[np.isfinite(values)]
        out.append(float(np.percentile(known, EDGE_PERCENTILE)) if known.size else math.nan)
    return out[0], out[1]


# The left band's fill: the median of the row's first matched values, this many.
FILL_FROM = 8


def fill_left_band(d: np.ndarray) -> np.ndarray:
    """``d`` with each row's band at the left edge that has no match given the row's first matched value.

    A point in front of the screen near the left edge of the left view lies left of the right view's frame
    (``x - D < 0``): nothing matches it, and a disparity filled from the background side would put it behind
    the planned range. The nearest disparities of its row whose match lands inside the right view
    (``x - D >= 1``) are the better guess (a surface cut by the frame's edge continues to them): the values
    before them (unknown, or matched onto the right view's edge) take the median of the first
    :data:`FILL_FROM`. Rows without any such value are
    left as they are.

    Examples
    --------
    >>> fill_left_band(np.array([[np.nan, 0.9, 5.0, np.nan, 3.0, 4.0, 2.0]], np.float32)).tolist()
    [[3.0, 3.0, 3.0, 3.0, 3.0, 4.0, 2.0]]
    >>> fill_left_band(np.array([[np.nan, np.nan, 1.0, 2.0, 2.0, 2.0]], np.float32)).tolist()
    [[2.0, 2.0, 1.0, 2.0, 2.0, 2.0]]
    """
    cols = np.arange(d.shape[1])
    with np.errstate(invalid="ignore"):
        known = np.isfinite(d) & (cols[None, :] - d >= 1.0)
    first = known.argmax(axis=1)
    rows = np.flatnonzero(known.any(axis=1) & (first > 0))
    if rows.size == 0:
        return d
    out = np.array(d)
    for r in rows:  # a loop over rows with a gap only (a Python loop, not per pixel)
        ahead = d[r, first[r]:][known[r, first[r]:]][:FILL_FROM]  # a stray match at the gap's end weighs little
        out[r, cols < first[r]] = np.median(ahead)
    return out


def masked_window(left: np.ndarray, right: np.ndarray, window: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The views with a floating window: ``window[0]`` columns black at the left edge of the left view,
    ``window[1]`` at the right edge of the right view (the inputs are not modified).

    Masking ``w`` columns of the left view's left edge puts that edge of the window ``w`` px in front of the
    screen (``D = x_left - x_right = w`` for the frame's edge): content at the edge with ``D <= w`` is then
    behind the window: the floating window of stereoscopic cinema (Devernay & Beardsley 2010).
    """
    wl, wr = window
    if wl > 0:
        left = np.array(left)
        left[:, :wl] = 0.0
    if wr > 0:
        right = np.array(right)
        right[:, right.shape[1] - wr:] = 0.0
    return left, right


def floating_window_of(mapping, edge: tuple[float, float], apply: bool) -> dict:
    """A shot's stereo window at its edges: the output's disparity ``D' = -psi(-q)`` of the edge cues ``q``
    (:func:`edge_cues`), and the floating window masking it (``apply``) in whole columns."""
    from vergence.video.analysis import WINDOW_MIN_PX

    d = [float(-mapping(-q)) if math.isfinite(q) else math.nan for q in edge]
    widths = [int(math.ceil(v)) if apply and math.isfinite(v) and v > WINDOW_MIN_PX else 0 for v in d]
    return {"edge_disparity_px": d, "applied": bool(apply), "left_px": widths[0], "right_px": widths[1]}
