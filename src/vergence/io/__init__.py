"""Files in and out: images, disparity maps, PFM, JSON; every write is atomic.

Images are float32 ``(H, W)`` or ``(H, W, 3)`` in the library, [0, 1] from 8/16-bit files and
linear from float files; disparity maps are float32 ``(H, W)`` with NaN for unknown. Conventions:
``docs/conventions.md``. Camera files live in ``vergence.io.cameras``.
"""

from vergence.io.atomic import atomic_write, write_json
from vergence.io.disparity import read_disparity, write_disparity
from vergence.io.images import read_image, write_image
from vergence.io.pfm import read_pfm, write_pfm

__all__ = [
    "atomic_write",
    "read_disparity",
    "read_image",
    "read_pfm",
    "write_disparity",
    "write_image",
    "write_json",
    "write_pfm",
]
