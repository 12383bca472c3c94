"""The ``--*-scale`` options of ``synthesize`` and ``interpolate``: one check for both."""

from __future__ import annotations

import numpy as np

from vergence._validate import check_positive

__all__ = ["MAX_SCALE", "check_scale"]

# A scale divides float32 values, so it must be a finite float32 itself (a larger one overflowed to
# inf with numpy warnings).
MAX_SCALE = float(np.finfo(np.float32).max)


def check_scale(option: str, scale: float) -> float:
    """A ``--*-scale`` value: > 0 and at most ``MAX_SCALE``."""
    check_positive(option, scale)
    if scale > MAX_SCALE:
        raise ValueError(f"{option} must be <= {MAX_SCALE:.4g} (it divides float32 values); got {scale:g}")
    return scale
