"""Files in and out: images, disparity maps, PFM, JSON, camera sets; every write is atomic.

Images are float32 ``(H, W)`` or ``(H, W, 3)`` in the library, [0, 1] from 8/16-bit files and
linear from float files; disparity maps are float32 ``(H, W)`` with NaN for unknown; camera sets
(Middlebury ``*_par.txt``, Bundler ``bundle.out``, COLMAP text, our JSON) become
:class:`vergence.camera.Camera`s. Conventions: ``docs/conventions.md``.
"""

from vergence.io.atomic import atomic_folder, atomic_write, write_json
from vergence.io.bundler import read_bundler, write_bundler
from vergence.io.camera_set import CameraSet
from vergence.io.cameras import CAMERA_FORMATS, CameraFormat, cameras_for_images, read_cameras, write_cameras
from vergence.io.cameras_json import read_cameras_json, write_cameras_json
from vergence.io.colmap import read_colmap, write_colmap
from vergence.io.depth import DEPTH_KINDS, read_depth
from vergence.io.header import HEADER_FORMATS, ImageHeader, read_header
from vergence.io.disparity import read_disparity, stores_integers, write_disparity
from vergence.io.images import read_image, write_image
from vergence.io.jsonfile import MAX_JSON_BYTES, MAX_JSON_DEPTH, read_json
from vergence.io.middlebury import read_middlebury_par, write_middlebury_par
from vergence.io.pfm import read_pfm, write_pfm

__all__ = [
    "CAMERA_FORMATS",
    "CameraFormat",
    "CameraSet",
    "DEPTH_KINDS",
    "HEADER_FORMATS",
    "ImageHeader",
    "MAX_JSON_BYTES",
    "MAX_JSON_DEPTH",
    "atomic_folder",
    "atomic_write",
    "cameras_for_images",
    "read_bundler",
    "read_cameras",
    "read_cameras_json",
    "read_colmap",
    "read_depth",
    "read_disparity",
    "read_header",
    "read_image",
    "read_json",
    "read_middlebury_par",
    "read_pfm",
    "stores_integers",
    "write_bundler",
    "write_cameras",
    "write_cameras_json",
    "write_colmap",
    "write_disparity",
    "write_image",
    "write_json",
    "write_middlebury_par",
    "write_pfm",
]
