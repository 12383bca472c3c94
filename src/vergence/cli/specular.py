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

``--fit screen|native`` says how the pair is shown on ``--display`` (stretched to its width, or one
image pixel per display pixel): every arcmin figure is for that (``report.json``'s ``display``).
``--table`` also writes the offset table (``specular_table.npz``); ``--reoptimise DIR`` re-solves the
table of ``DIR`` with new ``--weights``/``--weight-map``/``--absolute``/``--factor`` without
rendering it again (:func:`vergence.specular.specular_from_table`): the table fixes the scene, the
size, the rig, the display and its fit, ``--k``, ``--depth`` and ``--samples``; giving one of them
otherwise is refused.
"""

from __future__ import annotations

from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import (app, check_output_path, console, err_console, open_scene_quietly, options_named,
                               preset_display, spoken)
from vergence.cli._spinner import progress_bar
from vergence.commands import ParameterError
from vergence.commands._scene import scene_rig
from vergence.commands._specular import MAX_WEIGHT as _MAX_WEIGHT  # largest --weights value (and painted weight)
from vergence.commands._specular import weight_maps

__all__ = ["DEFAULT_DISPLAY", "specular"]

#: ``--display``'s default: S3's study display (Samsung 2233RZ, 22" 16:10, 1680 px wide, viewed from 60 cm).
DEFAULT_DISPLAY = "samsung-2233rz"
# OffsetPlanner's range of the reduction factor (checked here too: the planner runs after the table).
_FACTOR_RANGE = (1, 64)
# The defaults of the options a table fixes (None on the command line: not given).
_DEFAULT_K, _DEFAULT_DEPTH, _DEFAULT_SAMPLES = 32, 2, 16


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


def _inside(row: dict) -> str:
    """Plain (counts) and importance-weighted shares inside the zone, before -> after."""
    return (f"inside the zone {_share(row['inside_share_before'])} -> {_share(row['inside_share_after'])} of matched "
            f"px ({row['inside_before']}/{row['matched_before']} -> {row['inside_after']}/{row['matched_after']}), "
            f"importance-weighted {_share(row['comfort_share_before'])} -> {_share(row['comfort_share_after'])}")


def _summary(name: str, result, display_name: str, out: Path, names: list[str]) -> None:  # noqa: ANN001
    rep = result.report()
    s, cam, d = rep["settings"], result.physical_left.camera, rep["display"]
    console.print(f"specular {name}: {cam.width}x{cam.height}, {len(rep['layers'])} layers (D = {s['max_depth']}), "
                  f"k = {s['k']}, absolute term {s['variant']!r}, weights {s['alpha']}, "
                  f"comfort zone {rep['comfort_zone_arcmin'][0]:g}..{rep['comfort_zone_arcmin'][1]:g} arcmin",
                  highlight=False)  # fmt: skip
    console.print(f"display {display_name}, fit {d['fit']}: the {d['image_width_px']}-px image shown "
                  f"{d['shown_width_m'] * 100:.1f} cm wide ({d['screen_px_per_image_px']:g} screen px per image px) "
                  f"at {d['viewing_distance_m'] * 100:g} cm: {d['arcmin_per_px']:.3g} arcmin per image pixel",
                  highlight=False)  # fmt: skip
    if not result.specular:
        console.print("no specular surface in view: the outputs are the physical pair (report.json \"specular\": "
                      "false)", highlight=False)  # fmt: skip
    for layer in rep["layers"]:
        if layer["pixels"]:
            row = {k.replace("_pixels", ""): v for k, v in layer.items()}
            console.print(f"  layer {layer['layer']} ({layer['name']}): {layer['pixels']} px, matched "
                          f"{_share(layer['matched_before'])} -> {_share(layer['matched_after'])}, "
                          f"{_inside(row)}, mean offset {layer['offset_mean']:.3f}", highlight=False)  # fmt: skip
    if result.specular:
        console.print(f"  specular layers together: {_inside(rep['specular_layers'])}", highlight=False)
    for obj in rep["objects"]:
        console.print(f"  {obj['type']} '{obj['name']}' (objects[{obj['object']}], {obj['shape']}, {obj['pixels']} px "
                      f"seen): {_inside(obj)}", highlight=False)  # fmt: skip
    check, raw = rep.get("render_check"), rep.get("render_check_raw")
    if check is not None:  # the final render against the physical left eye: layer pixels lost or gained
        console.print(f"  final render: {sum(check['lost'])} layer pixels lost, {sum(check['foreign'])} foreign, "
                      f"{check['rim']} rim pixels" + ("" if raw is None else f" (as first traced: {sum(raw['lost'])} "
                      f"lost, {sum(raw['foreign'])} foreign, {raw['rim']} rim pixels)"), highlight=False)  # fmt: skip
    for line in rep["warnings"]:
        err_console.print(f"[yellow]warning:[/] {line}", highlight=False, soft_wrap=True)
    b, a = rep["cost_before"], rep["cost_after"]
    console.print("cost (mean per pixel) before -> after: " + ", ".join(f"{t} {b[t]:.4g} -> {a[t]:.4g}" for t in b),
                  highlight=False)  # fmt: skip
    console.print("times: " + ", ".join(f"{k} {v:.2f} s" for k, v in rep["seconds"].items()), highlight=False)
    console.print(f"wrote {len(names)} files to {out}:", highlight=False)
    for n in names:
        console.print(f"  {out / n}", highlight=False)


@app.command("specular")
def specular(
    scene: str | None = typer.Argument(None, help="Scene file (.json, docs/scenes.md) or built-in: glasses, stadium, "
                                       "tabletop. With --reoptimise: the table's (may be left out)."),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing)."),
    display: str | None = typer.Option(None, "--display", help=f"Display preset the pair is made for (default "
                                       f"{DEFAULT_DISPLAY}, S3's study display)."),
    fit: str | None = typer.Option(None, "--fit", metavar="screen|native", help="How the image is shown on the "
                                   "display: 'screen' stretches it to the display's width (full screen), 'native' "
                                   "shows one image pixel per display pixel. Every arcmin figure is for it. Default: "
                                   "screen."),
    table: bool = typer.Option(False, "--table", help="Also write the offset table (specular_table.npz) for "
                               "--reoptimise."),
    reoptimise: Path | None = typer.Option(None, "--reoptimise", metavar="DIR", help="Re-solve the offset table of "
                                           "DIR (written with --table) with new --weights, --weight-map, --absolute "
                                           "or --factor, without rendering the table again."),
    weights: str | None = typer.Option(None, "--weights", metavar="A,P,R,D", help="Cost weights: absolute, relative, "
                                       "rivalry, data (S3 §4: 1,1,10,0.1)."),
    weight_map: list[str] = typer.Option(
        [], "--weight-map", metavar="[TERM:]LAYER=FILE",
        help="Painted weights of layer LAYER (1-based), every cost term or only TERM (absolute, relative, rivalry, "
             "data): a grey image of the render's size (PNG: value / max code). Repeatable; maps multiply.",
    ),
    k: int | None = typer.Option(None, "--k", help=f"Offset steps of the table (default {_DEFAULT_K}, S3's): k + 1 "
                                 "renders of the left eye."),
    width: int | None = typer.Option(None, "--width", help="Image width in pixels (default: the scene's)."),
    height: int | None = typer.Option(None, "--height", help="Image height in pixels (default: the scene's)."),
    depth: int | None = typer.Option(None, "--depth", help=f"Maximum specular bounces D: 2^(D+1)-1 layers (default "
                                     f"{_DEFAULT_DEPTH}, S3's)."),
    samples: int | None = typer.Option(None, "--samples", help=f"Ambient-occlusion rays per diffuse hit (default "
                                       f"{_DEFAULT_SAMPLES})."),
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
    from dataclasses import replace

    from vergence.cli._specular_table import scene_source
    from vergence.specular import (ABSOLUTE_VARIANTS, COST_WEIGHTS, DEFAULT_VARIANT, DISPLAY_FITS, MAX_OFFSET_STEPS,
                                   PLAN_FACTOR, TABLE_FILE, specular_objects, specular_stereo, write_specular_table)


    if fit is not None and fit not in DISPLAY_FITS:
        raise ValueError(f"--fit must be one of {', '.join(DISPLAY_FITS)}; got {fit!r}")
    if absolute is not None and absolute not in ABSOLUTE_VARIANTS:
        raise ValueError(f"--absolute must be one of {', '.join(ABSOLUTE_VARIANTS)}; got {absolute!r}")
    if factor is not None and not _FACTOR_RANGE[0] <= factor <= _FACTOR_RANGE[1]:
        raise ValueError(f"--factor must be a whole number in [{_FACTOR_RANGE[0]}, {_FACTOR_RANGE[1]}]; got {factor}")
    if anaglyph_method not in ANAGLYPH_METHODS:
        raise ValueError(f"--anaglyph must be one of {', '.join(ANAGLYPH_METHODS)}; got {anaglyph_method!r}")
    if reoptimise is not None:
        given = {"SCENE": scene, "--display": display, "--fit": fit, "--k": k, "--depth": depth, "--samples": samples,
                 "--width": width, "--height": height, "--baseline": baseline, "--convergence": convergence}
        from vergence.cli._specular_table import reoptimise_folder

        if table:
            raise ValueError(f"--table and --reoptimise together: the table is already in {reoptimise}")
        result, names, name, display_name = reoptimise_folder(
            reoptimise, out, given=given, weights=_weights(weights), weight_map=weight_map, variant=absolute,
            factor=factor, anaglyph_method=anaglyph_method)  # fmt: skip
        _summary(name, result, display_name, out, names)
        return
    if scene is None:
        raise ValueError("give a SCENE (a scene file or a built-in name), or --reoptimise DIR")
    display = DEFAULT_DISPLAY if display is None else display
    fit = DISPLAY_FITS[0] if fit is None else fit
    k = _DEFAULT_K if k is None else k
    depth = _DEFAULT_DEPTH if depth is None else depth
    samples = _DEFAULT_SAMPLES if samples is None else samples
    variant = DEFAULT_VARIANT if absolute is None else absolute
    if not 2 <= k <= MAX_OFFSET_STEPS:
        raise ValueError(f"--k must be a whole number in [2, {MAX_OFFSET_STEPS}] (offsets m/k, m = 0..k); got {k}")
    factor = PLAN_FACTOR if factor is None else factor
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
    if depth == 0 and specular_objects(sc):
        raise ValueError(f"--depth 0 traces no specular layer (the first hit only), but {sc.name} has mirror or glass "
                         "objects: use --depth 1 or more (S3: 2)")  # fmt: skip
    _check_render_cost(w_px, h_px, depth, samples, k)
    try:
        maps = weight_maps(weight_map, n_layers=2 ** (depth + 1) - 1, width=w_px, height=h_px)
    except ParameterError as exc:
        raise spoken(exc) from exc
    src = Path(scene)
    for name in (*SPECULAR_OUTPUT_FILES, *((TABLE_FILE,) if table else ())):
        check_output_path(out / name, src)
    commit = atomic_folder(out)  # checks --out now (a file of that name is refused before the renders)
    if sc.environment.note:
        err_console.print(f"[yellow]note:[/] {sc.environment.note}", highlight=False, soft_wrap=True)
    with progress_bar(f"specular {sc.name}") as report:
        with options_named(k="--k", max_depth="--depth", samples="--samples", alpha="--weights",
                           variant="--absolute", factor="--factor"):  # fmt: skip
            result = specular_stereo(sc, left, right, screen, k=k, max_depth=depth, samples=samples,
                                     alpha=COST_WEIGHTS if alpha is None else alpha, variant=variant,
                                     maps=maps or None, factor=factor, fit=fit, keep_table=table,
                                     progress=report)  # fmt: skip
    with commit as tmp:  # all files or none, even on Ctrl-C
        names = [p.name for p in write_specular_outputs(result, tmp, anaglyph_method=anaglyph_method)]
        if table and result.specular:
            source = scene_source(scene, sc, display, baseline=baseline, convergence=convergence)
            names.append(write_specular_table(replace(result.table(), source=source), tmp / TABLE_FILE).name)
        raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM: commit nothing
    result = result.release()  # the table's memory, before the summary
    if table and not result.specular:
        console.print(f"no {TABLE_FILE} written: nothing specular is in view, there is no table to re-solve",
                      highlight=False)  # fmt: skip
    _summary(sc.name, result, display, out, names)
