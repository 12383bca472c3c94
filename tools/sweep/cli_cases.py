"""Command-line cases: one valid base invocation per command, then one hostile value at a time.

The options come from the Typer/click command tree, so a new option is swept without editing this
file; only the base invocations (which must succeed on the small fixtures) are written by hand.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tools.sweep import hostile

# Options whose value is a path the command writes (the rest of the path options are inputs).
OUTPUT_OPTIONS = frozenset({"out", "plot", "error_path", "preview", "confidence", "json_out", "report"})

_LENGTHS = ["--eye-separation", "0.063", "--viewing-distance", "2.2", "--screen-width", "1.1"]

# A valid invocation per command on the fixtures ({fx}) writing into the case folder ({case}).
BASES: dict[str, list[str]] = {
    # one 2D + depth image: a clip of one frame, no video decoder needed
    "analyze": ["{fx}/image.png", "--depth", "{fx}/depth.npy", "--depth-kind", "metric", "--display", "tv-55",
                "--report", "{case}/report"],
    # one 2D + depth image to a folder of one frame: no video encoder needed
    "convert": ["{fx}/image.png", "--depth", "{fx}/depth.npy", "--depth-kind", "metric", "--display", "tv-55",
                "--out", "{case}/converted", "--images"],
    "budget": ["--baseline", "0.1", "--convergence", "3", "--window", "1", *_LENGTHS, "--screen-pixels", "1920",
               "--depth", "5"],
    "mapping": ["--reference-baseline", "0.5", "--convergence", "20", "--window", "2.5", *_LENGTHS,
                "--constraint", "z=20,perceived=2.2,roundness=1", "--near", "10", "--far", "100"],
    "compare": ["{fx}/image.png", "{fx}/image_noisy.png"],
    "evaluate-disparity": ["{fx}/disp_left.pfm", "{fx}/disp_left_noisy.pfm"],
    "interpolate": ["--left", "{fx}/image.png", "--left-disparity", "{fx}/disp_left.pfm", "--right",
                    "{fx}/image_right.png", "--right-disparity", "{fx}/disp_right.pfm", "--position", "0.5",
                    "--out", "{case}/mid.png"],
    # the fixture's pair is 3 px apart with the right view ahead (D = -3): searched from -8, not piled up at 0
    "match": ["{fx}/image.png", "{fx}/image_right.png", "--min-disparity", "-8", "--max-disparity", "16", "--out",
              "{case}/disp.pfm"],
    "rectify": ["{fx}/left.png", "{fx}/right.png", "--cameras", "{fx}/cameras_par.txt", "--out", "{case}/rect"],
    "render": ["tabletop", "--out", "{case}/render", "--width", "16", "--height", "12", "--samples", "2",
               "--depth", "1"],
    "specular": ["glasses", "--out", "{case}/specular", "--width", "16", "--height", "12", "--k", "2", "--samples",
                 "1"],
    "synthesize": ["{fx}/image.png", "{fx}/depth.npy", "--out", "{case}/synth", "--budget-px", "4"],
    "demo": ["--out", "{case}/demo"],
}
# Options that exclude others: sweeping ``--display`` drops the three display lengths it replaces.
EXCLUDES = {"--display": set(_LENGTHS[0::2])}
# Options that need company to reach their own check: one synthesis control replaces another, and a
# PNG disparity map needs its scale (disparity = value / scale) before it is decoded.
CONTEXT: dict[tuple[str, str], tuple[set[str], list[str]]] = {
    ("synthesize", "--budget-arcmin"): ({"--budget-px"}, []),
    ("synthesize", "--focal-px"): ({"--budget-px"}, ["--interaxial", "0.065", "--convergence", "3"]),
    ("synthesize", "--interaxial"): ({"--budget-px"}, ["--focal-px", "500", "--convergence", "3"]),
}
PNG_SCALE = {("evaluate-disparity", "estimate"): "--estimate-scale", ("evaluate-disparity", "truth"): "--truth-scale",
             ("evaluate-disparity", "--truth-right"): "--truth-scale",
             ("interpolate", "--left-disparity"): "--disparity-scale",
             ("interpolate", "--right-disparity"): "--disparity-scale"}
# Commands whose base is too long for a sweep (the demo runs for minutes): only hostile outputs run.
LONG_COMMANDS = frozenset({"demo"})

# The cases of issue 9 that the generic sweep reaches only by chance, kept as regression cases.
ISSUE_CASES: tuple[tuple[str, tuple[str, ...], bool], ...] = (
    ("compare", ("--radius", "1e6"), False),
    ("match", ("--min-disparity", "-10000"), False),
    ("match", ("--max-disparity", "0", "--min-disparity", "-383"), False),
    ("match", ("--max-disparity", "-900", "--min-disparity", "-1000"), False),
    ("match", ("--block-size", "1001"), False),
    ("budget", ("--focal-mm", "5e-324", "--sensor-mm", "36"), False),
    ("budget", ("--baseline", "1e308"), False),
    ("mapping", ("--window", "5e-324", "--constraint", "z=20,perceived=5e-324"), False),
    ("mapping", ("--constraint", "z=20,perceived=2,roundness=1e9"), False),
    ("synthesize", ("--budget-px", "1e6"), False),
    ("synthesize", ("--budget-px", "200"), False),
    ("synthesize", ("--budget-px", "", "--focal-px", "5000", "--interaxial", "1", "--convergence", "3"), False),
    ("synthesize", ("--depth-kind", "inverse"), False),
    ("synthesize", ("--smooth-sigma", "-1"), False),
    ("render", ("--samples", "100000000"), False),
    ("render", ("--width", "1000000", "--height", "24"), False),
    ("render", ("--seed", "-1"), False),
    ("compare", ("{fx}/tiny.png", "{fx}/tiny.png"), False),
    # issue 26: a damaged or truncated offset table, a folder without one, an unknown fit, depth 0 on glass
    ("specular", ("--reoptimise", "{fx}/damaged_table"), True),
    ("specular", ("--reoptimise", "{fx}/truncated_table"), True),
    ("specular", ("--reoptimise", "{fx}/no_table"), True),
    ("specular", ("--fit", "wide"), True),
    ("specular", ("--depth", "0"), True),
    # issue 28: nothing lost (an output that exists is refused without --force; a missing --out folder is made),
    # a stereo INPUT whose layout cannot be guessed or is not one (the refusal names --layout)
    ("convert", ("--out", "{fx}/taken"), True),
    ("convert", ("--out", "{case}/new/deeper"), False),
    ("analyze", ("--report", "{fx}/old_report"), True),
    ("analyze", ("INPUT", "{fx}/sbs.png", "--depth", "", "--depth-kind", ""), True),
    ("analyze", ("INPUT", "{fx}/sbs.png", "--depth", "", "--depth-kind", "", "--layout", "lr"), True),
    ("convert", ("INPUT", "{fx}/sbs.png", "--depth", "", "--depth-kind", "", "--layout", "lr"), True),
    ("convert", ("INPUT", "{fx}/sbs.png", "--depth", "", "--depth-kind", "", "--layout", "sbs", "--floating-window",
                 ""), False),
    ("match", ("--min-disparity", "0"), False),  # the content at -3 px piles up at the bound 0: a warning, exit 0
)


# StereoSpace (issue 27): sub-commands of `vergence stereospace` on a built space of the fixtures
# (write_fixtures: a five-camera row over a textured plane, built once), the valid pair, then hostile
# inputs that must be refused in one line with exit code 2: a damaged points.npz (garbage, a cut zip,
# empty), an --out folder already used by another pair, unknown camera names.
STEREOSPACE_BASE = ("stereospace", "pair", "{fx}/space", "--at", "0,0.5,1,0.5", "--out", "{case}/pair", "--no-map")
STEREOSPACE_CASES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("damaged-points-garbage", ("stereospace", "pair", "{fx}/space_garbage", "--best", "--out", "{case}/pair")),
    ("damaged-points-cut", ("stereospace", "pair", "{fx}/space_cut", "--best", "--out", "{case}/pair")),
    ("damaged-points-empty", ("stereospace", "info", "{fx}/space_empty")),
    ("used-out", ("stereospace", "pair", "{fx}/space", "--best", "--out", "{fx}/used_out", "--no-map")),
    ("unknown-near", ("stereospace", "pair", "{fx}/space", "--near", "nobody", "--out", "{case}/pair")),
    ("unknown-view-at", ("stereospace", "view", "{fx}/stereo/cameras.json", "--images", "{fx}/stereo", "--at",
                         "nobody", "--out", "{case}/view.png")),
    ("view-at-without-image", ("stereospace", "view", "{fx}/stereo/cameras.json", "--images", "{fx}/stereo_gap",
                               "--at", "v2", "--out", "{case}/view.png")),
)


@dataclass(frozen=True)
class Case:
    """One run of the harness: a command line (``kind`` "cli"/"sigint") or a batch of API calls."""

    id: str
    kind: str
    target: str
    argv: tuple[str, ...] = ()
    hostile: bool = True
    strict: bool = False
    note: str = ""
    sigint_after: float | None = None
    outputs: tuple[str, ...] = ()  # what a finished run leaves (relative to its case folder)
    api_cases: tuple[dict, ...] = field(default=(), compare=False)


def write_fixtures(folder: Path) -> None:
    """Small valid inputs for the base invocations (a textured pair with its disparities, cameras)."""
    from vergence.camera import look_at
    from vergence.io import CameraSet, write_image, write_middlebury_par, write_pfm

    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    height, width, shift = 48, 64, 3
    texture = rng.random((height, width + shift, 3)).astype(np.float32)
    write_image(folder / "image.png", texture[:, shift:])
    write_image(folder / "image_right.png", texture[:, :width])
    noisy = np.clip(texture[:, shift:] + rng.normal(0, 0.02, (height, width, 3)), 0, 1).astype(np.float32)
    write_image(folder / "image_noisy.png", noisy)
    write_image(folder / "tiny.png", rng.random((2, 2, 3)).astype(np.float32))
    disparity = np.full((height, width), float(shift), np.float32)
    write_pfm(folder / "disp_left.pfm", disparity)
    write_pfm(folder / "disp_right.pfm", disparity)
    write_pfm(folder / "disp_left_noisy.pfm", disparity + rng.normal(0, 0.3, disparity.shape).astype(np.float32))
    depth = np.full((height, width), 4.0, np.float32)
    depth[16:32, 24:40] = 2.0
    np.save(folder / "depth.npy", depth)
    # A converging pair 0.1 m apart looking at a point 3 m ahead (the rectify fixture).
    cams = tuple(look_at((x, 0.0, 0.0), (0.0, 0.0, 3.0), (0.0, -1.0, 0.0), fov_deg=50.0, width=width, height=height)
                 for x in (-0.05, 0.05))
    write_image(folder / "left.png", texture[:, shift:])
    write_image(folder / "right.png", texture[:, :width])
    write_middlebury_par(folder / "cameras_par.txt", CameraSet(names=("left.png", "right.png"), cameras=cams))
    write_stereospace_fixtures(folder)
    # vergence specular --reoptimise (issue 26): a folder without a table, a table whose bytes are
    # damaged (a zip header, then noise) and one cut short (a real .npz archive, half of it)
    (folder / "no_table").mkdir(exist_ok=True)
    (folder / "damaged_table").mkdir(exist_ok=True)
    (folder / "damaged_table" / "specular_table.npz").write_bytes(b"PK\x03\x04" + rng.bytes(2048))
    (folder / "truncated_table").mkdir(exist_ok=True)
    whole = folder / "truncated_table" / "whole.npz"
    np.savez_compressed(whole, meta=np.array("{}"), analysis_disparity=rng.random((2, 3, 4, 5, 2)).astype(np.float32))
    data = whole.read_bytes()
    whole.unlink()
    (folder / "truncated_table" / "specular_table.npz").write_bytes(data[: len(data) // 2])
    # issue 28: a folder holding the output convert would write (refused without --force), a report folder holding
    # an earlier analyze report, and a side-by-side stereo image without a layout tag in its name
    (folder / "taken" / "image_LRF_Full_SBS").mkdir(parents=True, exist_ok=True)
    (folder / "taken" / "image_LRF_Full_SBS" / "frame_000000.png").write_bytes((folder / "image.png").read_bytes())
    (folder / "old_report").mkdir(exist_ok=True)
    (folder / "old_report" / "analysis.json").write_text("{}\n")
    write_image(folder / "sbs.png", np.concatenate([texture[:, shift:], texture[:, :width]], axis=1))


def write_stereospace_fixtures(folder: Path) -> None:
    """A built StereoSpace of five cameras on a row over a textured plane (``space``), copies whose
    ``points.npz`` is garbage, cut or empty, a used ``--out`` folder, and the images without ``v2``."""
    import shutil

    from vergence.camera import look_at
    from vergence.io import CameraSet, write_cameras_json, write_image
    from vergence.stereospace import build_space, save_space

    width, height, plane_z = 64, 48, 5.0
    for stale in ("stereo", "stereo_gap", "space", "space_garbage", "space_cut", "space_empty", "used_out"):
        shutil.rmtree(folder / stale, ignore_errors=True)  # a sweep run again into its folder
    stereo = folder / "stereo"
    stereo.mkdir(parents=True, exist_ok=True)
    cams = tuple(look_at([x, 0.0, 0.0], [0.0, 0.0, plane_z], [0.0, -1.0, 0.0], fov_deg=60.0, width=width,
                         height=height) for x in (-1.0, -0.5, 0.0, 0.5, 1.0))  # fmt: skip
    names = tuple(f"v{k}.png" for k in range(len(cams)))
    for name, cam in zip(names, cams):
        d = cam.ray_directions()
        t = (plane_z - cam.center[2]) / d[..., 2]
        x, y = cam.center[0] + t * d[..., 0], cam.center[1] + t * d[..., 1]
        g = 0.5 + 0.4 * np.sin(2.1 * x) * np.cos(2.7 * y)
        write_image(stereo / name, np.stack([g, 0.5 + 0.3 * np.sin(3.3 * x), 1.0 - g], axis=-1).astype(np.float32))
    rng = np.random.default_rng(7)
    pts = np.column_stack([rng.uniform(-2.5, 2.5, 150), rng.uniform(-1.5, 1.5, 150), np.full(150, plane_z)])
    obs, pixels = [], []
    for c, cam in enumerate(cams):
        xy, z = cam.project(pts)
        seen = np.flatnonzero((z > 0) & (xy[:, 0] >= 0) & (xy[:, 0] <= width - 1) & (xy[:, 1] >= 0)
                              & (xy[:, 1] <= height - 1))  # fmt: skip
        obs += [(int(p), c, int(p)) for p in seen]
        pixels.append(xy[seen])
    write_cameras_json(stereo / "cameras.json", CameraSet(
        names=names, cameras=cams, points=pts, colors=np.full((len(pts), 3), 128, np.uint8),
        observations=np.array(obs), observation_pixels=np.concatenate(pixels)))  # fmt: skip
    gap = shutil.copytree(stereo, folder / "stereo_gap")
    (gap / "v2.png").unlink()
    space = save_space(build_space(stereo / "cameras.json", images=stereo), folder / "space")
    whole = (space / "points.npz").read_bytes()
    for label, damage in (("garbage", b"not a zip archive\n" * 8), ("cut", whole[: len(whole) // 2]), ("empty", b"")):
        copy = shutil.copytree(space, folder / f"space_{label}")
        (copy / "points.npz").write_bytes(damage)
    (folder / "used_out").mkdir(exist_ok=True)
    (folder / "used_out" / "pair.json").write_text('{"a": "pair of another state"}\n')


def _option_kind(param) -> str:
    annotation = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    text = getattr(annotation, "__name__", None) or str(annotation)
    if getattr(param, "is_flag", False):
        return "flag"
    if "float" in text:
        return "float"
    if "int" in text:
        return "int"
    if "Path" in text:
        return "output" if param.name in OUTPUT_OPTIONS else "input"
    return "str"


def command_tree() -> dict[str, list]:
    """Command name -> its click parameters (options and arguments), from the Typer app."""
    import importlib

    import typer

    from vergence import cli

    # Commands may load on demand (listed in vergence.cli.COMMANDS): load them all, then ask the group.
    for module, _ in getattr(cli, "COMMANDS", {}).values():
        importlib.import_module(f"vergence.cli.{module}")
    group = typer.main.get_command(cli.app)
    ctx = group.context_class(group)
    commands = {name: group.get_command(ctx, name) for name in group.list_commands(ctx)}
    return {name: list(cmd.params) for name, cmd in sorted(commands.items()) if cmd is not None}


def python_names(tree: dict[str, list] | None = None) -> frozenset[str]:
    """Every Python parameter name of the public API and of the CLI functions (for ``python_name``)."""
    import importlib
    import inspect

    from tools.sweep.api_cases import API_MODULES

    names: set[str] = set()
    for module_name in API_MODULES:
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if callable(obj):
                try:
                    names.update(inspect.signature(obj).parameters)
                except (TypeError, ValueError):
                    pass
    for params in (tree or command_tree()).values():
        names.update(p.name for p in params)
    return frozenset(n for n in names if n and not n.startswith("_"))


def _replace_option(base: list[str], option: str, values: list[str], drop: set[str]) -> list[str]:
    """``base`` with ``option``'s value(s) replaced (or the option appended) and ``drop`` options removed."""
    out, i = [], 0
    while i < len(base):
        token = base[i]
        if token == option or token in drop:
            i += 2
            continue
        out.append(token)
        i += 1
    for value in values:
        out += [option] if value is None else [option, value]
    return out


def _hostile_values(kind: str, param) -> tuple[hostile.Hostile, ...]:
    if kind == "float":
        return hostile.FLOAT_VALUES
    if kind == "int":
        return hostile.INT_VALUES
    if kind == "output":
        return hostile.OUTPUT_VALUES
    if kind == "input":
        return tuple(hostile.Hostile(n, "{hostile}/" + n + hostile.FILE_SUFFIX[n], n in hostile.STRICT_FILES)
                     for n in hostile.FILE_SUFFIX)
    if kind == "flag":
        return (hostile.Hostile("set", "", False),)
    extra = ()
    if param.name == "scene":  # render's scene: a name or a JSON file
        extra = tuple(hostile.Hostile(n, "{hostile}/" + n + hostile.FILE_SUFFIX[n], True)
                      for n in ("missing", "folder", "empty_file", "nested_json", "bom_json", "garbage"))
    if param.name == "constraint":
        extra = (hostile.Hostile("subnormal_constraint", "z=5e-324,perceived=5e-324", False),
                 hostile.Hostile("nan_constraint", "z=nan,perceived=2", True),
                 hostile.Hostile("huge_roundness", "z=20,perceived=2,roundness=1e9", False))
    return hostile.STR_VALUES + extra


def cli_cases(*, quick: bool, rng: random.Random, per_option: int = 1, sample: int | None = None) -> list[Case]:
    """Every command x option x hostile value, then the issue's cases.

    ``quick``: ``per_option`` values drawn per option, and of those ``sample`` cases drawn at random
    (the bases and the issue's cases always run).
    """
    cases: list[Case] = []
    for command, params in command_tree().items():
        base = BASES.get(command)
        if base is None:
            continue
        if command not in LONG_COMMANDS:
            cases.append(Case(id=f"cli/{command}/base", kind="cli", target=command, argv=(command, *base),
                              hostile=False, note="the valid base invocation"))
        for param in params:
            kind = _option_kind(param)
            if command in LONG_COMMANDS and kind != "output":
                continue
            values = list(_hostile_values(kind, param))
            if quick and len(values) > per_option:
                values = rng.sample(values, per_option)
            for value in values:
                if value.name == "input_file" and not any("{fx}/" in t for t in base):
                    continue  # the command reads no file: there is no input to overwrite
                cases.append(_case_for(command, base, params, param, kind, value))
    if quick and sample is not None:
        bases = [c for c in cases if not c.hostile and c.id.endswith("/base")]
        rest = [c for c in cases if c not in bases]
        cases = bases + rng.sample(rest, min(sample, len(rest)))
    cases.append(Case(id="cli/stereospace/base", kind="cli", target="stereospace", argv=STEREOSPACE_BASE,
                      hostile=False, note="the valid base invocation"))
    for name, argv in STEREOSPACE_CASES:
        cases.append(Case(id=f"cli/stereospace/issue27-{name}", kind="cli", target="stereospace", argv=argv,
                          strict=True, note="issue 27: " + name.replace("-", " ")))
    for n, (command, extra, strict) in enumerate(ISSUE_CASES):
        argv = list(BASES[command])
        if command == "compare" and extra[0].startswith("{fx}"):
            argv = list(extra)
        else:
            for option, v in zip(extra[0::2], extra[1::2]):
                if option == "INPUT":  # the first argument (positional arguments come first in every base)
                    argv[0] = v
                elif option == "--floating-window":  # a flag: added
                    argv.append(option)
                else:
                    argv = _replace_option(argv, option, [] if v == "" else [v], set())
        cases.append(Case(id=f"cli/{command}/issue9-{n}", kind="cli", target=command, argv=(command, *argv),
                          strict=strict, note="issue 9: " + " ".join(extra)))
    return cases


def _case_for(command: str, base: list[str], params: list, param, kind: str, value: hostile.Hostile) -> Case:
    label = param.opts[0]
    if param.param_type_name == "argument":
        index = [p.name for p in params if p.param_type_name == "argument"].index(param.name)
        positional = [t for t in base if not t.startswith("--")]
        # Positional arguments come first in every base invocation.
        argv = list(base)
        argv[argv.index(positional[index])] = value.text
    elif kind == "flag":
        argv = _replace_option(base, label, [None], set())
    else:
        drop, extra = CONTEXT.get((command, label), (set(), []))
        argv = _replace_option(base, label, [value.text], EXCLUDES.get(label, set()) | drop) + extra
        if label == "--display":
            argv = _replace_option(argv, "--screen-pixels", [], set())
    scale = PNG_SCALE.get((command, label))
    if scale and kind == "input" and value.text.endswith((".png", ".jpg")) and scale not in argv:
        argv += [scale, "16"]
    return Case(id=f"cli/{command}/{param.name}={value.name}", kind="cli", target=command, argv=(command, *argv),
                hostile=kind != "flag", strict=value.strict, note=f"{label} {value.name}")


def sigint_cases(*, count: int, rng: random.Random) -> list[Case]:
    """Ctrl-C at random moments (0 to 4 s, imports included) into commands that write outputs."""
    targets = [("synthesize", [*BASES["synthesize"], "--views", "8", "--format", "views"]), ("render", BASES["render"]),
               ("match", BASES["match"]), ("interpolate", BASES["interpolate"]), ("budget", BASES["budget"])]
    # A run that exits 0 after Ctrl-C must have finished: the signal came after the work (while the
    # interpreter shut down), and every output is there; a swallowed interrupt would leave some out.
    outputs = {"synthesize": tuple(f"synth/view_{i:02d}.png" for i in range(8)) + ("synth/synthesis.json",),
               "render": ("render",), "match": ("disp.pfm",), "interpolate": ("mid.png",), "budget": ()}
    cases = []
    for n in range(count):
        command, argv = targets[n % len(targets)]
        delay = round(rng.uniform(0.0, 4.0), 2)
        cases.append(Case(id=f"sigint/{command}/{n}@{delay}s", kind="sigint", target=command,
                          argv=(command, *argv), hostile=False, sigint_after=delay, outputs=outputs[command],
                          note=f"SIGINT after {delay} s"))
    return cases


def random_cases(*, count: int, rng: random.Random) -> list[Case]:
    """Random extreme parameter sets for ``budget`` and ``mapping`` (log-uniform magnitudes, any sign)."""

    def extreme() -> str:
        magnitude = 10.0 ** rng.uniform(-320, 308)
        return repr(magnitude if rng.random() < 0.8 else -magnitude)

    cases = []
    for n in range(count):
        if n % 2 == 0:
            argv = ["budget", "--baseline", extreme(), "--convergence", extreme(), "--window", extreme(),
                    "--eye-separation", extreme(), "--viewing-distance", extreme(), "--screen-width", extreme(),
                    "--depth", extreme(), "--json"]
        else:
            argv = ["mapping", "--reference-baseline", extreme(), "--convergence", extreme(), "--window", extreme(),
                    *_LENGTHS, "--constraint", f"z={extreme()},perceived={extreme()}", "--near", extreme(),
                    "--far", extreme(), "--json"]
        cases.append(Case(id=f"random/{argv[0]}/{n}", kind="cli", target=argv[0], argv=tuple(argv),
                          note="random extreme parameters"))
    return cases
