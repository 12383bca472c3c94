"""StereoSpace (S2): stereo browsing of a calibrated photo collection.

The space of stereo pairs of a camera graph, its regions and parameters (S2 §4), and the navigation
through it by zoom and pan (S2 §4.1).
"""

from vergence.stereospace.space import PARALLEL_SINE, RELATIVE_TOLERANCE, StereoSpace, StereoState, stereo_point

__all__ = ["PARALLEL_SINE", "RELATIVE_TOLERANCE", "StereoSpace", "StereoState", "stereo_point"]
