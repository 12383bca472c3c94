"""Hole filling that never smears foreground into background (S1 §IV.B.2).

Disocclusions are by construction background: a surface the reference could not see because a
nearer one hid it. Every method here therefore takes its values from the background side of a
hole only: the farther of the two pixels bounding it on its row.

- ``"background"``: repeat the background neighbour along the scanline (intensity spreading).
- ``"mirror"``: mirror the background scanline into the hole, which keeps its texture (S1: gives
  noticeably better results than spreading), falling back to repetition where the mirrored pixel
  is not background.
- ``"inpaint"``: OpenCV's Telea inpainting after the foreground around the hole (beside, above or
  below it) has been replaced by the nearest background, so the inpainting only propagates
  background; the disparity is filled from the background side.
"""

from __future__ import annotations

import numpy as np

from vergence.synthesis import _stages
from vergence.synthesis._checks import check_holes, check_image, check_known_disparity, check_map, check_method

__all__ = ["FILL_METHODS", "fill_disparity", "fill_holes"]

# Hole-filling methods, name -> stage (one entry per method: the CLI choices, the dispatch and the
# error message all read this table).
FILL_METHODS = _stages.FILL_METHODS


def fill_disparity(disparity: object) -> np.ndarray:
    """Fill unknown (NaN) disparities from the farther neighbour along each row.

    An unknown run takes the smaller of the two known disparities that bound it (the background);
    runs touching the border take their only neighbour. Rows with no known value stay NaN.

    Parameters
    ----------
    disparity : (H, W) array
        Pixels, larger = nearer; NaN = unknown; no inf; at least one known value (an all-unknown
        map has no background to fill from).

    Returns
    -------
    (H, W) float32

    Notes
    -----
    Unknown disparities in a reference are mostly half-occluded background (seen by that view
    only); S1 §IV.B.2's rule, never spread across an occlusion boundary, applies the same way.

    Examples
    --------
    >>> import numpy as np
    >>> fill_disparity(np.array([[5.0, np.nan, np.nan, 2.0]])).tolist()
    [[5.0, 2.0, 2.0, 2.0]]
    """
    return _stages.fill_disparity(check_map("disparity", disparity))


def fill_holes(
    image: object, disparity: object, holes: object, *, method: str = "background"
) -> tuple[np.ndarray, np.ndarray]:
    """Fill the holes of a synthesized view from their background side only.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        The view with holes (float in [0, 1], uint8 or uint16; values in holes are ignored).
    disparity : (H, W) array
        Its disparity, larger = nearer; must be finite outside the holes (values in holes ignored).
    holes : (H, W) bool
        Pixels to fill.
    method : {"background", "mirror", "inpaint"}
        See the module docstring.

    Returns
    -------
    image : float32, shape of ``image``
        Filled view; pixels outside ``holes`` are unchanged.
    disparity : (H, W) float32
        Filled disparity: each hole run takes its background disparity. A row that is all hole
        stays NaN there (and black in the image, except with ``"inpaint"``).

    Raises
    ------
    ValueError
        Shapes differ, an unknown method, non-finite disparity outside the holes.

    Notes
    -----
    S1 §IV.B.2: holes left after blending are areas no reference sees; spread or mirror the
    neighbouring intensities, but never across an occlusion boundary (no smearing of foreground
    into background), or inpaint them.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.array([[0.9, 0.0, 0.0, 0.2]], dtype=np.float32)
    >>> d = np.array([[8.0, 0.0, 0.0, 1.0]])
    >>> out, dd = fill_holes(img, d, np.array([[False, True, True, False]]))
    >>> out.tolist(), dd.tolist()
    ([[0.8999999761581421, 0.20000000298023224, 0.20000000298023224, 0.20000000298023224]], [[8.0, 1.0, 1.0, 1.0]])
    """
    img = check_image("image", image)
    m = check_holes(holes, img)
    d = check_known_disparity(disparity, m, img)
    check_method("method", method, FILL_METHODS)
    out, out_d = _stages.fill_holes(_stages.as_hwc(img).copy(), d, m, method)
    return _stages.like(out, img), out_d
