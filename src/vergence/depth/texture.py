"""Where an image has texture to match: the local contrast gate of :func:`~vergence.depth.compute_disparity`.

Window matching, local or semi-global, needs intensity variation inside its window: on a flat
patch every disparity costs the same, and what a matcher reports there is its tie-breaking or its
smoothness term, not a measurement (S1 §III.B; Scharstein & Szeliski 2002 score the "textureless"
region apart for this reason). A uniform black or grey pair has no texture at all; OpenCV's SGBM still
answers on 75 % of it with disparity 0. These functions find the pixels with texture so the
pipeline can refuse such a pair, or warn when most of a pair is flat.
"""

from __future__ import annotations

import cv2
import numpy as np

from vergence._validate import as_image

__all__ = ["LOW_TEXTURED_PERCENT", "MIN_TEXTURE", "MIN_TEXTURED_PERCENT", "TEXTURE_WINDOW", "textured_pixels"]

# Side of the square window of the contrast, pixels: the 5 x 5 patch of the registration error's
# contrast gate (vergence.metrics), and between the 3 px SGBM and 7-9 px BM/window blocks.
TEXTURE_WINDOW = 5
# A pixel has texture when the RMS deviation of its TEXTURE_WINDOW window about the window mean
# (channels pooled) is at least this, in [0, 1] units: 2 grey levels of 8 bits, above the sensor
# noise of the Middlebury cameras (1.2 levels RMS, see vergence.metrics.MIN_CONTRAST) and the 0.29
# levels of 8-bit rounding, so sensor noise alone on a flat wall stays below it. Measured share of
# textured pixels at this level: 75-89 % on tsukuba, venus and the 2001 scenes, 16 % on Middlebury's
# almost textureless "plastic", 0 % on a uniform pair.
MIN_TEXTURE = 2.0 / 255.0
# Below this share of textured pixels (percent of each image) a pair is refused: there is nothing
# to measure a disparity from (a uniform pair has 0 %; the hardest Middlebury scene, plastic, 16 %).
MIN_TEXTURED_PERCENT = 1.0
# Below this share the pipeline warns that most of the map is extrapolated from the textured parts
# (plastic, 16 %, passes without a warning; a pair ten times flatter than the flattest Middlebury
# scene gets one).
LOW_TEXTURED_PERCENT = 10.0


def textured_pixels(image: object, *, min_texture: float = MIN_TEXTURE) -> np.ndarray:
    """Pixels whose ``TEXTURE_WINDOW`` x ``TEXTURE_WINDOW`` window has an RMS contrast of at least ``min_texture``.

    Parameters
    ----------
    image : (H, W) or (H, W, C) image
        In [0, 1] (or uint8/uint16); an alpha channel is ignored.
    min_texture : float
        Contrast threshold, [0, 1] intensity units, in (0, 0.5] (0.5 is the largest RMS deviation
        values in [0, 1] can have).

    Returns
    -------
    (H, W) bool
        True where ``sqrt(mean_c (E[I_c^2] - E[I_c]^2)) >= min_texture`` over the window (box mean,
        image borders mirrored as OpenCV's ``blur`` does).

    Raises
    ------
    ValueError
        On an invalid image, or ``min_texture`` outside (0, 0.5].

    Examples
    --------
    >>> textured_pixels(np.full((8, 8), 0.5)).any()
    np.False_
    >>> checker = (np.indices((8, 8)).sum(axis=0) % 2).astype(np.float32)  # contrast ~0.5
    >>> bool(textured_pixels(checker).all())
    True
    """
    img = as_image("image", image)
    if not (isinstance(min_texture, int | float | np.floating) and 0.0 < float(min_texture) <= 0.5):
        raise ValueError(f"min_texture must be a number in (0, 0.5]; got {min_texture!r}")
    img = img[:, :, None] if img.ndim == 2 else img[:, :, :3]
    # float32: half the time of float64 at 1080p (benchmarks/matching.py: the default pipeline went from 3.2x to
    # 2.5x raw SGBM). Its rounding of E[I^2] - E[I]^2 (about 1e-7 for values in [0, 1]) is 0.2 % of the
    # threshold's square, so only pixels within that of the threshold can change (tested against a float64 loop).
    x = np.ascontiguousarray(img, dtype=np.float32)
    box = (TEXTURE_WINDOW, TEXTURE_WINDOW)
    mean = cv2.blur(x, box).reshape(x.shape)
    square = cv2.blur(x * x, box).reshape(x.shape)
    square -= mean * mean
    # sqrt(mean_c variance) >= t  <=>  sum_c variance >= C t^2 (t > 0)
    return square.sum(axis=2) >= np.float32(x.shape[2] * float(min_texture) ** 2)
