"""A built StereoSpace on disk: ``space.json`` and ``points.npz`` in a folder (the space folder).

``space.json`` (format ``"vergence-stereospace"``, :data:`SPACE_FORMAT_VERSION`) records where the
collection came from (the camera file and the images folder, absolute paths), the camera names,
the camera graph's edges, the capture paths, the segments (camera centres) and their cameras, the
display and comfort zone of the quality, the leave-one-out PSNR per camera, the quality record of
every camera pair at a region vertex (:class:`~vergence.stereospace.VertexQuality`), the point
count and median reprojection error, and the build time. ``points.npz`` holds the sparse points
and their observations, so that loading does not triangulate again. The navigation map
(``map.png``) is drawn by :func:`vergence.report.navigation_map` beside them.

:func:`load_space` reads the camera file again at the recorded path and checks it against the
record (the same names, the same camera centres), so a moved or edited collection is refused
with one line rather than giving pairs of the wrong cameras.
"""

from __future__ import annotations

import datetime
import os
import zipfile
from pathlib import Path

import numpy as np

from vergence.io import atomic_folder, read_cameras, read_json, write_json
from vergence.stereospace.build import BuiltSpace, VertexQuality, vertex_pairs
from vergence.stereospace.collection import Collection
from vergence.stereospace.graph import camera_graph
from vergence.stereospace.pair import space_from_graph
from vergence.viewing import DISPLAY_PRESETS, ComfortZone

__all__ = ["SPACE_FILE", "SPACE_FORMAT_VERSION", "load_space", "save_space", "write_space"]

SPACE_FILE = "space.json"
POINTS_FILE = "points.npz"
SPACE_FORMAT_VERSION = 1
_FORMAT = "vergence-stereospace"
# Camera centres read again must match the recorded ones to this fraction of the collection's size:
# the JSON keeps 17 significant digits, so only an edited camera file differs.
_CENTRE_TOLERANCE = 1e-9


def write_space(built: BuiltSpace, folder: str | os.PathLike[str]) -> None:
    """Write ``space.json`` and ``points.npz`` of ``built`` into an existing ``folder`` (not atomic:
    :func:`save_space` wraps it; a command adding its own files calls it inside its atomic folder)."""
    if not isinstance(built, BuiltSpace):
        raise TypeError(f"built must be a BuiltSpace; got {type(built).__name__}")
    folder = Path(folder)
    col, display = built.collection, built.display
    first = col.cameras[0]
    record = {
        "format": _FORMAT,
        "version": SPACE_FORMAT_VERSION,
        "cameras_path": str(built.cameras_path),
        "images": str(built.images),
        "image_size": [first.width, first.height],
        "names": list(col.names),
        "point_count": col.point_count,
        "points_source": col.points_source,
        "median_reprojection_error_px": col.median_reprojection_error_px,
        "left_out": col.left_out,
        "unregistered": col.unregistered,
        "warnings": list(col.warnings),
        "edges": built.graph.edges.tolist(),
        "capture_paths": [list(p) for p in built.paths],
        "segments": built.space.segments.tolist(),
        "segment_cameras": built.segment_cameras.tolist(),
        "regions": len(built.space.regions),
        "display": {"preset": built.display_name, "eye_separation": display.eye_separation,
                    "distance": display.distance, "width": display.width, "resolution": display.resolution},
        "comfort_zone": {"crossed_arcmin": built.zone.crossed_arcmin, "uncrossed_arcmin": built.zone.uncrossed_arcmin},
        "loo_psnr_db": {n: (float(p) if np.isfinite(p) else None) for n, p in zip(col.names, built.psnr_db)},
        "vertex_quality": [q.to_dict() for _, q in sorted(built.vertex_qualities.items())],
        "map_frame": built.frame.tolist(),
        "build_seconds": built.build_seconds,
        "built_at": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }
    if not np.isfinite(record["median_reprojection_error_px"]):
        record["median_reprojection_error_px"] = None
    write_json(folder / SPACE_FILE, record)
    with open(folder / POINTS_FILE, "wb") as fh:
        np.savez(fh, points=col.points, observations=col.observations,
                 observation_pixels=col.observation_pixels, distortion=col.distortion)  # fmt: skip


def save_space(built: BuiltSpace, folder: str | os.PathLike[str]) -> Path:
    """Write the space folder atomically (:func:`vergence.io.atomic_folder`); return its path."""
    with atomic_folder(folder) as tmp:
        write_space(built, tmp)
    return Path(folder)


def _field(record: dict, key: str, kind: type | tuple[type, ...], where: Path):
    if key not in record or not isinstance(record[key], kind):
        raise ValueError(f"{where} is damaged: field {key!r} is missing or of the wrong type")
    return record[key]


def load_space(folder: str | os.PathLike[str]) -> BuiltSpace:
    """Read a space folder written by :func:`save_space`, with its collection from the recorded paths.

    Raises
    ------
    ValueError
        The folder or its ``space.json`` is missing, the JSON is corrupt or of another format or
        version, the camera file or an image is no longer at its recorded path, or the camera file
        now gives other names or other camera centres than at the build (one line, naming the file).
    """
    root = Path(os.fspath(folder))
    if not root.is_dir():
        raise ValueError(f"space folder {root} does not exist (build it with vergence stereospace build)")
    path = root / SPACE_FILE
    if not path.is_file():
        raise ValueError(f"{root} is not a built space: it has no {SPACE_FILE}")
    record = read_json(path, what="space file")
    if not isinstance(record, dict) or record.get("format") != _FORMAT:
        raise ValueError(f"{path} is not a vergence space file (format {_FORMAT!r})")
    if record.get("version") != SPACE_FORMAT_VERSION:
        raise ValueError(f"{path} has format version {record.get('version')!r}; this vergence reads version "
                         f"{SPACE_FORMAT_VERSION}: build the space again")  # fmt: skip
    cam_path = Path(_field(record, "cameras_path", str, path))
    img_dir = Path(_field(record, "images", str, path))
    names = _field(record, "names", list, path)
    if not cam_path.exists():
        raise ValueError(f"the camera file {cam_path} of the space {root} is missing (moved?): build the space again")
    if not img_dir.is_dir():
        raise ValueError(f"the images folder {img_dir} of the space {root} is missing (moved?): build the space again")
    points_path = root / POINTS_FILE
    if not points_path.is_file():
        raise ValueError(f"{root} is damaged: it has no {POINTS_FILE}")
    try:
        with open(points_path, "rb") as fh:  # ours to close: np.load leaks its handle on a broken zip
            if fh.read(4) != b"PK\x03\x04":  # np.load would take other bytes for a pickle
                raise ValueError("not an .npz archive")
            fh.seek(0)
            data = np.load(fh, allow_pickle=False)
            if not isinstance(data, np.lib.npyio.NpzFile):
                raise ValueError("not an .npz archive")
            with data:
                arrays = {k: data[k] for k in ("points", "observations", "observation_pixels", "distortion")}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:  # a cut or overwritten file
        raise ValueError(f"{points_path} is damaged ({type(exc).__name__}: {' '.join(str(exc).split())}): build the "
                         "space again") from None
    size = _field(record, "image_size", list, path)
    cset = read_cameras(cam_path, image_size=(int(size[0]), int(size[1])))
    index = {n: k for k, n in enumerate(cset.names)}
    missing = [n for n in names if n not in index or cset.cameras[index[n]] is None]
    if missing:
        raise ValueError(f"the camera file {cam_path} no longer has the camera {missing[0]} of the space "
                         f"{root}: build the space again")  # fmt: skip
    for n in names:
        if not (img_dir / n).is_file():
            raise ValueError(f"the image {img_dir / n} of the space {root} is missing: build the space again")
    cams = tuple(cset.cameras[index[n]] for n in names)
    try:
        col = Collection(names=tuple(names), cameras=cams, image_paths=tuple(img_dir / n for n in names),
                         points_source=_field(record, "points_source", str, path),
                         left_out=int(record.get("left_out", 0)), unregistered=int(record.get("unregistered", 0)),
                         warnings=tuple(record.get("warnings", ())), **arrays)  # fmt: skip
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{root} is damaged: {exc}") from None
    segments = np.asarray(_field(record, "segments", list, path), dtype=np.float64)
    graph = camera_graph(col)
    space, pairs = space_from_graph(col, graph)
    scale = max(1.0, float(np.abs(col.centers).max()))
    recorded_pairs = np.asarray(_field(record, "segment_cameras", list, path), dtype=np.int64)
    if (segments.shape != space.segments.shape or recorded_pairs.shape != pairs.shape
            or not np.array_equal(recorded_pairs, pairs)
            or np.abs(segments - space.segments).max() > _CENTRE_TOLERANCE * scale):  # fmt: skip
        raise ValueError(f"the cameras of {cam_path} differ from those the space {root} was built with "
                         f"(the file was edited?): build the space again")  # fmt: skip
    try:
        records = _field(record, "vertex_quality", list, path)
        qualities = {q.cameras: q for q in (VertexQuality.from_dict(r) for r in records)}
        display = _field(record, "display", dict, path)
        zone = ComfortZone(**_field(record, "comfort_zone", dict, path))
        loo = _field(record, "loo_psnr_db", dict, path)
        psnr = np.array([np.nan if loo.get(n) is None else float(loo[n]) for n in names])
        build_seconds = float(_field(record, "build_seconds", (int, float), path))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path} is damaged: {exc}") from None
    if display.get("preset") not in DISPLAY_PRESETS:
        raise ValueError(f"{path} is damaged: unknown display preset {display.get('preset')!r}")
    if set(qualities) != set(vertex_pairs(pairs)):
        raise ValueError(f"{path} is damaged: the vertex quality records do not match the regions")
    psnr.flags.writeable = False
    return BuiltSpace(collection=col, graph=graph, space=space, segment_cameras=pairs,
                      paths=tuple(tuple(int(v) for v in p) for p in _field(record, "capture_paths", list, path)),
                      display_name=display["preset"], zone=zone, psnr_db=psnr, vertex_qualities=qualities,
                      cameras_path=cam_path, images=img_dir, build_seconds=build_seconds)  # fmt: skip
