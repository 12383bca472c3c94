"""Validation shared by the matchers: a stereo pair as 8-bit arrays, a disparity search range, a block size."""

from __future__ import annotations

import math

import numpy as np

from vergence._validate import as_image, check_positive_int

__all__ = ["MAX_BLOCK_SIZE", "check_block_size", "check_disparity_range", "stereo_pair_u8"]

# Largest matching window side, pixels: OpenCV's StereoBM refuses more ("SADWindowSize must be ...
# within 5..255"), StereoSGBM finds no disparity at all with such windows on Middlebury-size pairs
# (and crashed at 1001 in OpenCV 4), and the window matchers' cost of a 255 px window already
# averages away every depth edge of a 1000 px image. One limit for every matcher.
MAX_BLOCK_SIZE = 255


def stereo_pair_u8(left: object, right: object) -> tuple[np.ndarray, np.ndarray]:
    """Validate a stereo pair (same size, both grey or both colour) and return 8-bit copies.

    Colour images keep three channels (an alpha channel is dropped); values are ``round(255 v)``.
    """
    a = as_image("left", left)
    b = as_image("right", right)
    if a.shape[:2] != b.shape[:2]:
        raise ValueError(f"right must have the size of left {a.shape[:2]}; got {b.shape[:2]}")
    ca = 1 if a.ndim == 2 else min(a.shape[2], 3)
    cb = 1 if b.ndim == 2 else min(b.shape[2], 3)
    if ca != cb:
        kind = {1: "grey", 3: "colour"}
        raise ValueError(f"left and right must both be grey or both colour; got {kind[ca]} and {kind[cb]}")

    def to_u8(img: np.ndarray) -> np.ndarray:
        img = img if img.ndim == 2 else (img[:, :, 0] if img.shape[2] == 1 else img[:, :, :3])
        return np.ascontiguousarray(np.rint(img * 255.0).astype(np.uint8))

    return to_u8(a), to_u8(b)


def check_disparity_range(max_disparity: object, min_disparity: object, width: int) -> tuple[int, int, int]:
    """Return (min, max, OpenCV numDisparities); the range must fit the image width."""
    for name, v in (("max_disparity", max_disparity), ("min_disparity", min_disparity)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer):
            raise TypeError(f"{name} must be an integer number of pixels; got {type(v).__name__}")
    lo, hi = int(min_disparity), int(max_disparity)
    if hi <= lo:
        raise ValueError(f"max_disparity must exceed the smallest disparity searched ({lo}); got {hi}")
    count = 16 * math.ceil((hi - lo + 1) / 16)
    if hi >= width or lo + count >= width:
        raise ValueError(f"disparity range [{lo}, {hi}] (searched as {count} disparities from {lo}) is wider than "
                         f"the image ({width} px)")
    # OpenCV matches the columns x with x - d inside the image for every searched d: [max(lo + count, 0),
    # width + min(lo, 0)); an empty interval overflows its buffer sizes instead of failing cleanly
    first, end = max(lo + count, 0), width + min(lo, 0)
    if end <= first:
        raise ValueError(
            f"disparity range [{lo}, {hi}] (searched as {count} disparities from {lo}) leaves no column to match "
            f"in an image {width} px wide: it needs max(min + {count}, 0) - min(min, 0) < {width}; got {first - min(lo, 0)}"
        )
    return lo, hi, count


def check_block_size(
    block_size: object, default: int, *, shape: tuple[int, ...] | None = None, minimum: int = 1, matcher: str = ""
) -> int:
    """``block_size`` (an odd number of pixels in ``[minimum, MAX_BLOCK_SIZE]``, at most the smaller
    side of an image of ``shape``), or ``default`` when it is None.

    ``matcher`` names the matcher that needs a ``minimum`` above 1, for the message.
    """
    if block_size is None:
        if shape is not None and default > min(shape[:2]):
            raise ValueError(f"block_size (default {default} px{' for ' + matcher if matcher else ''}) must not exceed "
                             f"the image's smaller side ({min(shape[:2])} px): give a smaller one")
        return default
    bs = check_positive_int("block_size", block_size)
    if bs % 2 == 0 or bs < minimum:
        need = "odd" if minimum <= 1 else f"odd and >= {minimum} for {matcher}"
        raise ValueError(f"block_size must be {need}; got {bs}")
    if bs > MAX_BLOCK_SIZE:
        raise ValueError(f"block_size must be at most {MAX_BLOCK_SIZE} px (MAX_BLOCK_SIZE); got {bs}")
    if shape is not None and bs > min(shape[:2]):
        raise ValueError(f"block_size must not exceed the image's smaller side ({min(shape[:2])} px); got {bs}")
    return bs
