"""The helpers the camera-file readers share: internal API of :mod:`vergence.io`, not for users.

Every reader and writer of a camera set (:mod:`~vergence.io.middlebury`, :mod:`~vergence.io.colmap`,
:mod:`~vergence.io.bundler`, :mod:`~vergence.io.cameras_json`) and the dispatcher
:mod:`~vergence.io.cameras` use these: text lines and numbers with errors naming the file and line,
the image size from an image's header, checked arguments, and atomic text writes.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image

from vergence.camera import Camera
from vergence.io._files import input_path, read_bytes
from vergence.io.atomic import atomic_write
from vergence.io.camera_set import CameraSet
from vergence.io.images import MAX_IMAGE_PIXELS

__all__ = [
    "check_camera_set",
    "check_image_size",
    "checked_camera",
    "checked_image_list",
    "format_float",
    "parse_count",
    "parse_floats",
    "read_image_size",
    "text_lines",
    "write_text",
]


def text_lines(path: Path) -> list[str]:
    """The lines of a UTF-8 text file; a byte-order mark and CRLF or CR line ends are accepted."""
    try:
        return read_bytes(path).decode("utf-8-sig").splitlines()
    except UnicodeDecodeError as exc:
        raise ValueError(f"cannot read {path}: not a UTF-8 text file") from exc


def parse_floats(tokens: Sequence[str], path: Path, line: int) -> list[float]:
    """The tokens as finite floats; an error names ``path`` and ``line`` (the file alone when ``line`` is 0)."""
    try:
        values = [float(t) for t in tokens]
    except ValueError as exc:
        where = f"{path}:{line}" if line else str(path)
        raise ValueError(f"{where}: expected numbers; got {' '.join(tokens)[:60]!r}") from exc
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{path}:{line}: numbers must be finite" if line else f"{path}: numbers must be finite")
    return values


def read_image_size(path: Path) -> tuple[int, int]:
    """(width, height) from the header of the image at ``path``, refused past ``MAX_IMAGE_PIXELS``."""
    if not path.is_file():
        raise FileNotFoundError(f"cannot find image {path} to read its size; pass image_size=(width, height)")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # the limit is checked below
            with Image.open(path) as im:
                width, height = int(im.size[0]), int(im.size[1])
    except Image.DecompressionBombError as exc:
        raise ValueError(
            f"cannot use image {path}: its header declares more pixels than the limit of {MAX_IMAGE_PIXELS:,} ({exc})"
        ) from exc
    except OSError as exc:
        raise ValueError(f"cannot read the size of image {path}: {exc}") from exc
    if width * height > MAX_IMAGE_PIXELS:
        raise ValueError(
            f"cannot use image {path}: its header declares {width} x {height} = {width * height:,} pixels; "
            f"the limit is {MAX_IMAGE_PIXELS:,}"
        )
    return width, height


def check_image_size(image_size: object) -> tuple[int, int]:
    """``image_size`` as (width, height), two positive integers, else ValueError."""
    if (not isinstance(image_size, Sequence) or len(image_size) != 2
            or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= 1 for v in image_size)):
        raise ValueError(f"image_size must be (width, height) with positive integers; got {image_size!r}")
    return int(image_size[0]), int(image_size[1])


def checked_camera(K: np.ndarray, R: np.ndarray, t: np.ndarray, size: tuple[int, int], where: str) -> Camera:
    """A :class:`~vergence.camera.Camera` of ``size`` (width, height); its ValueError is prefixed with ``where``."""
    try:
        return Camera(K=K, R=R, t=t, width=size[0], height=size[1])
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from exc


def format_float(v: float) -> str:
    """``v`` written so that it reads back exactly (``repr`` of a Python float)."""
    return repr(float(v))


def parse_count(value: float, what: str, path: Path) -> int:
    """A count read from a file: a non-negative integer."""
    if value != int(value) or value < 0:
        raise ValueError(f"{path}: the number of {what} must be an integer >= 0; got {value:g}")
    return int(value)


def check_camera_set(cameras: object) -> None:
    """TypeError unless ``cameras`` is a :class:`~vergence.io.camera_set.CameraSet`."""
    if not isinstance(cameras, CameraSet):
        raise TypeError(f"cameras must be a CameraSet; got {type(cameras).__name__}")


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` as UTF-8 to ``path`` atomically."""
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def checked_image_list(image_list: object) -> Path | list[str]:
    """``image_list`` as the path of an existing list.txt or as a list of image names."""
    if isinstance(image_list, str | os.PathLike):
        if os.fspath(image_list) == "":
            raise ValueError("image_list must name a file (Bundler's list.txt); got ''")
        return input_path(image_list)
    if not isinstance(image_list, Sequence):
        raise TypeError(f"image_list must be a path to list.txt or a sequence of names; got {type(image_list).__name__}")
    for i, entry in enumerate(image_list):
        if not isinstance(entry, str | os.PathLike) or os.fspath(entry) == "":
            raise TypeError(f"image_list[{i}] must be an image name (a non-empty str); got {entry!r}")
    return [os.fspath(e) for e in image_list]
