"""Triangle meshes from Wavefront OBJ and Stanford PLY files, read with numpy.

Only what the ray tracer needs: vertex positions, triangles (polygons are split into fans),
optional per-vertex normals and texture coordinates. OBJ: ``v``, ``vt``, ``vn``, ``f`` records
(1-based or negative indices; other records are ignored). PLY: ``ascii 1.0`` and
``binary_little_endian``/``binary_big_endian 1.0``, element ``vertex`` with ``x y z``
[``nx ny nz``] [``u v`` or ``s t``] and element ``face`` with a list property ``vertex_indices`` (or
``vertex_index``); other elements are skipped. Mitsuba's own loaders are not used: on LLVM 15 its
vertex-normal recomputation aborts the process.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MeshData", "read_mesh", "vertex_normals"]


@dataclass(frozen=True, slots=True, eq=False)
class MeshData:
    """Arrays of a triangle mesh: ``vertices (V, 3)``, ``faces (F, 3)``, optional ``normals (V, 3)``, ``uv (V, 2)``."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None
    uv: np.ndarray | None


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (sum of the adjacent face cross products, normalised).

    A vertex whose adjacent faces cancel, or that no face uses, gets +z.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    acc = np.zeros_like(v)
    for k in range(3):
        np.add.at(acc, f[:, k], cross)
    length = np.linalg.norm(acc, axis=1)
    bad = length <= 1e-300
    out = acc / np.where(bad, 1.0, length)[:, None]
    out[bad] = (0.0, 0.0, 1.0)
    return out


def _fail(path: Path, what: str) -> ValueError:
    return ValueError(f"cannot read mesh {path}: {what}")


def _read_obj(path: Path) -> MeshData:
    pos: list[list[float]] = []
    tex: list[list[float]] = []
    nrm: list[list[float]] = []
    corners: dict[tuple[int, int, int], int] = {}
    order: list[tuple[int, int, int]] = []
    faces: list[list[int]] = []
    text = path.read_text(encoding="utf-8", errors="replace")
    for lineno, raw in enumerate(text.splitlines(), start=1):
        parts = raw.split("#", 1)[0].split()
        if not parts:
            continue
        tag, args = parts[0], parts[1:]
        try:
            if tag in ("v", "vt", "vn"):
                n = 2 if tag == "vt" else 3
                if len(args) < n:
                    raise ValueError(f"line {lineno}: '{tag}' needs {n} coordinates")
                {"v": pos, "vt": tex, "vn": nrm}[tag].append([float(a) for a in args[:n]])
            elif tag == "f":
                if len(args) < 3:
                    raise ValueError(f"line {lineno}: a face needs 3 or more vertices")
                ids = []
                for a in args:
                    fields = (a.split("/") + ["", ""])[:3]
                    key = tuple(_obj_index(s, n, lineno) for s, n in zip(fields, (len(pos), len(tex), len(nrm))))
                    if key[0] < 0:
                        raise ValueError(f"line {lineno}: a face corner needs a vertex index")
                    if key not in corners:
                        corners[key] = len(order)
                        order.append(key)  # type: ignore[arg-type]
                    ids.append(corners[key])
                faces.extend([ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1))
        except ValueError as exc:
            msg = str(exc) if str(exc).startswith("line ") else f"line {lineno}: {exc}"
            raise _fail(path, msg) from None
    if not faces:
        raise _fail(path, "no faces")
    keys = np.array(order, dtype=np.int64)
    vertices = np.asarray(pos, dtype=np.float64)[keys[:, 0]]
    uv = None
    if (keys[:, 1] >= 0).all() and tex:
        uv = np.asarray(tex, dtype=np.float64)[keys[:, 1]]
    normals = None
    if (keys[:, 2] >= 0).all() and nrm:
        normals = np.asarray(nrm, dtype=np.float64)[keys[:, 2]]
    return MeshData(vertices, np.asarray(faces, dtype=np.int64), normals, uv)


def _obj_index(s: str, count: int, lineno: int) -> int:
    """0-based index from an OBJ index string (1-based, or negative = relative); -1 when empty."""
    if s == "":
        return -1
    i = int(s)
    j = i - 1 if i > 0 else count + i
    if i == 0 or not 0 <= j < count:
        raise ValueError(f"line {lineno}: index {i} out of range (1..{count})")
    return j


_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip


def _read_ply(path: Path) -> MeshData:
    data = path.read_bytes()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _fail(path, "not a PLY file (no 'ply' magic or no end_header)")
    header = data[:end].decode("ascii", errors="replace").splitlines()
    body_start = data.index(b"\n", end) + 1
    fmt = None
    elements: list[tuple[str, int, list[tuple[str, str, str | None]]]] = []
    for line in header[1:]:
        p = line.split()
        if not p or p[0] in ("comment", "obj_info"):
            continue
        if p[0] == "format" and len(p) >= 2:
            fmt = p[1]
        elif p[0] == "element" and len(p) == 3:
            elements.append((p[1], int(p[2]), []))
        elif p[0] == "property" and elements:
            if p[1] == "list" and len(p) == 5:
                elements[-1][2].append((p[4], _ply_type(path, p[3]), _ply_type(path, p[2])))
            elif len(p) == 3:
                elements[-1][2].append((p[2], _ply_type(path, p[1]), None))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise _fail(path, f"unsupported PLY format {fmt!r}")
    tables = _ply_ascii(path, data[body_start:], elements) if fmt == "ascii" else _ply_binary(
        path, data[body_start:], elements, "<" if fmt == "binary_little_endian" else ">"
    )
    vert, face = tables.get("vertex"), tables.get("face")
    if vert is None or face is None or not all(k in vert for k in "xyz"):
        raise _fail(path, "needs a 'vertex' element with x, y, z and a 'face' element")
    lists = face.get("vertex_indices", face.get("vertex_index"))
    if lists is None:
        raise _fail(path, "the face element has no vertex_indices list")
    vertices = np.stack([vert[k] for k in "xyz"], axis=1).astype(np.float64)
    tris = [[f[0], f[k], f[k + 1]] for f in lists for k in range(1, len(f) - 1)]
    faces = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0 or faces.min() < 0 or faces.max() >= len(vertices):
        raise _fail(path, "face indices out of range or no faces")
    normals = np.stack([vert[k] for k in ("nx", "ny", "nz")], 1) if all(k in vert for k in ("nx", "ny", "nz")) else None
    uv = None
    for a, b in (("u", "v"), ("s", "t"), ("texture_u", "texture_v")):
        if a in vert and b in vert:
            uv = np.stack([vert[a], vert[b]], axis=1).astype(np.float64)
            break
    return MeshData(vertices, faces, None if normals is None else normals.astype(np.float64), uv)


def _ply_type(path: Path, name: str) -> str:
    if name not in _PLY_TYPES:
        raise _fail(path, f"unknown PLY property type {name!r}")
    return _PLY_TYPES[name]


def _ply_ascii(path: Path, body: bytes, elements: list) -> dict[str, dict]:
    tokens = body.split()
    pos = 0
    tables: dict[str, dict] = {}
    try:
        for name, count, props in elements:
            cols: dict[str, list] = {p[0]: [] for p in props}
            for _ in range(count):
                for pname, ptype, ltype in props:
                    if ltype is None:
                        cols[pname].append(float(tokens[pos]))
                        pos += 1
                    else:
                        n = int(tokens[pos])
                        cols[pname].append([int(t) for t in tokens[pos + 1 : pos + 1 + n]])
                        pos += 1 + n
            tables[name] = {k: (np.asarray(v) if _scalar(props, k) else v) for k, v in cols.items()}
    except (IndexError, ValueError):
        raise _fail(path, "truncated or malformed ASCII body") from None
    return tables


def _scalar(props: list, name: str) -> bool:
    return next(p for p in props if p[0] == name)[2] is None


def _ply_binary(path: Path, body: bytes, elements: list, order: str) -> dict[str, dict]:
    offset = 0
    tables: dict[str, dict] = {}
    try:
        for name, count, props in elements:
            if all(p[2] is None for p in props):
                dt = np.dtype([(p[0], order + p[1]) for p in props])
                arr = np.frombuffer(body, dtype=dt, count=count, offset=offset)
                offset += dt.itemsize * count
                tables[name] = {p[0]: arr[p[0]].astype(np.float64) for p in props}
                continue
            cols: dict[str, list] = {p[0]: [] for p in props}
            for _ in range(count):
                for pname, ptype, ltype in props:
                    if ltype is None:
                        v = np.frombuffer(body, order + ptype, 1, offset)[0]
                        offset += np.dtype(ptype).itemsize
                        cols[pname].append(float(v))
                    else:
                        n = int(np.frombuffer(body, order + ltype, 1, offset)[0])
                        offset += np.dtype(ltype).itemsize
                        cols[pname].append(np.frombuffer(body, order + ptype, n, offset).tolist())
                        offset += np.dtype(ptype).itemsize * n
            tables[name] = {k: (np.asarray(v) if _scalar(props, k) else v) for k, v in cols.items()}
    except ValueError:
        raise _fail(path, "truncated binary body") from None
    return tables


def read_mesh(path: str | Path) -> MeshData:
    """Read a triangle mesh from an ``.obj`` or ``.ply`` file.

    Raises
    ------
    ValueError
        Unknown extension, malformed content, no faces, indices out of range, non-finite vertices.
    FileNotFoundError
        If the file does not exist.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".obj", ".ply"):
        raise ValueError(f"mesh path must end in .obj or .ply; got {p.name!r}")
    if not p.is_file():
        raise FileNotFoundError(f"mesh file not found: {p}")
    mesh = _read_obj(p) if suffix == ".obj" else _read_ply(p)
    if not np.isfinite(mesh.vertices).all():
        raise _fail(p, "vertex coordinates must be finite")
    return mesh
