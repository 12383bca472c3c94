"""StereoSpace (S2): stereo browsing of a calibrated photo collection."""

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

__all__ = [
    "CameraGraph",
    "Collection",
    "MATCH_NEIGHBOURS",
    "MAX_AXIS_ANGLE_DEG",
    "MAX_REPROJECTION_ERROR_PX",
    "MIN_SHARED_POINTS",
    "NEAR_FACTOR",
    "RATIO_TEST",
    "RING_CLOSURE",
    "camera_graph",
    "capture_paths",
    "load_collection",
    "project_distorted",
    "triangulate_points",
]
