"""``vergence budget``: the depth budget of a rig on a display (S0 §2), as a table or JSON, and a plot."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, err_console, option, options_named, print_json, run_command
from vergence.commands.budget import BUDGET
from vergence.viewing.budget import DepthBudget
from vergence.viewing.geometry import Display, Shooting

__all__ = ["budget", "print_warnings"]


def print_warnings(warnings: tuple[str, ...] | list[str]) -> None:
    """Each warning as one line on stderr (they are in the JSON too)."""
    for line in warnings:
        err_console.print(f"[bold yellow]warning:[/] {line}", highlight=False, soft_wrap=True)


def _fmt(value: float | None, spec: str) -> str:
    return "—" if value is None else format(value, spec)


def _table(result: DepthBudget, shooting: Shooting, display: Display) -> None:
    b_div, b_round = result.divergence_baseline, result.roundness_baseline
    console.print(
        f"rig: b = {shooting.baseline:.4g} m, H = {shooting.convergence:.4g} m, W = {shooting.window:.4g} m "
        f"(f = {shooting.focal:.3g});  display: b' = {display.eye_separation:.4g} m, "
        f"H' = {display.distance:.4g} m, W' = {display.width:.4g} m (f' = {display.focal:.3g})"
    )
    console.print(f"divergence baseline b_div = {b_div:.4g} m   (largest baseline with no divergence, S0 Eq. 3)")
    console.print(f"roundness baseline b_round = {b_round:.4g} m   (roundness 1 at H, S0 Eq. 5)")
    console.print(f"focal ratio f/f' = {result.focal_ratio:.4g} = b_round/b_div   (S0 Eq. 6)")
    z_div = result.divergence_depth
    console.print("eyes diverge beyond z = " + (f"{z_div:.4g} m" if math.isfinite(z_div) else "— (never)"))
    with_px = display.resolution is not None
    table = Table(title="depth budget")
    table.add_column("depth z (m)", justify="right")
    table.add_column("disparity d (% of W)", justify="right")
    if with_px:
        table.add_column("parallax (px)", justify="right")
    table.add_column("perceived z' (m)", justify="right")
    table.add_column("roundness ρ", justify="right")
    table.add_column("note")
    styles = {"eyes diverge": "red", "eyes parallel": "red", "cardboard": "yellow"}
    for s in result.samples:
        note = f"[{styles[s.note]}]{s.note}[/]" if s.note else ""
        row = [f"{s.depth:.4g}" if math.isfinite(s.depth) else "∞", f"{100 * s.disparity:+.3f}"]
        if with_px:
            row.append(_fmt(s.parallax_px, "+.1f"))
        # z' is null where the eyes diverge or are parallel (infinite); rho as in the JSON: Eq. (4) as is,
        # negative past divergence, null only where infinite (parallel eyes).
        perceived = "∞" if s.note == "eyes parallel" else _fmt(s.perceived_depth, ".4g")
        row += [perceived, _fmt(s.roundness, ".3f"), note]
        table.add_row(*row)
    console.print(table)


@app.command("budget")
def budget(
    baseline: float = option(BUDGET, "baseline"),
    convergence: float = option(BUDGET, "convergence"),
    window: float | None = option(BUDGET, "window"),
    focal_mm: float | None = option(BUDGET, "focal_mm"),
    sensor_mm: float | None = option(BUDGET, "sensor_mm"),
    eye_separation: float | None = option(BUDGET, "eye_separation"),
    viewing_distance: float | None = option(BUDGET, "viewing_distance"),
    screen_width: float | None = option(BUDGET, "screen_width"),
    screen_pixels: int | None = option(BUDGET, "screen_pixels"),
    display_preset: str | None = option(BUDGET, "display"),
    depth: list[float] | None = option(BUDGET, "depth"),
    as_json: bool = typer.Option(False, "--json", help="Print only the JSON on stdout."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Write a PNG of perceived depth and roundness against depth."
    ),
) -> None:
    """Depth budget of a rig on a display: divergence and roundness baselines, z' and roundness per depth (S0 §2)."""
    report = run_command(BUDGET, baseline=baseline, convergence=convergence, window=window, focal_mm=focal_mm,
                         sensor_mm=sensor_mm, eye_separation=eye_separation, viewing_distance=viewing_distance,
                         screen_width=screen_width, screen_pixels=screen_pixels, display=display_preset, depth=depth)
    shooting, display, result = report.shooting, report.display, report.budget
    if plot is not None:
        from vergence.report.budget_plot import plot_budget  # matplotlib only when a plot is asked for

        depths = [s.depth for s in result.samples if math.isfinite(s.depth)] or [shooting.convergence]
        near, far = min(depths), max(depths)
        if near == far:  # a single depth: show a range around it
            near, far = near / 2.0, far * 2.0
        with options_named(path="--plot"):
            plot_budget(shooting, display, near=near, far=far, path=plot)
    print_warnings(result.warnings)
    if as_json:
        print_json(report.to_dict())
        if plot is not None:
            err_console.print(f"plot written to {plot}", highlight=False)
        return
    _table(result, shooting, display)
    if plot is not None:
        console.print(f"plot written to {plot}", highlight=False)
