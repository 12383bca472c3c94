"""Our JSON camera files (``"format": "vergence-cameras"``): one ``Camera.to_dict`` per camera.

Unregistered cameras are ``null``; distortion, sparse points, colours and observations travel as
the :class:`~vergence.io.camera_set.CameraSet` holds them, so a round trip is exact.
"""

from __future__ import annotations

import os

import numpy as np

from vergence.camera import Camera
from vergence.io._camera_files import check_camera_set
from vergence.io._files import input_path
from vergence.io.atomic import write_json
from vergence.io.camera_set import CameraSet
from vergence.io.jsonfile import read_json

__all__ = ["read_cameras_json", "write_cameras_json"]


def write_cameras_json(path: str | os.PathLike[str], cameras: CameraSet) -> None:
    """Write our JSON camera file (``Camera.to_dict`` per camera, ``null`` when unregistered)."""
    check_camera_set(cameras)
    entries = [{"name": n, "camera": None if c is None else c.to_dict(), "distortion": d.tolist()}
               for n, c, d in zip(cameras.names, cameras.cameras, cameras.distortion)]
    write_json(path, {"format": "vergence-cameras", "version": 1, "cameras": entries,
                      "points": cameras.points, "colors": cameras.colors, "observations": cameras.observations,
                      "observation_pixels": cameras.observation_pixels})


def read_cameras_json(path: str | os.PathLike[str]) -> CameraSet:
    """Read a file written by :func:`write_cameras_json`."""
    p = input_path(path)
    data = read_json(p, what="camera file")
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
