"""The JSON scene format (``docs/scenes.md``): reading, validation with the place of each error.

Unknown keys, missing fields and bad values raise a ``ValueError``/``TypeError`` naming where they
sit, e.g. ``scene.json: objects[2] (sphere): radius must be > 0; got -1``. Relative paths (textures,
meshes, ``.hdr`` maps) resolve against the scene file's folder.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from vergence._validate import as_float_array
from vergence.render.meshio import read_mesh, vertex_normals
from vergence.render.scene import (
    MATERIALS,
    Environment,
    Material,
    Mesh,
    Rectangle,
    Scene,
    SceneCamera,
    Sphere,
    Stereo,
    Texture,
)

__all__ = ["load_scene", "scene_files", "scene_from_dict"]


def _fields(where: str, data: object, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> dict:
    if not isinstance(data, dict):
        raise TypeError(f"{where} must be a JSON object; got {type(data).__name__}")
    missing = [k for k in required if k not in data]
    if missing:
        raise ValueError(f"{where} is missing field(s) {', '.join(missing)}")
    unknown = sorted(set(data) - set(required) - set(optional))
    if unknown:
        valid = ", ".join(sorted(required + optional))
        raise ValueError(f"{where} has unknown field(s) {', '.join(unknown)}; valid fields: {valid}")
    return data


def _build(where: str, cls: type, **kwargs: Any) -> Any:
    try:
        return cls(**kwargs)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"{where}: {exc}") from None


def _resolve(base_dir: Path | None, where: str, value: object) -> Path:
    if not isinstance(value, str) or not value:
        raise TypeError(f"{where}.path must be a non-empty string; got {value!r}")
    p = Path(value)
    return p if p.is_absolute() or base_dir is None else base_dir / p


def _environment(data: object, base_dir: Path | None) -> Environment:
    if isinstance(data, dict) and "hdr" in data:
        d = _fields("environment", data, ("hdr",), ("intensity", "rotation_deg"))
        path = _resolve(base_dir, "environment", d["hdr"])
        if path.suffix.lower() != ".hdr":
            raise ValueError(f"environment.hdr must be a Radiance .hdr file; got {path.name!r}")
        from vergence.io import read_image

        try:
            image = read_image(path)
        except (ValueError, OSError) as exc:
            raise type(exc)(f"environment: {exc}") from None
        return _build("environment", Environment, image=image, intensity=d.get("intensity", 1.0),
                      rotation_deg=d.get("rotation_deg", 0.0), source=str(path))  # fmt: skip
    d = _fields("environment", data, ("color",), ("intensity",))
    return _build("environment", Environment, color=d["color"], intensity=d.get("intensity", 1.0))


def _material(name: str, data: object, base_dir: Path | None) -> Material:
    where = f"materials[{name!r}]"
    if not isinstance(data, dict):
        raise TypeError(f"{where} must be a JSON object; got {type(data).__name__}")
    kind = data.get("type")
    if kind not in MATERIALS:
        raise ValueError(f"{where}.type must be one of {', '.join(MATERIALS)}; got {kind!r}")
    spec = {"checker": (("colors",), ("squares",)), "diffuse": (("color",), ()), "glass": ((), ("ior", "color")),
            "mirror": ((), ("color",)), "texture": (("path",), ())}[kind]  # fmt: skip
    d = dict(_fields(where, data, ("type",) + spec[0], spec[1]))
    d.pop("type")
    if kind == "texture":
        from vergence.io import read_image

        path = _resolve(base_dir, where, d["path"])
        try:
            image = read_image(path)
        except (ValueError, OSError) as exc:
            raise type(exc)(f"{where}: {exc}") from None
        return _build(where, Texture, image=image, path=str(path))
    return _build(where, MATERIALS[kind], **d)


def _transform(where: str, data: object) -> np.ndarray:
    if isinstance(data, list):
        M = as_float_array(f"{where}.transform", data, shape=(4, 4))
        if not np.allclose(M[3], [0, 0, 0, 1]):
            raise ValueError(f"{where}.transform must have last row [0, 0, 0, 1]; got {M[3].tolist()}")
        return M
    d = _fields(f"{where}.transform", data, (), ("translate", "rotate_deg", "scale"))
    from scipy.spatial.transform import Rotation

    scale = as_float_array(f"{where}.transform.scale", d.get("scale", 1.0)) * np.ones(3)
    rot = Rotation.from_euler("xyz", as_float_array(f"{where}.transform.rotate_deg", d.get("rotate_deg", [0, 0, 0]),
                                                    shape=(3,)), degrees=True).as_matrix()  # fmt: skip
    M = np.eye(4)
    M[:3, :3] = rot @ np.diag(scale)
    M[:3, 3] = as_float_array(f"{where}.transform.translate", d.get("translate", [0, 0, 0]), shape=(3,))
    return M


def _mesh(where: str, d: dict, base_dir: Path | None) -> Mesh:
    path = _resolve(base_dir, where, d["path"])
    try:
        data = read_mesh(path)
    except (ValueError, FileNotFoundError) as exc:
        raise type(exc)(f"{where}: {exc}") from None
    M = _transform(where, d.get("transform", [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    A = M[:3, :3]
    det = float(np.linalg.det(A))
    if abs(det) < 1e-12:
        raise ValueError(f"{where}.transform must be invertible; got determinant {det:g}")
    vertices = data.vertices @ A.T + M[:3, 3]
    faces = data.faces[:, ::-1] if det < 0 else data.faces  # a mirroring transform keeps normals outward
    smooth = d.get("smooth", True)
    if not isinstance(smooth, bool):
        raise TypeError(f"{where}.smooth must be true or false; got {smooth!r}")
    normals = None
    if smooth:
        normals = vertex_normals(vertices, faces) if data.normals is None else data.normals @ np.linalg.inv(A)
    return _build(where, Mesh, vertices=vertices, faces=faces, material=d["material"], normals=normals,
                  uv=data.uv, path=str(path))  # fmt: skip


def _object(i: int, data: object, base_dir: Path | None) -> Sphere | Rectangle | Mesh:
    if not isinstance(data, dict):
        raise TypeError(f"objects[{i}] must be a JSON object; got {type(data).__name__}")
    kind = data.get("type")
    where = f"objects[{i}] ({kind})"
    if kind == "sphere":
        d = _fields(where, data, ("type", "center", "radius", "material"))
        return _build(where, Sphere, center=d["center"], radius=d["radius"], material=d["material"])
    if kind == "rectangle":
        d = _fields(where, data, ("type", "center", "normal", "up", "size", "material"))
        return _build(where, Rectangle, **{k: d[k] for k in ("center", "normal", "up", "size", "material")})
    if kind == "mesh":
        d = _fields(where, data, ("type", "path", "material"), ("transform", "smooth"))
        return _mesh(where, d, base_dir)
    raise ValueError(f"objects[{i}].type must be one of mesh, rectangle, sphere; got {kind!r}")


def _base_dir(base_dir: object) -> Path | None:
    """``base_dir`` as the existing folder relative paths resolve against (None: the working folder)."""
    if base_dir is None:
        return None
    if not isinstance(base_dir, str | os.PathLike):
        raise TypeError(f"base_dir must be a str, a path or None; got {type(base_dir).__name__}")
    base = Path(base_dir)
    if not base.exists():
        raise FileNotFoundError(f"base_dir must be an existing folder; {base} does not exist")
    if not base.is_dir():
        raise NotADirectoryError(f"base_dir must be a folder; {base} is a file")
    return base


def scene_from_dict(data: object, *, base_dir: str | Path | None = None, name: str = "scene") -> Scene:
    """Build a :class:`Scene` from parsed JSON (see ``docs/scenes.md``).

    Relative paths (textures, meshes, ``.hdr`` maps) resolve against ``base_dir`` (the scene file's
    folder for :func:`load_scene`). Unknown keys, missing fields and bad values raise a
    ``ValueError``/``TypeError`` that names the place in the file.

    Raises
    ------
    TypeError
        If ``base_dir`` is not None, a str or a path, or ``name`` is not a str.
    FileNotFoundError, NotADirectoryError
        If ``base_dir`` is given but is not an existing folder.
    """
    base = _base_dir(base_dir)
    if not isinstance(name, str):
        raise TypeError(f"name must be a str; got {type(name).__name__}")
    d = _fields("scene", data, ("camera", "environment", "materials", "objects"), ("name", "description", "stereo"))
    cam = _fields("camera", d["camera"], ("position", "look_at", "up", "fov_deg", "width", "height"),
                  ("principal_point", "lens"))  # fmt: skip
    camera = _build("camera", SceneCamera, **cam)
    if not isinstance(d["materials"], dict):
        raise TypeError(f"materials must be a JSON object of named materials; got {type(d['materials']).__name__}")
    materials = {k: _material(k, v, base) for k, v in d["materials"].items()}
    if not isinstance(d["objects"], list):
        raise TypeError(f"objects must be a JSON list; got {type(d['objects']).__name__}")
    objects = tuple(_object(i, o, base) for i, o in enumerate(d["objects"]))
    stereo = None
    if "stereo" in d:
        s = _fields("stereo", d["stereo"], ("baseline", "convergence"))
        stereo = _build("stereo", Stereo, baseline=s["baseline"], convergence=s["convergence"])
    scene_name = d.get("name", name)
    if not isinstance(scene_name, str):
        raise TypeError(f"name must be a string; got {type(scene_name).__name__}")
    return Scene(camera=camera, environment=_environment(d["environment"], base), materials=materials,
                 objects=objects, stereo=stereo, name=scene_name)  # fmt: skip


def scene_files(data: object, *, base_dir: str | Path | None = None) -> tuple[Path, ...]:
    """The files a scene reads, as :func:`scene_from_dict` resolves them: textures, meshes, ``.hdr`` maps.

    Lets a caller check them before the scene is built (``vergence serve`` refuses a scene whose files
    lead outside its data folder). Only the places that hold a path are looked at (``environment.hdr``,
    a texture material's ``path``, a mesh object's ``path``), and only well-formed ones (a non-empty
    string): anything else is :func:`scene_from_dict`'s to refuse. Nothing is read or checked on disk.

    Parameters
    ----------
    data : object
        Parsed JSON of a scene file (``docs/scenes.md``).
    base_dir : str or Path, optional
        The folder relative paths resolve against (the scene file's); None leaves them relative.

    Returns
    -------
    tuple of Path
        In the order environment, materials, objects; absolute paths as written.

    Examples
    --------
    >>> scene_files({"environment": {"hdr": "sky.hdr"}, "materials": {"wood": {"type": "texture",
    ...              "path": "/textures/wood.png"}}, "objects": [{"type": "mesh", "path": "cup.obj"}]},
    ...             base_dir="/scenes")
    (PosixPath('/scenes/sky.hdr'), PosixPath('/textures/wood.png'), PosixPath('/scenes/cup.obj'))
    """
    base = None if base_dir is None else Path(base_dir)
    if not isinstance(data, dict):
        return ()
    found = []
    environment, materials, objects = data.get("environment"), data.get("materials"), data.get("objects")
    if isinstance(environment, dict):
        found.append(environment.get("hdr"))
    if isinstance(materials, dict):
        found += [m.get("path") for m in materials.values() if isinstance(m, dict) and m.get("type") == "texture"]
    if isinstance(objects, list):
        found += [o.get("path") for o in objects if isinstance(o, dict) and o.get("type") == "mesh"]
    return tuple(_resolve(base, "", value) for value in found if isinstance(value, str) and value)


def load_scene(path: str | Path) -> Scene:
    """Read a JSON scene file (``docs/scenes.md``); errors name the file and the bad entry.

    The file's size and nesting are checked before parsing (:func:`vergence.io.read_json`:
    ``MAX_JSON_BYTES``, ``MAX_JSON_DEPTH``).
    """
    from vergence.io import read_json

    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"scene {p} is a folder; give a scene file (.json)")
    if not p.is_file():
        raise FileNotFoundError(f"scene file not found: {p}")
    data = read_json(p, what="scene file")
    try:
        return scene_from_dict(data, base_dir=p.parent, name=p.stem)
    except (ValueError, TypeError, OSError) as exc:  # OSError: a missing texture, mesh or .hdr file
        raise type(exc)(f"{p.name}: {exc}") from None
