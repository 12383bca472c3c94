"""Camera rigs built from one camera: pure geometry, no rendering engine.

- :func:`stereo_pair`: the parallel, shifted-sensor stereo rig of S0 §2.
- :class:`WorldDistortion`: the Tri-Rig's world distortion phi, its inverse and Jacobian (S0 §6, Fig. 9).
"""

from vergence.rigs.distortion import WorldDistortion
from vergence.rigs.stereo import stereo_pair

__all__ = ["WorldDistortion", "stereo_pair"]
