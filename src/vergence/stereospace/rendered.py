"""A photo collection ray-traced from a scene: cameras on an arc, images, a camera file.

S2 browses calibrated photo collections (S2 §3). A fresh clone has none of its own (the real ones,
kermit and dino, live in the shared data), so :func:`render_collection` makes one from a scene of
:mod:`vergence.render`: ``views`` cameras on a horizontal arc around the scene camera's look-at
point, at its distance and height, each looking at that point with the scene camera's lens; each
view ray-traced (first hits, ambient occlusion) and tone-mapped with one exposure; the cameras
written in our JSON camera format without points, so that
:func:`~vergence.stereospace.load_collection` matches and triangulates them as it does for any
collection without a reconstruction. The truth of every camera is known, which a real collection's
is not.

Cost: the built-in scenes at 320 x 240, 12 views: about 0.45 s of rendering and 0.26-0.32 s of
triangulation (2,177 and 2,608 points) on two cores (``benchmarks/stereospace_rendered.py``).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from numbers import Integral, Real
from pathlib import Path

import numpy as np

__all__ = ["COLLECTION_ARC_DEG", "COLLECTION_VIEWS", "MAX_COLLECTION_VIEWS", "render_collection"]

#: Views of a rendered collection by default: a capture path of 12 photographs, as a walk around.
COLLECTION_VIEWS = 12
#: The arc they span by default, degrees: 60 (5.5 degrees between neighbours, wide enough for
#: StereoSpace regions, close enough for matching).
COLLECTION_ARC_DEG = 60.0
#: Most views of one rendered collection.
MAX_COLLECTION_VIEWS = 360

Progress = Callable[[float, str], None]


def _orbit(offset: np.ndarray, up: np.ndarray, angle: float) -> np.ndarray:
    """``offset`` turned by ``angle`` (radians) about the unit axis ``up`` (Rodrigues)."""
    return (offset * np.cos(angle) + np.cross(up, offset) * np.sin(angle)
            + up * float(up @ offset) * (1.0 - np.cos(angle)))  # fmt: skip


def render_collection(
    scene: object,
    folder: str | os.PathLike[str],
    *,
    views: int = COLLECTION_VIEWS,
    arc_deg: float = COLLECTION_ARC_DEG,
    samples: int = 4,
    progress: Progress | None = None,
) -> Path:
    """Ray-trace a collection of ``scene`` into ``folder``; returns the camera file (``cameras.json``).

    Parameters
    ----------
    scene : vergence.render.Scene
        Its camera (pinhole) gives the look-at point, the distance, the height, the lens and the
        image size of every view (:func:`vergence.render.builtin_scene` takes a size).
    folder : str or os.PathLike
        An existing folder; ``view_00.png`` ... and ``cameras.json`` are written into it.
    views : int
        Cameras on the arc, evenly spaced, in [3, :data:`MAX_COLLECTION_VIEWS`].
    arc_deg : float
        The arc, degrees, in (0, 360]; centred on the scene camera (the middle view is the scene's
        own when ``views`` is odd). A full 360 leaves out the last view, which would repeat the first.
    samples : int
        Ambient-occlusion rays per hit (:func:`vergence.render.render`).
    progress : callable(fraction, message), optional

    Raises
    ------
    TypeError
        If ``scene`` is not a vergence.render.Scene.
    ValueError
        On a fisheye scene camera, a bad ``views`` or ``arc_deg``, or a folder that does not exist.
    """
    from vergence.io import write_cameras, write_image
    from vergence.io.camera_set import CameraSet
    from vergence.render import Scene, Tracer, tonemap
    from vergence.render.tonemap import auto_exposure

    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a vergence.render.Scene; got {type(scene).__name__}")
    if scene.camera.lens != "pinhole":
        raise ValueError(f"the scene camera must be a pinhole to make a photo collection; got {scene.camera.lens!r}")
    if isinstance(views, bool) or not isinstance(views, Integral) or not 3 <= views <= MAX_COLLECTION_VIEWS:
        raise ValueError(f"views must be a whole number in [3, {MAX_COLLECTION_VIEWS}]; got {views!r}")
    if isinstance(arc_deg, bool) or not isinstance(arc_deg, Real) or not 0.0 < float(arc_deg) <= 360.0:
        raise ValueError(f"arc_deg must be in (0, 360]; got {arc_deg!r}")
    out = Path(os.fspath(folder))
    if not out.is_dir():
        raise ValueError(f"folder must be an existing folder; got {out}")
    report = progress if progress is not None else (lambda f, m: None)
    camera = scene.camera
    target = np.array(camera.look_at, dtype=np.float64)
    up = np.array(camera.up, dtype=np.float64)
    up /= np.linalg.norm(up)
    offset = np.array(camera.position, dtype=np.float64) - target
    full = float(arc_deg) == 360.0
    angles = np.radians(np.linspace(-float(arc_deg) / 2, float(arc_deg) / 2, int(views) + full)[: int(views)])
    tracer = Tracer(scene)
    names, cameras, exposure = [], [], None
    for i, angle in enumerate(angles):
        report(i / len(angles), f"rendering view {i + 1} of {len(angles)}")
        cam = dataclasses.replace(camera, position=target + _orbit(offset, up, float(angle))).build()
        beauty = np.asarray(tracer.render(cam, max_depth=0, samples=samples).beauty, dtype=np.float64)
        exposure = auto_exposure(beauty) if exposure is None else exposure  # one exposure: photos of one scene
        name = f"view_{i:02d}.png"
        write_image(out / name, tonemap(beauty, exposure=exposure))
        names.append(name)
        cameras.append(cam)
    path = out / "cameras.json"
    write_cameras(path, CameraSet(names=tuple(names), cameras=tuple(cameras)))
    report(1.0, f"{len(names)} views rendered")
    return path
