"""Vergence: stereoscopic 3D images that look right on a given display.

Subpackages: ``viewing`` (S0 viewing geometry, comfort, disparity mapping), ``render`` (ray tree),
``synthesis`` (DIBR), ``depth`` (stereo matching), ``io``; modules ``camera``, ``display``, ``metrics``.
Conventions: ``docs/conventions.md``; references: ``docs/references.md``.

Importing Vergence changes no process-wide state. On a machine whose cores are shared, set
``OMP_WAIT_POLICY=PASSIVE`` before the first Numba kernel runs (the ``vergence`` command does): Numba's
OpenMP threads otherwise spin while they wait and steal the cores the kernels need.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
