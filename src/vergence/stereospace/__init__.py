"""StereoSpace (S2): stereo browsing of calibrated photo collections.

Novel views by S2's method: :func:`mls_similarity` (the moving-least-squares similarity deformation
of Schaefer et al. 2006), :func:`mls_warp` (an image warped through it on a coarse grid) and
:func:`s2_view` (up to four warped sources blended with S2's angle and field-of-view penalties).
"""

from __future__ import annotations

from vergence.stereospace.mls import MLS_MIN_HANDLES, mls_similarity, mls_warp
from vergence.stereospace.mls_view import S2_MAX_SOURCES, S2_PENALTY_FLOOR, S2_THRESHOLD_SCALE, S2View, s2_view

__all__ = [
    "MLS_MIN_HANDLES",
    "S2View",
    "S2_MAX_SOURCES",
    "S2_PENALTY_FLOOR",
    "S2_THRESHOLD_SCALE",
    "mls_similarity",
    "mls_warp",
    "s2_view",
]
