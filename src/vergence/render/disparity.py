"""Disparity measured on rendered geometry: every first hit of one view projected into the other.

For a rendered stereo pair the truth needs no matching: the left view's first-hit points (node 1 of
the S3 §3.1 ray tree) are projected into the right camera. With the shifted-sensor rig of S0 §2 a
point at camera-frame depth ``z`` then has ``x_left - x_right = fx b (1/z - 1/H)`` pixels (S0
Eq. (1a) in pixels, opposite sign; ``docs/conventions.md``).
"""

from __future__ import annotations

import numpy as np

from vergence.camera import Camera
from vergence.render.results import RenderResult

__all__ = ["screen_disparity"]


def screen_disparity(left: RenderResult, right: RenderResult) -> np.ndarray:
    """Pixel disparity ``x_left - x_right`` ``(H, W)`` of every first hit seen through the left view.

    Parameters
    ----------
    left, right : RenderResult
        The two views of one scene (e.g. from :func:`~vergence.render.render_stereo`); the right
        one supplies only its camera, a pinhole :class:`~vergence.camera.Camera`.

    Returns
    -------
    (H, W) float64
        ``x_left - x_right`` in pixels at each left pixel; NaN where the left ray escapes or the
        point lies behind the right camera. Positive in front of the convergence plane.

    Raises
    ------
    TypeError
        If an argument is not a RenderResult or the right camera is not a pinhole Camera.

    Examples
    --------
    A fronto-parallel wall at depth z = 2 m, rig b = 0.1 m, H = 4 m: ``fx b (1/z - 1/H)`` px.
    """
    for name, value in (("left", left), ("right", right)):
        if not isinstance(value, RenderResult):
            raise TypeError(f"{name} must be a vergence.render.RenderResult; got {type(value).__name__}")
    if not isinstance(right.camera, Camera):
        raise TypeError(f"right.camera must be a pinhole vergence.camera.Camera; got {type(right.camera).__name__}")
    points = np.asarray(left.position[0], dtype=np.float64)  # node 1: the first hit of each left pixel
    h, w = points.shape[:2]
    x_left = np.broadcast_to(np.arange(w, dtype=np.float64), (h, w))
    valid = np.isfinite(points).all(axis=-1)
    out = np.full((h, w), np.nan)
    x_right, _ = right.camera.project(points[valid])
    out[valid] = x_left[valid] - x_right[:, 0]
    return out
