"""A source view of image-based rendering (:func:`vergence.synthesis.render_ibr`): camera, image, depth."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.camera import Camera
from vergence.synthesis._checks import check_camera, check_depth_values, check_image

__all__ = ["IBRSource"]


@dataclass(frozen=True, slots=True)
class IBRSource:
    """One source view of :func:`render_ibr`: a camera, its image and its depth map.

    Parameters
    ----------
    camera : Camera
    image : (H, W, 3) array
        Colours, float in [0, 1] (uint8 / uint16 are scaled), the camera's size; kept as float32.
    depth : (H, W) array
        Camera-frame z in metres, > 0 where a surface is seen, NaN where none (sky); kept as float64.

    Raises
    ------
    TypeError
        A camera that is not a :class:`~vergence.camera.Camera`, a non-numeric image or depth.
    ValueError
        Sizes differing from the camera's, an image without 3 channels or outside [0, 1], a depth
        that is inf or <= 0.
    """

    camera: Camera
    image: np.ndarray
    depth: np.ndarray

    def __post_init__(self) -> None:
        cam = check_camera("camera", self.camera)
        size = (cam.height, cam.width)
        img = check_image("image", self.image)
        if img.ndim != 3 or img.shape[2] != 3:
            raise ValueError(f"image must have shape (H, W, 3) (colour); got {img.shape}")
        if img.shape[:2] != size:
            raise ValueError(f"image must have shape {size + (3,)} matching the camera; got {img.shape}")
        if np.iscomplexobj(self.depth):
            raise TypeError("depth must be real; got a complex array")
        try:
            z = np.ascontiguousarray(self.depth, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"depth must be numeric; got {type(self.depth).__name__}") from exc
        if z.shape != size:
            raise ValueError(f"depth must have shape {size} matching the image and camera; got {z.shape}")
        check_depth_values("depth", z)
        object.__setattr__(self, "image", np.ascontiguousarray(img))
        object.__setattr__(self, "depth", z)
