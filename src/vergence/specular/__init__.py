"""Specular disparity (S3): glass and mirrors in stereo, analysed on the ray tree of :mod:`vergence.render`.

- Per-layer disparity (S3 §3.2): each pixel of each layer of the left eye matched to the pixel of
  the same layer of the right eye nearest in 3D, in an 81 x 9 window, with a cutoff at 1/100 of the
  scene diameter (:func:`layer_disparity`, :class:`LayerDisparity`); in arcminutes for a display
  (:func:`disparity_arcmin`).
- Per-layer camera offsets (S3 §3.4): the left eye's shading camera moved along the baseline
  (:func:`offset_camera`, :func:`offset_rays`), the table of renders and disparities at k + 1
  offsets (:func:`tabulate_offsets`, :class:`OffsetTable`) and the final render with a camera per
  layer and pixel (:func:`render_offsets`; it and the table import Mitsuba when called).
- What the viewer sees of each layer (S3 §3.2): linear tone map, CSF low-pass, CIELAB L*
  (:func:`perceived_lightness`, :class:`PerceivedLightness`, :func:`csf_lowpass`).
- Importance = proximity x distinctiveness x contrast (S3 §3.2) (:func:`importance`,
  :class:`Importance`, :func:`distinctiveness`, :func:`peli_contrast`, :func:`contrast_q`).
- Rivalry: holes filled, then a 7 x 7 SSD of L* (S3 §3.2) (:func:`rivalry`, :class:`Rivalry`, :func:`fill_matches`).
- The cost of a pixel's layered disparities, absolute (S3's or outside the comfort zone only),
  relative, rivalry and data, with painted weight maps, and its gradient (S3 §3.3, Eq. 2:
  :func:`disparity_cost`, :class:`CostTerms`, :func:`disparity_cost_gradient`).
- Per-pixel camera offsets minimising it on a tabulated ``g(y)`` (S3 §3.4: :func:`optimise_offsets`),
  solved at low resolution and brought back up edge-aware, weighted by importance (S3 §3.4:
  :func:`weighted_block_mean`, :func:`joint_bilateral_upsample`); the table's analysis
  (:func:`analyse_table`, :class:`OffsetAnalysis`) and the whole-image plan (:class:`OffsetPlanner`).
- End to end (S3 §3-4): :func:`specular_stereo` -> :class:`SpecularResult`, measured per layer
  (:class:`LayerState`, :func:`comfort_share`), for the pair shown with a fit on the display
  (:func:`fit_display`, :data:`DISPLAY_FITS`, :func:`arcmin_per_pixel`, :func:`display_block`); plain
  and importance-weighted shares inside the comfort zone per layer and per mirror or glass object
  (:func:`zone_count`, :class:`ZoneCount`, :func:`object_shares`, :func:`specular_objects`,
  :func:`zone_warnings`, :data:`MOSTLY_OUTSIDE`); the offset table kept on disk and re-solved
  (:class:`SpecularTable`, :func:`write_specular_table`, :func:`read_specular_table`,
  :func:`specular_from_table`, :data:`TABLE_FILE`, :data:`TABLE_FORMAT`).
- The baselines S3 §4.1 compares with: every specular layer at the disparity of the surface it is
  seen on, or a constant offset behind or in front of it (Templin et al. 2012) (:func:`on_surface`,
  :func:`near_surface`).

The analysis works on arrays (``RenderResult.position``, ``radiance``); importing the package also
imports :mod:`vergence.render` (the tone map of :func:`perceived_lightness` lives there), and with
it Mitsuba. The table and the final render trace rays.
"""

from vergence.specular.cost import (
    ABSOLUTE_VARIANTS,
    COMFORT_MARGIN_ARCMIN,
    COST_TERMS,
    COST_WEIGHTS,
    RELATIVE_LAMBDA_ARCMIN,
    RIVALRY_TOLERANCE,
    VERTICAL_TOLERANCE_ARCMIN,
    CostTerms,
    disparity_cost,
    disparity_cost_gradient,
)
from vergence.specular.importance_factors import (
    CONTRAST_SATURATION_JND,
    CONTRAST_WINDOW,
    DISTINCTIVENESS_SCALE,
    SSD_WINDOW,
    Importance,
    contrast_q,
    distinctiveness,
    importance,
    peli_contrast,
)
from vergence.specular.lightness import (
    PerceivedLightness,
    csf_lowpass,
    csf_mannos_sakrison,
    layer_lightness,
    lightness_from_srgb,
    perceived_lightness,
    pixels_per_degree,
)
from vergence.specular.matching import (
    EPSILON_FRACTION,
    LAYER_MATCH_METHODS,
    MATCH_WINDOW,
    LayerDisparity,
    disparity_arcmin,
    layer_disparity,
    scene_diameter,
)
from vergence.specular.optimise import DESCENT_STEPS, FIRST_STEP, RESTARTS, OffsetSolution, optimise_offsets
from vergence.specular.tabulated import OffsetAnalysis, analyse_table
from vergence.specular.planning import (
    FILL_WEIGHT,
    IMPORTANCE_FLOOR,
    PLAN_FACTOR,
    PLAN_SIGMA_RANGE,
    OffsetPlan,
    OffsetPlanner,
)
from vergence.specular.pipeline import (
    DEFAULT_VARIANT,
    MAX_TABLE_BYTES,
    SpecularResult,
    offset_table_bytes,
    specular_from_table,
    specular_stereo,
)
from vergence.specular.render_check import (
    REPAIR_STEPS,
    RenderCheck,
    RepairedRender,
    check_render,
    repair_render,
)
from vergence.specular.result_report import SEPARATION_ARCMIN, layer_labels
from vergence.specular.resample import joint_bilateral_upsample, push_pull_fill, weighted_block_mean
from vergence.specular.rivalry_map import RIVALRY_WINDOW, Rivalry, fill_matches, rivalry
from vergence.specular.offsets import (
    MAX_OFFSET_STEPS,
    OffsetTable,
    offset_camera,
    offset_rays,
    render_offsets,
    tabulate_offsets,
)
from vergence.specular.surface_baselines import NEAR_SURFACE_ARCMIN, SAME_SURFACE_FRACTION, near_surface, on_surface
from vergence.specular.display_fit import DISPLAY_FITS, arcmin_per_pixel, display_block, fit_display
from vergence.specular.shares import (
    MOSTLY_OUTSIDE,
    LayerState,
    ZoneCount,
    comfort_share,
    object_shares,
    specular_objects,
    zone_count,
    zone_warnings,
)
from vergence.specular.table_file import (
    TABLE_FILE,
    TABLE_FORMAT,
    SpecularTable,
    read_specular_table,
    write_specular_table,
)

__all__ = [
    "ABSOLUTE_VARIANTS",
    "COMFORT_MARGIN_ARCMIN",
    "CONTRAST_SATURATION_JND",
    "CONTRAST_WINDOW",
    "COST_TERMS",
    "COST_WEIGHTS",
    "CostTerms",
    "DEFAULT_VARIANT",
    "DESCENT_STEPS",
    "DISPLAY_FITS",
    "DISTINCTIVENESS_SCALE",
    "EPSILON_FRACTION",
    "FILL_WEIGHT",
    "FIRST_STEP",
    "IMPORTANCE_FLOOR",
    "Importance",
    "LAYER_MATCH_METHODS",
    "LayerDisparity",
    "LayerState",
    "MATCH_WINDOW",
    "MAX_OFFSET_STEPS",
    "MAX_TABLE_BYTES",
    "MOSTLY_OUTSIDE",
    "NEAR_SURFACE_ARCMIN",
    "OffsetAnalysis",
    "OffsetPlan",
    "OffsetPlanner",
    "OffsetSolution",
    "OffsetTable",
    "PLAN_FACTOR",
    "PLAN_SIGMA_RANGE",
    "PerceivedLightness",
    "RELATIVE_LAMBDA_ARCMIN",
    "REPAIR_STEPS",
    "RESTARTS",
    "RIVALRY_TOLERANCE",
    "RIVALRY_WINDOW",
    "RenderCheck",
    "RepairedRender",
    "Rivalry",
    "SAME_SURFACE_FRACTION",
    "SEPARATION_ARCMIN",
    "SSD_WINDOW",
    "SpecularResult",
    "SpecularTable",
    "TABLE_FILE",
    "TABLE_FORMAT",
    "VERTICAL_TOLERANCE_ARCMIN",
    "ZoneCount",
    "analyse_table",
    "arcmin_per_pixel",
    "check_render",
    "comfort_share",
    "contrast_q",
    "csf_lowpass",
    "csf_mannos_sakrison",
    "disparity_arcmin",
    "disparity_cost",
    "disparity_cost_gradient",
    "display_block",
    "distinctiveness",
    "fill_matches",
    "fit_display",
    "importance",
    "joint_bilateral_upsample",
    "layer_disparity",
    "layer_labels",
    "layer_lightness",
    "lightness_from_srgb",
    "near_surface",
    "object_shares",
    "offset_camera",
    "offset_rays",
    "offset_table_bytes",
    "on_surface",
    "optimise_offsets",
    "peli_contrast",
    "perceived_lightness",
    "pixels_per_degree",
    "push_pull_fill",
    "read_specular_table",
    "render_offsets",
    "repair_render",
    "rivalry",
    "scene_diameter",
    "specular_from_table",
    "specular_objects",
    "specular_stereo",
    "tabulate_offsets",
    "weighted_block_mean",
    "write_specular_table",
    "zone_count",
    "zone_warnings",
]
