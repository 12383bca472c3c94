"""The web sweep's data folder (``vergence serve --data``): a few valid entries among hostile ones (issue 29).

:func:`write_data_folder` builds ``<scratch>/data`` and, beside it, ``<scratch>/outside``, a folder the
server must never read from. Valid: a Middlebury camera file of two views (the rectify twin's cameras)
and a shot file (the rig planner's). Hostile: a symbolic-link loop, a link looping to itself, a link to a
camera file outside, a link to a scene file outside, a link to the outside folder, a FIFO named like a
camera file (an ``open`` of it blocks), a camera file without read permission (readable all the same
when the sweep runs as root), a truncated camera file, a camera file whose name is not UTF-8, and a
Middlebury collection whose images but one are links to images outside.

Everything outside carries :data:`OUTSIDE_MARKER` where it can (text files), so an answer that shows
it served data from outside.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["FORBIDDEN_NAMES", "OUTSIDE_MARKER", "DataFolder", "listed_forbidden", "write_data_folder"]

#: Text planted in every outside text file: an answer that contains it served data from outside.
OUTSIDE_MARKER = "vergence-sweep-outside-4b1d"

#: Entries of the data folder that ``GET /api/data`` must never list: loops, links out, a linked folder
#: (any name under it), a FIFO. A name listed means a link out was followed or a loop was not skipped.
FORBIDDEN_NAMES = ("loop-a", "loop-b", "self_par.txt", "out_par.txt", "out-scene.json", "out-folder/",
                   "pipe_par.txt")

# The collection whose images lead outside: v0.png lies in the data folder, v1-v3 are links out.
_VIEWS = ("v0.png", "v1.png", "v2.png", "v3.png")
_SIZE = (32, 24)  # width, height of its views (px)


@dataclass(frozen=True)
class DataFolder:
    """What :func:`write_data_folder` made: the data folder, the outside folder and entry names by role."""

    root: Path
    outside: Path
    cameras: str  # the valid two-view camera file (rectify's)
    shot: str  # the valid shot file
    collection_out: str  # the collection whose images link outside
    truncated: str  # the truncated camera file
    outside_files: tuple[Path, ...]  # the outside files a link points at (resolved)


def _cameras(count: int, width: int, height: int) -> tuple:
    from vergence.camera import look_at

    return tuple(look_at((0.1 * i, 0.0, 0.0), (0.15, 0.0, 3.0), (0.0, -1.0, 0.0), fov_deg=50.0, width=width,
                         height=height) for i in range(count))  # fmt: skip


def write_data_folder(scratch: Path, *, cameras_par: Path) -> DataFolder:
    """Write ``scratch/data`` and ``scratch/outside`` (module notes); ``cameras_par`` is copied as the
    valid camera file (the sweep's fixture, whose image names the rectify twin's uploads carry)."""
    from vergence.io import CameraSet, write_image, write_middlebury_par
    from vergence.rigs import EXAMPLE_SHOTS

    root, outside = scratch / "data", scratch / "outside"
    root.mkdir(parents=True)
    outside.mkdir(parents=True)
    rng = np.random.default_rng(29)
    width, height = _SIZE

    # outside: a camera file, a scene file and a text file carrying the marker, and three views
    (outside / "secret.txt").write_text(f"{OUTSIDE_MARKER}\n")
    write_middlebury_par(outside / "secret_par.txt", CameraSet(names=(f"{OUTSIDE_MARKER}.png", "b.png"),
                                                               cameras=_cameras(2, width, height)))
    (outside / "scene.json").write_text(json.dumps({"camera": {}, "environment": {}, "materials": {}, "objects": [],
                                                    "name": OUTSIDE_MARKER}))
    (outside / "col").mkdir()
    for name in _VIEWS[1:]:
        write_image(outside / "col" / name, rng.random((height, width, 3)).astype(np.float32))

    # valid entries
    (root / "rect").mkdir()
    (root / "rect" / "cameras_par.txt").write_bytes(cameras_par.read_bytes())
    (root / "shot.json").write_text(json.dumps(EXAMPLE_SHOTS["stadium-tri"]))

    # a Middlebury collection: one view inside, three links to views outside
    (root / "col").mkdir()
    write_middlebury_par(root / "col" / "views_par.txt", CameraSet(names=_VIEWS, cameras=_cameras(4, width, height)))
    write_image(root / "col" / _VIEWS[0], rng.random((height, width, 3)).astype(np.float32))
    for name in _VIEWS[1:]:
        os.symlink(outside / "col" / name, root / "col" / name)

    # loops, links out, a linked folder, a FIFO, an unreadable, a truncated and a non-UTF-8 camera file
    os.symlink("loop-b", root / "loop-a")
    os.symlink("loop-a", root / "loop-b")
    os.symlink("self_par.txt", root / "self_par.txt")
    os.symlink(outside / "secret_par.txt", root / "out_par.txt")
    os.symlink(outside / "scene.json", root / "out-scene.json")
    os.symlink(outside, root / "out-folder")
    os.mkfifo(root / "pipe_par.txt")
    good = (root / "rect" / "cameras_par.txt").read_text()
    (root / "unreadable_par.txt").write_text(good)
    (root / "unreadable_par.txt").chmod(0)
    (root / "truncated_par.txt").write_text(good[: len(good) // 2])
    (root / os.fsdecode(b"name-\xff_par.txt")).write_text(good)
    return DataFolder(root=root, outside=outside, cameras="rect/cameras_par.txt", shot="shot.json",
                      collection_out="col/views_par.txt", truncated="truncated_par.txt",
                      outside_files=tuple(sorted(p.resolve() for p in outside.rglob("*") if p.is_file())))


def listed_forbidden(names: list[str]) -> str | None:
    """The first name of ``names`` (as ``GET /api/data`` lists them) that :data:`FORBIDDEN_NAMES` forbids."""
    for name in names:
        for bad in FORBIDDEN_NAMES:
            if name == bad or (bad.endswith("/") and name.startswith(bad)):
                return name
    return None
