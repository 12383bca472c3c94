"""``vergence mapping``: the disparity mapping psi built from director constraints (S0 §6, Eq. 7–9)."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, err_console, option, options_named, print_json, run_command
from vergence.cli.budget import print_warnings
from vergence.commands.mapping import MAPPING
from vergence.viewing.geometry import CARDBOARD_ROUNDNESS
from vergence.viewing.mapping_constraints import ConstrainedMapping

__all__ = ["mapping"]

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
    reference_baseline: float = option(MAPPING, "reference_baseline"),
    convergence: float = option(MAPPING, "convergence"),
    window: float = option(MAPPING, "window"),
    eye_separation: float | None = option(MAPPING, "eye_separation"),
    viewing_distance: float | None = option(MAPPING, "viewing_distance"),
    screen_width: float | None = option(MAPPING, "screen_width"),
    display_preset: str | None = option(MAPPING, "display"),
    constraint: list[str] = option(MAPPING, "constraint"),
    near: float = option(MAPPING, "near"),
    depth: list[float] | None = option(MAPPING, "depth"),
    far: float = option(MAPPING, "far"),
    as_json: bool = typer.Option(False, "--json", help="Print only the JSON on stdout."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a PNG of psi, perceived depth and roundness."),
) -> None:
    """Build the disparity mapping psi from director constraints and report it (S0 §6, Eq. 7–9)."""
    report = run_command(MAPPING, reference_baseline=reference_baseline, convergence=convergence, window=window,
                         eye_separation=eye_separation, viewing_distance=viewing_distance, screen_width=screen_width,
                         display=display_preset, constraint=constraint, near=near, depth=depth, far=far)
    result = report.mapping
    if plot is not None:
        from vergence.report.mapping_plot import plot_mapping  # matplotlib only when a plot is asked for

        with options_named(path="--plot"):
            plot_mapping(result, path=plot)
    print_warnings(result.warnings)
    if as_json:
        print_json(report.to_dict())
        if plot is not None:
            err_console.print(f"plot written to {plot}", highlight=False)
        return
    _summary(result, None if report.depths is None else list(report.depths))
    if plot is not None:
        console.print(f"plot written to {plot}", highlight=False)
