"""Depth from stereo (S1 §III, §V.A; S2 §3.2): rectification, matching, refinement, evaluation.

- :mod:`~vergence.depth.rectify`: Fusiello-Trucco-Verri rectification of a calibrated pair (Fusiello et al. 2000).
- :mod:`~vergence.depth.matching`: OpenCV StereoSGBM/StereoBM and our window matcher, then refinement.
- :mod:`~vergence.depth.patchmatch`: PatchMatch Stereo, slanted support windows (Bleyer et al. 2011).
- :mod:`~vergence.depth.planes`: robust disparity planes of colour segments fill weakly textured areas.
- :mod:`~vergence.depth.texture`: where an image has texture to match (uniform pairs are refused).
- :mod:`~vergence.depth.refine`: left-right check, speckles, background filling, weighted median, confidence.
- :mod:`~vergence.depth.evaluate`: the Middlebury bad-pixel and RMS figures over the standard regions.
- :mod:`~vergence.depth.conversion`: depth from disparity and back (S1 Eq. 7).
"""

from vergence.depth._pair import MAX_BLOCK_SIZE
from vergence.depth.block import match_blocks
from vergence.depth.conversion import depth_from_disparity, disparity_from_depth
from vergence.depth.evaluate import (
    RegionScore,
    evaluate_disparity,
    mask_agreement,
    middlebury_regions,
    nonoccluded_mask,
    read_middlebury_masks,
)
from vergence.depth.matching import (
    MATCHERS,
    compute_disparity,
    match_bm,
    match_sgbm,
    sgbm_parameters,
)
from vergence.depth.patchmatch import PatchMatchParameters, PatchMatchResult, match_patchmatch, patchmatch_stereo
from vergence.depth.planes import (
    MIN_INLIER_SHARE,
    PLANE_SCALES,
    SegmentPlanes,
    fill_from_planes,
    fit_segment_planes,
    segment_image,
)
from vergence.depth.preview import disparity_preview
from vergence.depth.rectify import (
    Rectification,
    RectifiedPair,
    RowAlignment,
    measure_row_alignment,
    rectify_cameras,
    rectify_pair,
)
from vergence.depth.refine import (
    SMOOTHING_METHODS,
    RefinedDisparity,
    confidence_map,
    fill_occlusions,
    left_right_check,
    refine_disparity,
    remove_speckles,
    unreliable_pixels,
    weighted_median_filter,
)
from vergence.depth.texture import MIN_TEXTURE, MIN_TEXTURED_PERCENT, textured_pixels

__all__ = [
    "MATCHERS",
    "MAX_BLOCK_SIZE",
    "MIN_INLIER_SHARE",
    "MIN_TEXTURE",
    "MIN_TEXTURED_PERCENT",
    "PLANE_SCALES",
    "PatchMatchParameters",
    "PatchMatchResult",
    "Rectification",
    "RectifiedPair",
    "RefinedDisparity",
    "RegionScore",
    "RowAlignment",
    "SMOOTHING_METHODS",
    "SegmentPlanes",
    "compute_disparity",
    "confidence_map",
    "depth_from_disparity",
    "disparity_from_depth",
    "disparity_preview",
    "evaluate_disparity",
    "fill_from_planes",
    "fill_occlusions",
    "fit_segment_planes",
    "left_right_check",
    "mask_agreement",
    "match_blocks",
    "match_bm",
    "match_patchmatch",
    "match_sgbm",
    "measure_row_alignment",
    "middlebury_regions",
    "nonoccluded_mask",
    "patchmatch_stereo",
    "read_middlebury_masks",
    "rectify_cameras",
    "rectify_pair",
    "refine_disparity",
    "remove_speckles",
    "segment_image",
    "sgbm_parameters",
    "textured_pixels",
    "unreliable_pixels",
    "weighted_median_filter",
]
