"""``vergence mapping``: the disparity mapping psi built from director constraints (S0 §6, Eq. 7–9)."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, display_from_options, err_console, options_named, print_json
from vergence.cli.budget import print_warnings
from vergence.viewing.geometry import CARDBOARD_ROUNDNESS, DISPLAY_PRESETS, Shooting
from vergence.viewing.mapping_constraints import ConstrainedMapping, DirectorConstraint, psi_from_constraints

__all__ = ["OPTION_NAMES", "mapping"]

# The library's argument names and the options that set them: errors name what the user typed.
OPTION_NAMES = {
    "baseline": "--reference-baseline",
    "convergence": "--convergence",
    "window": "--window",
    "eye_separation": "--eye-separation",
    "distance": "--viewing-distance",
    "width": "--screen-width",
    "near": "--near",
    "far": "--far",
    "constraint": "--constraint",
    "constraints": "--constraint",
    "depths": "--depth",
    "path": "--plot",
}

def _fmt(v: float, spec: str) -> str:
    return "∞" if v == math.inf else ("—" if not math.isfinite(v) else format(v, spec))


def _summary(result: ConstrainedMapping, depths: list[float] | None) -> None:
    ref, display = result.reference, result.display
    console.print(
        f"reference rig: b_r = {ref.baseline:.4g} m, H = {ref.convergence:.4g} m, W = {ref.window:.4g} m "
        f"(f = {ref.focal:.3g});  display: b' = {display.eye_separation:.4g} m, H' = {display.distance:.4g} m, "
        f"W' = {display.width:.4g} m (f' = {display.focal:.3g})"
    )
    lo, hi = result.disparity_range
    console.print(
        f"scene depths {result.near:.4g} m – {_fmt(result.far, '.4g')} m: d from {lo:+.5f} to {hi:+.5f};  "
        f"divergence limit b'/W' = {result.divergence_limit:.5f} (S0 Eq. 8)"
    )
    table = Table(title="control points (psi from the constraints, S0 §6)")
    table.add_column("constraint", overflow="fold")
    for col in ("d", "ψ(d)", "ψ'(d)", "slope from", "z' (Eq. 7)", "ρ (Eq. 9)"):
        table.add_column(col, justify="left" if col == "slope from" else "right")
    for c, cp in zip(result.constraints, result.control_points):
        origin = "roundness" if c.roundness is not None else ("z'=∞" if cp.prescribed else "PCHIP/1")
        zp = float(result.perceived_depth(c.depth))
        rho = float(result.roundness(c.depth))
        table.add_row(str(c).replace(",", ", "), f"{cp.disparity:+.4f}", f"{cp.value:+.4f}", f"{cp.slope:.4g}",
                      origin, _fmt(zp, ".4g"), _fmt(rho, ".3f"))
    console.print(table)
    s = result.sample(11) if depths is None else result.at_depths(depths)
    table = Table(title="mapped depth over the scene" if depths is None else "mapped depth at the given depths")
    for col in ("depth z (m)", "d", "ψ(d)", "perceived z' (m)", "roundness ρ", "note"):
        table.add_column(col, justify="left" if col == "note" else "right")
    for z, d, m, zp, rho in zip(s.depth, s.disparity, s.mapped, s.perceived_depth, s.roundness):
        note = "[yellow]cardboard[/]" if math.isfinite(rho) and rho < CARDBOARD_ROUNDNESS else ""
        table.add_row(_fmt(z, ".4g"), f"{d:+.5f}", f"{m:+.5f}", _fmt(zp, ".4g"), _fmt(rho, ".3f"), note)
    console.print(table)
    rho_min, z_min = result.min_roundness()
    flat = f"[yellow]cardboard[/], below {CARDBOARD_ROUNDNESS}" if rho_min < CARDBOARD_ROUNDNESS else "not cardboard"
    console.print(f"lowest roundness over the scene: ρ = {rho_min:.3f} at z = {z_min:.4g} m ({flat})")
    console.print(f"monotone: {'yes' if result.monotone else '[red]no[/]'};  "
                  f"diverges (psi > b'/W' somewhere): {'[red]yes[/]' if result.diverges else 'no'}")


@app.command("mapping")
def mapping(
    reference_baseline: float = typer.Option(..., "--reference-baseline", help="Reference rig baseline b_r (m)."),
    convergence: float = typer.Option(..., "--convergence", help="Convergence distance H (m)."),
    window: float = typer.Option(..., "--window", help="Convergence-window width W (m)."),
    eye_separation: float | None = typer.Option(None, "--eye-separation", help="Viewer eye separation b' (m)."),
    viewing_distance: float | None = typer.Option(None, "--viewing-distance", help="Viewing distance H' (m)."),
    screen_width: float | None = typer.Option(None, "--screen-width", help="Screen width W' (m)."),
    display_preset: str | None = typer.Option(
        None, "--display", help=f"Display preset instead of the three lengths: {', '.join(sorted(DISPLAY_PRESETS))}."
    ),
    constraint: list[str] = typer.Option(
        ..., "--constraint", help="Director constraint 'z=Z,perceived=Z[,roundness=R]' (inf allowed); repeat."
    ),
    near: float = typer.Option(..., "--near", help="Nearest scene depth (m)."),
    depth: list[float] | None = typer.Option(
        None, "--depth", help="Report these scene depths (m, inf allowed; repeat) instead of samples over the scene."
    ),
    far: float = typer.Option(..., "--far", help="Farthest scene depth (m); inf allowed."),
    as_json: bool = typer.Option(False, "--json", help="Print only the JSON on stdout."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a PNG of psi, perceived depth and roundness."),
) -> None:
    """Build the disparity mapping psi from director constraints and report it (S0 §6, Eq. 7–9)."""
    depths = list(depth) if depth else None
    if near >= far:  # the library would say "far must be > near": name both options
        raise ValueError(f"--far must be > --near {near:g}; got {far:g}")
    with options_named(**OPTION_NAMES):
        reference = Shooting(baseline=reference_baseline, convergence=convergence, window=window)
        display = display_from_options(display_preset, eye_separation, viewing_distance, screen_width)
        constraints = [DirectorConstraint.from_string(text) for text in constraint]
        result = psi_from_constraints(reference, display, constraints, near=near, far=far)
        # 201 samples evenly spaced in d over [d(near), d(far)], or the --depth values
        report = result.to_dict(depths=depths)
        if plot is not None:
            from vergence.report.mapping_plot import plot_mapping  # matplotlib only when a plot is asked for

            plot_mapping(result, path=plot)
    print_warnings(result.warnings)
    if as_json:
        print_json(report)
        if plot is not None:
            err_console.print(f"plot written to {plot}", highlight=False)
        return
    _summary(result, depths)
    if plot is not None:
        console.print(f"plot written to {plot}", highlight=False)
