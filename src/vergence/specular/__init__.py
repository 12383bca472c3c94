"""Specular disparity (S3): glass and mirrors in stereo, analysed on the ray tree of :mod:`vergence.render`.

- Per-layer disparity (S3 §3.2): each pixel of each layer of the left eye matched to the pixel of
  the same layer of the right eye nearest in 3D, in an 81 x 9 window, with a cutoff at 1/100 of the
  scene diameter (:func:`layer_disparity`, :class:`LayerDisparity`); in arcminutes for a display
  (:func:`disparity_arcmin`).
- Per-layer camera offsets (S3 §3.4): the left eye's shading camera moved along the baseline
  (:func:`offset_camera`, :func:`offset_rays`), the table of renders and disparities at k + 1
  offsets (:func:`tabulate_offsets`, :class:`OffsetTable`) and the final render with a camera per
  layer and pixel (:func:`render_offsets`; it and the table import Mitsuba when called).

Importing this package imports Numba, not Mitsuba: it works on arrays (``RenderResult.position``).
"""

from vergence.specular.matching import (
    EPSILON_FRACTION,
    LAYER_MATCH_METHODS,
    MATCH_WINDOW,
    LayerDisparity,
    disparity_arcmin,
    layer_disparity,
    scene_diameter,
)
from vergence.specular.offsets import (
    MAX_OFFSET_STEPS,
    OffsetTable,
    offset_camera,
    offset_rays,
    render_offsets,
    tabulate_offsets,
)

__all__ = [
    "EPSILON_FRACTION",
    "LAYER_MATCH_METHODS",
    "LayerDisparity",
    "MATCH_WINDOW",
    "MAX_OFFSET_STEPS",
    "OffsetTable",
    "disparity_arcmin",
    "layer_disparity",
    "offset_camera",
    "offset_rays",
    "render_offsets",
    "scene_diameter",
    "tabulate_offsets",
]
