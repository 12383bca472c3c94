"""The calibrated camera set shared by every camera-file format.

Every reader (:mod:`~vergence.io.middlebury`, :mod:`~vergence.io.colmap`, :mod:`~vergence.io.bundler`,
:mod:`~vergence.io.cameras_json`) returns a :class:`CameraSet` in our conventions
(``docs/conventions.md``): camera frame x right, y down, z forward; ``x_cam = R @ x_world + t``;
pixel centres at integer coordinates with the origin at the top-left pixel. Lens distortion is kept
beside each camera as OpenCV ``(k1, k2, p1, p2)`` in normalised image coordinates, ready for
``cv2.undistort``. :func:`vergence.io.read_cameras` picks the reader from the file name; the helpers
the readers share are in :mod:`vergence.io._camera_files`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vergence.camera import Camera

__all__ = ["CameraSet"]


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
    notes : tuple of str, optional
        What the reader assumed that the file did not say, in words (e.g. that Bundler cameras
        were paired with the sorted image names of a folder); shown to the user by the CLI.
    """

    names: tuple[str, ...]
    cameras: tuple[Camera | None, ...]
    distortion: np.ndarray | None = None
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    colors: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.uint8))
    observations: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    observation_pixels: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.notes, str) or not all(isinstance(n, str) for n in self.notes):
            raise TypeError(f"notes must be a tuple of str; got {self.notes!r}")
        object.__setattr__(self, "notes", tuple(self.notes))
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
