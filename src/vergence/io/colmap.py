"""COLMAP text models (``cameras.txt`` + ``images.txt``; Schoenberger & Frahm 2016), read and written.

COLMAP's camera frame is ours (x right, y down, z forward); ``images.txt`` stores the
world-to-camera rotation as a quaternion ``(qw, qx, qy, qz)``. COLMAP puts the centre of the
top-left pixel at (0.5, 0.5), so ``cx = cx_colmap - 0.5`` (and the same for y). Models PINHOLE,
SIMPLE_PINHOLE, SIMPLE_RADIAL, RADIAL and OPENCV; their distortion becomes OpenCV ``(k1, k2, p1, p2)``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from vergence.io._camera_files import (
    check_camera_set,
    checked_camera,
    format_float,
    parse_floats,
    text_lines,
    write_text,
)
from vergence.io._files import input_path
from vergence.io.camera_set import CameraSet

__all__ = ["read_colmap", "write_colmap"]
_COLMAP_PARAMS = {"SIMPLE_PINHOLE": 3, "PINHOLE": 4, "SIMPLE_RADIAL": 4, "RADIAL": 5, "OPENCV": 8}


def _colmap_dir(path: str | os.PathLike[str]) -> Path:
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    return p if p.is_dir() else p.parent


def _integer(token: str, what: str, path: Path, line: int) -> int:
    try:
        return int(token)
    except ValueError:
        raise ValueError(f"{path}:{line}: {what} must be an integer; got {token[:20]!r}") from None


def _colmap_intrinsics(model: str, prm: list[float]) -> tuple[np.ndarray, np.ndarray]:
    dist = np.zeros(4)
    if model in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
        fx = fy = prm[0]
        cx, cy = prm[1], prm[2]
        dist[: len(prm) - 3] = prm[3:]
    else:  # PINHOLE, OPENCV
        fx, fy, cx, cy = prm[:4]
        dist[: len(prm) - 4] = prm[4:]
    K = np.array([[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]])
    return K, dist


def read_colmap(path: str | os.PathLike[str]) -> CameraSet:
    """Read a COLMAP text model (``cameras.txt`` + ``images.txt``) from its folder.

    ``path`` is the folder or either file in it. Cameras come in the order of ``images.txt``,
    named by the image name. Supported models: PINHOLE, SIMPLE_PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV.

    Raises
    ------
    ValueError
        On an unsupported model, a wrong parameter count, an unknown camera id, or malformed lines.
    FileNotFoundError
        If ``cameras.txt`` or ``images.txt`` is missing.
    """
    folder = _colmap_dir(path)
    cpath, ipath = input_path(folder / "cameras.txt"), input_path(folder / "images.txt")
    intr: dict[int, tuple[np.ndarray, np.ndarray, tuple[int, int]]] = {}
    for i, line in enumerate(text_lines(cpath), start=1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) < 4 or tok[1] not in _COLMAP_PARAMS:
            raise ValueError(f"{cpath}:{i}: camera model must be one of {', '.join(sorted(_COLMAP_PARAMS))}; "
                             f"got {tok[1] if len(tok) > 1 else line!r}")
        if len(tok) != 4 + _COLMAP_PARAMS[tok[1]]:
            raise ValueError(f"{cpath}:{i}: {tok[1]} takes {_COLMAP_PARAMS[tok[1]]} parameters; got {len(tok) - 4}")
        K, dist = _colmap_intrinsics(tok[1], parse_floats(tok[4:], cpath, i))
        width, height = _integer(tok[2], "WIDTH", cpath, i), _integer(tok[3], "HEIGHT", cpath, i)
        if width < 1 or height < 1:
            raise ValueError(f"{cpath}:{i}: the image size must be positive; got {width}x{height}")
        intr[_integer(tok[0], "CAMERA_ID", cpath, i)] = (K, dist, (width, height))
    names, cams, dists = [], [], []
    lines = text_lines(ipath)
    i = 0
    while i < len(lines):
        tok = lines[i].split()
        i += 1
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) != 10:
            raise ValueError(f"{ipath}:{i}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME; got {len(tok)} fields")
        q = parse_floats(tok[1:5], ipath, i)
        t = np.array(parse_floats(tok[5:8], ipath, i))
        cam_id = _integer(tok[8], "CAMERA_ID", ipath, i)
        if cam_id not in intr:
            raise ValueError(f"{ipath}:{i}: image {tok[9]} uses camera {cam_id}, which cameras.txt does not define")
        norm = math.sqrt(sum(v * v for v in q))
        if not norm > 0:
            raise ValueError(f"{ipath}:{i}: the quaternion must be non-zero")
        R = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()  # scipy order: x, y, z, w
        K, dist, size = intr[cam_id]
        names.append(Path(tok[9]).name)
        cams.append(checked_camera(K, R, t, size, f"{ipath}:{i}"))
        dists.append(dist)
        i += 1  # skip the POINTS2D line (may be empty)
    return CameraSet(names=tuple(names), cameras=tuple(cams), distortion=np.array(dists).reshape(-1, 4))


def _colmap_model(K: np.ndarray, dist: np.ndarray) -> tuple[str, list[float]]:
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5
    square = fx == fy
    if not dist.any():
        return ("SIMPLE_PINHOLE", [fx, cx, cy]) if square else ("PINHOLE", [fx, fy, cx, cy])
    if square and not dist[1:].any():
        return "SIMPLE_RADIAL", [fx, cx, cy, dist[0]]
    if square and not dist[2:].any():
        return "RADIAL", [fx, cx, cy, dist[0], dist[1]]
    return "OPENCV", [fx, fy, cx, cy, *dist]


def write_colmap(folder: str | os.PathLike[str], cameras: CameraSet) -> None:
    """Write ``cameras.txt`` and ``images.txt`` (one COLMAP camera per image) into ``folder``.

    The smallest model that holds each camera is chosen (SIMPLE_PINHOLE ... OPENCV). Raises
    ``ValueError`` for skewed intrinsics and unregistered cameras, which COLMAP cannot represent.
    """
    check_camera_set(cameras)
    out = Path(folder)
    if not out.is_dir():
        raise FileNotFoundError(f"cannot write a COLMAP model into {out}: no such folder")
    if cameras.unregistered:
        raise ValueError("cameras must all be registered for a COLMAP model")
    crows, irows = ["# Camera list: CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]"], ["# Image list: IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME, then POINTS2D"]
    for i, (name, cam) in enumerate(zip(cameras.names, cameras.cameras), start=1):
        if cam.K[0, 1] != 0.0:
            raise ValueError(f"camera {name!r} has skew {cam.K[0, 1]:g}; COLMAP models have none")
        model, prm = _colmap_model(cam.K, cameras.distortion[i - 1])
        crows.append(" ".join([str(i), model, str(cam.width), str(cam.height), *(format_float(v) for v in prm)]))
        x, y, z, w = Rotation.from_matrix(cam.R).as_quat()
        irows += [" ".join([str(i), *(format_float(v) for v in (w, x, y, z, *cam.t)), str(i), name]), ""]
    write_text(out / "cameras.txt", "\n".join(crows) + "\n")
    write_text(out / "images.txt", "\n".join(irows) + "\n")
