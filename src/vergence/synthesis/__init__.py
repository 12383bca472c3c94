"""View synthesis from colour + depth (S1): warping, blending, hole filling and depth controls.

Primitives: :func:`forward_warp` / :func:`backward_warp` (rectified), :func:`warp_to_camera`
(general 3D, z-buffer or McMillan order), :func:`median_refine`, :func:`dilate_foreground`,
:func:`contour_mask`, :func:`smooth_depth`, :func:`blend_views`, :func:`fill_holes`; one result
type, :class:`WarpedView`. Depth controls: :func:`plan_parallax`. Pipelines (``dibr.py``, imported
on first use so that importing a primitive does not load them): :func:`interpolate_view`,
:func:`synthesize_stereo`, :func:`synthesize_views`, :func:`synthesize_view`. Multi-view
image-based rendering (``ibr.py``, also on first use): :func:`render_ibr` with ULR or Bayesian
weights, the Bayesian weights of Pujades et al. 2014 alone: :func:`bayesian_weights`
(``ibr_bayes.py``). Quality against the real view: :func:`assess_view`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from vergence.synthesis.advice import MOSTLY_HOLES_FRACTION, holes_warnings, plan_comfort, stereo_warnings
from vergence.synthesis.blend import baseline_weights, blend_views
from vergence.synthesis.controls import (
    DEPTH_KINDS,
    INVERSE_DEPTH_RANGE,
    MAX_PARALLAX_WIDTHS,
    MAX_VIEWS,
    MIN_METRIC_DEPTH,
    MIN_PARALLAX_PX,
    ParallaxPlan,
    nearness_from_depth,
    plan_parallax,
    views_offsets,
)
from vergence.synthesis.filters import (
    MAX_FILTER_RADIUS,
    MAX_SMOOTH_SIGMA,
    contour_mask,
    dilate_foreground,
    median_refine,
    smooth_depth,
)
from vergence.synthesis.holes import FILL_METHODS, fill_disparity, fill_holes
from vergence.synthesis.quality import ViewQuality, assess_view, error_image
from vergence.synthesis.view import NEARNESS_UNITS, WarpedView
from vergence.synthesis.warp import backward_warp, forward_warp
from vergence.synthesis.warp3d import WARP_ORDERS, epipole, refine_camera_warp, warp_to_camera

if TYPE_CHECKING:
    from vergence.synthesis.dibr import (
        MAX_SYNTHESIS_BYTES,
        StereoResult,
        interpolate_view,
        synthesize_stereo,
        synthesize_view,
        synthesize_views,
    )
    from vergence.synthesis.ibr import IBR_INTERPOLATIONS, IBR_LINK_LIMIT_PX, IBR_WEIGHTS, IBRResult, render_ibr
    from vergence.synthesis.ibr_source import IBRSource
    from vergence.synthesis.ibr_bayes import (
        BAYES_DEFORMATION_CAP,
        BAYES_DEPTH_CONTINUITY,
        BAYES_GEOMETRIC_CAP,
        BAYES_GRADIENT_THRESHOLD,
        BAYES_MIN_DEFORMATION,
        BAYES_SIGMA_DEPTH,
        BAYES_SIGMA_SENSOR,
        bayesian_weights,
    )

# Pipelines and multi-view IBR, loaded on first attribute access (PEP 562), so that importing a
# primitive neither loads them nor compiles their kernels.
_LAZY = {
    "BAYES_DEFORMATION_CAP": "vergence.synthesis.ibr_bayes",
    "BAYES_DEPTH_CONTINUITY": "vergence.synthesis.ibr_bayes",
    "BAYES_GEOMETRIC_CAP": "vergence.synthesis.ibr_bayes",
    "BAYES_GRADIENT_THRESHOLD": "vergence.synthesis.ibr_bayes",
    "BAYES_MIN_DEFORMATION": "vergence.synthesis.ibr_bayes",
    "BAYES_SIGMA_DEPTH": "vergence.synthesis.ibr_bayes",
    "BAYES_SIGMA_SENSOR": "vergence.synthesis.ibr_bayes",
    "bayesian_weights": "vergence.synthesis.ibr_bayes",
    "IBRResult": "vergence.synthesis.ibr",
    "IBRSource": "vergence.synthesis.ibr_source",
    "IBR_INTERPOLATIONS": "vergence.synthesis.ibr",
    "IBR_LINK_LIMIT_PX": "vergence.synthesis.ibr",
    "IBR_WEIGHTS": "vergence.synthesis.ibr",
    "MAX_SYNTHESIS_BYTES": "vergence.synthesis.dibr",
    "StereoResult": "vergence.synthesis.dibr",
    "interpolate_view": "vergence.synthesis.dibr",
    "synthesize_stereo": "vergence.synthesis.dibr",
    "synthesize_view": "vergence.synthesis.dibr",
    "synthesize_views": "vergence.synthesis.dibr",
    "render_ibr": "vergence.synthesis.ibr",
}


def __getattr__(name: str) -> object:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "BAYES_DEFORMATION_CAP",
    "BAYES_DEPTH_CONTINUITY",
    "BAYES_GEOMETRIC_CAP",
    "BAYES_GRADIENT_THRESHOLD",
    "BAYES_MIN_DEFORMATION",
    "BAYES_SIGMA_DEPTH",
    "BAYES_SIGMA_SENSOR",
    "DEPTH_KINDS",
    "FILL_METHODS",
    "IBRResult",
    "IBRSource",
    "IBR_INTERPOLATIONS",
    "IBR_LINK_LIMIT_PX",
    "IBR_WEIGHTS",
    "INVERSE_DEPTH_RANGE",
    "MAX_FILTER_RADIUS",
    "MAX_PARALLAX_WIDTHS",
    "MAX_SMOOTH_SIGMA",
    "MAX_SYNTHESIS_BYTES",
    "MAX_VIEWS",
    "MIN_METRIC_DEPTH",
    "MIN_PARALLAX_PX",
    "MOSTLY_HOLES_FRACTION",
    "NEARNESS_UNITS",
    "ParallaxPlan",
    "StereoResult",
    "ViewQuality",
    "WARP_ORDERS",
    "WarpedView",
    "assess_view",
    "backward_warp",
    "baseline_weights",
    "bayesian_weights",
    "blend_views",
    "contour_mask",
    "dilate_foreground",
    "epipole",
    "error_image",
    "fill_disparity",
    "fill_holes",
    "forward_warp",
    "holes_warnings",
    "interpolate_view",
    "median_refine",
    "nearness_from_depth",
    "plan_comfort",
    "plan_parallax",
    "refine_camera_warp",
    "render_ibr",
    "smooth_depth",
    "stereo_warnings",
    "synthesize_stereo",
    "synthesize_view",
    "synthesize_views",
    "views_offsets",
    "warp_to_camera",
]
