"""Vergence: stereoscopic 3D images that look right on a given display.

Subpackages: ``viewing`` (S0 viewing geometry, comfort, disparity mapping), ``render`` (ray tree),
``synthesis`` (DIBR), ``depth`` (stereo matching), ``io``; modules ``camera``, ``display``, ``metrics``.
Conventions: ``docs/conventions.md``.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
