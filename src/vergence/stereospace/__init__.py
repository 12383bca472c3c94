"""StereoSpace (S2): stereo browsing of calibrated photo collections.

Novel views by S2's method: :func:`mls_similarity` (the moving-least-squares similarity deformation
of Schaefer et al. 2006) and :func:`mls_warp` (an image warped through it on a coarse grid).
"""

from __future__ import annotations

from vergence.stereospace.mls import MLS_MIN_HANDLES, mls_similarity, mls_warp

__all__ = ["MLS_MIN_HANDLES", "mls_similarity", "mls_warp"]
