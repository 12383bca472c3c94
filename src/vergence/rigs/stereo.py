"""The parallel, shifted-sensor stereo rig of S0 §2 built on one camera.

Two cameras with the orientation and intrinsics of ``camera``, their centres ``b/2`` to the left
and right of its centre along its x axis, and their principal points shifted horizontally so that
both frusta cut the plane at camera-frame depth ``H`` in the same window: the one ``camera`` sees
there. A point at depth ``z`` then has pixel disparity

    x_left - x_right = fx b (1/z - 1/H)

(zero on the convergence plane, positive in front of it), which is S0 Eq. (1a),
``d = (b/W)(z - H)/z`` as a fraction of the window width ``W = H width / fx``, with the opposite
sign (``d = x_r - x_l``; see ``docs/conventions.md``). Pure geometry: no rendering engine here.
"""

from __future__ import annotations

import math

import numpy as np

from vergence.camera import Camera
from vergence.rigs._shifted import check_rig_length

__all__ = ["stereo_pair"]


def stereo_pair(camera: Camera, *, baseline: float, convergence: float) -> tuple[Camera, Camera]:
    """Left and right cameras of a shifted-sensor rig centred on ``camera`` (S0 §2).

    Parameters
    ----------
    camera : Camera
        The central (cyclopean) camera; its image is the convergence window.
    baseline : float
        Distance ``b`` between the two optical centres, metres, in ``LENGTH_RANGE`` (1e-6 to 1e6).
    convergence : float
        Camera-frame depth ``H`` of the convergence plane, metres, in ``LENGTH_RANGE``.

    Returns
    -------
    left, right : Camera
        Same ``R``, size and focal lengths as ``camera``; centres ``C -+ (b/2) r`` with ``r`` the
        camera's right axis (first row of ``R``); principal points
        ``cx -+ fx b / (2 H)`` (the sensor shift), ``cy`` unchanged.

    Raises
    ------
    TypeError
        If ``camera`` is not a :class:`~vergence.camera.Camera`.
    ValueError
        If ``baseline`` or ``convergence`` is not finite and in
        :data:`vergence.viewing.LENGTH_RANGE`, or the sensor shift (or the shifted principal point)
        is not finite (a focal length near the float64 limit).

    Notes
    -----
    Seen from the left camera, a point ``(X, Y, z)`` of the central camera frame is at
    ``X + b/2``, so ``x_l = fx (X + b/2)/z + cx - fx b/(2H)``; likewise
    ``x_r = fx (X - b/2)/z + cx + fx b/(2H)``. Both equal ``fx X/H + cx`` at ``z = H`` (same window)
    and ``x_l - x_r = fx b (1/z - 1/H)``: S0 Eq. (1a) times ``-W_px``.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=101, height=51)
    >>> left, right = stereo_pair(cam, baseline=0.1, convergence=2.0)
    >>> left.center.tolist(), left.principal_point
    ([-0.05, 0.0, 0.0], (48.7375, 25.0))
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a vergence.camera.Camera; got {type(camera).__name__}")
    b = check_rig_length("baseline", baseline)
    H = check_rig_length("convergence", convergence)
    right_axis = camera.R[0]
    shift_px = float(camera.K[0, 0]) * b / (2.0 * H)  # sensor shift fx b / (2H), S0 §2 (Python floats: no warning)
    cx = float(camera.K[0, 2])
    if not (math.isfinite(cx - shift_px) and math.isfinite(cx + shift_px)):
        raise ValueError(f"convergence must keep the sensor shift fx b / (2 H) finite; got {shift_px:g} px with "
                         f"fx = {camera.K[0, 0]:g} px, b = {b:g} m, H = {H:g} m")  # fmt: skip
    cams = []
    for sign in (-1.0, 1.0):
        center = camera.center + sign * (b / 2.0) * right_axis
        K = np.array(camera.K, copy=True)
        K[0, 2] = cx + sign * shift_px
        cams.append(Camera(K=K, R=camera.R, t=-camera.R @ center, width=camera.width, height=camera.height))
    return cams[0], cams[1]
