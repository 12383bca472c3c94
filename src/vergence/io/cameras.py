"""Camera files of any supported format: one table from format name to reader and writer.

:data:`CAMERA_FORMATS` maps each format name to its reader, its writer and the file names it
claims; :func:`read_cameras` and :func:`write_cameras` dispatch through it (by the ``format``
argument, or by the file name when it is left out), and their errors list its names. Adding a
format is one module beside this one and one entry in the table.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from vergence.camera import Camera
from vergence.io._camera_files import check_image_size, checked_image_list
from vergence.io.bundler import read_bundler, write_bundler
from vergence.io.camera_set import CameraSet
from vergence.io.cameras_json import read_cameras_json, write_cameras_json
from vergence.io.colmap import read_colmap, write_colmap
from vergence.io.middlebury import read_middlebury_par, write_middlebury_par

__all__ = ["CAMERA_FORMATS", "CameraFormat", "cameras_for_images", "read_cameras", "write_cameras"]


@dataclass(frozen=True, slots=True)
class CameraFormat:
    """One camera-file format: how to read it, write it and recognise its files.

    Parameters
    ----------
    read : callable
        ``read(path, **options) -> CameraSet``.
    write : callable
        ``write(path, cameras) -> None``.
    options : tuple of str
        The keyword options of :func:`read_cameras` this reader takes (others are not passed).
    claims : callable
        ``claims(path) -> bool``: whether a file or folder name is in this format.
    pattern : str
        The file names it claims, in words, for error messages.
    sniff : callable, optional
        ``sniff(head) -> bool``: whether a file whose name no format claims is in this format,
        from its first lines (text, at most ``_SNIFF_BYTES``).
    """

    read: Callable[..., CameraSet]
    write: Callable[[str | os.PathLike[str], CameraSet], None]
    options: tuple[str, ...]
    claims: Callable[[Path], bool]
    pattern: str
    sniff: Callable[[str], bool] | None = None


# Bytes read to recognise a camera file by its content: a Middlebury header and first camera line
# (22 numbers) or the Bundler and JSON headers fit many times over.
_SNIFF_BYTES = 4096


def _looks_middlebury(head: str) -> bool:
    """A count alone on the first line, then ``name`` and 21 numbers (Seitz et al. 2006's layout)."""
    lines = [ln.split() for ln in head.splitlines() if ln.strip()]
    if len(lines) < 2 or len(lines[0]) != 1 or not lines[0][0].isdigit() or len(lines[1]) != 22:
        return False
    try:
        [float(v) for v in lines[1][1:]]
    except ValueError:
        return False
    return True


CAMERA_FORMATS: MappingProxyType[str, CameraFormat] = MappingProxyType({
    "middlebury": CameraFormat(read_middlebury_par, write_middlebury_par, ("image_size",),
                               lambda p: p.name.lower().endswith("_par.txt"), "*_par.txt", _looks_middlebury),
    "bundler": CameraFormat(read_bundler, write_bundler, ("image_size", "image_list"),
                            lambda p: p.name.lower().endswith(".out"), "*.out",
                            lambda head: head.startswith("# Bundle file v0.3")),
    "colmap": CameraFormat(read_colmap, write_colmap, (),
                           lambda p: p.is_dir() or p.name.lower() in ("cameras.txt", "images.txt"),
                           "cameras.txt/images.txt or their folder"),
    "json": CameraFormat(read_cameras_json, write_cameras_json, (),
                         lambda p: p.name.lower().endswith(".json"), "*.json",
                         lambda head: head.lstrip().startswith("{") and '"vergence-cameras"' in head),
})
"""Format name -> :class:`CameraFormat`, read-only."""


def _format_of(path: object, format: str | None) -> tuple[Path, CameraFormat]:
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    if format is not None:
        if not isinstance(format, str) or format not in CAMERA_FORMATS:
            raise ValueError(f"format must be one of {', '.join(CAMERA_FORMATS)}; got {format!r}")
        return p, CAMERA_FORMATS[format]
    for fmt in CAMERA_FORMATS.values():
        if fmt.claims(p):
            return p, fmt
    if p.is_file():  # a name no format claims: recognise the content
        try:
            with open(p, "rb") as fh:
                head = fh.read(_SNIFF_BYTES).decode("utf-8-sig", errors="replace")
        except OSError as exc:
            raise OSError(f"cannot read {p}: {exc.strerror or exc}") from None
        for fmt in CAMERA_FORMATS.values():
            if fmt.sniff is not None and fmt.sniff(head):
                return p, fmt
    known = ", ".join(f"{f.pattern} ({name})" for name, f in CAMERA_FORMATS.items())
    raise ValueError(f"camera file {p.name!r} has no known format by its name or content; expected {known}")


def read_cameras(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    image_size: tuple[int, int] | None = None,
    image_list: str | os.PathLike[str] | Sequence[str] | None = None,
) -> CameraSet:
    """Read any supported camera file, in the format named or the one its name implies.

    ``*_par.txt`` -> Middlebury, ``*.out`` -> Bundler, ``*.json`` -> ours, a folder or
    ``cameras.txt``/``images.txt`` -> COLMAP (:data:`CAMERA_FORMATS`); a file whose name no format
    claims is recognised by its first lines (a Middlebury count and camera line, Bundler's header,
    our JSON's ``"vergence-cameras"``). ``image_size`` applies to
    Middlebury and Bundler (the other readers ignore it, but a malformed size is refused whatever
    the format), ``image_list`` to Bundler only: given with another format it is refused, as a
    mistake that would otherwise be dropped unseen.

    Raises
    ------
    ValueError
        If ``format`` is not a name of :data:`CAMERA_FORMATS`, or it is left out and the file name
        matches no format (the message lists them); if ``image_size`` is not two positive integers;
        if ``image_list`` is given for a format other than Bundler.
    TypeError
        If ``image_list`` is neither a path nor a sequence of image names.
    FileNotFoundError
        If ``image_list`` is a path to a missing file.
    """
    if image_size is not None:
        check_image_size(image_size)
    if image_list is not None:
        checked_image_list(image_list)
    p, fmt = _format_of(path, format)
    if image_list is not None and "image_list" not in fmt.options:
        name = next(n for n, f in CAMERA_FORMATS.items() if f is fmt)
        raise ValueError(f"image_list applies to Bundler cameras (*.out) only; {p.name} is a {name} camera file")
    given = {"image_size": image_size, "image_list": image_list}
    return fmt.read(p, **{k: given[k] for k in fmt.options})


def write_cameras(path: str | os.PathLike[str], cameras: CameraSet, *, format: str | None = None) -> None:
    """Write ``cameras`` in the format named, or the one the name of ``path`` implies.

    Raises
    ------
    ValueError
        As :func:`read_cameras` for the format, and as the format's writer for cameras it cannot hold.
    """
    p, fmt = _format_of(path, format)
    fmt.write(p, cameras)


def cameras_for_images(
    path: str | os.PathLike[str],
    images: Sequence[tuple[str | os.PathLike[str], tuple[int, int]]],
    *,
    format: str | None = None,
    image_list: str | os.PathLike[str] | Sequence[str] | None = None,
) -> list[tuple[Camera, np.ndarray]]:
    """The camera and distortion of each image, each read with that image's size.

    Middlebury ``*_par.txt`` and Bundler ``bundle.out`` store no image size, and a Bundler ``K``
    depends on it, so the file is read once per distinct size in ``images``.

    Parameters
    ----------
    path : str or os.PathLike
        The camera file (any format of :data:`CAMERA_FORMATS`).
    images : sequence of (name, (width, height))
        The images, by file name (a path is reduced to its name), with their sizes.
    format, image_list
        As :func:`read_cameras`.

    Returns
    -------
    list of (Camera, (4,) array)
        One ``(camera, distortion)`` per image, in order.

    Raises
    ------
    ValueError
        If an image has no registered camera in the file, or the file is a Bundler bundle that does
        not name its images (no ``list.txt`` beside it and no ``image_list``).
    """
    p, fmt = _format_of(path, format)
    sets: dict[tuple[int, int], CameraSet] = {}
    for _, size in images:
        if size not in sets:
            sets[size] = read_cameras(p, format=format, image_size=size, image_list=image_list)
    out = []
    for name, size in images:
        cams = sets[size]
        key = Path(os.fspath(name)).name
        if (image_list is None and fmt is CAMERA_FORMATS["bundler"] and key not in cams.names
                and cams.names == tuple(str(i) for i in range(len(cams)))):
            raise ValueError(f"{p.name} does not name its images: no list.txt was found beside it and its folder "
                             "does not hold one JPEG image per camera; "
                             "pass image_list (Bundler's list.txt)")
        out.append((cams.camera(key), cams.distortion[cams.index(key)]))
    return out
