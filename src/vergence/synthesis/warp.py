"""Rectified forward and backward warping with a z-buffer and the gap/hole rule (S1 §IV.A–B).

Two rectified views on one horizontal line: a pixel at column x with disparity d (pixels,
``x_left - x_right``, positive in front; see ``docs/conventions.md``) moves to ``x - scale d`` in
the target view, ``scale`` being the target's position along the baseline in units of the
baseline the disparity was measured on (S1 Eq. 7). Resampling is one-dimensional along
the rows (S1 §IV.A).
"""

from __future__ import annotations

from vergence._validate import check_finite
from vergence.synthesis import _stages
from vergence.synthesis._checks import check_image, check_map, check_nonnegative
from vergence.synthesis.view import WarpedView

__all__ = ["backward_warp", "forward_warp"]


def forward_warp(
    image: object, disparity: object, *, scale: float = 1.0, gradient_limit: float = 1.0
) -> WarpedView:
    """Forward-warp a rectified view: the pixel at x with disparity d moves to ``x - scale d``.

    The nearest surface (larger disparity) wins where several pixels land on one target pixel
    (z-buffer). Two horizontal neighbours whose target positions spread apart by at most
    ``gradient_limit`` pixels more than their source spacing (``|scale (d1 - d0)| <= limit``) are
    one surface: every target pixel centre between them receives the linear interpolation of the
    pair (sub-pixel splatting, which closes the sampling gaps). A larger jump is an occlusion
    boundary and the target interval stays a hole (disocclusion).

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        Float in [0, 1], uint8 or uint16.
    disparity : (H, W) array
        Pixels, ``x_left - x_right`` on the reference baseline; NaN = unknown (the pixel is skipped).
        Negative values are allowed (points behind the zero-parallax plane of a shifted set-up).
    scale : float
        Target position in baselines: 1 is the right view of a left reference, 0.5 the middle,
        negative values move the other way (a right reference toward the left).
    gradient_limit : float
        Largest gap, in target pixels, that is still a sampling gap (S1 Sec. IV.B.1).

    Returns
    -------
    WarpedView
        Warped image (0 in holes), the hole mask and, as ``nearness`` (unit ``"px"``), the warped
        source disparity (not scaled; NaN in holes); ``depth`` is None.

    Raises
    ------
    ValueError
        Shapes differ, disparity holds inf or is all unknown, a non-finite scale, a negative limit.

    Notes
    -----
    Rectified warping ``x' = x - scale d``, S1 Eq. (7) with ``Z = f b / d``; gap vs hole by the
    disparity-gradient rule of S1 Sec. IV.B.1: near on the left with a 10-px jump leaves a
    10-px hole. Rows run in parallel (Numba); within a row the z-test keeps the larger disparity.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.linspace(0, 1, 8, dtype=np.float32)[None, :]
    >>> res = forward_warp(img, np.full((1, 8), 2.0), scale=1.0)
    >>> res.holes.astype(int).tolist()
    [[0, 0, 0, 0, 0, 0, 1, 1]]
    """
    img = check_image("image", image)
    d = check_map("disparity", disparity, "image", img)
    s = check_finite("scale", scale)
    limit = check_nonnegative("gradient_limit", gradient_limit)
    out, zbuf, holes = _stages.forward_warp(_stages.as_hwc(img), d, s, limit)
    return WarpedView(image=_stages.like(out, img), holes=holes, nearness=zbuf, nearness_unit="px")


def backward_warp(image: object, disparity: object, *, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Inverse (backward) warp: the target pixel at x takes the source colour at ``x + scale d(x)``.

    ``disparity`` lives on the target grid (e.g. a forward-warped, median-filtered disparity);
    colours are interpolated linearly along the row.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        The source view (float in [0, 1], uint8 or uint16).
    disparity : (H, W) array
        Target-grid disparity in pixels, NaN = unknown.
    scale : float
        As in :func:`forward_warp`: the same ``scale`` undoes that forward warp.

    Returns
    -------
    image : float32, shape of ``image``
        Sampled colours, 0 where not valid.
    valid : (H, W) bool
        Known disparity and a source position within the row.

    Notes
    -----
    The inverse of S1 Eq. (7) on rectified rows; used after median filtering of the warped depth
    (Do et al., S1 §IV.B.1).

    Examples
    --------
    >>> import numpy as np
    >>> img = np.linspace(0, 1, 5, dtype=np.float32)[None, :]
    >>> out, ok = backward_warp(img, np.full((1, 5), 0.5))
    >>> np.round(out, 3).tolist(), ok.tolist()
    ([[0.125, 0.375, 0.625, 0.875, 1.0]], [[True, True, True, True, True]])
    """
    img = check_image("image", image)
    d = check_map("disparity", disparity, "image", img)
    s = check_finite("scale", scale)
    out, valid = _stages.backward_warp(_stages.as_hwc(img), d, s)
    return _stages.like(out, img), valid
