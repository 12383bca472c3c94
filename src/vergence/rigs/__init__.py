"""Camera rigs built from one camera: pure geometry, no rendering engine.

- :func:`stereo_pair`: the parallel, shifted-sensor stereo rig of S0 §2.
"""

from vergence.rigs.stereo import stereo_pair

__all__ = ["stereo_pair"]
