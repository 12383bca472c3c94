"""The shifted-sensor geometry the rigs share: internal API of :mod:`vergence.rigs`.

:func:`~vergence.rigs.stereo.stereo_pair`, the tri- and quadri-rigs and the world distortion build
their cameras with these: a rig length checked against :data:`vergence.viewing.LENGTH_RANGE`, and the
right camera of a shifted-sensor pair (S0 §2) whose left camera is given.
"""

from __future__ import annotations

import math

import numpy as np

from vergence._validate import check_positive
from vergence.camera import Camera
from vergence.viewing.geometry import LENGTH_RANGE

__all__ = ["check_rig_length", "shifted_right_camera"]


def check_rig_length(name: str, value: object) -> float:
    """A rig length in metres, refused outside LENGTH_RANGE (where the rig's figures stay finite)."""
    v = check_positive(name, value)
    if not LENGTH_RANGE[0] <= v <= LENGTH_RANGE[1]:
        raise ValueError(f"{name} must be in [{LENGTH_RANGE[0]:g}, {LENGTH_RANGE[1]:g}] m (LENGTH_RANGE); got {v:g}")
    return v


def shifted_right_camera(camera: Camera, baseline: float, convergence: float) -> Camera:
    """``camera`` moved ``baseline`` along its right axis, principal point ``cx + fx b / H``: the right
    camera of a shifted-sensor pair whose left camera is ``camera`` (S0 §2; its window is ``camera``'s
    image at depth ``H``). Lengths already validated by the caller."""
    center = camera.center + baseline * camera.R[0]
    K = np.array(camera.K, copy=True)
    K[0, 2] += camera.focal_px * baseline / convergence  # sensor shift fx b / H (S0 §2)
    if not math.isfinite(K[0, 2]):
        raise ValueError(f"convergence must keep the sensor shift fx b / H finite; got cx = {K[0, 2]:g} px")
    return Camera(K=K, R=camera.R, t=-camera.R @ center, width=camera.width, height=camera.height)
