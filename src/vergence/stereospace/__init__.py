"""StereoSpace (S2): stereo browsing of a calibrated photo collection.

The space of stereo pairs of a camera graph, its regions and parameters (S2 §4), and the navigation
through it by zoom and pan with jumps between regions (S2 §4.1).
"""

from vergence.stereospace.navigation import JUMP_SAMPLES, MOVE_EVENTS, Move, pan, tangent, zoom
from vergence.stereospace.space import (
    JUMP_CONE_DEG,
    PARALLEL_SINE,
    RELATIVE_TOLERANCE,
    StereoSpace,
    StereoState,
    stereo_point,
)

__all__ = [
    "JUMP_CONE_DEG",
    "JUMP_SAMPLES",
    "MOVE_EVENTS",
    "Move",
    "PARALLEL_SINE",
    "RELATIVE_TOLERANCE",
    "StereoSpace",
    "StereoState",
    "pan",
    "stereo_point",
    "tangent",
    "zoom",
]
