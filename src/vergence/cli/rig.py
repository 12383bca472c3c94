"""``vergence rig plan|render SHOT``: the Quadri-Rig and the Tri-Rig of S0 §5–6 from a shot file.

``plan`` prints the real cameras the shot needs (focal lengths, baselines; ``--json`` for a program,
``--plot`` for a picture from above). ``render`` ray-traces them, synthesises the director's stereo
pair by image-based rendering and measures it against the ray-traced truth (``docs/shots.md``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from vergence.cli import raise_if_interrupted
from vergence.cli.budget import print_warnings
from vergence.cli._app import app, check_output_path, console, err_console, option, options_named, print_json, \
    run_command  # fmt: skip
from vergence.cli._spinner import progress_bar
from vergence.commands.rig_plan import RIG_PLAN

__all__ = ["rig_app"]

rig_app = typer.Typer(name="rig", help="Plan and render the Quadri-Rig and the Tri-Rig of a shot file (S0 §5–6).",
                      no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False)  # fmt: skip
app.add_typer(rig_app, name="rig")

_WEIGHTS = ("ulr", "bayesian", "both")


def _load(shot: Path):  # noqa: ANN202
    from vergence.rigs import load_shot

    return load_shot(shot)


def _baseline(a, b) -> float:  # noqa: ANN001
    return float(np.linalg.norm(np.asarray(a.center) - np.asarray(b.center)))


def _print_plan(shot, rig) -> None:  # noqa: ANN001
    title = "Quadri-Rig (S0 §5, Eq. 10)" if shot.rig == "quadri" else "Tri-Rig (S0 §6)"
    ratio_of = "virtual" if shot.rig == "quadri" else "director"
    table = Table(title=f"{title}: {len(rig.cameras)} cameras")
    for col in ("camera", "element", "eye", "centre (m)", "fx (px)", f"fx / {ratio_of}", "baseline (m)"):
        table.add_column(col, justify="left" if col in ("camera", "element", "eye", "centre (m)") else "right",
                         no_wrap=col != "centre (m)", min_width=17 if col == "centre (m)" else None)
    from vergence.rigs import plan_document

    rows = []
    for row, rc in zip(plan_document(shot, rig)["cameras"], rig.cameras):
        c = " ".join(f"{v:.2f}" for v in rc.camera.center)
        b = "—" if row["baseline"] is None else f"{row['baseline']:.4f}"
        rows.append((row["name"], row["element"], row["eye"], c, f"{row['fx']:.1f}", f"{row['fx_ratio']:.3f}", b))
        table.add_row(*rows[-1])
    if console.measure(table, options=console.options.update(max_width=10_000)).maximum <= console.width:
        console.print(table)
    else:  # a narrow terminal or a log: one line a camera rather than a squeezed column
        console.print(table.title, highlight=False)
        for name, element, eye, c, fx, ratio, b in rows:
            console.print(f"  {name} ({element}, {eye} eye)\n    centre {c} m; fx {fx} px, {ratio} x {ratio_of}; "
                          f"baseline {b} m", highlight=False, soft_wrap=False)  # fmt: skip
    if shot.rig == "quadri":
        console.print(f"virtual eyes: baseline {_baseline(rig.left, rig.right):.4g} m; real cameras {rig.setback:g} m "
                      "behind them", highlight=False)  # fmt: skip
    else:
        ref = rig.reference
        console.print(f"reference rig for psi: b_r = {ref.baseline:.4g} m, H = {ref.convergence:.4g} m, "
                      f"W = {ref.window:.4g} m; psi monotone: {'yes' if rig.mapping.monotone else 'no'}, "
                      f"diverges: {'yes' if rig.mapping.diverges else 'no'}", highlight=False)  # fmt: skip


@rig_app.command("plan")
def plan(
    shot: Path = option(RIG_PLAN, "shot"),
    as_json: bool = typer.Option(False, "--json", help="Print only the JSON on stdout."),
    plot: Path | None = typer.Option(None, "--plot", help="Draw the rig from above into this PNG or SVG."),
) -> None:
    """Plan the real cameras of SHOT: positions, focal lengths (fx and the ratio), baselines."""
    report = run_command(RIG_PLAN, shot=shot)
    s, rig = report.shot, report.rig
    if plot is not None:
        check_output_path(plot, shot)
        _plot(s, rig, plot)
    if as_json:
        print_json(report.to_dict())
        if plot is not None:
            err_console.print(f"plot written to {plot}", highlight=False)
        print_warnings(rig.warnings)
        return
    _print_plan(s, rig)
    print_warnings(rig.warnings)
    if plot is not None:
        console.print(f"plot written to {plot}", highlight=False)


def _plot(shot, rig, path: Path) -> None:  # noqa: ANN001
    from vergence.report.rig_plot import plot_rig

    with options_named(path="--plot"):
        if shot.rig == "quadri":
            virtual = [("virtual left", rig.left, "virtual"), ("virtual right", rig.right, "virtual")]
            plot_rig(path, rig.cameras, elements=rig.elements, virtual=virtual, title="Quadri-Rig from above")
        else:
            plot_rig(path, rig.cameras, virtual=[("reference right", rig.reference_right, "virtual")],
                     title="Tri-Rig from above",
                     reach=rig.reference.convergence)  # fmt: skip


def _coverage_png(mask: np.ndarray) -> np.ndarray:
    return np.where(mask, 1.0, 0.0).astype(np.float32)


@rig_app.command("render")
def render(
    shot: Path = typer.Argument(..., help="Shot file (JSON, docs/shots.md)."),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing; all files or none)."),
    weights: str = typer.Option("both", "--weights", help="IBR blending weights: ulr, bayesian or both."),
    samples: int = typer.Option(16, "--samples", help="Ambient-occlusion rays per diffuse hit."),
    supersample: int = typer.Option(3, "--supersample", help="k: k x k sub-pixel rays per pixel in every ray-traced image."),  # SHOT_SUPERSAMPLE
    sources: str = typer.Option("all", "--sources", help="Quadri-Rig: each eye from all 2N real cameras (all) or its own N, as S0 (eye)."),
    ulr_k: int = typer.Option(4, "--ulr-k", help="ULR: the k best sources per pixel weigh in (Buehler et al. 2001)."),  # ULR_K
    visibility_tolerance: float = typer.Option(0.01, "--visibility-tolerance", help="Relative depth agreement of the visibility test (0.01 = 1 %), plus the surface's slope."),  # IBR_OCCLUSION_TOLERANCE
    deformation_cap: float = typer.Option(20.0, "--deformation-cap", help="Bayesian: the largest deformation weight (>= 1)."),  # BAYES_DEFORMATION_CAP
) -> None:
    """Render the real cameras of SHOT, synthesise the director's pair (ULR / Bayesian) and measure it."""
    from vergence.io import atomic_folder, write_image, write_pfm
    from vergence.rigs.shoot import RIG_SOURCES, RIG_WEIGHTS, render_shot

    if weights not in RIG_WEIGHTS:
        raise ValueError(f"--weights must be one of {', '.join(RIG_WEIGHTS)}; got {weights!r}")
    if sources not in RIG_SOURCES:
        raise ValueError(f"--sources must be one of {', '.join(RIG_SOURCES)}; got {sources!r}")
    for name, value in (("--samples", samples), ("--supersample", supersample)):
        if value < 1:
            raise ValueError(f"{name} must be >= 1; got {value}")
    from vergence.rigs.shoot import check_ibr_settings

    with options_named(k="--ulr-k", occlusion_tolerance="--visibility-tolerance", deformation_cap="--deformation-cap"):
        check_ibr_settings(ulr_k, visibility_tolerance, deformation_cap)  # refused before the shot is even read
    s = _load(shot)
    print_warnings(s.plan().warnings)  # refuse a rig the planner refuses before any rendering; warn once
    if out.exists() and out.resolve() == shot.resolve():
        raise ValueError(f"--out {out} would overwrite the shot file")
    start = time.perf_counter()
    # not on a terminal: a line a tenth (the curved-ray truth reports every octave)
    with progress_bar("rendering", lines=True) as report:
        with options_named(samples="--samples", supersample="--supersample", sources="--sources", k="--ulr-k",
                           occlusion_tolerance="--visibility-tolerance", deformation_cap="--deformation-cap"):
            result = render_shot(s, weights=RIG_WEIGHTS[weights], samples=samples, supersample=supersample,
                                 sources=sources, k=ulr_k, occlusion_tolerance=visibility_tolerance,
                                 deformation_cap=deformation_cap, progress=report)  # fmt: skip
    elapsed = time.perf_counter() - start
    with atomic_folder(out) as tmp:
        (tmp / "cameras").mkdir()
        for name, (image, depth) in result.cameras.items():
            write_image(tmp / "cameras" / f"{name}.png", image)
            write_pfm(tmp / "cameras" / f"{name}_depth.pfm", np.asarray(depth, dtype=np.float32))
            (tmp / "cameras" / f"{name}_camera.json").write_text(json.dumps(_camera_of(result.rig, name).to_dict()))
        (tmp / "truth").mkdir()
        for eye, image in result.truth.items():
            write_image(tmp / "truth" / f"{eye}.png", image)
        for method, pair in result.images.items():
            (tmp / method).mkdir()
            for eye, image in pair.items():
                write_image(tmp / method / f"{eye}.png", image)
                res = result.results[method].get(eye)
                coverage = np.ones(image.shape[:2], bool) if res is None else res.coverage
                write_image(tmp / method / f"coverage_{eye}.png", _coverage_png(coverage))
        if result.mapped_disparity is not None:
            write_pfm(tmp / "mapped_disparity.pfm", result.mapped_disparity)
        doc = {"rig": s.rig, "shot": str(shot), "scene": str(s.scene), "size": [s.camera.width, s.camera.height],
               "exposure": result.exposure, "samples": samples, "supersample": supersample, **result.report}  # fmt: skip
        (tmp / "report.json").write_text(json.dumps(doc, indent=2, allow_nan=False) + "\n")
        raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM: commit nothing
    _print_report(s, result, out, elapsed)


def _camera_of(rig, name: str):  # noqa: ANN001, ANN202
    return next(rc.camera for rc in rig.cameras if rc.name == name)


def _print_report(shot, result, out: Path, elapsed: float) -> None:  # noqa: ANN001
    table = Table(title=f"{'Quadri' if shot.rig == 'quadri' else 'Tri'}-Rig against the truth")
    for col in ("method", "eye", "PSNR (dB)", "DSSIM", "DSSIM inside", "filled (dB)", "coverage"):
        table.add_column(col, justify="left" if col in ("method", "eye") else "right")
    for method, eyes in result.report["methods"].items():
        for eye, m in eyes.items():
            p = "∞" if m["psnr"] is None and m["coverage"] > 0 else ("—" if m["psnr"] is None else f"{m['psnr']:.2f}")
            d = "—" if m["dssim"] is None else f"{m['dssim']:.2e}"
            d_in = "—" if m.get("dssim_inside") is None else f"{m['dssim_inside']:.2e} ({100 * m['inside']:.1f} %)"
            f = "—" if m.get("psnr_filled") is None else f"{m['psnr_filled']:.2f}"
            table.add_row(method, eye, p, d, d_in, f, f"{100 * m['coverage']:.1f} %")
    console.print(table)
    if shot.rig == "tri":
        console.print("∞: the left eye is the director's image itself", highlight=False)
    console.print("PSNR, DSSIM: over the covered pixels (a DSSIM window reaching a hole compares its black); DSSIM "
                  "inside: from the 7x7 windows wholly inside the covered area (the share of the image they centre "
                  "on); filled: PSNR of the whole image, each row's run of holes filled from its farther side "
                  "(S1's background fill)", highlight=False)  # fmt: skip
    reference = ("S0 Table 1 (Quadri-Rig, lego): ULR 33.93 / 33.94 dB, Bayesian 34.00 / 34.02 dB, DSSIM ~2.9e-2; "
                 if shot.rig == "quadri" else "S0 has no reference for the Tri-Rig's right eye; ")  # fmt: skip
    console.print(f"{reference}{elapsed:.1f} s; wrote {out}", highlight=False)
