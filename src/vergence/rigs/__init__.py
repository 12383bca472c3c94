"""Camera rigs built from one camera: pure geometry, no rendering engine.

- :func:`stereo_pair`: the parallel, shifted-sensor stereo rig of S0 §2.
- :func:`plan_quadri_rig`: the Quadri-Rig of S0 §5 (real cameras standing in for a virtual rig, Eq. (10)).
- :func:`plan_tri_rig`: the Tri-Rig of S0 §6 (director, subject and background cameras, psi).
- :class:`WorldDistortion`: the Tri-Rig's world distortion phi, its inverse and Jacobian (S0 §6, Fig. 9).
- :func:`load_shot`, :func:`plan_document`, :data:`EXAMPLE_SHOTS`: shot files (``docs/shots.md``) naming the rig, the scene, the display and the camera.
"""

from vergence.rigs.cameras import ELEMENT_NAME_PATTERN, RIG_EYES, RigCamera
from vergence.rigs.distortion import WorldDistortion
from vergence.rigs.quadri import QuadriRig, plan_quadri_rig
from vergence.rigs.shot import EXAMPLE_SHOTS, SHOT_RIGS, Shot, ShotCamera, load_shot, plan_document, shot_from_dict
from vergence.rigs.stereo import stereo_pair
from vergence.rigs.tri import TRI_REFERENCES, TriRig, plan_tri_rig

__all__ = [
    "ELEMENT_NAME_PATTERN",
    "EXAMPLE_SHOTS",
    "QuadriRig",
    "RIG_EYES",
    "RigCamera",
    "SHOT_RIGS",
    "Shot",
    "ShotCamera",
    "TRI_REFERENCES",
    "TriRig",
    "WorldDistortion",
    "load_shot",
    "plan_document",
    "plan_quadri_rig",
    "plan_tri_rig",
    "shot_from_dict",
    "stereo_pair",
]
