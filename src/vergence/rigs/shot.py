"""Shot files: what the director wants, in JSON (format: ``docs/shots.md``).

::

    {"rig": "quadri" | "tri",
     "scene": "stadium" | "path/to/scene.json",          (relative to the shot file)
     "display": "tv-55" | {"eye_separation", "distance", "width"[, "resolution"]},
     "camera": {"position", "look_at"[, "up"], "fov_deg", "width", "height"},
     quadri: "baseline", "convergence", "setback", "elements": [{"name", "point"}, ...]
     tri:    "constraints": ["z=30,perceived=3,roundness=1", ...][, "reference": "round" | "div"][, "near"][, "far"]}

:func:`load_shot` reads a file, :func:`shot_from_dict` a parsed object; :meth:`Shot.plan` plans the rig
(:func:`~vergence.rigs.plan_quadri_rig` or :func:`~vergence.rigs.plan_tri_rig`). Unknown keys and
missing fields are refused by name at every level, with the valid keys listed. The renderer is not
imported here: a built-in scene name is checked against :data:`vergence.render.BUILTIN_SCENES` only when
one is given (that import loads Mitsuba).
"""

from __future__ import annotations

import math
import os
import types
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from vergence._validate import as_float_array, check_finite, check_positive_int
from vergence.camera import Camera, look_at
from vergence.rigs.cameras import check_element_name
from vergence.rigs.quadri import QuadriRig, plan_quadri_rig
from vergence.rigs.tri import TRI_REFERENCES, TriRig, plan_tri_rig
from vergence.viewing import DISPLAY_PRESETS, DirectorConstraint, Display, check_display

__all__ = ["EXAMPLE_SHOTS", "SHOT_RIGS", "Shot", "ShotCamera", "load_shot", "plan_document", "shot_from_dict"]

SHOT_RIGS = ("quadri", "tri")
"""The rigs a shot file can ask for (its ``"rig"``)."""

_STADIUM_UP = [0.0, 1.0, 0.0]
EXAMPLE_SHOTS = types.MappingProxyType({
    "stadium-quadri": {
        "rig": "quadri", "scene": "stadium", "display": "tv-55",
        "camera": {"position": [0.0, 1.6, -20.0], "look_at": [0.0, 1.0, -30.0], "up": _STADIUM_UP, "fov_deg": 24.0,
                   "width": 480, "height": 270},
        "baseline": 0.2, "convergence": 10.0, "setback": 20.0,
        "elements": [{"name": "subject", "point": [0.0, 1.0, -30.0]},
                     {"name": "background", "point": [0.0, 2.0, -63.0]}],
    },
    "stadium-tri": {
        "rig": "tri", "scene": "stadium", "display": "tv-55",
        "camera": {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "up": _STADIUM_UP, "fov_deg": 8.0,
                   "width": 480, "height": 270},
        "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=6"], "reference": "round",
        "near": 25.0, "far": None,
    },
})  # fmt: skip
"""The example shots whose scene is built in, by name: ``examples/shots/<name>.json`` as parsed JSON (a
test checks they agree), for programs that run without the source tree (the workbench's presets, the
demo). Read-only: copy one (``copy.deepcopy``) before changing it; :func:`shot_from_dict` reads it."""

_COMMON = ("rig", "scene", "display", "camera")
# Per rig: (required keys, optional keys) besides _COMMON.
_RIG_KEYS = {
    "quadri": (("baseline", "convergence", "setback", "elements"), ()),
    "tri": (("constraints",), ("reference", "near", "far")),
}
_CAMERA_KEYS = (("position", "look_at", "fov_deg", "width", "height"), ("up",))
_DISPLAY_KEYS = (("eye_separation", "distance", "width"), ("resolution",))
_ELEMENT_KEYS = (("name", "point"), ())
_DEFAULT_UP = (0.0, 1.0, 0.0)


def _keys(what: str, data: object, keys: tuple[tuple[str, ...], tuple[str, ...]]) -> dict:
    """``data`` as a dict holding every required key and no unknown one, else a one-line error naming them."""
    if not isinstance(data, Mapping):
        raise TypeError(f"{what} must be a JSON object; got {type(data).__name__}")
    required, optional = keys
    valid = ", ".join(required + tuple(f"{k} (optional)" for k in optional))
    unknown = [k for k in data if k not in required + optional]
    if unknown:
        raise ValueError(f"{what} has unknown key(s) {', '.join(map(repr, unknown))}; valid keys: {valid}")
    missing = [k for k in required if k not in data]
    if missing:
        raise ValueError(f"{what} is missing field(s) {', '.join(missing)}; valid keys: {valid}")
    return dict(data)


def _vector(name: str, value: object) -> tuple[float, float, float]:
    if isinstance(value, str) or not isinstance(value, list | tuple):
        raise TypeError(f"{name} must be a list of 3 numbers; got {type(value).__name__}")
    if any(isinstance(v, bool) or not isinstance(v, int | float) for v in value):
        raise TypeError(f"{name} must be a list of 3 numbers; got {list(value)!r}")
    x, y, z = as_float_array(name, value, shape=(3,)).tolist()
    return (x, y, z)


@dataclass(frozen=True, slots=True)
class ShotCamera:
    """The shot's camera as the file gives it: :func:`~vergence.camera.look_at` arguments.

    ``position``, ``look_at`` and ``up`` in world metres (``up`` defaults to +y), ``fov_deg`` the
    horizontal field of view in degrees, ``width`` x ``height`` pixels.
    """

    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    up: tuple[float, float, float]
    fov_deg: float
    width: int
    height: int

    def __post_init__(self) -> None:
        for name in ("position", "look_at", "up"):
            value = getattr(self, name)
            if isinstance(value, str | bytes):
                raise TypeError(f"{name} must be 3 numbers; got {type(value).__name__}")
            object.__setattr__(self, name, tuple(as_float_array(name, value, shape=(3,)).tolist()))
        object.__setattr__(self, "fov_deg", check_finite("fov_deg", self.fov_deg))
        object.__setattr__(self, "width", check_positive_int("width", self.width))
        object.__setattr__(self, "height", check_positive_int("height", self.height))
        self.camera()  # look_at's own checks: a field of view in (0, 180) degrees, distinct points, up not along the view

    def camera(self) -> Camera:
        """The pinhole camera (principal point at the image centre, square pixels)."""
        return look_at(self.position, self.look_at, self.up, fov_deg=self.fov_deg, width=self.width, height=self.height)

    def to_dict(self) -> dict[str, object]:
        return {"position": list(self.position), "look_at": list(self.look_at), "up": list(self.up),
                "fov_deg": self.fov_deg, "width": self.width, "height": self.height}  # fmt: skip


@dataclass(frozen=True, slots=True)
class Shot:
    """A parsed shot file (``docs/shots.md``).

    Attributes
    ----------
    rig : str
        ``"quadri"`` or ``"tri"``.
    scene : str or Path
        A built-in scene name, or the resolved path of a scene file.
    display : Display
        The viewing set-up.
    view : ShotCamera
        The ``camera`` entry; :attr:`camera` is its pinhole camera (the Quadri-Rig's virtual centre camera,
        the Tri-Rig's director camera).
    baseline, convergence, setback : float or None
        Quadri-Rig only: the virtual rig's ``b_v``, ``H_v`` and the real cameras' setback, metres.
    elements : tuple of (str, (x, y, z))
        Quadri-Rig only: element names and world points.
    constraints : tuple of DirectorConstraint
        Tri-Rig only, as given (the planner sorts them).
    reference : str
        Tri-Rig only: ``"round"`` (default) or ``"div"``.
    near : float or None
        Tri-Rig only: nearest scene depth for psi; None = the planner's default (half the nearest constraint's depth).
    far : float
        Tri-Rig only: farthest scene depth, inf by default.
    path : Path or None
        The shot file, when read from one.
    """

    rig: str
    scene: str | Path
    display: Display
    view: ShotCamera
    baseline: float | None = None
    convergence: float | None = None
    setback: float | None = None
    elements: tuple[tuple[str, tuple[float, float, float]], ...] = ()
    constraints: tuple[DirectorConstraint, ...] = ()
    reference: str = "round"
    near: float | None = None
    far: float = math.inf
    path: Path | None = None

    def __post_init__(self) -> None:
        if self.rig not in SHOT_RIGS:
            raise ValueError(f"rig must be one of {', '.join(SHOT_RIGS)}; got {self.rig!r}")
        check_display(self.display)
        if not isinstance(self.view, ShotCamera):
            raise TypeError(f"view must be a ShotCamera; got {type(self.view).__name__}")
        if self.reference not in TRI_REFERENCES:
            raise ValueError(f"reference must be one of {', '.join(TRI_REFERENCES)}; got {self.reference!r}")

    @property
    def camera(self) -> Camera:
        """The shot's camera: the virtual centre camera (quadri) or the director's camera (tri)."""
        return self.view.camera()

    def plan(self) -> QuadriRig | TriRig:
        """Plan the rig (:func:`~vergence.rigs.plan_quadri_rig` or :func:`~vergence.rigs.plan_tri_rig`).

        Raises the planner's one-line ``ValueError`` when the geometry is impossible (an element behind the
        cameras, constraints psi cannot meet, ...).
        """
        if self.rig == "quadri":
            return plan_quadri_rig(self.camera, baseline=self.baseline, convergence=self.convergence,
                                   setback=self.setback, elements=list(self.elements))  # fmt: skip
        return plan_tri_rig(self.camera, self.display, list(self.constraints), reference=self.reference,
                            near=self.near, far=self.far)  # fmt: skip

    def to_dict(self) -> dict[str, object]:
        """The shot as a JSON object :func:`shot_from_dict` reads back to an equal Shot.

        A scene file is written as its absolute path; a display equal to a preset as the preset's name;
        an infinite ``far`` as ``null``.
        """
        d = self.display
        display: str | dict[str, object] | None = next((k for k, p in DISPLAY_PRESETS.items() if p == d), None)
        if display is None:
            display = {"eye_separation": d.eye_separation, "distance": d.distance, "width": d.width}
            if d.resolution is not None:
                display["resolution"] = d.resolution
        out: dict[str, object] = {"rig": self.rig, "scene": str(self.scene), "display": display,
                                  "camera": self.view.to_dict()}  # fmt: skip
        if self.rig == "quadri":
            out.update(baseline=self.baseline, convergence=self.convergence, setback=self.setback,
                       elements=[{"name": n, "point": list(p)} for n, p in self.elements])  # fmt: skip
        else:
            out.update(constraints=[str(c) for c in self.constraints], reference=self.reference)
            if self.near is not None:
                out["near"] = self.near
            out["far"] = self.far if math.isfinite(self.far) else None
        return out


def _builtin_scenes() -> tuple[str, ...]:
    """:data:`vergence.render.BUILTIN_SCENES`, imported on demand (the import loads Mitsuba)."""
    from vergence.render.builtin import BUILTIN_SCENES

    return tuple(BUILTIN_SCENES)


def _scene(value: object, base_dir: Path | None) -> str | Path:
    """A built-in name, or the resolved path of an existing scene file (relative to ``base_dir``)."""
    if not isinstance(value, str) or not value:
        raise TypeError(f"scene must be a non-empty string (a built-in scene name or a scene file); "
                        f"got {value!r}")  # fmt: skip
    names = _builtin_scenes()
    if value in names:  # a bare built-in name is the built-in scene, whatever sits beside the shot file
        return value
    path = Path(value) if base_dir is None else Path(base_dir) / value
    if path.is_file():
        return path.resolve()
    if path.is_dir():
        raise IsADirectoryError(f"scene {path} is a folder; give a scene file (.json), or a built-in scene by its "
                                f"bare name: {', '.join(names)}")
    if path.suffix or len(Path(value).parts) > 1:
        raise FileNotFoundError(f"scene file not found: {path}")
    if value not in names:
        raise ValueError(f"scene must be a scene file or a built-in scene ({', '.join(names)}); got {value!r}")
    return value


def _display(value: object) -> Display:
    if isinstance(value, str):
        return Display.preset(value)
    data = _keys("display", value, _DISPLAY_KEYS)
    try:
        return Display(**data)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"display {exc}") from None


def _camera(value: object) -> ShotCamera:
    data = _keys("camera", value, _CAMERA_KEYS)
    position = _vector("camera.position", data["position"])
    target = _vector("camera.look_at", data["look_at"])
    up = _vector("camera.up", data.get("up", list(_DEFAULT_UP)))
    fov_deg = check_finite("camera.fov_deg", data["fov_deg"])
    width = check_positive_int("camera.width", data["width"])
    height = check_positive_int("camera.height", data["height"])
    try:
        return ShotCamera(position=position, look_at=target, up=up, fov_deg=fov_deg, width=width, height=height)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"camera: {exc}") from None


def _elements(value: object) -> tuple[tuple[str, tuple[float, float, float]], ...]:
    if not isinstance(value, list):
        raise TypeError(f"elements must be a list of {{\"name\", \"point\"}} objects; got {type(value).__name__}")
    out = []
    for k, item in enumerate(value):
        data = _keys(f"elements[{k}]", item, _ELEMENT_KEYS)
        name = check_element_name(data["name"], what=f"elements[{k}].name")
        out.append((name, _vector(f"elements[{k}].point", data["point"])))
    return tuple(out)


def _constraints(value: object) -> tuple[DirectorConstraint, ...]:
    if not isinstance(value, list):
        raise TypeError(f"constraints must be a list of strings 'z=Z,perceived=Z[,roundness=R]'; "
                        f"got {type(value).__name__}")  # fmt: skip
    out = []
    for k, item in enumerate(value):
        if not isinstance(item, str):
            raise TypeError(f"constraints[{k}] must be a string 'z=Z,perceived=Z[,roundness=R]'; got {item!r}")
        out.append(DirectorConstraint.from_string(item))
    return tuple(out)


def shot_from_dict(data: object, *, base_dir: str | os.PathLike[str] | None = None) -> Shot:
    """A :class:`Shot` from a parsed shot file; a relative scene path is taken from ``base_dir``.

    Parameters
    ----------
    data : dict
        The JSON object (``docs/shots.md``).
    base_dir : str or PathLike, optional
        Folder a relative ``scene`` path is relative to (the shot file's); default the working folder.

    Raises
    ------
    TypeError
        A value of the wrong type (a string for a number, a number for a list, ...).
    ValueError
        An unknown key or a missing field (at any level; the valid keys are listed), an unknown rig,
        display preset, built-in scene or reference, or a value out of range.
    FileNotFoundError
        A scene path that does not exist (the message gives the path).

    Examples
    --------
    >>> shot = shot_from_dict({"rig": "tri", "scene": "stadium", "display": "tv-55",
    ...     "camera": {"position": [0, 2.2, 0], "look_at": [0, 1.1, -30], "fov_deg": 8, "width": 480, "height": 270},
    ...     "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=6"]})
    >>> [c.name for c in shot.plan().cameras]
    ['director', 'subject', 'background']
    """
    if not isinstance(data, Mapping):
        raise TypeError(f"shot must be a JSON object; got {type(data).__name__}")
    rig = data.get("rig")
    if rig is None:
        raise ValueError(f"shot is missing field(s) rig (one of {', '.join(SHOT_RIGS)})")
    if rig not in SHOT_RIGS:
        raise ValueError(f"rig must be one of {', '.join(SHOT_RIGS)}; got {rig!r}")
    required, optional = _RIG_KEYS[rig]
    fields = _keys(f"a {rig} shot", data, (_COMMON + required, optional))
    common = {
        "rig": rig,
        "scene": _scene(fields["scene"], None if base_dir is None else Path(base_dir)),
        "display": _display(fields["display"]),
        "view": _camera(fields["camera"]),
    }
    if rig == "quadri":
        numbers = {k: check_finite(k, fields[k]) for k in ("baseline", "convergence", "setback")}
        return Shot(**common, **numbers, elements=_elements(fields["elements"]))
    reference = fields.get("reference", "round")  # checked by Shot
    near = fields.get("near")
    far = fields.get("far")
    return Shot(**common, constraints=_constraints(fields["constraints"]), reference=reference,
                near=None if near is None else check_finite("near", near),
                far=math.inf if far is None else check_finite("far", far))  # fmt: skip


def load_shot(path: str | os.PathLike[str]) -> Shot:
    """Read a shot file (JSON, ``docs/shots.md``); a relative scene path is relative to the file.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        No such file; a scene path that does not exist.
    ValueError, TypeError
        Invalid JSON, an unknown key, a missing field, a wrong type: one line beginning with the file's path.
    """
    from vergence.io.jsonfile import read_json  # vergence.io loads Pillow: not for `import vergence.rigs`

    data = read_json(path, what="shot file")
    try:
        shot = shot_from_dict(data, base_dir=Path(path).parent)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"shot file {path}: {exc}") from None
    return replace(shot, path=Path(path))



def _distance(a: Camera, b: Camera) -> float:
    return float(np.linalg.norm(np.asarray(a.center) - np.asarray(b.center)))


def plan_document(shot: Shot, rig: QuadriRig | TriRig | None = None) -> dict[str, object]:
    """The plan of ``shot`` as JSON: what ``vergence rig plan --json`` prints (``docs/shots.md``).

    Parameters
    ----------
    shot : Shot
    rig : QuadriRig or TriRig, optional
        ``shot.plan()``, when already planned.

    Returns
    -------
    dict
        ``rig``, ``shot`` (the shot file, None without one) and ``cameras``: one row per real camera
        with ``name``, ``element``, ``eye``, ``camera`` (:meth:`Camera.to_dict`), ``fx`` (px),
        ``fx_ratio`` (to the virtual centre camera's fx for a Quadri-Rig, S0 Eq. (10), to the
        director's for a Tri-Rig) and ``baseline`` (m: to the other eye's camera of the same element,
        Quadri-Rig; to the director, Tri-Rig). A Quadri-Rig adds ``virtual`` (centre, left, right
        cameras), ``elements`` and ``setback``; a Tri-Rig ``reference`` (psi's reference rig:
        baseline, convergence, window), ``reference_right``, psi's ``control_points``, ``monotone``
        and ``diverges``. Both add ``warnings``: the rig's one-line warnings (a Quadri-Rig's absurd
        geometry, a Tri-Rig's psi comfort warnings).

    Raises
    ------
    ValueError
        When ``rig`` is None and the planner refuses the shot (``Shot.plan``).

    Examples
    --------
    >>> doc = plan_document(shot_from_dict(EXAMPLE_SHOTS["stadium-tri"]))
    >>> [(c["name"], round(c["baseline"], 3)) for c in doc["cameras"]]
    [('director', 0.0), ('subject', 0.65), ('background', 0.208)]
    """
    if not isinstance(shot, Shot):
        raise TypeError(f"shot must be a vergence.rigs.Shot; got {type(shot).__name__}")
    if rig is None:
        rig = shot.plan()
    ref = rig.center if shot.rig == "quadri" else rig.director
    fx0 = float(ref.K[0, 0])
    by_key = {(rc.element, rc.eye): rc for rc in rig.cameras}
    rows = []
    for rc in rig.cameras:
        if shot.rig == "quadri":
            other = by_key.get((rc.element, "right" if rc.eye == "left" else "left"))
            b = _distance(rc.camera, other.camera) if other is not None else None
        else:
            b = _distance(rc.camera, rig.director)
        rows.append({"name": rc.name, "element": rc.element, "eye": rc.eye, "camera": rc.camera.to_dict(),
                     "fx": float(rc.camera.K[0, 0]), "fx_ratio": float(rc.camera.K[0, 0]) / fx0, "baseline": b})
    out: dict[str, object] = {"rig": shot.rig, "shot": None if shot.path is None else str(shot.path), "cameras": rows}
    if shot.rig == "quadri":
        out["virtual"] = {"center": rig.center.to_dict(), "left": rig.left.to_dict(), "right": rig.right.to_dict()}
        out["elements"] = [{"name": n, "point": [float(v) for v in p]} for n, p in rig.elements]
        out["setback"] = float(rig.setback)
    else:
        r = rig.reference
        out["reference"] = {"baseline": r.baseline, "convergence": r.convergence, "window": r.window}
        out["reference_right"] = rig.reference_right.to_dict()
        out["control_points"] = [{"disparity": cp.disparity, "value": cp.value, "slope": cp.slope}
                                 for cp in rig.mapping.control_points]  # fmt: skip
        out["monotone"] = bool(rig.mapping.monotone)
        out["diverges"] = bool(rig.mapping.diverges)
    out["warnings"] = list(rig.warnings)
    return out
