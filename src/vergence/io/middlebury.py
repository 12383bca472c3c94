"""Middlebury multi-view ``*_par.txt`` camera files (Seitz et al. 2006), read and written.

One line with the count, then ``name k11..k33 r11..r33 t1 t2 t3`` per camera: projection
``K [R | t]`` with the origin at the top-left pixel, which is our convention
(``docs/conventions.md``), so the numbers are taken as they are. The files store no image size.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from vergence.io._camera_files import (
    check_camera_set,
    check_image_size,
    checked_camera,
    format_float,
    parse_count,
    parse_floats,
    read_image_size,
    text_lines,
    write_text,
)
from vergence.io._files import input_path
from vergence.io.camera_set import CameraSet

__all__ = ["read_middlebury_par", "write_middlebury_par"]


def read_middlebury_par(path: str | os.PathLike[str], *, image_size: tuple[int, int] | None = None) -> CameraSet:
    """Read a Middlebury multi-view ``*_par.txt`` (first line: count; then ``name K R t`` per line).

    Parameters
    ----------
    path : str or os.PathLike
        The parameter file.
    image_size : (width, height), optional
        Shared image size; by default each image's size is read from the file beside ``path``
        (a missing image is then an error).

    Raises
    ------
    ValueError
        On a malformed or truncated file (the message gives the line), or a non-rotation R.
    FileNotFoundError
        If ``image_size`` is not given and an image named in the file does not exist.
    """
    p = input_path(path)
    size = None if image_size is None else check_image_size(image_size)
    lines = [ln for ln in text_lines(p) if ln.strip()]
    try:
        count = int(lines[0].split()[0])
    except (IndexError, ValueError) as exc:
        raise ValueError(f"{p}:1: expected the number of cameras on the first line") from exc
    count = parse_count(count, "cameras", p)
    body = lines[1:]
    if len(body) < count:
        raise ValueError(f"{p} is truncated: the header announces {count} cameras, the file has {len(body)}")
    names, cams = [], []
    for i, line in enumerate(body[:count], start=2):
        tok = line.split()
        if len(tok) != 22:
            raise ValueError(f"{p}:{i}: expected 22 fields (name, 9 of K, 9 of R, 3 of t); got {len(tok)}")
        v = np.array(parse_floats(tok[1:], p, i))
        wh = size if size is not None else read_image_size(p.parent / tok[0])
        names.append(Path(tok[0]).name)
        cams.append(checked_camera(v[:9].reshape(3, 3), v[9:18].reshape(3, 3), v[18:], wh, f"{p}:{i}"))
    return CameraSet(names=tuple(names), cameras=tuple(cams))


def write_middlebury_par(path: str | os.PathLike[str], cameras: CameraSet) -> None:
    """Write a Middlebury ``*_par.txt`` atomically; refuses distortion and unregistered cameras."""
    check_camera_set(cameras)
    if cameras.unregistered or np.any(cameras.distortion != 0):
        raise ValueError("cameras must all be registered and distortion-free for a Middlebury par file")
    rows = [str(len(cameras))]
    for name, cam in zip(cameras.names, cameras.cameras):
        vals = [*cam.K.ravel(), *cam.R.ravel(), *cam.t]
        rows.append(" ".join([name, *(format_float(v) for v in vals)]))
    write_text(path, "\n".join(rows) + "\n")
