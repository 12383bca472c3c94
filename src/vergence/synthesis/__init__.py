"""View synthesis from colour + depth (S1): warping, blending, hole filling and depth controls.

Primitives: :func:`forward_warp` / :func:`backward_warp` (rectified), :func:`warp_to_camera`
(general 3D, z-buffer or McMillan order), :func:`median_refine`, :func:`dilate_foreground`,
:func:`contour_mask`, :func:`smooth_depth`, :func:`blend_views`, :func:`fill_holes`.
Depth controls: :func:`plan_parallax`. Pipelines: :func:`interpolate_view`,
:func:`synthesize_stereo`, :func:`synthesize_views`, :func:`synthesize_view`. Quality against the
real view: :func:`assess_view`.
"""

from vergence.synthesis.blend import BlendResult, baseline_weights, blend_views
from vergence.synthesis.controls import (
    DEPTH_KINDS,
    ParallaxPlan,
    nearness_from_depth,
    plan_parallax,
    views_offsets,
)
from vergence.synthesis.dibr import (
    StereoResult,
    ViewResult,
    interpolate_view,
    synthesize_stereo,
    synthesize_view,
    synthesize_views,
)
from vergence.synthesis.filters import contour_mask, dilate_foreground, median_refine, smooth_depth
from vergence.synthesis.holes import FILL_METHODS, fill_disparity, fill_holes
from vergence.synthesis.quality import ViewQuality, assess_view
from vergence.synthesis.warp import WarpResult, backward_warp, forward_warp
from vergence.synthesis.warp3d import (
    WARP_ORDERS,
    CameraWarpResult,
    epipole,
    refine_camera_warp,
    warp_to_camera,
)

__all__ = [
    "BlendResult",
    "CameraWarpResult",
    "DEPTH_KINDS",
    "FILL_METHODS",
    "ParallaxPlan",
    "StereoResult",
    "ViewQuality",
    "ViewResult",
    "WARP_ORDERS",
    "WarpResult",
    "assess_view",
    "backward_warp",
    "baseline_weights",
    "blend_views",
    "contour_mask",
    "dilate_foreground",
    "epipole",
    "fill_disparity",
    "fill_holes",
    "forward_warp",
    "interpolate_view",
    "median_refine",
    "nearness_from_depth",
    "plan_parallax",
    "refine_camera_warp",
    "smooth_depth",
    "synthesize_stereo",
    "synthesize_view",
    "synthesize_views",
    "views_offsets",
    "warp_to_camera",
]
