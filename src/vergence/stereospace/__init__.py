"""StereoSpace (S2): stereo browsing of a calibrated photo collection.

- Collections (S2 §3): a camera set, its images and sparse 3D points (read, or matched and
  triangulated); the camera graph and its capture paths.
- The space of stereo pairs of the camera graph, its regions and parameters (S2 §4), and the
  navigation through it by zoom and pan with jumps between regions (S2 §4.1).
"""

from vergence.stereospace.collection import Collection, load_collection
from vergence.stereospace.graph import (
    MAX_AXIS_ANGLE_DEG,
    MIN_SHARED_POINTS,
    NEAR_FACTOR,
    RING_CLOSURE,
    CameraGraph,
    camera_graph,
    capture_paths,
)
from vergence.stereospace.triangulation import (
    MATCH_NEIGHBOURS,
    MAX_REPROJECTION_ERROR_PX,
    RATIO_TEST,
    project_distorted,
    triangulate_points,
)
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
    "CameraGraph",
    "Collection",
    "JUMP_CONE_DEG",
    "JUMP_SAMPLES",
    "MATCH_NEIGHBOURS",
    "MAX_AXIS_ANGLE_DEG",
    "MAX_REPROJECTION_ERROR_PX",
    "MIN_SHARED_POINTS",
    "MOVE_EVENTS",
    "Move",
    "NEAR_FACTOR",
    "PARALLEL_SINE",
    "RATIO_TEST",
    "RELATIVE_TOLERANCE",
    "RING_CLOSURE",
    "StereoSpace",
    "StereoState",
    "camera_graph",
    "capture_paths",
    "load_collection",
    "pan",
    "project_distorted",
    "stereo_point",
    "tangent",
    "triangulate_points",
    "zoom",
]
