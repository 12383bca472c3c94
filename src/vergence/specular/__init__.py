"""Specular disparity (S3): glass and mirrors in stereo, analysed on the ray tree of :mod:`vergence.render`.

- Per-layer disparity (S3 §3.2): each pixel of each layer of the left eye matched to the pixel of
  the same layer of the right eye nearest in 3D, in an 81 x 9 window, with a cutoff at 1/100 of the
  scene diameter (:func:`layer_disparity`, :class:`LayerDisparity`); in arcminutes for a display
  (:func:`disparity_arcmin`).

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

__all__ = [
    "EPSILON_FRACTION",
    "LAYER_MATCH_METHODS",
    "LayerDisparity",
    "MATCH_WINDOW",
    "disparity_arcmin",
    "layer_disparity",
    "scene_diameter",
]
