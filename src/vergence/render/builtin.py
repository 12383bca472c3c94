"""Built-in scenes, generated in code: ``stadium`` (S0 §4), ``glasses`` (S3), ``tabletop`` (DIBR).

- ``stadium``: a player on a mown field 30 m from a long lens (8 deg), a ball, bleachers full of
  spectators 60-75 m away; default rig b = 0.5 m converged on the player (H = 30 m).
- ``glasses``: two glass spheres (ior 1.5 and 1.33), a solid glass goblet and a tilted mirror in
  front of a wall of lettered tiles on a checker floor, lit by an HDR sky. The sky is
  ``venice_sunset_1k.hdr`` from the shared test data (``$VERGENCE_SHARED_DATA/hdri``, default
  ``<repository>/../shared/data/hdri``) when present; otherwise the constant colour
  :data:`GLASSES_FALLBACK_SKY`, and ``scene.environment.note`` says so (the render settings and the
  CLI repeat it; a log record is also emitted).
- ``tabletop``: textured boxes, a mug, spheres and a vase on a wooden table before a papered wall:
  diffuse only, several depths, clear occlusions.
"""

from __future__ import annotations

import logging
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from vergence.render import _procedural as proc
from vergence.render.scene import (
    Checker,
    Diffuse,
    Environment,
    Glass,
    Mirror,
    Rectangle,
    Scene,
    SceneCamera,
    Sphere,
    Stereo,
    Texture,
)
from vergence.render.scenefile import load_scene

__all__ = ["BUILTIN_SCENES", "GLASSES_FALLBACK_SKY", "builtin_scene", "open_scene", "shared_hdri"]

BUILTIN_SCENES = ("glasses", "stadium", "tabletop")
# Late-afternoon sky radiance used when the HDR map is absent: a warm grey of about the map's mean.
GLASSES_FALLBACK_SKY = (0.9, 0.8, 0.7)
_log = logging.getLogger("vergence.render")


def shared_hdri(name: str) -> Path:
    """Path of ``name`` in the shared HDR folder (it may not exist)."""
    root = os.environ.get("VERGENCE_SHARED_DATA")
    base = Path(root) if root else Path(__file__).resolve().parents[3].parent / "shared" / "data"
    return base / "hdri" / name


def _camera(position, look_at, fov_deg, width, height) -> SceneCamera:  # noqa: ANN001
    return SceneCamera(position=position, look_at=look_at, up=(0.0, 1.0, 0.0), fov_deg=fov_deg, width=width, height=height)


def _glasses(width: int, height: int) -> Scene:
    hdr = shared_hdri("venice_sunset_1k.hdr")
    if hdr.is_file():
        from vergence.io import read_image

        env = Environment(image=read_image(hdr), intensity=1.0, rotation_deg=150.0, source=str(hdr))
    else:
        note = f"HDR map {hdr} not found: constant sky colour {list(GLASSES_FALLBACK_SKY)} used instead"
        _log.warning("glasses scene: %s", note)
        env = Environment(color=GLASSES_FALLBACK_SKY, source="fallback", note=note)
    materials = {
        "tiles": Texture(image=proc.tile_texture()),
        "floor": Checker(colors=[[0.85, 0.83, 0.78], [0.18, 0.2, 0.24]], squares=(12, 12)),
        "glass": Glass(ior=1.5),
        "water": Glass(ior=1.33, color=(0.85, 0.95, 1.0)),
        "crystal": Glass(ior=1.6, color=(1.0, 0.92, 0.8)),
        "mirror": Mirror(color=(0.92, 0.92, 0.95)),
        "red": Diffuse(color=(0.8, 0.15, 0.1)),
        "frame": Diffuse(color=(0.25, 0.2, 0.15)),
        "blocks": Texture(image=proc.tile_texture(256, 256, cols=2, rows=2)),
    }
    yaw = np.radians(-40.0)
    mirror_n = np.array([np.sin(yaw), 0.0, np.cos(yaw)])
    goblet = [(0.0, 0.0), (0.22, 0.0), (0.22, 0.03), (0.05, 0.06), (0.04, 0.3), (0.12, 0.4), (0.2, 0.55),
              (0.22, 0.72), (0.2, 0.85), (0.0, 0.85)]  # fmt: skip
    # Layout: the mirror's reflection cone (to the left-front) holds only diffuse objects, so that at
    # D = 2 nothing in the mirror needs a third bounce.
    objects = [
        Rectangle(center=(0.0, 1.6, -3.0), normal=(0, 0, 1), up=(0, 1, 0), size=(8.0, 5.0), material="tiles"),
        Rectangle(center=(0.0, 0.0, -1.0), normal=(0, 1, 0), up=(0, 0, -1), size=(8.0, 8.0), material="floor"),
        Sphere(center=(-0.4, 0.5, -1.6), radius=0.5, material="glass"),
        Sphere(center=(0.25, 0.3, 0.3), radius=0.3, material="water"),
        proc.lathe(goblet, base=(0.5, 0.0, -1.9), material="crystal"),
        Rectangle(center=(1.55, 0.85, -1.3), normal=mirror_n, up=(0, 1, 0), size=(1.1, 1.5), material="mirror"),
        Rectangle(center=(1.55, 0.85, -1.3) - 0.01 * mirror_n, normal=mirror_n, up=(0, 1, 0), size=(1.2, 1.6),
                  material="frame"),  # fmt: skip
        Sphere(center=(1.0, 0.22, 0.6), radius=0.22, material="red"),
        proc.box((-1.6, 0.35, 0.4), (0.7, 0.7, 0.7), "blocks"),
    ]
    cam = _camera((0.0, 1.15, 3.2), (0.1, 0.55, -0.6), 42.0, width, height)
    return Scene(camera=cam, environment=env, materials=materials, objects=tuple(objects),
                 stereo=Stereo(baseline=0.065, convergence=3.6), name="glasses")  # fmt: skip


def _stadium(width: int, height: int) -> Scene:
    materials = {
        "grass": Texture(image=proc.grass_texture()),
        "concrete": Diffuse(color=(0.55, 0.55, 0.52)),
        "jersey": Diffuse(color=(0.75, 0.1, 0.12)),
        "shorts": Diffuse(color=(0.95, 0.95, 0.95)),
        "skin": Diffuse(color=(0.72, 0.5, 0.36)),
        "ball": Checker(colors=[[0.95, 0.95, 0.95], [0.08, 0.08, 0.08]], squares=(8, 4)),
    }
    px, pz = 0.0, -30.0  # the subject, 30 m in front of the camera (S0 §4: z_s)
    objects = [
        Rectangle(center=(0.0, 0.0, -40.0), normal=(0, 1, 0), up=(0, 0, -1), size=(120.0, 100.0), material="grass"),
        proc.cylinder((px - 0.12, 0.0, pz), 0.08, 0.85, "skin", segments=24),
        proc.cylinder((px + 0.12, 0.0, pz + 0.05), 0.08, 0.85, "skin", segments=24),
        proc.cylinder((px, 0.6, pz), 0.22, 0.3, "shorts", segments=32),
        proc.lathe([(0.0, 0.0), (0.2, 0.0), (0.24, 0.35), (0.26, 0.55), (0.0, 0.6)], base=(px, 0.88, pz),
                   material="jersey", segments=32),  # fmt: skip
        proc.cylinder((px - 0.33, 1.0, pz), 0.06, 0.45, "skin", segments=16),
        proc.cylinder((px + 0.33, 1.0, pz), 0.06, 0.45, "skin", segments=16),
        Sphere(center=(px, 1.62, pz), radius=0.13, material="skin"),
        Sphere(center=(px + 0.45, 0.11, pz + 0.4), radius=0.11, material="ball"),
    ]
    # Bleachers: 10 tiers, 0.8 m deep and 0.5 m high, from 60 m back; spectators on each riser.
    for k in range(10):
        z, y = -60.0 - 0.8 * k, 0.5 * k
        materials[f"crowd{k}"] = Texture(image=proc.crowd_texture(seed=11 + k))
        objects.append(Rectangle(center=(0.0, y + 0.25, z), normal=(0, 0, 1), up=(0, 1, 0), size=(60.0, 0.5),
                                 material=f"crowd{k}"))  # fmt: skip
        objects.append(Rectangle(center=(0.0, y + 0.5, z - 0.4), normal=(0, 1, 0), up=(0, 0, -1), size=(60.0, 0.8),
                                 material="concrete"))  # fmt: skip
    env = Environment(color=(0.8, 0.85, 0.95), source="color")
    cam = _camera((0.0, 2.2, 0.0), (px, 1.1, pz), 8.0, width, height)
    return Scene(camera=cam, environment=env, materials=materials, objects=tuple(objects),
                 stereo=Stereo(baseline=0.5, convergence=30.0), name="stadium")  # fmt: skip


def _tabletop(width: int, height: int) -> Scene:
    materials = {
        "wood": Texture(image=proc.wood_texture()),
        "paper": Texture(image=proc.poster_texture()),
        "tiles": Texture(image=proc.tile_texture(384, 240, cols=4, rows=3)),
        "checker": Checker(colors=[[0.9, 0.75, 0.2], [0.15, 0.3, 0.6]], squares=(10, 5)),
        "mug": Checker(colors=[[0.85, 0.85, 0.82], [0.7, 0.2, 0.2]], squares=(12, 1)),
        "green": Diffuse(color=(0.25, 0.6, 0.3)),
        "floor": Diffuse(color=(0.35, 0.33, 0.3)),
    }
    top = 0.75
    vase = [(0.0, 0.0), (0.06, 0.0), (0.09, 0.08), (0.1, 0.16), (0.05, 0.26), (0.045, 0.32), (0.06, 0.36), (0.0, 0.36)]
    objects = [
        Rectangle(center=(0.0, 1.5, -0.9), normal=(0, 0, 1), up=(0, 1, 0), size=(4.0, 3.0), material="paper"),
        Rectangle(center=(0.0, 0.0, 0.0), normal=(0, 1, 0), up=(0, 0, -1), size=(6.0, 6.0), material="floor"),
        Rectangle(center=(0.0, top, -0.25), normal=(0, 1, 0), up=(0, 0, -1), size=(1.8, 1.1), material="wood"),
        proc.box((-0.45, top + 0.15, -0.5), (0.3, 0.3, 0.3), "tiles"),
        proc.box((0.35, top + 0.06, -0.1), (0.22, 0.12, 0.34), "tiles"),
        proc.cylinder((-0.1, top, -0.35), 0.07, 0.16, "mug"),
        Sphere(center=(0.15, top + 0.1, 0.1), radius=0.1, material="checker"),
        Sphere(center=(-0.25, top + 0.06, 0.05), radius=0.06, material="green"),
        proc.lathe(vase, base=(0.5, top, -0.55), material="checker"),
    ]
    env = Environment(color=(1.0, 0.95, 0.88), source="color")
    cam = _camera((0.0, 1.25, 0.95), (0.0, 0.8, -0.3), 50.0, width, height)
    return Scene(camera=cam, environment=env, materials=materials, objects=tuple(objects),
                 stereo=Stereo(baseline=0.04, convergence=1.2), name="tabletop")  # fmt: skip


def builtin_scene(name: str, *, width: int = 320, height: int = 240) -> Scene:
    """A built-in scene by name (see :data:`BUILTIN_SCENES`) at the given image size.

    Examples
    --------
    >>> scene = builtin_scene("tabletop", width=64, height=48)
    >>> scene.name, scene.stereo.convergence
    ('tabletop', 1.2)
    """
    makers = {"glasses": _glasses, "stadium": _stadium, "tabletop": _tabletop}
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, one of {', '.join(BUILTIN_SCENES)}; got {type(name).__name__}")
    if name not in makers:
        raise ValueError(f"unknown built-in scene {name!r}; valid scenes: {', '.join(BUILTIN_SCENES)}")
    return makers[name](width, height)


def open_scene(spec: str | Path, *, width: int | None = None, height: int | None = None) -> Scene:
    """A scene file (``.json``) or a built-in scene name, optionally at another image size.

    A bare built-in name (the text ``"glasses"``) is always the built-in scene, whatever the current
    folder holds: a folder that ``vergence render glasses --out glasses/`` wrote cannot shadow it. A
    file of that name is reached as a path (``"./glasses"`` or a :class:`~pathlib.Path`). A missing
    size follows the other at the scene camera's aspect ratio (:meth:`SceneCamera.resized`).
    """
    path = Path(spec)
    if isinstance(spec, str) and spec in BUILTIN_SCENES:
        scene = builtin_scene(spec)
    elif path.is_file():
        scene = load_scene(path)
    elif path.is_dir():
        raise IsADirectoryError(f"scene {spec} is a folder; give a scene file (.json), or a built-in scene by its "
                                f"bare name: {', '.join(BUILTIN_SCENES)}")  # fmt: skip
    elif path.suffix or len(path.parts) > 1 or not isinstance(spec, str):
        raise FileNotFoundError(f"scene file not found: {path}")
    else:
        raise ValueError(f"scene must be a scene file or one of {', '.join(BUILTIN_SCENES)}; got {str(spec)!r}")
    return replace(scene, camera=scene.camera.resized(width=width, height=height))
