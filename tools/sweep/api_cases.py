"""Python API cases: every public name called with one hostile argument at a time.

A call starts from guessed valid arguments (by annotation, then by parameter name: ``image`` is a
small RGB array, ``depth`` a (H, W) map, ``display`` a desktop display); one argument is then replaced
by a hostile value of its kind. The same code builds the values in the parent (to list the cases) and
in the driver subprocess (to make the calls), so a case is just (module, name, parameter, token).
"""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import numpy as np

API_MODULES = (
    "vergence.camera",
    "vergence.display",
    "vergence.metrics",
    "vergence.depth",
    "vergence.io",
    "vergence.render",
    "vergence.report.budget_plot",
    "vergence.report.mapping_plot",
    "vergence.report.preview",
    "vergence.rigs",
    "vergence.synthesis",
    "vergence.viewing",
)
# Public names not called: the demo runs for minutes; the abstract base has nothing to call.
SKIPPED = frozenset({"run_demo", "DisparityMapping", "atomic_write", "select_variant"})

# Records inside results (a budget's samples, a render's settings and ray tree, the camera-format
# table's rows) and the classes that a function returns but a user also builds (cameras, scenes,
# camera sets, blends): see result_types().
NESTED_RECORDS = frozenset({"DepthSample", "RenderSettings", "Hits", "RayTree", "CameraFormat"})
USER_BUILT = frozenset({"Camera", "CameraSet", "Scene", "BlendedMapping"})

HEIGHT, WIDTH = 24, 48  # wide enough for the matchers' smallest disparity search (16)
IMAGE_NAMES = frozenset({"image", "left", "right", "reference", "guide", "left_image", "right_image", "source_image",
                         "radiance", "colors", "color"})
MASK_NAMES = frozenset({"mask", "holes", "support", "update"})
SCALAR_NAMES = {"z": 5.0, "d": 0.01, "parallax_px": 4.0, "disparity_arcmin": 10.0, "x_center": 8.0, "cos_i": 0.5,
                "n1": 1.0, "n2": 1.5, "target": 0.5, "position": 0.5, "t": 0.5, "s": 0.5}
NUMBER_DEFAULTS = {"baseline": 0.1, "convergence": 3.0, "window": 1.0, "focal_px": 500.0, "interaxial": 0.065,
                   "distance": 2.0, "eye_separation": 0.063, "width": 16, "height": 12, "fov_deg": 50.0,
                   "max_disparity": 4, "radius": 2, "sigma": 1.0, "lo": 0.0, "hi": 8.0, "scale": 1.0,
                   "threshold": 1.0, "near": 10.0, "far": 100.0, "transition": 0.5, "max_size": 4,
                   "max_depth": 2, "views": 2, "num_disparities": 16, "channels": 3, "ior": 1.5,
                   "source_min": 0.0, "source_max": 10.0, "target_min": 0.0, "target_max": 10.0}
SEQUENCE_DEFAULTS = {"positions": [0.0, 1.0], "weights": [0.5, 0.5], "cuts": [0.5], "offsets": (-0.5, 0.5),
                     "constraints": ["z=20,perceived=2.2,roundness=1"], "squares": (8, 8), "size": (1.0, 1.0)}
READ_FIXTURES = {"read_image": "image.png", "read_pfm": "disp_left.pfm", "read_depth": "depth.npy",
                 "read_disparity": "disp_left.pfm", "read_cameras": "cameras_par.txt",
                 "read_middlebury_par": "cameras_par.txt", "cameras_for_images": "cameras_par.txt",
                 "read_cameras_json": "cameras.json", "stores_integers": "image.png", "load_scene": "scene.json",
                 "open_scene": "tabletop", "read_colmap": ".", "read_bundler": "cameras_par.txt",
                 "read_middlebury_masks": "."}
WRITE_SUFFIX = {"write_image": ".png", "write_pfm": ".pfm", "write_disparity": ".pfm", "write_json": ".json",
                "write_cameras": ".json", "write_cameras_json": ".json", "write_bundler": ".out",
                "write_colmap": "", "write_middlebury_par": "_par.txt", "plot_budget": ".png", "plot_mapping": ".png",
                "save_render": ""}

# Vectors by parameter name (scene geometry, colours); the second camera of a pair sits 0.1 m right.
VECTOR_NAMES = {"position": (0.0, 0.0, 0.0), "target": (0.0, 0.0, 3.0), "look_at": (0.0, 0.0, 3.0),
                "up": (0.0, -1.0, 0.0), "center": (0.0, 0.0, 3.0), "normal": (0.0, 0.0, -1.0),
                "color": (0.5, 0.5, 0.5), "colors": ((0.2, 0.2, 0.2), (0.8, 0.8, 0.8)), "t": (0.0, 0.0, 0.0)}
SECOND_CAMERA_NAMES = frozenset({"right", "target", "b", "right_camera"})
# Valid values that neither the annotation nor the name gives; options a call needs (one control).
VALID_OVERRIDES = {
    ("Camera", "K"): lambda v: np.array([[50.0, 0, (WIDTH - 1) / 2], [0, 50.0, (HEIGHT - 1) / 2], [0, 0, 1]]),
    ("Camera", "R"): lambda v: np.eye(3),
    ("FisheyeCamera", "R"): lambda v: np.eye(3),
    ("synthesize_views", "parallax_px"): lambda v: v.map - 3.0,
    ("Mesh", "vertices"): lambda v: np.array([[0.0, 0, 3], [1, 0, 3], [0, 1, 3]]),
    ("Mesh", "faces"): lambda v: np.array([[0, 1, 2]]),
    ("Environment", "color"): lambda v: np.array([0.5, 0.5, 0.5]),
    ("scene_from_dict", "data"): lambda v: {"camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, -1, 0],
                                                       "fov_deg": 50, "width": 8, "height": 6},
                                            "environment": {"color": [1.0, 1.0, 1.0]},
                                            "materials": {"m": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}},
                                            "objects": [{"type": "sphere", "center": [0, 0, 3], "radius": 1,
                                                         "material": "m"}]},
}
EXTRA_KWARGS = {"plan_parallax": {"budget_px": 4.0}, "synthesize_stereo": {"budget_px": 4.0},
                "Environment": {"color": np.array([0.5, 0.5, 0.5])}}

# Parameters that name a folder (given the hostile folder they must work; given a file, refuse).
FOLDER_PARAMETERS = frozenset({("scene_from_dict", "base_dir"), ("atomic_folder", "path")})
# Functions that read only a path's name, never the file (stores_integers: by its extension), swept as
# output paths; and functions whose arrays broadcast (schlick; shift_sensor_positions, Fehn's formula
# applied element-wise), where another shape is no mistake.
NAME_ONLY_PATHS = frozenset({"stores_integers"})
BROADCASTING = frozenset({"schlick", "shift_sensor_positions"})

# Hostile tokens per kind of parameter; a trailing "!" marks a strict one (any normal return is suspect).
HOSTILE_TOKENS = {
    "number": ("nan!", "inf", "neg_inf!", "negative", "zero", "subnormal", "huge", "numeric_string!", "none!"),
    "array": ("empty", "all_nan", "other_shape", "four_channels", "one_d", "string!", "none!", "negative",
              "uint8", "huge_values"),
    "object": ("none!", "string!", "number!"),
    "path": ("missing!", "folder!", "empty_file!", "truncated_png!", "huge_png!", "huge_jpeg!", "huge_hdr!",
             "truncated_pfm!", "pfm_3_channels", "nested_json!", "bom_json", "garbage!"),
    "out_path": ("existing_folder", "missing_parent", "unknown_extension"),
    "folder": ("missing", "folder", "empty_file!", "nested_json!", "garbage!"),  # a folder is valid here
    "str": ("empty", "unknown", "none!", "number!"),  # a title may be anything; a method name may not
    "sequence": ("empty", "none!", "string!", "nan_items!"),
    "bool": ("none!", "string!"),
    "any": (),  # an argument that may be anything (the object write_json serialises)
}


# Array tokens whose degenerate result (all NaN, empty) shows a value returned instead of an error;
# other arrays (negative, huge, of another shape) may well map to NaN by convention (invalid = NaN).
CONTENTLESS_ARRAYS = frozenset({"all_nan", "empty"})
# The "parameter" of a case that gives every required array argument the same hostile value (two
# empty masks agree how well?).
ALL_ARRAYS = "*"


def public_callables() -> list[tuple[str, str]]:
    """(module, name) of every public callable in :data:`API_MODULES`."""
    found = []
    for module_name in API_MODULES:
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):
            if name not in SKIPPED and callable(getattr(module, name)) and not name.isupper():
                found.append((module_name, name))
    return found


def result_types(callables: list[tuple[str, str]]) -> frozenset[str]:
    """Names of the classes that public functions return: records of results, built by the library.

    Their fields are not validated on construction (the library fills them), so only their base call
    runs; the classes a user builds (``Display``, ``Shooting``, ``Camera``) are swept like functions.
    """
    returned = set()
    for module_name, name in callables:
        obj = getattr(importlib.import_module(module_name), name)
        if inspect.isclass(obj):
            continue
        try:
            returned.add(str(inspect.signature(obj).return_annotation))
        except (TypeError, ValueError):
            pass
    text = " ".join(returned)
    found = {n for _, n in callables if re.search(rf"\b{n}\b", text)}
    return frozenset((found | NESTED_RECORDS) - USER_BUILT)


def param_kind(func_name: str, name: str, annotation: str) -> str:
    """The kind of value a parameter takes (a key of :data:`HOSTILE_TOKENS`)."""
    a = annotation
    if name == "obj":
        return "any"
    if (func_name, name) in FOLDER_PARAMETERS:
        return "folder"
    if "PathLike" in a or a in ("str | Path", "str | Path | None"):
        writes = func_name in WRITE_SUFFIX or func_name.startswith("write_") or func_name in NAME_ONLY_PATHS
        return "out_path" if writes else "path"
    if (name in SEQUENCE_DEFAULTS or "Sequence" in a or a.startswith(("tuple", "list"))
            or name in ("views", "operators")):
        if name != "views" or "Sequence" in a:
            return "sequence"
    if any(k in a for k in ("Camera", "Display", "Shooting", "Scene", "Mapping", "WarpedView", "RenderResult",
                            "Generator", "Progress", "ComfortZone", "Rectification", "Environment", "Stereo",
                            "Budget", "Material")):
        return "object"
    if a.startswith("bool"):
        return "bool"
    if a.startswith(("float", "int")) and "ndarray" not in a:
        return "number"
    if a.startswith("str"):
        return "str"
    return "array"


class Values:
    """Builds valid and hostile argument values inside ``folder`` (fixtures in ``folder/fixtures``)."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.fixtures = self.folder / "fixtures"
        self.hostile = self.folder / "hostile"
        self.out = self.folder / "api_out"
        self.out.mkdir(parents=True, exist_ok=True)
        self._cache: dict[str, object] = {}
        rng = np.random.default_rng(1)
        self.rgb = rng.random((HEIGHT, WIDTH, 3)).astype(np.float32)
        ramp = np.linspace(2.0, 4.0, WIDTH, dtype=np.float32)
        self.map = np.broadcast_to(ramp, (HEIGHT, WIDTH)).copy()

    # --- objects, built once per process -------------------------------------------------------
    def _object(self, annotation: str) -> object:
        if annotation in self._cache:
            return self._cache[annotation]
        from vergence.camera import look_at
        from vergence.viewing import Display, LinearMapping, Shooting

        if "CameraSet" in annotation:
            from vergence.io import read_middlebury_par

            value = read_middlebury_par(self.fixtures / "cameras_par.txt")
        elif "WarpedView" in annotation:
            from vergence.synthesis import forward_warp

            value = forward_warp(self.rgb, self.map)
        elif "RenderResult" in annotation:
            from vergence.render import builtin_scene, render

            value = render(builtin_scene("tabletop", width=8, height=6), samples=1, max_depth=1)
        elif "SceneCamera" in annotation or "Stereo" in annotation or "Environment" in annotation:
            value = None
        elif "Scene" in annotation:
            from vergence.render import builtin_scene

            value = builtin_scene("tabletop", width=8, height=6)
        elif "Camera" in annotation:
            value = look_at((0.0, 0.0, 0.0), (0.0, 0.0, 3.0), (0.0, -1.0, 0.0), fov_deg=50.0, width=WIDTH,
                            height=HEIGHT)
        elif "Display" in annotation:
            value = Display(eye_separation=0.063, distance=2.2, width=1.1, resolution=1920)
        elif "Shooting" in annotation:
            value = Shooting(baseline=0.1, convergence=3.0, window=1.0)
        elif "Mapping" in annotation:
            value = LinearMapping(0.0, 10.0, 0.0, 10.0)
        elif "Generator" in annotation:
            value = np.random.default_rng(0)
        else:
            value = None
        self._cache[annotation] = value
        return value

    def valid(self, func_name: str, name: str, annotation: str) -> object:
        """A plausible valid value for parameter ``name`` of ``func_name``."""
        if (func_name, name) in VALID_OVERRIDES:
            return VALID_OVERRIDES[(func_name, name)](self)
        kind = param_kind(func_name, name, annotation)
        if kind == "object" and "Camera" in annotation and name in SECOND_CAMERA_NAMES:
            from vergence.camera import look_at

            return look_at((0.1, 0.0, 0.0), (0.0, 0.0, 3.0), (0.0, -1.0, 0.0), fov_deg=50.0, width=WIDTH,
                           height=HEIGHT)
        if name in VECTOR_NAMES and kind == "array":
            return np.asarray(VECTOR_NAMES[name], float)
        if kind == "folder":
            return str(self.fixtures)
        if kind == "path":
            fixture = READ_FIXTURES.get(func_name, "image.png")
            return fixture if fixture == "tabletop" else str(self.fixtures / fixture)
        if kind == "out_path":
            return str(self.out / f"{func_name}{WRITE_SUFFIX.get(func_name, '.png')}")
        if kind == "sequence":
            if "WarpedView" in annotation:
                view = self._object("WarpedView")
                return [view, view]
            if name == "operators":
                mapping = self._object("Mapping")
                return [mapping, mapping]
            if name == "views":
                return [self.rgb, self.rgb]
            return SEQUENCE_DEFAULTS.get(name, [1.0, 2.0])
        if kind == "object":
            return self._object(annotation)
        if kind == "bool":
            return False
        if kind == "number":
            value = NUMBER_DEFAULTS.get(name, 1.0)
            return int(value) if annotation.startswith("int") else float(value)
        if kind == "str":
            return {"name": "tabletop", "material": "m", "scene": "tabletop"}.get(name, "x")
        if name in SCALAR_NAMES:
            return SCALAR_NAMES[name]
        if _image_like(func_name, name):
            return self.rgb.copy()
        if name in MASK_NAMES or "mask" in func_name:
            return np.ones((HEIGHT, WIDTH), bool)
        return self.map.copy()

    def hostile_value(self, func_name: str, name: str, annotation: str, token: str) -> object:
        """The hostile value ``token`` (without its "!") for that parameter."""
        kind = param_kind(func_name, name, annotation)
        token = token.rstrip("!")
        image_like = _image_like(func_name, name)
        if kind in ("path", "folder"):
            from tools.sweep.hostile import FILE_SUFFIX

            return str(self.hostile / f"{token}{FILE_SUFFIX[token]}")
        if kind == "out_path":
            suffix = WRITE_SUFFIX.get(func_name, ".png")
            return str({"existing_folder": self.out / "existing_dir",
                        "missing_parent": self.out / "no" / "such" / f"x{suffix}",
                        "unknown_extension": self.out / "x.xyz"}[token])
        common = {"none": None, "string": "abc", "numeric_string": "30", "number": 1.5}
        if token in common:
            return common[token]
        if kind == "number":
            return {"nan": float("nan"), "inf": float("inf"), "neg_inf": float("-inf"), "negative": -1.0,
                    "zero": 0.0, "subnormal": 5e-324, "huge": 1e308}[token] if not annotation.startswith("int") else \
                {"nan": float("nan"), "inf": float("inf"), "neg_inf": float("-inf"), "negative": -1, "zero": 0,
                 "subnormal": 5e-324, "huge": 2**63}[token]
        if kind == "str":
            return {"empty": "", "unknown": "no-such-choice"}[token]
        if kind == "sequence":
            return {"empty": [], "nan_items": [float("nan"), float("nan")]}[token]
        shape = (HEIGHT, WIDTH, 3) if image_like else (HEIGHT, WIDTH)
        # The shape tokens keep the valid values (a scalar's value, a map's mean): only the shape is wrong.
        fill = float(np.mean(self.valid(func_name, name, annotation))) if not image_like else 0.5
        if token == "empty":
            return np.empty((0, 0, 3) if image_like else (0, 0), np.float32)
        if token == "all_nan":
            return np.full(shape, np.nan, np.float32)
        if token == "other_shape":
            return np.full((5, 7, 3) if image_like else (5, 7), fill, np.float32)
        if token == "four_channels":
            return np.full((HEIGHT, WIDTH, 4), fill, np.float32)
        if token == "one_d":
            return np.full(WIDTH, fill, np.float32)
        if token == "negative":
            return -np.ones(shape, np.float32)
        if token == "uint8":
            return np.full(shape, 200, np.uint8)
        if token == "huge_values":
            return np.full(shape, 1e38, np.float32)
        raise KeyError(token)


def _image_like(func_name: str, name: str) -> bool:
    """Whether a parameter takes an RGB image (a mask function's ``reference`` is a mask)."""
    return name in IMAGE_NAMES and "mask" not in func_name


def annotations_of(func) -> dict[str, tuple[str, bool, object]]:
    """Parameter name -> (annotation text, required, default) of a callable (``self`` and ``**`` left out)."""
    out = {}
    for p in inspect.signature(func).parameters.values():
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        annotation = p.annotation if isinstance(p.annotation, str) else getattr(p.annotation, "__name__", "")
        out[p.name] = (str(annotation or ""), p.default is p.empty, p.default)
    return out


def api_case_specs(*, quick: bool, rng, per_param: int = 2) -> list[dict]:
    """The API cases: for each public callable a base call, then each parameter x hostile token."""
    specs = []
    callables = public_callables()
    records = result_types(callables)
    for module_name, name in callables:
        func = getattr(importlib.import_module(module_name), name)
        try:
            params = annotations_of(func)
        except (TypeError, ValueError):
            continue
        if name in records:  # built by the library from valid parts: nothing for a user to get wrong
            continue
        specs.append({"id": f"api/{name}/base", "module": module_name, "name": name, "param": None, "token": None})
        # Arrays the valid call passes (the required ones): only those must agree in shape; an optional
        # array left out (middlebury_regions' image, truth_right) leaves the first free to change shape.
        n_arrays = sum(param_kind(name, p, a) == "array" and req for p, (a, req, _) in params.items())
        n_required_arrays = sum(param_kind(name, p, a) == "array" and required
                                for p, (a, required, _) in params.items())
        if n_required_arrays >= 2:
            for token in sorted(CONTENTLESS_ARRAYS):
                specs.append({"id": f"api/{name}/{ALL_ARRAYS}={token}", "module": module_name, "name": name,
                              "param": ALL_ARRAYS, "token": token, "kind": "array"})
        for pname, (annotation, required, _) in params.items():
            kind = param_kind(name, pname, annotation)
            tokens = list(HOSTILE_TOKENS[kind])
            if not required or "None" in annotation:
                tokens = [t for t in tokens if t != "none!"]
            if kind == "array" and n_arrays >= 2 and name not in BROADCASTING:  # disagrees with the other arrays
                tokens = [t + "!" if t == "other_shape" else t for t in tokens]
            if quick and len(tokens) > per_param:
                tokens = rng.sample(tokens, per_param)
            for token in tokens:
                specs.append({"id": f"api/{name}/{pname}={token.rstrip('!')}", "module": module_name, "name": name,
                              "param": pname, "token": token, "kind": kind})
    return specs
