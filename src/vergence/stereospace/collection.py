"""A calibrated photo collection: cameras, their images and sparse 3D points (S2 §3.1).

:func:`load_collection` reads any camera file of :func:`vergence.io.read_cameras` (Bundler, COLMAP,
Middlebury ``*_par.txt``, our JSON), keeps the cameras whose image is in the images folder (the
others are counted and reported), checks each image's size against its camera from the file
header only, and takes the sparse points from the file (Bundler, COLMAP) or, when it has none,
makes them by matching and triangulating (:mod:`vergence.stereospace.triangulation`).
Conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from vergence.camera import Camera
from vergence.io import CameraSet, read_cameras, read_image
from vergence.io.images import MAX_IMAGE_PIXELS
from vergence.stereospace.triangulation import MATCH_NEIGHBOURS, project_distorted, triangulate_collection

__all__ = ["CAMERA_STATUSES", "Collection", "camera_roster", "load_collection"]

CAMERA_STATUSES = ("kept", "no image", "unregistered")
"""What :func:`load_collection` does with a camera of the file (:func:`camera_roster`)."""

Progress = Callable[[float, str], None]


def _frozen(value: object, shape: tuple[int, ...], dtype: type, name: str) -> np.ndarray:
    arr = np.array(value, dtype=dtype, copy=True)
    if arr.size == 0:
        arr = arr.reshape((0, *shape[1:]))
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"{name} must have shape {want}; got {arr.shape}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, slots=True, eq=False)
class Collection:
    """Calibrated cameras with their images and sparse points.

    Parameters
    ----------
    names : tuple of str
        One name per camera (its image's file name).
    cameras : tuple of Camera
        Registered cameras, each of its image's size.
    image_paths : tuple of Path
        The image of each camera.
    points : (P, 3) float64
        Sparse world points.
    observations : (M, 2) int
        ``(point, camera)`` for each sighting of a point in an image.
    observation_pixels : (M, 2) float64
        The measured (x, y) of each observation (distorted, as in the image).
    distortion : (N, 4) float64, optional
        OpenCV ``(k1, k2, p1, p2)`` per camera; zeros when absent.
    points_source : str
        ``"file"`` (from the camera file) or ``"triangulated"``.
    left_out : int
        Cameras of the file left out because their image is not in the folder.
    unregistered : int
        Cameras of the file the reconstruction could not register (Bundler f = 0), left out.
    warnings : tuple of str
        What was left out or assumed, in words.

    Attributes
    ----------
    reprojection_errors_px : (M,) float64
        Distance from each observation to the projection of its point (with distortion).
    point_count : int
        ``len(points)``.
    median_reprojection_error_px : float
        Median of ``reprojection_errors_px`` (NaN without observations).
    """

    names: tuple[str, ...]
    cameras: tuple[Camera, ...]
    image_paths: tuple[Path, ...]
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    observations: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))
    observation_pixels: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    distortion: np.ndarray | None = None
    points_source: str = "file"
    left_out: int = 0
    unregistered: int = 0
    warnings: tuple[str, ...] = ()
    reprojection_errors_px: np.ndarray = field(init=False)
    point_count: int = field(init=False)
    median_reprojection_error_px: float = field(init=False)

    def __post_init__(self) -> None:
        names, cams, paths = tuple(self.names), tuple(self.cameras), tuple(Path(p) for p in self.image_paths)
        if not (len(names) == len(cams) == len(paths)):
            raise ValueError(f"names, cameras and image_paths must have one entry per camera; "
                             f"got {len(names)}, {len(cams)}, {len(paths)}")  # fmt: skip
        if not all(isinstance(c, Camera) for c in cams):
            raise TypeError("cameras must hold Camera instances")
        if len(set(names)) != len(names):
            raise ValueError("names must be unique")
        pts = _frozen(self.points, (None, 3), np.float64, "points")
        if not np.isfinite(pts).all():
            raise ValueError("points must be finite (no NaN or inf)")
        obs = _frozen(self.observations, (None, 2), np.int64, "observations")
        pix = _frozen(self.observation_pixels, (len(obs), 2), np.float64, "observation_pixels")
        if obs.size and (obs.min(axis=0) < 0).any() | (obs[:, 0].max() >= len(pts)) | (obs[:, 1].max() >= len(cams)):
            raise ValueError("observations must index existing points and cameras")
        dist = np.zeros((len(cams), 4)) if self.distortion is None else self.distortion
        dist = _frozen(dist, (len(cams), 4), np.float64, "distortion")
        if self.points_source not in ("file", "triangulated"):
            raise ValueError(f"points_source must be 'file' or 'triangulated'; got {self.points_source!r}")
        errors = np.full(len(obs), np.nan)
        for c in np.unique(obs[:, 1]):
            sel = obs[:, 1] == c
            proj = project_distorted(cams[c], dist[c], pts[obs[sel, 0]])
            errors[sel] = np.linalg.norm(proj - pix[sel], axis=1)
        errors.flags.writeable = False
        finite = errors[np.isfinite(errors)]
        values = {"names": names, "cameras": cams, "image_paths": paths, "points": pts, "observations": obs,
                  "observation_pixels": pix, "distortion": dist, "warnings": tuple(self.warnings),
                  "reprojection_errors_px": errors, "point_count": len(pts),
                  "median_reprojection_error_px": float(np.median(finite)) if finite.size else float("nan")}
        for key, value in values.items():
            object.__setattr__(self, key, value)

    def __len__(self) -> int:
        return len(self.names)

    @property
    def centers(self) -> np.ndarray:
        """(N, 3) camera centres."""
        return np.array([c.center for c in self.cameras]).reshape(-1, 3)


# ---------------------------------------------------------------------------------------- loading
def _header_size(path: Path) -> tuple[int, int]:
    """(width, height) of an image from its header (the pixels are not decoded)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                width, height = int(im.size[0]), int(im.size[1])
    except (OSError, Image.DecompressionBombError) as exc:
        raise ValueError(f"cannot read the size of image {path}: {exc}") from None
    if width * height > MAX_IMAGE_PIXELS:
        raise ValueError(f"image {path} declares {width} x {height} pixels; the limit is {MAX_IMAGE_PIXELS:,}")
    return width, height


def _inside(path: Path, within: Path | None) -> bool:
    """Whether ``path`` is a file whose resolved path (links followed) lies in ``within`` (None: anywhere)."""
    if within is None:
        return path.is_file()
    try:
        return Path(os.path.realpath(path, strict=True)).is_relative_to(within) and path.is_file()
    except (OSError, RuntimeError, ValueError):  # a link to nothing, a link loop, a NUL in a name
        return False


_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".ppm", ".pgm", ".tif", ".tiff", ".bmp")


def _read_set(cameras_path: Path, images: Path,
              within: Path | None = None) -> tuple[CameraSet, list[int], list[tuple[int, int]]]:  # fmt: skip
    """The camera set read at the images' size, the indices kept and their images' sizes.

    Middlebury and Bundler files store no image size (Bundler's ``K`` depends on it): they are
    read at the size of the first image of the folder that they name, and every other image must
    have that size; COLMAP and JSON cameras carry their own size. Only images inside ``within``
    are looked at (:func:`load_collection`).
    """
    probe = next((q for q in sorted(images.iterdir()) if q.suffix.lower() in _IMAGE_SUFFIXES and _inside(q, within)),
                 None)  # fmt: skip
    if probe is None:
        raise ValueError(f"images folder {images} holds no image")
    size = _header_size(probe)
    cset = read_cameras(cameras_path, image_size=size)
    kept = [i for i, n in enumerate(cset.names) if cset.cameras[i] is not None and _inside(images / n, within)]
    if not kept:
        raise ValueError(f"no camera of {cameras_path.name} has its image in {images} "
                         f"(it names {', '.join(cset.names[:3])}, ...)")  # fmt: skip
    first = _header_size(images / cset.names[kept[0]])
    if first != size:
        size = first
        cset = read_cameras(cameras_path, image_size=size)
    sizes = []
    for i in kept:
        got, cam = _header_size(images / cset.names[i]), cset.cameras[i]
        if got != (cam.width, cam.height):
            raise ValueError(f"image {cset.names[i]} is {got[0]} x {got[1]} pixels; its camera in "
                             f"{cameras_path.name} is {cam.width} x {cam.height}")  # fmt: skip
        sizes.append(got)
    return cset, kept, sizes


def _gray(path: Path) -> np.ndarray:
    img = read_image(path)
    if img.ndim == 3:
        img = img @ np.array([0.299, 0.587, 0.114], np.float32)  # ITU-R BT.601 luma
    return np.clip(img * 255.0 + 0.5, 0, 255).astype(np.uint8)


def camera_roster(cameras_path: str | os.PathLike[str], *, images: str | os.PathLike[str]) -> dict[str, str]:
    """Each camera name of a camera file and what :func:`load_collection` will do with it, in the file's order.

    Reads the camera file only (no image is decoded, nothing is triangulated), so that a command can
    refuse an unknown camera name at once instead of after the collection's triangulation.

    Returns
    -------
    dict
        name -> ``"kept"``, ``"no image"`` (not a file in ``images``: left out) or ``"unregistered"``
        (the reconstruction could not register it, f = 0: left out); :data:`CAMERA_STATUSES`.

    Raises
    ------
    ValueError
        ``images`` is not a folder or holds no image; the camera file cannot be read.
    """
    cam_path, img_dir = Path(os.fspath(cameras_path)), Path(os.fspath(images))
    if not img_dir.is_dir():
        raise ValueError(f"images must be a folder of images; {img_dir} is not a folder")
    probe = next((q for q in sorted(img_dir.iterdir()) if q.suffix.lower() in _IMAGE_SUFFIXES and q.is_file()), None)
    if probe is None:
        raise ValueError(f"images folder {img_dir} holds no image")
    cset = read_cameras(cam_path, image_size=_header_size(probe))
    return {n: "unregistered" if cam is None else ("kept" if (img_dir / n).is_file() else "no image")
            for n, cam in zip(cset.names, cset.cameras)}  # fmt: skip


def load_collection(
    cameras_path: str | os.PathLike[str],
    *,
    images: str | os.PathLike[str],
    neighbours: int = MATCH_NEIGHBOURS,
    progress: Progress | None = None,
    within: str | os.PathLike[str] | None = None,
) -> Collection:
    """Read a camera file and its images into a :class:`Collection` (S2 §3.1).

    Cameras whose image is not in ``images`` are left out (``left_out`` and a line of
    ``warnings``); cameras the reconstruction could not register likewise (``unregistered``).
    Points come from the camera file (Bundler, COLMAP), with their observations in the kept
    cameras; a file without points gets them by matching each image with its ``neighbours``
    nearest cameras and triangulating (:mod:`vergence.stereospace.triangulation`): for dino (48
    images of 640 x 480, k = 4) that takes about 3 s on one core and gives about 6,500 points at a
    median reprojection error of 0.18 px (``benchmarks/stereospace_collection.py``).

    Parameters
    ----------
    cameras_path : str or os.PathLike
        Any camera file of :func:`vergence.io.read_cameras`.
    images : str or os.PathLike
        The folder of the images, named as in the camera file.
    neighbours : int
        Cameras each image is matched with when the points are triangulated.
    progress : callable, optional
        ``progress(fraction, message)`` during the triangulation.
    within : str or os.PathLike, optional
        A folder every image must lie in once its path is resolved (``vergence serve`` passes the
        data folder): an image that leads outside it (a symbolic link out, a name with ``..`` or an
        absolute name in the camera file) is left out, unread, like a missing one, and counted in
        ``left_out`` and ``warnings`` (which name only the camera file). None: images anywhere.

    Raises
    ------
    ValueError
        If an image's size differs from its camera (the message names the image), fewer than two
        cameras have an image, the points are all behind every camera, or matching finds none.
    """
    cam_path, img_dir = Path(os.fspath(cameras_path)), Path(os.fspath(images))
    if not img_dir.is_dir():
        raise ValueError(f"images must be a folder of images; {img_dir} is not a folder")
    if not isinstance(neighbours, int) or isinstance(neighbours, bool) or neighbours < 1:
        raise ValueError(f"neighbours must be a positive integer; got {neighbours!r}")
    if within is not None and not Path(os.fspath(within)).is_dir():
        raise ValueError(f"within must be a folder; {os.fspath(within)} is not a folder")
    root = None if within is None else Path(os.path.realpath(os.fspath(within)))
    cset, kept, _ = _read_set(cam_path, img_dir, root)
    named = [n for i, n in enumerate(cset.names) if cset.cameras[i] is not None]
    outside = sum(1 for n in named if (img_dir / n).is_file() and not _inside(img_dir / n, root))
    left_out = len(named) - len(kept)
    if len(kept) < 2:
        raise ValueError(f"a collection needs at least two cameras with an image; {cam_path.name} has "
                         f"{len(kept)} with its image in {img_dir}" +
                         (f" ({outside} more lead outside the allowed folder (within))" if outside else ""))  # fmt: skip
    notes = list(cset.notes)
    if left_out - outside:
        notes.append(f"{left_out - outside} of the {len(cset)} cameras of {cam_path.name} have no image in "
                     f"{img_dir}: left out")  # fmt: skip
    if outside:
        notes.append(f"{outside} of the {len(cset)} cameras of {cam_path.name} name an image that leads outside "
                     "the allowed folder (within): left out, unread")  # fmt: skip
    if cset.unregistered:
        notes.append(f"{len(cset.unregistered)} cameras of {cam_path.name} are not registered (f = 0): left out")
    names = tuple(cset.names[i] for i in kept)
    cams = tuple(cset.cameras[i] for i in kept)  # type: ignore[misc]
    dist = cset.distortion[kept]
    paths = tuple(img_dir / n for n in names)
    if len(cset.points):
        new_index = np.full(len(cset), -1)
        new_index[kept] = np.arange(len(kept))
        obs = cset.observations
        sel = new_index[obs[:, 1]] >= 0
        observations = np.stack([obs[sel, 0], new_index[obs[sel, 1]]], axis=1)
        points, pixels, source = cset.points, cset.observation_pixels[sel], "file"
        depth = np.stack([points @ c.R[2] + c.t[2] for c in cams])
        if not (depth > 0).any():
            raise ValueError(f"the points of {cam_path.name} are behind every camera")
    else:
        start = time.perf_counter()
        points, observations, pixels, candidates = triangulate_collection(
            cams, dist, lambda i: _gray(paths[i]), neighbours=neighbours, progress=progress)
        if candidates and not len(points):
            raise ValueError(f"the points triangulated for {cam_path.name} are behind every camera")
        if not len(points):
            raise ValueError(f"matching the images of {cam_path.name} found no points to triangulate")
        source = "triangulated"
        notes.append(f"{len(points)} points triangulated from {len(cams)} images in "
                     f"{time.perf_counter() - start:.1f} s")  # fmt: skip
    return Collection(names=names, cameras=cams, image_paths=paths, points=points, observations=observations,
                      observation_pixels=pixels, distortion=dist, points_source=source, left_out=left_out,
                      unregistered=len(cset.unregistered), warnings=tuple(notes))
