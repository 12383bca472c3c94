"""What the workbench may read: the collections, scenes and shot files of the ``--data`` folders, by id.

A client never sends a path: it chooses an id that :meth:`DataIndex.entries` listed, and the server
maps it back to the resolved path it found. A file or folder whose resolved path leaves its data
folder (a symbolic link out, whatever its name) is neither listed nor reachable; symbolic links to
folders are not followed at all. Nor is an entry whose companion files lead outside: a scene whose
textures, meshes or ``.hdr`` map do (:func:`vergence.render.scenefile.scene_files`), a collection
whose ``images.txt``, ``points3D.txt`` or ``list.txt`` (read beside the camera file or one folder
up) does. A collection's images are checked when a job reads them (``load_collection(within=)``).

What cannot be read (a symbolic-link loop, a link to nothing, a folder without permission) or
leads outside is skipped and counted (:attr:`DataIndex.skipped`, ``"skipped"`` of ``GET /api/data``),
never named: the rest keeps working.
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["BUILTIN_COLLECTIONS", "DATA_LABEL", "MAX_DATA_DEPTH", "MAX_DATA_FILES", "DataEntry", "DataIndex", "check_data_dirs"]

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

# Files a camera reader reads beside the camera file or one folder up (COLMAP's images.txt and
# points3D.txt, Bundler's list.txt): each that exists there must lie inside the data folder.
_COMPANIONS = ("images.txt", "points3D.txt", "list.txt")

#: What a server path of a data folder becomes in a message (:meth:`DataIndex.redact`).
DATA_LABEL = "<data>"


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
    root : Path or None
        The resolved data folder it lies in (None for a built-in): a job reads nothing outside it.
    """

    id: str
    kind: str
    name: str
    format: str
    path: Path | None
    root: Path | None = None

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


def _scene_data(path: Path) -> dict | None:
    """The parsed JSON of a scene file (an object with the four sections of docs/scenes.md), else None."""
    from vergence.io import read_json

    try:
        data = read_json(path, what="scene file")
    except (OSError, ValueError, TypeError):
        return None
    return data if isinstance(data, dict) and {"camera", "environment", "materials", "objects"} <= set(data) else None


def _inside(path: Path, root: Path) -> bool:
    """Whether ``path``, as written and with its links resolved, lies in ``root`` (a loop: no)."""
    try:
        return Path(os.path.abspath(path)).is_relative_to(root) and Path(os.path.realpath(path)).is_relative_to(root)
    except (OSError, RuntimeError, ValueError):
        return False


def _confined(kind: str, path: Path, root: Path, scene: dict | None = None) -> bool:
    """Whether what an entry's readers read besides its file stays in ``root`` (module notes)."""
    if kind == "scene":
        from vergence.render.scenefile import scene_files

        return all(_inside(p, root) for p in scene_files(scene, base_dir=path.parent))
    if kind == "collection":
        near = [folder / name for folder in (path.parent, path.parent.parent) for name in _COMPANIONS]
        return all(_inside(p, root) for p in near if os.path.lexists(p))
    return True


def _is_shot_file(path: Path) -> bool:
    """A JSON object naming a rig of :data:`vergence.rigs.SHOT_RIGS` and a camera (docs/shots.md)."""
    from vergence.io import read_json
    from vergence.rigs import SHOT_RIGS

    try:
        data = read_json(path, what="shot file")
    except (OSError, ValueError, TypeError):
        return False
    return isinstance(data, dict) and data.get("rig") in SHOT_RIGS and "camera" in data


def _stamp(path: Path) -> tuple[int, int] | None:
    """A file's modification time (ns) and size; None once it is gone."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


def _id(kind: str, path: Path) -> str:
    return f"{kind}-{hashlib.sha256(os.fsencode(path)).hexdigest()[:16]}"


class DataIndex:
    """The collections and scenes of the data folders, and the built-in scenes, by id.

    Parameters
    ----------
    data_dirs : sequence of str or os.PathLike
        The folders the server may read (:func:`check_data_dirs` checks them).

    Attributes
    ----------
    roots : tuple of Path
        The data folders, resolved.
    skipped : int
        Files and folders the last walk left out because they could not be read (a link loop, a
        link to nothing, no permission) or lead outside their data folder (a link out, a linked
        folder, a scene's texture or a collection's list out); also counted when
        :data:`MAX_DATA_FILES` stopped the walk early.

    Notes
    -----
    The folders are walked once, when the index is made, then only on demand: :meth:`refresh`
    (``GET /api/data`` calls it, so the page's list is up to date when it loads), and :meth:`get` of
    an id it does not know, or whose file is gone or changed (its modification time or size).
    Looking an id up (every job and file request) parses nothing: one ``stat`` of its file.
    """

    def __init__(self, data_dirs: Sequence[str | os.PathLike[str]] = ()) -> None:
        self.roots = check_data_dirs(data_dirs)
        self._lock = threading.Lock()
        self._entries: list[DataEntry] = []
        self._by_id: dict[str, DataEntry] = {}
        self._stamps: dict[str, tuple[int, int] | None] = {}
        self.skipped = 0
        self.refresh()

    def entries(self) -> list[DataEntry]:
        """Every entry of the last walk: the built-in scenes and collections first, then what the
        data folders hold, sorted by kind and name."""
        with self._lock:
            return list(self._entries)

    def refresh(self) -> list[DataEntry]:
        """Walk the data folders again (at most :data:`MAX_DATA_FILES` files each); returns :meth:`entries`."""
        from vergence.render.builtin import BUILTIN_SCENES

        found = [DataEntry(f"scene:{n}", "scene", n, "builtin", None) for n in BUILTIN_SCENES]
        found += [DataEntry(f"collection:{n}", "collection", f"{n} (rendered: {COLLECTION_VIEWS} views on an arc)",
                            "builtin", None) for n in BUILTIN_COLLECTIONS]
        skipped = 0
        for root in self.roots:
            entries, left_out = self._search(root)
            found += sorted(entries, key=lambda e: (e.kind, e.name))
            skipped += left_out
        stamps = {e.id: _stamp(e.path) for e in found if e.path is not None}
        with self._lock:
            self._entries, self._by_id, self._stamps, self.skipped = found, {e.id: e for e in found}, stamps, skipped
        return list(found)

    def get(self, entry_id: str) -> DataEntry:
        """The entry of an id listed by :meth:`entries` (the folders walked again if it is unknown or gone).

        Raises
        ------
        KeyError
            If no entry has this id (the message says where the ids come from).
        """
        with self._lock:
            entry = self._by_id.get(entry_id)
            stamp = self._stamps.get(entry_id)
        if entry is None or (entry.path is not None and _stamp(entry.path) != stamp):
            self.refresh()
            with self._lock:
                entry = self._by_id.get(entry_id)
        if entry is None:
            raise KeyError(f"unknown data id {entry_id!r}; GET /api/data lists the ids")
        return entry

    def redact(self, text: str) -> str:
        """``text`` with each data folder's server path replaced by :data:`DATA_LABEL` (for a message).

        A data folder that is the file system's root (``--data /``) is left as it is: every path is
        then a data entry's name.
        """
        for root in sorted(self.roots, key=lambda r: len(str(r)), reverse=True):
            if root != Path(root.anchor):
                text = text.replace(str(root), DATA_LABEL)
        return text

    def _search(self, root: Path) -> tuple[list[DataEntry], int]:
        found: list[DataEntry] = []
        skipped = seen = 0

        def unreadable(exc: OSError) -> None:
            nonlocal skipped
            skipped += 1

        for folder, dirs, files in os.walk(root, onerror=unreadable, followlinks=False):
            here = Path(folder)
            depth = len(here.relative_to(root).parts)
            linked = [d for d in dirs if os.path.islink(here / d)]
            skipped += sum(not d.startswith(".") for d in linked)  # a linked folder is never followed
            dirs[:] = sorted(d for d in dirs if not d.startswith(".") and d not in linked) if depth < MAX_DATA_DEPTH else []
            for name in sorted(files):
                seen += 1
                if seen > MAX_DATA_FILES:
                    return found, skipped + 1
                if name.startswith("."):
                    continue
                try:
                    entry = self._entry(root, here / name)
                except (OSError, RuntimeError, ValueError):
                    entry = None  # unreadable: skipped below
                if isinstance(entry, DataEntry):
                    found.append(entry)
                elif entry is None:
                    skipped += 1
        return found, skipped

    def _entry(self, root: Path, path: Path) -> DataEntry | bool | None:
        """The entry of a file; False for a file that is no data; None for one skipped (unreadable or outside)."""
        try:
            resolved = Path(os.path.realpath(path, strict=True))
        except (OSError, RuntimeError, ValueError):
            return None  # a link loop, a link to nothing
        if not resolved.is_relative_to(root):
            return None  # a link out of the data folder
        if not resolved.is_file():
            return False  # a fifo, a socket, a device: no data
        # for people, in JSON: a name that is no UTF-8 (undecodable bytes) shows U+FFFD where they are
        name = os.fsencode(path.relative_to(root).as_posix()).decode("utf-8", "replace")
        fmt = _camera_format(resolved)
        if fmt is not None:
            kind, scene = "collection", None
        elif resolved.suffix.lower() != ".json":
            return False
        elif (scene := _scene_data(resolved)) is not None:
            kind, fmt = "scene", "json"
        elif _is_shot_file(resolved):
            kind, fmt = "shot", "json"
        else:
            return False
        if not _confined(kind, resolved, root, scene):
            return None
        return DataEntry(_id(kind, resolved), kind, name, fmt, resolved, root)
