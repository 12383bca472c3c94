"""What the workbench may read: the collections, scenes and shot files of the ``--data`` folders, by id.

A client never sends a path: it chooses an id that :meth:`DataIndex.entries` listed, and the server
maps it back to the resolved path it found. A file or folder whose resolved path leaves its data
folder (a symbolic link out, whatever its name) is neither listed nor reachable; symbolic links to
folders are not followed at all.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["BUILTIN_COLLECTIONS", "MAX_DATA_DEPTH", "MAX_DATA_FILES", "DataEntry", "DataIndex", "check_data_dirs"]

# Folder levels below a data folder that are searched (a collection's cameras sit at most in
# dataset/sparse/0/); and files looked at in all, so that a huge folder cannot stall a request.
MAX_DATA_DEPTH = 4
MAX_DATA_FILES = 20_000

# The built-in collections: ray-traced from these built-in scenes when a job opens them
# (vergence.stereospace.render_collection), so that a fresh clone has a collection to browse. Not
# glasses: its mirror and glass would be warped as if they were diffuse surfaces (S2's views are).
BUILTIN_COLLECTIONS = ("tabletop", "stadium")

# Views of a built-in collection (vergence.stereospace.COLLECTION_VIEWS, without importing the library here).
COLLECTION_VIEWS = 12

# Bytes read to tell a camera file from a scene file.
_SNIFF_BYTES = 4096


@dataclass(frozen=True, slots=True)
class DataEntry:
    """One thing the workbench can open.

    Attributes
    ----------
    id : str
        Opaque: ``scene:<name>`` for a built-in scene, else the kind and a hash of the resolved path.
    kind : str
        ``"collection"`` (a camera file and its images), ``"scene"`` (a scene file or built-in) or
        ``"shot"`` (a shot file, ``docs/shots.md``: the rig planner's presets).
    name : str
        For people: the path relative to its data folder, or the built-in scene's name.
    format : str
        The camera format of a collection (a name of :data:`vergence.io.CAMERA_FORMATS`),
        ``"json"`` for a scene or shot file, ``"builtin"`` for a built-in scene.
    path : Path or None
        The resolved path (server side only; None for a built-in scene).
    """

    id: str
    kind: str
    name: str
    format: str
    path: Path | None

    def to_dict(self) -> dict[str, str]:
        """The entry as the API shows it: no path."""
        return {"id": self.id, "kind": self.kind, "name": self.name, "format": self.format}


def check_data_dirs(data_dirs: Sequence[str | os.PathLike[str]]) -> tuple[Path, ...]:
    """The data folders, resolved; each must be an existing folder.

    Raises
    ------
    ValueError
        Naming the first one that does not exist or is not a folder.
    """
    roots = []
    for d in data_dirs:
        p = Path(os.fspath(d))
        if not p.exists():
            raise ValueError(f"data folder {p} does not exist")
        if not p.is_dir():
            raise ValueError(f"data folder {p} is not a folder")
        roots.append(p.resolve())
    return tuple(roots)


def _head(path: Path) -> str:
    try:
        with open(path, "rb") as fh:
            return fh.read(_SNIFF_BYTES).decode("utf-8-sig", errors="replace")
    except OSError:
        return ""


def _camera_format(path: Path) -> str | None:
    """The camera format of a file by its name and first bytes (COLMAP by its pair of text files)."""
    from vergence.io import CAMERA_FORMATS

    if path.name.lower() == "cameras.txt":
        return "colmap" if (path.parent / "images.txt").is_file() else None
    for name, fmt in CAMERA_FORMATS.items():
        if name == "colmap" or not fmt.claims(path):
            continue
        if fmt.sniff is None or fmt.sniff(_head(path)):
            return name
    return None


def _is_scene_file(path: Path) -> bool:
    """A JSON object with the four sections of a scene file (docs/scenes.md)."""
    from vergence.io import read_json

    try:
        data = read_json(path, what="scene file")
    except (OSError, ValueError, TypeError):
        return False
    return isinstance(data, dict) and {"camera", "environment", "materials", "objects"} <= set(data)


def _is_shot_file(path: Path) -> bool:
    """A JSON object naming a rig of :data:`vergence.rigs.SHOT_RIGS` and a camera (docs/shots.md)."""
    from vergence.io import read_json
    from vergence.rigs import SHOT_RIGS

    try:
        data = read_json(path, what="shot file")
    except (OSError, ValueError, TypeError):
        return False
    return isinstance(data, dict) and data.get("rig") in SHOT_RIGS and "camera" in data


def _id(kind: str, path: Path) -> str:
    return f"{kind}-{hashlib.sha256(os.fsencode(path)).hexdigest()[:16]}"


class DataIndex:
    """The collections and scenes of the data folders, and the built-in scenes, by id.

    Parameters
    ----------
    data_dirs : sequence of str or os.PathLike
        The folders the server may read (:func:`check_data_dirs` checks them).

    Notes
    -----
    The folders are searched again on each call, so that new files appear without a restart.
    """

    def __init__(self, data_dirs: Sequence[str | os.PathLike[str]] = ()) -> None:
        self.roots = check_data_dirs(data_dirs)

    def entries(self) -> list[DataEntry]:
        """Every entry: the built-in scenes and collections first, then what the data folders hold,
        sorted by name."""
        from vergence.render.builtin import BUILTIN_SCENES

        found = [DataEntry(f"scene:{n}", "scene", n, "builtin", None) for n in BUILTIN_SCENES]
        found += [DataEntry(f"collection:{n}", "collection", f"{n} (rendered: {COLLECTION_VIEWS} views on an arc)",
                            "builtin", None) for n in BUILTIN_COLLECTIONS]
        for root in self.roots:
            found += sorted(self._search(root), key=lambda e: (e.kind, e.name))
        return found

    def get(self, entry_id: str) -> DataEntry:
        """The entry of an id listed by :meth:`entries`.

        Raises
        ------
        KeyError
            If no entry has this id (the message says where the ids come from).
        """
        for entry in self.entries():
            if entry.id == entry_id:
                return entry
        raise KeyError(f"unknown data id {entry_id!r}; GET /api/data lists the ids")

    def _search(self, root: Path) -> list[DataEntry]:
        found = []
        seen = 0
        for folder, dirs, files in os.walk(root, followlinks=False):
            here = Path(folder)
            depth = len(here.relative_to(root).parts)
            dirs[:] = sorted(d for d in dirs if not d.startswith(".")) if depth < MAX_DATA_DEPTH else []
            for name in sorted(files):
                seen += 1
                if seen > MAX_DATA_FILES:
                    return found
                if name.startswith("."):
                    continue
                entry = self._entry(root, here / name)
                if entry is not None:
                    found.append(entry)
        return found

    def _entry(self, root: Path, path: Path) -> DataEntry | None:
        resolved = path.resolve()
        if not resolved.is_relative_to(root) or not resolved.is_file():
            return None  # a link out of the data folder, or to nothing
        name = path.relative_to(root).as_posix()
        fmt = _camera_format(resolved)
        if fmt is not None:
            return DataEntry(_id("collection", resolved), "collection", name, fmt, resolved)
        if resolved.suffix.lower() == ".json" and _is_scene_file(resolved):
            return DataEntry(_id("scene", resolved), "scene", name, "json", resolved)
        if resolved.suffix.lower() == ".json" and _is_shot_file(resolved):
            return DataEntry(_id("shot", resolved), "shot", name, "json", resolved)
        return None
