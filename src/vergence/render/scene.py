"""Scenes for the ray tracer: camera, environment, materials, objects (frozen, validated).

World frame: right-handed, **+y up** (the zenith of the environment map), lengths in metres,
angles in degrees where the name ends in ``_deg``. Every class validates itself; the JSON reader
(``scenefile.py``, format in ``docs/scenes.md``) adds where in the file a bad value sits.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from vergence import camera as _camera
from vergence._validate import as_float_array, check_finite, check_positive, check_positive_int
from vergence.render.lenses import FisheyeCamera, check_min_fov
from vergence.render.limits import MAX_RENDER_SIDE
from vergence.viewing.geometry import LENGTH_RANGE

__all__ = [
    "Checker",
    "Diffuse",
    "Environment",
    "Glass",
    "IOR_RANGE",
    "LENSES",
    "MAX_RADIANCE",
    "MAX_SCENE_EXTENT",
    "Mesh",
    "Mirror",
    "Rectangle",
    "Scene",
    "SceneCamera",
    "Sphere",
    "Stereo",
    "Texture",
]

LENSES = ("fisheye", "pinhole")

#: Largest |coordinate| of any scene point (object centres and extents, mesh vertices, the
#: camera), metres: 100 km. Mitsuba casts in float32, whose spacing at 1e5 m is 8 mm; the built-in
#: scenes span under 100 m. Beyond, first hits lose the precision the refinement starts from.
MAX_SCENE_EXTENT = 1e5

#: Largest radiance an environment can send (colour or HDR map value, times ``intensity``): 1e7,
#: a hundred times the sun's disc in the brightest shared HDR map (quarry_01: 8.7e4). Keeps the
#: float32 sums of up to 127 weighted layers far from overflow.
MAX_RADIANCE = 1e7

#: Refractive indices a :class:`Glass` may have, [1, 4]: air (1) to germanium (4.0, the highest of
#: common optical materials; diamond is 2.42). Schlick's approximation (Schlick 1994) is fitted on
#: dielectrics in this range.
IOR_RANGE = (1.0, 4.0)


def _ro(arr: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    out = np.array(arr, dtype=dtype, copy=True)
    out.flags.writeable = False
    return out


def _vec3(name: str, value: object) -> np.ndarray:
    return _ro(_within_extent(name, as_float_array(name, value, shape=(3,))))


def _within_extent(name: str, points: np.ndarray, reach: float = 0.0) -> np.ndarray:
    """``points`` (with ``reach`` around them), refused past MAX_SCENE_EXTENT metres from the origin."""
    far = float(np.abs(points).max(initial=0.0)) + reach
    if far > MAX_SCENE_EXTENT:
        raise ValueError(f"{name} must lie within {MAX_SCENE_EXTENT:g} m of the origin (MAX_SCENE_EXTENT); "
                         f"reaches {far:g} m")  # fmt: skip
    return points


def _unit(name: str, value: object) -> np.ndarray:
    v = as_float_array(name, value, shape=(3,))
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ValueError(f"{name} must be a non-zero vector; got {v.tolist()}")
    return _ro(v / n)


def _color(name: str, value: object, *, hdr: bool = False) -> np.ndarray:
    c = as_float_array(name, value, shape=(3,))
    if c.min() < 0.0 or (not hdr and c.max() > 1.0):
        want = ">= 0" if hdr else "in [0, 1]"
        raise ValueError(f"{name} must have components {want}; got {c.tolist()}")
    return _ro(c)


def _text(name: str, value: object, *, optional: bool = False) -> str | None:
    """``value`` if it is a non-empty str (or None when ``optional``); a material name, a path, a label."""
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str{' or None' if optional else ''}; got {type(value).__name__}")
    if not value:
        raise ValueError(f"{name} must be a non-empty str; got ''")
    return value


def _albedo_image(name: str, value: object) -> np.ndarray:
    img = as_float_array(name, value, dtype=np.float32)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] != 3 or min(img.shape[:2]) < 1:
        raise ValueError(f"{name} must have shape (h, w) or (h, w, 3); got {img.shape}")
    if img.min() < 0.0 or img.max() > 1.0:
        raise ValueError(f"{name} values must lie in [0, 1] (an albedo); got [{img.min():g}, {img.max():g}]")
    return _ro(img, np.float32)


# ------------------------------------------------------------------------------ camera and environment
@dataclass(frozen=True, slots=True, eq=False)
class SceneCamera:
    """The scene's camera: ``look_at`` framing, horizontal field of view over the full width.

    ``principal_point`` defaults to the image centre ``((width-1)/2, (height-1)/2)``; ``lens`` is
    ``"pinhole"`` (fov in (0, 180)) or ``"fisheye"`` (equidistant, fov in (0, 180]).
    """

    position: np.ndarray
    look_at: np.ndarray
    up: np.ndarray
    fov_deg: float
    width: int
    height: int
    principal_point: tuple[float, float] | None = None
    lens: str = "pinhole"

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _vec3("position", self.position))
        object.__setattr__(self, "look_at", _vec3("look_at", self.look_at))
        object.__setattr__(self, "up", _vec3("up", self.up))
        object.__setattr__(self, "width", check_positive_int("width", self.width))
        object.__setattr__(self, "height", check_positive_int("height", self.height))
        for name in ("width", "height"):
            if getattr(self, name) > MAX_RENDER_SIDE:
                raise ValueError(f"{name} must be <= {MAX_RENDER_SIDE} pixels (MAX_RENDER_SIDE); got {getattr(self, name)}")
        if not isinstance(self.lens, str) or self.lens not in LENSES:
            raise ValueError(f"lens must be one of {', '.join(LENSES)}; got {self.lens!r}")
        if self.principal_point is not None:
            pp = as_float_array("principal_point", self.principal_point, shape=(2,))
            object.__setattr__(self, "principal_point", (float(pp[0]), float(pp[1])))
        object.__setattr__(self, "fov_deg", check_finite("fov_deg", self.fov_deg))
        check_min_fov(self.fov_deg)
        self.build()  # validates the framing (fov range, degenerate look_at / up)

    def build(self) -> _camera.Camera | FisheyeCamera:
        """The camera: a :class:`~vergence.camera.Camera` or a :class:`~vergence.render.FisheyeCamera`."""
        pp = self.principal_point
        if self.lens == "pinhole":
            return _camera.look_at(self.position, self.look_at, self.up, fov_deg=self.fov_deg, width=self.width,
                                   height=self.height, principal_point=pp)  # fmt: skip
        # The pose only: look_at's pinhole focal length is not used by the fisheye.
        pose = _camera.look_at(self.position, self.look_at, self.up, fov_deg=90.0, width=self.width,
                               height=self.height, principal_point=pp)  # fmt: skip
        return FisheyeCamera(R=pose.R, t=pose.t, width=self.width, height=self.height, fov_deg=self.fov_deg,
                             principal_point=pose.principal_point)  # fmt: skip

    def resized(self, *, width: int | None = None, height: int | None = None) -> SceneCamera:
        """The same framing at another image size (the horizontal field of view is kept).

        A missing size follows the other one at the same aspect ratio; an explicit principal point
        is rescaled with the image: ``(c + 0.5) * new / old - 0.5``.
        """
        if width is None and height is None:
            return self
        width = None if width is None else check_positive_int("width", width)
        height = None if height is None else check_positive_int("height", height)
        w = max(1, round(self.width * height / self.height)) if width is None else width
        h = max(1, round(self.height * w / self.width)) if height is None else height
        pp = self.principal_point
        if pp is not None:
            pp = ((pp[0] + 0.5) * w / self.width - 0.5, (pp[1] + 0.5) * h / self.height - 0.5)
        return SceneCamera(position=self.position, look_at=self.look_at, up=self.up, fov_deg=self.fov_deg, width=w,
                           height=h, principal_point=pp, lens=self.lens)  # fmt: skip


@dataclass(frozen=True, slots=True, eq=False)
class Environment:
    """Radiance arriving from infinity: a constant ``color`` or an equirectangular ``image``.

    ``image`` is linear HDR ``(h, w, 3)``, row 0 at the zenith (+y), column ``w/2`` facing -z,
    columns growing towards +x; it is scaled by ``intensity`` and turned by ``rotation_deg`` about +y
    (the column that faced -z then faces ``(sin r, 0, -cos r)``). ``source`` names where it came
    from; ``note`` announces a substitution (a missing file replaced by a constant colour).
    """

    color: np.ndarray | None = None
    image: np.ndarray | None = None
    intensity: float = 1.0
    rotation_deg: float = 0.0
    source: str = "color"
    note: str | None = None

    def __post_init__(self) -> None:
        if (self.color is None) == (self.image is None):
            raise ValueError("environment needs exactly one of color or image (an .hdr map)")
        if self.color is not None:
            object.__setattr__(self, "color", _color("color", self.color, hdr=True))
        else:
            img = as_float_array("image", self.image, dtype=np.float32)
            if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] < 2 or img.shape[1] < 2:
                raise ValueError(f"image must have shape (h, w, 3) with h, w >= 2; got {img.shape}")
            if img.min() < 0.0:
                raise ValueError(f"image must be radiance >= 0; got min {img.min():g}")
            object.__setattr__(self, "image", _ro(img, np.float32))
        intensity = check_finite("intensity", self.intensity)
        if intensity < 0.0:
            raise ValueError(f"intensity must be >= 0; got {intensity:g}")
        peak = float((self.color if self.image is None else self.image).max()) * intensity
        if peak > MAX_RADIANCE:
            raise ValueError(f"{'color' if self.image is None else 'image'} x intensity must be <= {MAX_RADIANCE:g} "
                             f"(MAX_RADIANCE); got {peak:g}")  # fmt: skip
        object.__setattr__(self, "intensity", intensity)
        object.__setattr__(self, "rotation_deg", check_finite("rotation_deg", self.rotation_deg))
        _text("source", self.source)
        _text("note", self.note, optional=True)

    def describe(self) -> str:
        """One line: where the lighting comes from (and the substitution note, if any)."""
        if self.image is None:
            text = f"constant colour {[round(float(c), 6) for c in self.color]} x {self.intensity:g}"
        else:
            text = f"{self.source} x {self.intensity:g}, rotated {self.rotation_deg:g} deg"
        return text if self.note is None else f"{text} ({self.note})"


@dataclass(frozen=True, slots=True)
class Stereo:
    """Default stereo rig of a scene: ``baseline`` b and convergence distance H, metres, in ``LENGTH_RANGE``."""

    baseline: float
    convergence: float

    def __post_init__(self) -> None:
        for name in ("baseline", "convergence"):
            v = check_positive(name, getattr(self, name))
            if not LENGTH_RANGE[0] <= v <= LENGTH_RANGE[1]:  # as vergence.rigs.stereo_pair takes them
                raise ValueError(f"{name} must be in [{LENGTH_RANGE[0]:g}, {LENGTH_RANGE[1]:g}] m (LENGTH_RANGE); "
                                 f"got {v:g}")  # fmt: skip
            object.__setattr__(self, name, v)


# ------------------------------------------------------------------------------ materials
@dataclass(frozen=True, slots=True, eq=False)
class Diffuse:
    """Lambertian, albedo ``color`` in [0, 1]."""

    color: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "color", _color("color", self.color))


@dataclass(frozen=True, slots=True, eq=False)
class Checker:
    """Lambertian checkerboard in texture space: ``squares = (nu, nv)`` cells of ``colors[0]``/``[1]``."""

    colors: np.ndarray
    squares: tuple[int, int] = (8, 8)

    def __post_init__(self) -> None:
        c = as_float_array("colors", self.colors, shape=(2, 3))
        for k in range(2):
            _color(f"colors[{k}]", c[k])
        object.__setattr__(self, "colors", _ro(c))
        if not isinstance(self.squares, tuple | list) or len(self.squares) != 2:
            raise ValueError(f"squares must be a pair [nu, nv]; got {self.squares!r}")
        object.__setattr__(self, "squares", tuple(check_positive_int(f"squares[{k}]", self.squares[k]) for k in range(2)))


@dataclass(frozen=True, slots=True, eq=False)
class Texture:
    """Lambertian with an albedo image ``(h, w, 3)`` in [0, 1] (row 0 at v = 1), repeated outside [0, 1]^2."""

    image: np.ndarray
    path: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "image", _albedo_image("image", self.image))
        _text("path", self.path, optional=True)


@dataclass(frozen=True, slots=True, eq=False)
class Mirror:
    """Perfect specular reflector; reflected radiance is multiplied by ``color``."""

    color: np.ndarray = (1.0, 1.0, 1.0)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        object.__setattr__(self, "color", _color("color", self.color))


@dataclass(frozen=True, slots=True, eq=False)
class Glass:
    """Dielectric of index ``ior`` in air: Schlick reflection and refraction; ``color`` tints entering light."""

    ior: float = 1.5
    color: np.ndarray = (1.0, 1.0, 1.0)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        ior = check_positive("ior", self.ior)
        if not IOR_RANGE[0] <= ior <= IOR_RANGE[1]:
            raise ValueError(f"ior must be in [{IOR_RANGE[0]:g}, {IOR_RANGE[1]:g}] (IOR_RANGE); got {ior:g}")
        object.__setattr__(self, "ior", ior)
        object.__setattr__(self, "color", _color("color", self.color))


MATERIALS = {"checker": Checker, "diffuse": Diffuse, "glass": Glass, "mirror": Mirror, "texture": Texture}
Material = Checker | Diffuse | Glass | Mirror | Texture


# ------------------------------------------------------------------------------ objects
@dataclass(frozen=True, slots=True, eq=False)
class Sphere:
    """Sphere of ``radius`` around ``center``; texture coordinates: u = longitude, v = latitude (+y up)."""

    center: np.ndarray
    radius: float
    material: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vec3("center", self.center))
        object.__setattr__(self, "radius", check_positive("radius", self.radius))
        _within_extent("sphere", self.center, self.radius)
        _text("material", self.material)


@dataclass(frozen=True, slots=True, eq=False)
class Rectangle:
    """Two-sided rectangle ``size = (w, h)`` around ``center``; ``up`` gives the v direction.

    Seen from the side ``normal`` points to, u grows to the right (``up x normal``) and v upwards.
    """

    center: np.ndarray
    normal: np.ndarray
    up: np.ndarray
    size: tuple[float, float]
    material: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vec3("center", self.center))
        n = _unit("normal", self.normal)
        up = as_float_array("up", self.up, shape=(3,))
        up = up - np.dot(up, n) * n
        if np.linalg.norm(up) < 1e-9 * max(1.0, float(np.linalg.norm(self.up))):
            raise ValueError("up must not be parallel to normal")
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "up", _ro(up / np.linalg.norm(up)))
        s = as_float_array("size", self.size, shape=(2,))
        object.__setattr__(self, "size", (check_positive("size[0]", s[0]), check_positive("size[1]", s[1])))
        _within_extent("rectangle", self.center, 0.5 * float(np.hypot(*self.size)))
        _text("material", self.material)

    @property
    def right(self) -> np.ndarray:
        """Unit u direction ``up x normal``."""
        return np.cross(self.up, self.normal)


@dataclass(frozen=True, slots=True, eq=False)
class Mesh:
    """Triangle mesh in world coordinates; faces wound counter-clockwise seen from outside.

    ``normals`` (per vertex) give smooth shading; without them each face is flat. ``uv`` (per
    vertex) are texture coordinates, required by textured materials.
    """

    vertices: np.ndarray
    faces: np.ndarray
    material: str
    normals: np.ndarray | None = None
    uv: np.ndarray | None = None
    path: str | None = None

    def __post_init__(self) -> None:
        _text("material", self.material)
        _text("path", self.path, optional=True)
        v = as_float_array("vertices", self.vertices, shape=(None, 3))
        f = np.asarray(self.faces)
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer):
            raise ValueError(f"faces must be a non-empty (F, 3) integer array; got {f.shape} {f.dtype}")
        if f.min() < 0 or f.max() >= len(v):
            raise ValueError(f"faces must index vertices 0..{len(v) - 1}; got {f.min()}..{f.max()}")
        object.__setattr__(self, "vertices", _ro(_within_extent("vertices", v)))
        object.__setattr__(self, "faces", _ro(f, np.int64))
        if self.normals is not None:
            n = as_float_array("normals", self.normals, shape=(len(v), 3))
            length = np.linalg.norm(n, axis=1)
            if (length == 0).any():
                raise ValueError("normals must be non-zero vectors")
            object.__setattr__(self, "normals", _ro(n / length[:, None]))
        if self.uv is not None:
            object.__setattr__(self, "uv", _ro(as_float_array("uv", self.uv, shape=(len(v), 2))))


# ------------------------------------------------------------------------------ scene
@dataclass(frozen=True, slots=True, eq=False)
class Scene:
    """Everything the renderer needs: camera, environment, named materials, objects, optional rig."""

    camera: SceneCamera
    environment: Environment
    materials: dict[str, Material]
    objects: tuple[Sphere | Rectangle | Mesh, ...]
    stereo: Stereo | None = None
    name: str = "scene"

    def __post_init__(self) -> None:
        for attr, cls in (("camera", SceneCamera), ("environment", Environment)):
            if not isinstance(getattr(self, attr), cls):
                raise TypeError(f"{attr} must be a {cls.__name__}; got {type(getattr(self, attr)).__name__}")
        if self.stereo is not None and not isinstance(self.stereo, Stereo):
            raise TypeError(f"stereo must be a Stereo or None; got {type(self.stereo).__name__}")
        if not isinstance(self.materials, Mapping):
            raise TypeError(f"materials must be a mapping of names to materials; got {type(self.materials).__name__}")
        mats = dict(self.materials)
        for key, mat in mats.items():
            if not isinstance(key, str) or not key:
                raise ValueError(f"material names must be non-empty strings; got {key!r}")
            if not isinstance(mat, Material):
                raise TypeError(f"materials[{key!r}] must be a material ({', '.join(MATERIALS)}); got {type(mat).__name__}")
        object.__setattr__(self, "materials", MappingProxyType(mats))
        if isinstance(self.objects, str) or not isinstance(self.objects, Sequence):
            raise TypeError(f"objects must be a sequence of Sphere, Rectangle or Mesh; got {type(self.objects).__name__}")
        objs = tuple(self.objects)
        for i, obj in enumerate(objs):
            if not isinstance(obj, Sphere | Rectangle | Mesh):
                raise TypeError(f"objects[{i}] must be a Sphere, Rectangle or Mesh; got {type(obj).__name__}")
            if obj.material not in mats:
                raise ValueError(f"objects[{i}] uses unknown material {obj.material!r}; defined: {', '.join(sorted(mats))}")
            mat = mats[obj.material]
            if isinstance(mat, Glass) and isinstance(obj, Rectangle):
                raise ValueError(f"objects[{i}]: glass {obj.material!r} needs a closed surface (sphere or mesh), not a rectangle")
            if isinstance(mat, Checker | Texture) and isinstance(obj, Mesh) and obj.uv is None:
                raise ValueError(f"objects[{i}]: textured material {obj.material!r} needs a mesh with texture coordinates")
        object.__setattr__(self, "objects", objs)
        _text("name", self.name)
