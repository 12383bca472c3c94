"""Vergence: stereoscopic 3D images that look right on a given display.

Subpackages: ``viewing`` (S0 viewing geometry, comfort, disparity mapping), ``render`` (ray tree),
``synthesis`` (DIBR), ``depth`` (stereo matching), ``io``; modules ``camera``, ``display``, ``metrics``.
Conventions: ``docs/conventions.md``.
"""

import os as _os

# Numba's OpenMP threads spin while they wait by default; on a machine whose cores are shared (CI, a
# laptop running other work) that spinning steals the cores the kernels need (measured: forward_warp
# 3.3x slower than with passive waiting under a load average of 5 on 2 cores). A user's own setting wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"

__all__ = ["__version__"]
