"""StereoSpace (S2): stereo browsing of a calibrated photo collection.

- Collections (S2 §3): a camera set, its images and sparse 3D points (read, or matched and
  triangulated); the camera graph and its capture paths.
- Novel views by S2's method: :func:`mls_similarity` (the moving-least-squares similarity
  deformation of Schaefer et al. 2006), :func:`mls_warp` (an image warped through it on a coarse
  grid) and :func:`s2_view` (up to four warped sources blended with S2's angle and field-of-view
  penalties).
- Novel views at any camera and their leave-one-out PSNR: :func:`neighbours`, :func:`plane_view`
  (the one-plane baseline), :func:`source_depth` / :func:`source_depths` (per-view depth matched in
  the collection, :func:`check_depth` against the other views), :func:`novel_view` (``"mls"`` or
  ``"depth"``: per-view depth + ULR rendering), :func:`leave_one_out`.
- The space of stereo pairs of the camera graph, its regions and parameters (S2 §4), and the
  navigation through it by zoom and pan with jumps between regions (S2 §4.1).
- The stereo pair at a state (:func:`stereo_pair`: two novel views rectified together, packed for a
  display) and a quality value of a pair (:func:`pair_quality`: comfort and rectification distortion).
- A collection ray-traced from a scene (:func:`render_collection`: cameras on an arc, images and a
  camera file; a fresh clone's collection).
- Which way is up in a collection and which eye of a pair is the left one (:func:`collection_up`,
  :func:`eye_order`: pairs of rolled photos stay upright, S2 §4.2).
- Where browsing starts (:func:`start_state`: the most comfortable state between three consecutive
  cameras of a capture path; :func:`state_near`), and finding a good state in a built space
  (:func:`best_states` by the vertex qualities, :func:`vertex_state`, :func:`state_at_camera`).
- Framing and comfort of a pair (:func:`frame_cameras`: fit to the frame or crop;
  :func:`convergence_shift`: the horizontal image shift that centres the disparities in the zone).
- A built space (:func:`build_space`: graph, regions, leave-one-out PSNR, a quality per region
  vertex, :func:`vertex_quality`), saved to and loaded from a folder (:func:`save_space`,
  :func:`load_space`), and the frame of its top-view navigation map (:func:`map_frame`, S2 §4.3.1).
"""

from vergence.stereospace.collection import CAMERA_STATUSES, Collection, camera_roster, load_collection
from vergence.stereospace.orientation import UP_AGREEMENT, UP_DISTINCT, UP_MIN_COSINE, collection_up, eye_order
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
from vergence.stereospace.navigation import JUMP_SAMPLES, MAX_PAN_JUMPS, MOVE_EVENTS, Move, pan, pan_sign, tangent, zoom
from vergence.stereospace.space import (
    JUMP_CONE_DEG,
    PARALLEL_SINE,
    RELATIVE_TOLERANCE,
    StereoSpace,
    StereoState,
    stereo_point,
)
from vergence.stereospace.mls import MLS_MIN_HANDLES, mls_similarity, mls_warp
from vergence.stereospace.framing import FRAMINGS, ConvergenceShift, convergence_shift, frame_cameras
from vergence.stereospace.pair import (
    MAX_VIEW_SIDE,
    PAIR_METHODS,
    PreparedCollection,
    StereoPairResult,
    pair_cameras,
    space_from_graph,
    stereo_pair,
)
from vergence.stereospace.quality import pair_quality
from vergence.stereospace.start import RankedState, best_states, start_state, state_at_camera, state_near, vertex_state
from vergence.stereospace.sources import neighbours
from vergence.stereospace.depths import (
    CONSISTENCY_TOLERANCE,
    CONSISTENCY_VIEWS,
    CONSISTENCY_VOTES,
    CONSISTENCY_WINDOW,
    DISPARITY_MARGIN_PX,
    TEXTURE_MIN_STD,
    TEXTURE_WINDOW,
    check_depth,
    source_depth,
    source_depths,
)
from vergence.stereospace.views import NOVEL_VIEW_METHODS, NovelView, leave_one_out, novel_view, plane_view
from vergence.stereospace.rendered import (
    COLLECTION_ARC_DEG,
    COLLECTION_VIEWS,
    MAX_COLLECTION_VIEWS,
    render_collection,
)
from vergence.stereospace.build import (
    DEFAULT_DISPLAY,
    DISPARITY_TRIM,
    DISTORTION_LIMIT,
    PSNR_CEIL_DB,
    PSNR_FLOOR_DB,
    BuiltSpace,
    VertexQuality,
    build_space,
    map_frame,
    vertex_pairs,
    vertex_quality,
)
from vergence.stereospace.spacefile import SPACE_FILE, SPACE_FORMAT_VERSION, load_space, save_space, write_space
from vergence.stereospace.mls_view import (
    S2_HANDLE_CELL_PX,
    S2_MAX_SOURCES,
    S2_PENALTY_FLOOR,
    S2_THRESHOLD_SCALE,
    S2View,
    s2_view,
)

__all__ = [
    "BuiltSpace",
    "CAMERA_STATUSES",
    "COLLECTION_ARC_DEG",
    "COLLECTION_VIEWS",
    "CONSISTENCY_TOLERANCE",
    "CONSISTENCY_VIEWS",
    "CONSISTENCY_VOTES",
    "CONSISTENCY_WINDOW",
    "CameraGraph",
    "Collection",
    "ConvergenceShift",
    "DEFAULT_DISPLAY",
    "DISPARITY_MARGIN_PX",
    "DISPARITY_TRIM",
    "DISTORTION_LIMIT",
    "FRAMINGS",
    "JUMP_CONE_DEG",
    "JUMP_SAMPLES",
    "MATCH_NEIGHBOURS",
    "MAX_AXIS_ANGLE_DEG",
    "MAX_COLLECTION_VIEWS",
    "MAX_PAN_JUMPS",
    "MAX_REPROJECTION_ERROR_PX",
    "MAX_VIEW_SIDE",
    "MIN_SHARED_POINTS",
    "MLS_MIN_HANDLES",
    "MOVE_EVENTS",
    "Move",
    "NEAR_FACTOR",
    "NOVEL_VIEW_METHODS",
    "NovelView",
    "PAIR_METHODS",
    "PARALLEL_SINE",
    "PSNR_CEIL_DB",
    "PSNR_FLOOR_DB",
    "PreparedCollection",
    "RATIO_TEST",
    "RELATIVE_TOLERANCE",
    "RING_CLOSURE",
    "RankedState",
    "S2View",
    "S2_HANDLE_CELL_PX",
    "S2_MAX_SOURCES",
    "S2_PENALTY_FLOOR",
    "S2_THRESHOLD_SCALE",
    "SPACE_FILE",
    "SPACE_FORMAT_VERSION",
    "StereoPairResult",
    "StereoSpace",
    "StereoState",
    "TEXTURE_MIN_STD",
    "TEXTURE_WINDOW",
    "UP_AGREEMENT",
    "UP_DISTINCT",
    "UP_MIN_COSINE",
    "VertexQuality",
    "best_states",
    "build_space",
    "camera_graph",
    "camera_roster",
    "capture_paths",
    "check_depth",
    "collection_up",
    "convergence_shift",
    "eye_order",
    "frame_cameras",
    "leave_one_out",
    "load_collection",
    "load_space",
    "map_frame",
    "mls_similarity",
    "mls_warp",
    "neighbours",
    "novel_view",
    "pair_cameras",
    "pair_quality",
    "pan",
    "pan_sign",
    "plane_view",
    "project_distorted",
    "render_collection",
    "s2_view",
    "save_space",
    "source_depth",
    "source_depths",
    "space_from_graph",
    "start_state",
    "state_at_camera",
    "state_near",
    "stereo_pair",
    "stereo_point",
    "tangent",
    "triangulate_points",
    "vertex_pairs",
    "vertex_quality",
    "vertex_state",
    "write_space",
    "zoom",
]
