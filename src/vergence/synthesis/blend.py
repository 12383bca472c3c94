"""Blending of two or more warped views with a depth test and per-pixel weights (S1 Sec. IV.B.2).

Each source has been warped to the target view (a :class:`~vergence.synthesis.WarpedView`); where
several see a pixel, the nearest surface wins (a depth test across sources); among the sources
that agree on the nearest surface, the reliable ones (not along a depth contour in their own view,
S1 Sec. IV.B.3) are preferred, and their colours are averaged with per-source, per-pixel weights:
one weight per source from its distance to the target along the baseline (S1 Sec. IV.B.2,
:func:`baseline_weights`), or any (N, H, W) weights (unstructured lumigraph or Bayesian weights).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vergence._validate import as_float_array, check_finite, check_positive
from vergence.synthesis import _stages
from vergence.synthesis._checks import within_float32
from vergence.synthesis.view import WarpedView

__all__ = ["baseline_weights", "blend_views"]


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
        Non-negative weights summing to 1. For two references they are the linear ones of S1 Sec. IV.B.2,
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
    if np.iscomplexobj(positions):
        raise TypeError("positions must be real; got a complex array")
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
        w[i] = (p[j] - t) / (p[j] - p[i])  # S1 Sec. IV.B.2: w_L = |t_v - t_R| / |t_R - t_L|
        w[j] = 1.0 - w[i]
    else:
        side = left if left.size else right
        w[side[np.argmin(np.abs(p[side] - t))]] = 1.0
    return w


def blend_views(
    views: Sequence[WarpedView],
    weights: object,
    *,
    depth_tolerance: float = 1.0,
    depth_rtol: float = 0.01,
) -> WarpedView:
    """Blend warped views: nearest surface first, reliable pixels next, weighted average last.

    Parameters
    ----------
    views : sequence of N WarpedView
        The sources warped to one target: one image layout, one ``nearness_unit``.
    weights : (N,) or (N, H, W) array
        Non-negative weights per source, or per source and target pixel (e.g.
        :func:`baseline_weights`); not all zero. A source with weight 0 at a pixel only fills it
        when no weighted source sees it (so a target at a reference position reproduces that
        reference exactly where it is known).
    depth_tolerance : float
        Depth test on ``nearness`` when some view has no metric ``depth`` (rectified views):
        two sources within this many pixels of disparity see the same surface; a larger
        difference is an occlusion and the nearer surface wins.
    depth_rtol : float
        Depth test when every view carries metric ``depth`` (general cameras): a source sees the
        nearest surface when its target depth is at most ``(1 + depth_rtol)`` times the smallest.

    Returns
    -------
    WarpedView
        Blended colours (0 in holes), ``nearness`` (and ``depth`` when all views have it) averaged
        with the same weights over the sources that passed the depth test (NaN in holes);
        ``reliability`` (when some view tracks it) True where a reliable source contributed;
        the ``payload`` channels (the keys every view has) blended like the colours.

    Raises
    ------
    ValueError
        No views, layouts, units or payload keys differ, weights of the wrong shape, negative or
        all zero, a non-positive tolerance.

    Notes
    -----
    S1 Sec. IV.B.2: blending compensates for intensity differences and distortions of the two
    warps; the nearer reference weighs more; the depth test is the z-buffer rule applied across
    sources. Sources without ``reliability`` count as reliable everywhere they see.

    Examples
    --------
    >>> import numpy as np
    >>> a = WarpedView(np.zeros((1, 2), np.float32), np.zeros((1, 2), bool), np.array([[1.0, 1.0]], np.float32))
    >>> b = WarpedView(np.ones((1, 2), np.float32), np.zeros((1, 2), bool), np.array([[1.0, 9.0]], np.float32))
    >>> blend_views([a, b], [0.75, 0.25]).image.tolist()
    [[0.25, 1.0]]
    """
    n = len(views)
    if n == 0:
        raise ValueError("views must be a non-empty sequence; got none")
    for i, v in enumerate(views):
        if not isinstance(v, WarpedView):
            raise TypeError(f"views[{i}] must be a WarpedView; got {type(v).__name__}")
    first = views[0]
    for i, v in enumerate(views[1:], start=1):
        if v.image.shape != first.image.shape:
            raise ValueError(f"views[{i}].image must have shape {first.image.shape} like views[0]; got {v.image.shape}")
        if v.nearness_unit != first.nearness_unit:
            raise ValueError(f"views[{i}].nearness_unit must be {first.nearness_unit!r} like views[0]; got {v.nearness_unit!r}")
        if set(v.payload) != set(first.payload):
            raise ValueError(f"views[{i}].payload must have the keys {sorted(first.payload)} of views[0]; got {sorted(v.payload)}")
    hw = first.image.shape[:2]
    w = as_float_array("weights", weights)
    if w.shape == (n,):
        w = np.broadcast_to(w[:, None, None], (n, *hw))
    elif w.shape != (n, *hw):
        raise ValueError(f"weights must have shape ({n},) or {(n, *hw)}; got {w.shape}")
    if (w < 0).any() or not (w.sum(axis=0) > 0).any():
        raise ValueError("weights must be >= 0 and not all zero")
    tol = within_float32("depth_tolerance", check_positive("depth_tolerance", depth_tolerance))
    rtol = check_positive("depth_rtol", depth_rtol)
    return _stages.blend(list(views), w, tol, rtol)
