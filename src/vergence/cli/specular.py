"""``vergence specular``: glass and mirrors made fusible by per-pixel, per-layer camera offsets (S3, issue 12).

Opens a scene file or a built-in scene with its stereo rig, runs
:func:`vergence.specular.specular_stereo` (the offset table, the per-pixel offsets, the final render
with a camera per layer and pixel, S3 §4's baselines) and writes its files with
:func:`vergence.report.specular_outputs.write_specular_outputs` into ``--out``: all or none. Every
option, weight map and the cost of the renders are checked before the first ray is traced.

``--weight-map`` paints S3 Eq. 2's per-layer, per-pixel weights (S3 §3.3): ``LAYER=FILE`` scales
every cost term of layer ``LAYER`` (1-based, as ``report.json``'s ``"layer"``), ``TERM:LAYER=FILE``
only ``TERM`` (:data:`vergence.specular.COST_TERMS`); maps of the same term and layer multiply.
``FILE`` is a grey image of the render's size: PNG/PGM/JPEG values / max code (so in [0, 1]),
``.pfm``/``.npy``/``.hdr`` as stored; finite, in [0, 1e6].
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from vergence.cli import raise_if_interrupted
from vergence.cli._app import (app, check_output_path, console, err_console, open_scene_quietly, options_named,
                               preset_display, spoken)
from vergence.commands import ParameterError
from vergence.commands._scene import scene_rig
from vergence.commands._specular import MAX_WEIGHT as _MAX_WEIGHT  # largest --weights value (and painted weight)
from vergence.commands._specular import weight_maps

__all__ = ["DEFAULT_DISPLAY", "specular"]

#: ``--display``'s default: S3's study display (Samsung 2233RZ, 22" 16:10, 1680 px wide, viewed from 60 cm).
DEFAULT_DISPLAY = "samsung-2233rz"
# OffsetPlanner's range of the reduction factor (checked here too: the planner runs after the table).
_FACTOR_RANGE = (1, 64)


def _weights(text: str | None) -> tuple[float, float, float, float] | None:
    """``--weights A,P,R,D`` as four finite numbers >= 0 (absolute, relative, rivalry, data)."""
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4 or not all(0 <= v <= _MAX_WEIGHT for v in values):  # NaN fails too
        raise ValueError(f"--weights must be four numbers in [0, {_MAX_WEIGHT:g}], absolute,relative,rivalry,data "
                         f"(e.g. 1,1,10,0.1); got {text!r}")  # fmt: skip
    return values  # type: ignore[return-value]


def _check_render_cost(width: int, height: int, depth: int, samples: int, k: int) -> None:
    """Refuse a render past the renderer's limits, or an offset table past its memory limit, before
    the first of the k + 2 renders."""
    from vergence.render.limits import render_cost
    from vergence.specular import MAX_TABLE_BYTES, offset_table_bytes

    with options_named(samples="--samples", max_depth="--depth", width="--width", height="--height"):
        one = render_cost(width, height, max_depth=depth, samples=samples)
    if one.problem() is not None:
        raise ValueError(f"one render of {width}x{height} pixels with --depth {depth}, --samples {samples} "
                         f"{one.problem()}: lower --width/--height, --depth or --samples")  # fmt: skip
    need = offset_table_bytes(width, height, k=k, max_depth=depth)
    if need > MAX_TABLE_BYTES:
        raise ValueError(f"the offset table of --k {k} at {width}x{height} with --depth {depth} needs about "
                         f"{need / 2**30:.1f} GiB of memory; the limit is {MAX_TABLE_BYTES / 2**30:g} GiB "
                         "(MAX_TABLE_BYTES): lower --k, --width/--height or --depth")  # fmt: skip


def _share(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.0f} %"


def _summary(name: str, result, display_name: str, out: Path, names: list[str]) -> None:  # noqa: ANN001
    rep = result.report()
    s, cam = rep["settings"], result.physical_left.camera
    console.print(f"specular {name}: {cam.width}x{cam.height}, {len(rep['layers'])} layers (D = {s['max_depth']}), "
                  f"k = {s['k']}, absolute term {s['variant']!r}, weights {s['alpha']}, display {display_name}, "
                  f"comfort zone {rep['comfort_zone_arcmin'][0]:g}..{rep['comfort_zone_arcmin'][1]:g} arcmin",
                  highlight=False)  # fmt: skip
    if not result.specular:
        console.print("no specular surface in view: the outputs are the physical pair (report.json \"specular\": "
                      "false)", highlight=False)  # fmt: skip
    for layer in rep["layers"]:
        if layer["pixels"]:
            console.print(f"  layer {layer['layer']} ({layer['name']}): {layer['pixels']} px, comfort share "
                          f"{_share(layer['comfort_share_before'])} -> {_share(layer['comfort_share_after'])}, "
                          f"matched {_share(layer['matched_before'])} -> {_share(layer['matched_after'])}, "
                          f"mean offset {layer['offset_mean']:.3f}", highlight=False)  # fmt: skip
    b, a = rep["cost_before"], rep["cost_after"]
    console.print("cost (mean per pixel) before -> after: " + ", ".join(f"{t} {b[t]:.4g} -> {a[t]:.4g}" for t in b),
                  highlight=False)  # fmt: skip
    console.print("times: " + ", ".join(f"{k} {v:.2f} s" for k, v in rep["seconds"].items()), highlight=False)
    console.print(f"wrote {len(names)} files to {out}:", highlight=False)
    for n in names:
        console.print(f"  {out / n}", highlight=False)


@app.command("specular")
def specular(
    scene: str = typer.Argument(..., help="Scene file (.json, docs/scenes.md) or built-in: glasses, stadium, tabletop."),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing)."),
    display: str = typer.Option(DEFAULT_DISPLAY, "--display", help="Display preset the pair is made for (S3's study "
                                "display by default)."),
    weights: str | None = typer.Option(None, "--weights", metavar="A,P,R,D", help="Cost weights: absolute, relative, "
                                       "rivalry, data (S3 §4: 1,1,10,0.1)."),
    weight_map: list[str] = typer.Option(
        [], "--weight-map", metavar="[TERM:]LAYER=FILE",
        help="Painted weights of layer LAYER (1-based), every cost term or only TERM (absolute, relative, rivalry, "
             "data): a grey image of the render's size (PNG: value / max code). Repeatable; maps multiply.",
    ),
    k: int = typer.Option(32, "--k", help="Offset steps of the table (S3: 32): k + 1 renders of the left eye."),
    width: int | None = typer.Option(None, "--width", help="Image width in pixels (default: the scene's)."),
    height: int | None = typer.Option(None, "--height", help="Image height in pixels (default: the scene's)."),
    depth: int = typer.Option(2, "--depth", help="Maximum specular bounces D: 2^(D+1)-1 layers (S3: 2)."),
    samples: int = typer.Option(16, "--samples", help="Ambient-occlusion rays per diffuse hit."),
    absolute: str | None = typer.Option(None, "--absolute", metavar="comfort|screen", help="The absolute term: "
                                        "'comfort' costs only what lies outside the comfort zone, 'screen' is "
                                        "S3's (pulls every layer to the screen). Default: comfort."),
    factor: int | None = typer.Option(None, "--factor", help="Solve the offsets on factor x factor blocks, then "
                                      "upsample (S3 §3.4; default 4)."),
    baseline: float | None = typer.Option(None, "--baseline", help="Rig baseline b in metres (default: the scene's)."),
    convergence: float | None = typer.Option(None, "--convergence", help="Convergence distance H in metres (default: "
                                             "the scene's)."),
    anaglyph_method: str = typer.Option("dubois", "--anaglyph", help="Anaglyph method of the *_anaglyph.png files."),
) -> None:
    """Make the glass and mirrors of SCENE fusible (S3): per-layer offsets, renders, analysis, report."""
    from vergence import render as vr
    from vergence.display import ANAGLYPH_METHODS
    from vergence.io import atomic_folder
    from vergence.report.specular_outputs import SPECULAR_OUTPUT_FILES, write_specular_outputs
    from vergence.specular import (ABSOLUTE_VARIANTS, COST_WEIGHTS, DEFAULT_VARIANT, MAX_OFFSET_STEPS, PLAN_FACTOR,
                                   specular_stereo)

    variant = DEFAULT_VARIANT if absolute is None else absolute
    if variant not in ABSOLUTE_VARIANTS:
        raise ValueError(f"--absolute must be one of {', '.join(ABSOLUTE_VARIANTS)}; got {variant!r}")
    if not 2 <= k <= MAX_OFFSET_STEPS:
        raise ValueError(f"--k must be a whole number in [2, {MAX_OFFSET_STEPS}] (offsets m/k, m = 0..k); got {k}")
    factor = PLAN_FACTOR if factor is None else factor
    if not _FACTOR_RANGE[0] <= factor <= _FACTOR_RANGE[1]:
        raise ValueError(f"--factor must be a whole number in [{_FACTOR_RANGE[0]}, {_FACTOR_RANGE[1]}]; got {factor}")
    if anaglyph_method not in ANAGLYPH_METHODS:
        raise ValueError(f"--anaglyph must be one of {', '.join(ANAGLYPH_METHODS)}; got {anaglyph_method!r}")
    if not 0 <= depth <= vr.MAX_DEPTH:
        raise ValueError(f"--depth must be a whole number in [0, {vr.MAX_DEPTH}]; got {depth}")
    alpha = _weights(weights)
    screen = preset_display(display)
    with options_named(width="--width", height="--height"):
        sc = open_scene_quietly(scene, width, height)  # its environment note is printed below, once
    try:
        left, right, _, _ = scene_rig(sc, baseline, convergence, needed_by="vergence specular")
    except ParameterError as exc:
        raise spoken(exc) from exc
    w_px, h_px = sc.camera.width, sc.camera.height
    _check_render_cost(w_px, h_px, depth, samples, k)
    try:
        maps = weight_maps(weight_map, n_layers=2 ** (depth + 1) - 1, width=w_px, height=h_px)
    except ParameterError as exc:
        raise spoken(exc) from exc
    src = Path(scene)
    for name in SPECULAR_OUTPUT_FILES:
        check_output_path(out / name, src)
    commit = atomic_folder(out)  # checks --out now (a file of that name is refused before the renders)
    if sc.environment.note:
        err_console.print(f"[yellow]note:[/] {sc.environment.note}", highlight=False, soft_wrap=True)
    columns = (TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    # The bar only on a terminal: piped or captured stderr stays empty (errors are one line).
    with Progress(*columns, console=err_console, transient=True, disable=not err_console.is_terminal) as bar:
        task = bar.add_task(f"specular {sc.name}", total=1.0)
        report = lambda f, m: bar.update(task, completed=f, description=m)  # noqa: E731
        with options_named(k="--k", max_depth="--depth", samples="--samples", alpha="--weights",
                           variant="--absolute", factor="--factor"):  # fmt: skip
            result = specular_stereo(sc, left, right, screen, k=k, max_depth=depth, samples=samples,
                                     alpha=COST_WEIGHTS if alpha is None else alpha, variant=variant,
                                     maps=maps or None, factor=factor, progress=report)  # fmt: skip
    with commit as tmp:  # all files or none, even on Ctrl-C
        names = [p.name for p in write_specular_outputs(result, tmp, anaglyph_method=anaglyph_method)]
        raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM: commit nothing
    _summary(sc.name, result, display, out, names)
