"""The ``--*-scale`` options of ``synthesize`` and ``interpolate``: one check for both."""

from __future__ import annotations

from vergence._validate import check_positive

__all__ = ["SCALE_RANGE", "check_scale"]

# A scale divides the stored values in float32: over this range every value of a 16-bit file over the
# scale stays a normal float32 (65535 / 1e-30 = 6.6e34 < 3.4e38; 1 / 1e30 = 1e-30 > 1.2e-38). Outside
# it the division overflowed or underflowed with numpy warnings; Middlebury and KITTI use 1 to 256,
# millimetre depth 1000.
SCALE_RANGE = (1e-30, 1e30)


def check_scale(option: str, scale: float) -> float:
    """A ``--*-scale`` value within ``SCALE_RANGE``."""
    check_positive(option, scale)
    lo, hi = SCALE_RANGE
    if not lo <= scale <= hi:
        raise ValueError(f"{option} must lie in [{lo:g}, {hi:g}] (it divides float32 values); got {scale:g}")
    return scale
