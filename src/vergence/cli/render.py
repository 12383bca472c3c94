"""``vergence render``: ray-trace a scene file or a built-in scene into its S3 ray tree (S3 §3.1).

Writes ``render.npz`` (or ``left.npz`` / ``right.npz`` for ``--eye``) with the arrays radiance,
position, normal (N, H, W, 3), depth (H, W), beauty (H, W, 3); the depth alone as ``*_depth.pfm``
(metric, NaN where nothing was hit: ``vergence synthesize *_beauty.png *_depth.pfm`` takes it); the
camera(s) as JSON; PNG previews (tone-mapped beauty, depth with a colour bar, contact sheet of the
layers) and, with ``--eye both --preview LAYOUT``, the pair packed for a display
(:data:`vergence.display.LAYOUTS`). The cost is estimated and checked against the documented limits
(:mod:`vergence.render.limits`) before anything is traced; the output folder receives all files or
none. Mitsuba is imported only when the command runs.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, check_output_path, console, err_console, open_scene_quietly, options_named, spoken
from vergence.cli._spinner import progress_bar
from vergence.commands import ParameterError
from vergence.commands._scene import scene_rig

__all__ = ["render"]

_EYES = ("left", "right", "both")


def _rig(scene, eye, baseline, convergence):  # noqa: ANN001, ANN202
    """(left, right, baseline, convergence) for --eye, from the options or the scene's "stereo" block."""
    if eye is None:
        if baseline is not None or convergence is not None:
            raise ValueError("--baseline and --convergence need --eye left, right or both")
        return None
    if eye not in _EYES:
        raise ValueError(f"--eye must be one of {', '.join(_EYES)}; got {eye!r}")
    try:
        return scene_rig(scene, baseline, convergence, needed_by="--eye")
    except ParameterError as exc:
        raise spoken(exc) from exc


@app.command("render")
def render(
    scene: str = typer.Argument(..., help="Scene file (.json, docs/scenes.md) or built-in: glasses, stadium, tabletop."),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing)."),
    eye: str | None = typer.Option(None, "--eye", help="left, right or both: render the stereo rig (S0 §2)."),
    baseline: float | None = typer.Option(None, "--baseline", help="Rig baseline b in metres (default: the scene's)."),
    convergence: float | None = typer.Option(None, "--convergence", help="Convergence distance H in metres."),
    width: int | None = typer.Option(None, "--width", help="Image width in pixels (default: the scene's)."),
    height: int | None = typer.Option(None, "--height", help="Image height in pixels (default: the scene's)."),
    depth: int = typer.Option(2, "--depth", help="Maximum specular bounces D: 2^(D+1)-1 layers."),
    samples: int = typer.Option(16, "--samples", help="Ambient-occlusion rays per diffuse hit."),
    seed: int | None = typer.Option(None, "--seed", min=0, help="Random AO directions from this seed (default: fixed lattice)."),
    supersample: int = typer.Option(1, "--supersample", help="k: average k x k sub-pixel rays per pixel (anti-aliasing)."),
    preview: str | None = typer.Option(
        None, "--preview", metavar="LAYOUT",
        help="With --eye both: also write the pair packed as LAYOUT (anaglyph, sbs, half-sbs, tb, ...).",
    ),
) -> None:
    """Ray-trace SCENE into the S3 ray tree: per-layer radiance, position, normal; depth; previews."""
    from vergence import render as vr
    from vergence.display import LAYOUTS, pack
    from vergence.io import atomic_folder, write_image
    from vergence.render.limits import render_cost
    from vergence.report.preview import save_render

    if preview is not None and eye != "both":
        raise ValueError("--preview needs --eye both (a stereo pair)")
    if preview is not None and preview not in LAYOUTS:
        raise ValueError(f"--preview must be one of {', '.join(LAYOUTS)}; got {preview!r}")
    options_cli = {"max_depth": "--depth", "samples": "--samples", "supersample": "--supersample",
                   "width": "--width", "height": "--height", "baseline": "--baseline",
                   "convergence": "--convergence"}  # fmt: skip
    with options_named(**options_cli):
        sc = open_scene_quietly(scene, width, height)  # its environment note is printed below, once
        rig = _rig(sc, eye, baseline, convergence)
        stems = ["render"] if rig is None else (["left", "right"] if eye == "both" else [eye])
        pair = None if rig is None else rig[:2]
        rig = None if rig is None else rig[2:]
        if isinstance(depth, bool) or not 0 <= depth <= vr.MAX_DEPTH:
            raise ValueError(f"max_depth must be an integer in [0, {vr.MAX_DEPTH}]; got {depth}")
        for name, value in (("samples", samples), ("supersample", supersample)):
            if value < 1:
                raise ValueError(f"{name} must be >= 1; got {value}")
    cost = render_cost(sc.camera.width, sc.camera.height, max_depth=depth, samples=samples, supersample=supersample,
                       views=len(stems))  # fmt: skip
    if cost.problem() is not None:
        raise ValueError(f"{sc.camera.width}x{sc.camera.height} pixels x {len(stems)} view(s) with --depth {depth}, "
                         f"--samples {samples}, --supersample {supersample} {cost.problem()}: lower --width/--height, "
                         "--depth, --samples or --supersample")  # fmt: skip
    src = Path(scene)
    for stem in stems:
        for suffix in (".npz", "_camera.json", "_beauty.png", "_depth.png", "_depth.pfm", "_layers.png"):
            check_output_path(out / f"{stem}{suffix}", src)
    if sc.environment.note:
        err_console.print(f"[yellow]note:[/] {sc.environment.note}", highlight=False, soft_wrap=True)
    rng = None if seed is None else np.random.default_rng(seed)
    options = {"max_depth": depth, "samples": samples, "rng": rng, "supersample": supersample}
    cam = sc.camera.build()
    start = time.perf_counter()
    with progress_bar(f"rendering {sc.name}") as report:
        if rig is None:
            results = [vr.render(sc, camera=cam, progress=report, **options)]
        elif eye == "both":
            results = list(vr.render_stereo(sc, baseline=rig[0], convergence=rig[1], progress=report, **options))
        else:
            results = [vr.render(sc, camera=pair[0] if eye == "left" else pair[1], progress=report, **options)]
    elapsed = time.perf_counter() - start
    exposure = vr.auto_exposure(results[0].beauty)  # one exposure for both eyes
    with atomic_folder(out) as tmp:  # all files or none, even on Ctrl-C
        names = [p.name for stem, res in zip(stems, results) for p in save_render(res, tmp, stem=stem, exposure=exposure)]
        if preview is not None:
            left, right = (vr.tonemap(res.beauty, exposure=exposure) for res in results)
            write_image(tmp / f"stereo_{preview}.png", pack(left, right, layout=preview))
            names.append(f"stereo_{preview}.png")
        raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM: commit nothing
    written = [out / n for n in names]
    r = results[0]
    console.print(
        f"rendered {sc.name}: {len(results)} view(s) {r.camera.width}x{r.camera.height}, {r.n_layers} layers "
        f"(D = {depth}), {samples} AO samples, {r.settings.variant}, {elapsed:.2f} s; lighting: {r.settings.environment}",
        highlight=False,
    )
    if rig is not None:
        console.print(f"rig: baseline {rig[0]:g} m, convergence {rig[1]:g} m (zero disparity there)", highlight=False)
    for p in written:
        console.print(f"  {p}", highlight=False)
