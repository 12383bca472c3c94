"""Calibrated camera sets: the :class:`CameraSet`, Middlebury ``*_par.txt``, COLMAP text, our JSON.

Every reader returns a :class:`CameraSet` in our conventions (``docs/conventions.md``): camera frame
x right, y down, z forward; ``x_cam = R @ x_world + t``; pixel centres at integer coordinates with
the origin at the top-left pixel. Lens distortion is kept beside each camera as OpenCV
``(k1, k2, p1, p2)`` in normalised image coordinates, ready for ``cv2.undistort``.
Bundler ``bundle.out`` lives in :mod:`vergence.io.bundler`; :func:`read_cameras` reads any of them.

Format conventions converted here:

- **Middlebury** multi-view (Seitz et al. 2006): ``name k11..k33 r11..r33 t1 t2 t3``, projection
  ``K [R | t]``, origin top-left. Taken as is; the files store no image size.
- **COLMAP** text (``cameras.txt``, ``images.txt``): same camera frame as ours, quaternion
  ``(qw, qx, qy, qz)`` world-to-camera; COLMAP puts the centre of the top-left pixel at (0.5, 0.5),
  so ``cx = cx_colmap - 0.5``. Models PINHOLE, SIMPLE_PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image
from scipy.spatial.transform import Rotation

from vergence.camera import Camera
from vergence.io._files import input_path, read_bytes
from vergence.io.atomic import atomic_write, write_json

__all__ = [
    "CameraSet",
    "read_cameras",
    "read_cameras_json",
    "read_colmap",
    "read_middlebury_par",
    "write_cameras_json",
    "write_colmap",
    "write_middlebury_par",
]
_COLMAP_PARAMS = {"SIMPLE_PINHOLE": 3, "PINHOLE": 4, "SIMPLE_RADIAL": 4, "RADIAL": 5, "OPENCV": 8}


def _frozen(arr: object, dtype: type) -> np.ndarray:
    out = np.array(arr, dtype=dtype, copy=True)
    out.flags.writeable = False
    return out


def _rows(value: object, ncols: int, dtype: type) -> np.ndarray:
    """A read-only ``(N, ncols)`` copy; an empty input gives ``(0, ncols)``."""
    arr = np.asarray(value)
    return _frozen(arr.reshape(-1, ncols) if arr.size else np.zeros((0, ncols)), dtype)


@dataclass(frozen=True, slots=True, eq=False)
class CameraSet:
    """Named calibrated cameras, their lens distortion and (optionally) the sparse SfM points.

    Parameters
    ----------
    names : tuple of str
        One unique name per camera (the image file name where the format gives one).
    cameras : tuple of Camera or None
        ``None`` marks a camera the reconstruction could not register (Bundler f = 0).
    distortion : (N, 4) array, optional
        OpenCV ``(k1, k2, p1, p2)`` per camera, normalised coordinates; zeros when absent.
    points : (P, 3) array, optional
        Sparse 3D points in world coordinates (metres or the reconstruction's unit).
    colors : (P, 3) uint8 array, optional
        RGB colour of each point.
    observations : (M, 3) int array, optional
        ``(point, camera, feature)`` for each observation of a point in an image.
    observation_pixels : (M, 2) array, optional
        The observed (x, y) in our pixel convention (distorted, as measured).
    """

    names: tuple[str, ...]
    cameras: tuple[Camera | None, ...]
    distortion: np.ndarray | None = None
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    colors: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.uint8))
    observations: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    observation_pixels: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def __post_init__(self) -> None:
        names, cams = tuple(self.names), tuple(self.cameras)
        if len(names) != len(cams):
            raise ValueError(f"names must have one entry per camera ({len(cams)}); got {len(names)}")
        if not all(isinstance(n, str) and n and not any(c.isspace() for c in n) for n in names):
            raise ValueError("names must be non-empty strings without whitespace")
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"names must be unique; repeated: {', '.join(dup)}")
        if not all(c is None or isinstance(c, Camera) for c in cams):
            raise TypeError("cameras must hold Camera instances or None")
        dist = np.zeros((len(cams), 4)) if self.distortion is None else np.asarray(self.distortion, float)
        if dist.shape != (len(cams), 4) or not np.isfinite(dist).all():
            raise ValueError(f"distortion must be finite with shape ({len(cams)}, 4); got {dist.shape}")
        pts, cols = _rows(self.points, 3, np.float64), _rows(self.colors, 3, np.uint8)
        obs, pix = _rows(self.observations, 3, np.int64), _rows(self.observation_pixels, 2, np.float64)
        if cols.shape[0] != pts.shape[0]:
            raise ValueError(f"colors must have one row per point ({pts.shape[0]}); got {cols.shape[0]}")
        if pix.shape[0] != obs.shape[0]:
            raise ValueError(f"observation_pixels must have one row per observation ({obs.shape[0]}); got {pix.shape[0]}")
        if obs.size and (obs[:, 0].min() < 0 or obs[:, 0].max() >= len(pts) or obs[:, 1].min() < 0
                         or obs[:, 1].max() >= len(cams)):
            raise ValueError("observations must index existing points and cameras")
        values = {"names": names, "cameras": cams, "distortion": _frozen(dist, np.float64), "points": pts,
                  "colors": cols, "observations": obs, "observation_pixels": pix}
        for key, value in values.items():
            object.__setattr__(self, key, value)

    def __len__(self) -> int:
        return len(self.names)

    @property
    def unregistered(self) -> tuple[int, ...]:
        """Indices of cameras the reconstruction could not register (``None`` entries)."""
        return tuple(i for i, c in enumerate(self.cameras) if c is None)

    def index(self, name: str) -> int:
        """Index of the camera called ``name`` (a path is reduced to its file name)."""
        key = Path(os.fspath(name)).name
        if key not in self.names:
            shown = ", ".join(self.names[:5]) + (", ..." if len(self.names) > 5 else "")
            raise ValueError(f"camera set has no camera named {key!r}; it has {len(self.names)}: {shown}")
        return self.names.index(key)

    def camera(self, name: str) -> Camera:
        """The registered camera called ``name``; unregistered or unknown names raise ``ValueError``."""
        i = self.index(name)
        cam = self.cameras[i]
        if cam is None:
            raise ValueError(f"camera {self.names[i]!r} is not registered in the reconstruction (f = 0)")
        return cam


# ---------------------------------------------------------------------------------------- helpers
def _text_lines(path: Path) -> list[str]:
    try:
        return read_bytes(path).decode("utf-8").splitlines()
    except UnicodeDecodeError as exc:
        raise ValueError(f"cannot read {path}: not a UTF-8 text file") from exc


def _floats(tokens: Sequence[str], path: Path, line: int) -> list[float]:
    try:
        values = [float(t) for t in tokens]
    except ValueError as exc:
        where = f"{path}:{line}" if line else str(path)
        raise ValueError(f"{where}: expected numbers; got {' '.join(tokens)[:60]!r}") from exc
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{path}:{line}: numbers must be finite" if line else f"{path}: numbers must be finite")
    return values


def _image_size(path: Path) -> tuple[int, int]:
    if not path.is_file():
        raise FileNotFoundError(f"cannot find image {path} to read its size; pass image_size=(width, height)")
    try:
        with Image.open(path) as im:
            return int(im.size[0]), int(im.size[1])
    except OSError as exc:
        raise ValueError(f"cannot read the size of image {path}: {exc}") from exc


def _check_size(image_size: object) -> tuple[int, int]:
    if (not isinstance(image_size, Sequence) or len(image_size) != 2
            or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= 1 for v in image_size)):
        raise ValueError(f"image_size must be (width, height) with positive integers; got {image_size!r}")
    return int(image_size[0]), int(image_size[1])


def _camera(K: np.ndarray, R: np.ndarray, t: np.ndarray, size: tuple[int, int], where: str) -> Camera:
    try:
        return Camera(K=K, R=R, t=t, width=size[0], height=size[1])
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from exc


def _fmt(v: float) -> str:
    return repr(float(v))


def _count(value: float, what: str, path: Path) -> int:
    """A count read from a file: a non-negative integer."""
    if value != int(value) or value < 0:
        raise ValueError(f"{path}: the number of {what} must be an integer >= 0; got {value:g}")
    return int(value)


# ------------------------------------------------------------------------------------- Middlebury
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
    size = None if image_size is None else _check_size(image_size)
    lines = [ln for ln in _text_lines(p) if ln.strip()]
    try:
        count = int(lines[0].split()[0])
    except (IndexError, ValueError) as exc:
        raise ValueError(f"{p}:1: expected the number of cameras on the first line") from exc
    count = _count(count, "cameras", p)
    body = lines[1:]
    if len(body) < count:
        raise ValueError(f"{p} is truncated: the header announces {count} cameras, the file has {len(body)}")
    names, cams = [], []
    for i, line in enumerate(body[:count], start=2):
        tok = line.split()
        if len(tok) != 22:
            raise ValueError(f"{p}:{i}: expected 22 fields (name, 9 of K, 9 of R, 3 of t); got {len(tok)}")
        v = np.array(_floats(tok[1:], p, i))
        wh = size if size is not None else _image_size(p.parent / tok[0])
        names.append(Path(tok[0]).name)
        cams.append(_camera(v[:9].reshape(3, 3), v[9:18].reshape(3, 3), v[18:], wh, f"{p}:{i}"))
    return CameraSet(names=tuple(names), cameras=tuple(cams))


def write_middlebury_par(path: str | os.PathLike[str], cameras: CameraSet) -> None:
    """Write a Middlebury ``*_par.txt`` atomically; refuses distortion and unregistered cameras."""
    _check_set(cameras)
    if cameras.unregistered or np.any(cameras.distortion != 0):
        raise ValueError("cameras must all be registered and distortion-free for a Middlebury par file")
    rows = [str(len(cameras))]
    for name, cam in zip(cameras.names, cameras.cameras):
        vals = [*cam.K.ravel(), *cam.R.ravel(), *cam.t]
        rows.append(" ".join([name, *(_fmt(v) for v in vals)]))
    _write_text(path, "\n".join(rows) + "\n")


# ----------------------------------------------------------------------------------------- COLMAP
def _colmap_dir(path: str | os.PathLike[str]) -> Path:
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    return p if p.is_dir() else p.parent


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
    for i, line in enumerate(_text_lines(cpath), start=1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) < 4 or tok[1] not in _COLMAP_PARAMS:
            raise ValueError(f"{cpath}:{i}: camera model must be one of {', '.join(sorted(_COLMAP_PARAMS))}; "
                             f"got {tok[1] if len(tok) > 1 else line!r}")
        if len(tok) != 4 + _COLMAP_PARAMS[tok[1]]:
            raise ValueError(f"{cpath}:{i}: {tok[1]} takes {_COLMAP_PARAMS[tok[1]]} parameters; got {len(tok) - 4}")
        K, dist = _colmap_intrinsics(tok[1], _floats(tok[4:], cpath, i))
        intr[int(tok[0])] = (K, dist, _check_size((int(tok[2]), int(tok[3]))))
    names, cams, dists = [], [], []
    lines = _text_lines(ipath)
    i = 0
    while i < len(lines):
        tok = lines[i].split()
        i += 1
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) != 10:
            raise ValueError(f"{ipath}:{i}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME; got {len(tok)} fields")
        q = _floats(tok[1:5], ipath, i)
        t = np.array(_floats(tok[5:8], ipath, i))
        cam_id = int(tok[8])
        if cam_id not in intr:
            raise ValueError(f"{ipath}:{i}: image {tok[9]} uses camera {cam_id}, which cameras.txt does not define")
        norm = math.sqrt(sum(v * v for v in q))
        if not norm > 0:
            raise ValueError(f"{ipath}:{i}: the quaternion must be non-zero")
        R = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()  # scipy order: x, y, z, w
        K, dist, size = intr[cam_id]
        names.append(Path(tok[9]).name)
        cams.append(_camera(K, R, t, size, f"{ipath}:{i}"))
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
    _check_set(cameras)
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
        crows.append(" ".join([str(i), model, str(cam.width), str(cam.height), *(_fmt(v) for v in prm)]))
        x, y, z, w = Rotation.from_matrix(cam.R).as_quat()
        irows += [" ".join([str(i), *(_fmt(v) for v in (w, x, y, z, *cam.t)), str(i), name]), ""]
    _write_text(out / "cameras.txt", "\n".join(crows) + "\n")
    _write_text(out / "images.txt", "\n".join(irows) + "\n")


# ------------------------------------------------------------------------------------------- JSON
def write_cameras_json(path: str | os.PathLike[str], cameras: CameraSet) -> None:
    """Write our JSON camera file (``Camera.to_dict`` per camera, ``null`` when unregistered)."""
    _check_set(cameras)
    entries = [{"name": n, "camera": None if c is None else c.to_dict(), "distortion": d.tolist()}
               for n, c, d in zip(cameras.names, cameras.cameras, cameras.distortion)]
    write_json(path, {"format": "vergence-cameras", "version": 1, "cameras": entries,
                      "points": cameras.points, "colors": cameras.colors, "observations": cameras.observations,
                      "observation_pixels": cameras.observation_pixels})


def read_cameras_json(path: str | os.PathLike[str]) -> CameraSet:
    """Read a file written by :func:`write_cameras_json`."""
    p = input_path(path)
    try:
        data = json.loads(read_bytes(p).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"cannot read {p}: not valid JSON ({exc})") from exc
    if not isinstance(data, dict) or data.get("format") != "vergence-cameras" or not isinstance(data.get("cameras"), list):
        raise ValueError(f"{p} is not a vergence camera file (format 'vergence-cameras' with a 'cameras' list)")
    names, cams, dists = [], [], []
    for k, e in enumerate(data["cameras"]):
        if not isinstance(e, dict) or "name" not in e or "camera" not in e:
            raise ValueError(f"{p}: camera entry {k} must have 'name' and 'camera'")
        names.append(e["name"])
        cams.append(None if e["camera"] is None else Camera.from_dict(e["camera"]))
        dists.append(e.get("distortion", [0.0] * 4))
    return CameraSet(names=tuple(names), cameras=tuple(cams), distortion=np.array(dists, float).reshape(-1, 4),
                     points=data.get("points", []), colors=np.array(data.get("colors", []), np.uint8),
                     observations=np.array(data.get("observations", []), np.int64),
                     observation_pixels=data.get("observation_pixels", []))


# ------------------------------------------------------------------------------------- dispatcher
def read_cameras(
    path: str | os.PathLike[str],
    *,
    image_size: tuple[int, int] | None = None,
    image_list: str | os.PathLike[str] | Sequence[str] | None = None,
) -> CameraSet:
    """Read any supported camera file, chosen by its name.

    ``*_par.txt`` -> Middlebury, ``*.out`` -> Bundler, ``*.json`` -> ours, a folder or
    ``cameras.txt``/``images.txt`` -> COLMAP. ``image_size`` applies to Middlebury and Bundler,
    ``image_list`` to Bundler only.

    Raises
    ------
    ValueError
        If the name matches no supported format (the message lists them).
    """
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    name = p.name.lower()
    if p.is_dir() or name in ("cameras.txt", "images.txt"):
        return read_colmap(p)
    if name.endswith("_par.txt"):
        return read_middlebury_par(p, image_size=image_size)
    if name.endswith(".out"):
        from vergence.io.bundler import read_bundler  # bundler.py builds on this module

        return read_bundler(p, image_size=image_size, image_list=image_list)
    if name.endswith(".json"):
        return read_cameras_json(p)
    raise ValueError(f"camera file {p.name!r} has no known format; expected *_par.txt (Middlebury), *.out "
                     "(Bundler), cameras.txt/images.txt or their folder (COLMAP), or *.json (vergence)")


def _check_set(cameras: object) -> None:
    if not isinstance(cameras, CameraSet):
        raise TypeError(f"cameras must be a CameraSet; got {type(cameras).__name__}")


def _write_text(path: str | os.PathLike[str], text: str) -> None:
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
