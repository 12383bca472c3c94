"""Viewing geometry (S0 §2), comfort zone and disparity mapping (S0 Eq. 7–9, Lang et al. 2010)."""

from vergence.viewing.geometry import (
    CARDBOARD_ROUNDNESS,
    CONTROL_EFFECTS,
    DISPLAY_PRESETS,
    Display,
    Shooting,
    disparity,
    divergence_baseline,
    divergence_depth,
    focal_ratio,
    perceived_depth,
    perceived_depth_from_depth,
    roundness,
    roundness_baseline,
    scene_depth_from_disparity,
    shift_sensor_parallax,
    shift_sensor_positions,
)

__all__ = [
    "CARDBOARD_ROUNDNESS",
    "CONTROL_EFFECTS",
    "DISPLAY_PRESETS",
    "Display",
    "Shooting",
    "disparity",
    "divergence_baseline",
    "divergence_depth",
    "focal_ratio",
    "perceived_depth",
    "perceived_depth_from_depth",
    "roundness",
    "roundness_baseline",
    "scene_depth_from_disparity",
    "shift_sensor_parallax",
    "shift_sensor_positions",
]
