"""Files in and out: images, disparity maps, PFM, JSON, camera sets; every write is atomic.

Images are float32 ``(H, W)`` or ``(H, W, 3)`` in the library, [0, 1] from 8/16-bit files and
linear from float files; disparity maps are float32 ``(H, W)`` with NaN for unknown; camera sets
(Middlebury ``*_par.txt``, Bundler ``bundle.out``, COLMAP text, our JSON) become
:class:`vergence.camera.Camera`s. Conventions: ``docs/conventions.md``.
"""

from vergence.io.atomic import atomic_write, write_json
from vergence.io.bundler import read_bundler, write_bundler
from vergence.io.cameras import (
    CameraSet,
    read_cameras,
    read_cameras_json,
    read_colmap,
    read_middlebury_par,
    write_cameras_json,
    write_colmap,
    write_middlebury_par,
)
from vergence.io.depth import DEPTH_KINDS, read_depth
from vergence.io.disparity import read_disparity, write_disparity
from vergence.io.images import read_image, write_image
from vergence.io.pfm import read_pfm, write_pfm

__all__ = [
    "CameraSet",
    "DEPTH_KINDS",
    "atomic_write",
    "read_bundler",
    "read_cameras",
    "read_cameras_json",
    "read_colmap",
    "read_depth",
    "read_disparity",
    "read_image",
    "read_middlebury_par",
    "read_pfm",
    "write_bundler",
    "write_cameras_json",
    "write_colmap",
    "write_disparity",
    "write_image",
    "write_json",
    "write_middlebury_par",
    "write_pfm",
]
