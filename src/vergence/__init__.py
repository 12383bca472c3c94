"""Vergence: stereoscopic 3D images that look right on a given display.

Subpackages: ``viewing`` (S0 viewing geometry, comfort, disparity mapping), ``render`` (ray tree),
``synthesis`` (DIBR), ``depth`` (stereo matching), ``io``; modules ``camera``, ``display``, ``metrics``.
Conventions: ``docs/conventions.md``; references: ``docs/references.md``.

Importing Vergence changes no process-wide state. On a machine whose cores are shared, set
``OMP_WAIT_POLICY=PASSIVE`` before the first Numba kernel runs (the ``vergence`` command does): Numba's
OpenMP threads otherwise spin while they wait and steal the cores the kernels need.

Numba compiles each kernel on its first use and caches the machine code. The ``vergence`` command
keeps that cache in a folder the user owns: ``NUMBA_CACHE_DIR`` when set, else
``$XDG_CACHE_HOME/vergence/numba``, else ``~/.cache/vergence/numba``
(:func:`vergence._cache.numba_cache_dir`); ``vergence warm`` (:func:`vergence.warm.warm`) fills it
ahead. Imported as a library, Vergence leaves ``NUMBA_CACHE_DIR`` to the program: without it Numba
caches beside the package's sources (or in its own user folder where those are read-only).
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
