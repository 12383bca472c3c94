"""Issue 9, the sweep's depth/metrics cases (tools/sweep, /work/notes/sweep_quick1.md): one hostile
option at a time on an otherwise valid call, each refused with the documented error."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.depth import (
    compute_disparity,
    disparity_preview,
    middlebury_regions,
    rectify_cameras,
    rectify_pair,
    refine_disparity,
)

H, W = 24, 48


def _pair() -> tuple[np.ndarray, np.ndarray]:
    right = np.random.default_rng(0).random((H, W)).astype(np.float32)
    return np.roll(right, 3, axis=1), right


def _cameras():
    a = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=W, height=H)
    b = look_at([0.1, 0, 0], [0.1, 0, 5], [0, -1, 0], fov_deg=60, width=W, height=H)
    return a, b


def _ramp() -> np.ndarray:
    return np.broadcast_to(np.linspace(2.0, 4.0, W, dtype=np.float32), (H, W)).copy()


# name -> call with the bool option given; a string ("no", "False") is truthy and used to pass unseen
BOOL_OPTIONS = {
    "keep_invalid (compute_disparity)": lambda v: compute_disparity(*_pair(), max_disparity=16, keep_invalid=v),
    "keep_invalid (refine_disparity)": lambda v: refine_disparity(_ramp(), _pair()[0], keep_invalid=v),
    "colour_bar": lambda v: disparity_preview(_ramp(), lo=0.0, hi=8.0, colour_bar=v),
    "disc_includes_occlusions": lambda v: middlebury_regions(_ramp(), disc_includes_occlusions=v),
    "common_principal_point (rectify_cameras)": lambda v: rectify_cameras(*_cameras(), common_principal_point=v),
    "common_principal_point (rectify_pair)": lambda v: rectify_pair(*_pair(), *_cameras(), common_principal_point=v),
}


@pytest.mark.parametrize("option", list(BOOL_OPTIONS))
@pytest.mark.parametrize("value", ["False", None, 1])
def test_bool_option_refuses_non_bool(option, value):
    """Sweep cases api/{compute_disparity,refine_disparity}/keep_invalid=string, disparity_preview/colour_bar,
    middlebury_regions/disc_includes_occlusions, rectify_{cameras,pair}/common_principal_point."""
    name = option.split(" ")[0]
    with pytest.raises(TypeError, match=rf"^{name} must be a bool; got {type(value).__name__}$"):
        BOOL_OPTIONS[option](value)


@pytest.mark.parametrize("option", list(BOOL_OPTIONS))
def test_bool_option_takes_numpy_bool(option):
    BOOL_OPTIONS[option](np.bool_(False))
