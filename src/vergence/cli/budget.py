"""``vergence budget``: the depth budget of a rig on a display (S0 §2), as a table or JSON, and a plot."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, display_from_options, err_console, options_named, print_json
from vergence.viewing.budget import DepthBudget, depth_budget
from vergence.viewing.geometry import DISPLAY_PRESETS, Display, Shooting

__all__ = ["OPTION_NAMES", "budget"]

# The library's argument names and the options that set them: errors name what the user typed.
OPTION_NAMES = {
    "baseline": "--baseline",
    "convergence": "--convergence",
    "window": "--window",
    "focal_mm": "--focal-mm",
    "sensor_mm": "--sensor-mm",
    "eye_separation": "--eye-separation",
    "distance": "--viewing-distance",
    "width": "--screen-width",
    "resolution": "--screen-pixels",
    "depths": "--depth",
    "path": "--plot",
}


def print_warnings(warnings: tuple[str, ...] | list[str]) -> None:
    """Each warning as one line on stderr (they are in the JSON too)."""
    for line in warnings:
        err_console.print(f"[bold yellow]warning:[/] {line}", highlight=False, soft_wrap=True)


def _shooting(baseline: float, convergence: float, window: float | None, focal_mm: float | None,
              sensor_mm: float | None) -> Shooting:
    """The rig from either --window or --focal-mm with --sensor-mm (exactly one of the two)."""
    if window is not None and (focal_mm is not None or sensor_mm is not None):
        raise ValueError("give either --window or --focal-mm with --sensor-mm, not both")
    if window is not None:
        return Shooting(baseline=baseline, convergence=convergence, window=window)
    if focal_mm is None and sensor_mm is None:
        raise ValueError("the convergence window is missing: give --window, or --focal-mm with --sensor-mm")
    if sensor_mm is None:
        raise ValueError("--sensor-mm (sensor width in mm) is required with --focal-mm")
    if focal_mm is None:
        raise ValueError("--focal-mm (focal length in mm) is required with --sensor-mm")
    try:
        return Shooting.from_focal(baseline=baseline, convergence=convergence, focal_mm=focal_mm, sensor_mm=sensor_mm)
    except ValueError as exc:
        if not str(exc).startswith("window "):
            raise
        # The window was not typed: it is H S / F (S0 §2); say which options made it.
        raise ValueError(f"the convergence window H S/F from --convergence, --sensor-mm and --focal-mm "
                         f"{str(exc).removeprefix('window ')}") from None


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
    baseline: float = typer.Option(..., "--baseline", help="Camera baseline b (m)."),
    convergence: float = typer.Option(..., "--convergence", help="Convergence distance H (m)."),
    window: float | None = typer.Option(None, "--window", help="Convergence-window width W (m)."),
    focal_mm: float | None = typer.Option(
        None, "--focal-mm", help="Focal length F (mm), with --sensor-mm instead of --window."
    ),
    sensor_mm: float | None = typer.Option(None, "--sensor-mm", help="Sensor width S (mm), with --focal-mm."),
    eye_separation: float | None = typer.Option(None, "--eye-separation", help="Viewer eye separation b' (m)."),
    viewing_distance: float | None = typer.Option(None, "--viewing-distance", help="Viewing distance H' (m)."),
    screen_width: float | None = typer.Option(None, "--screen-width", help="Screen width W' (m)."),
    screen_pixels: int | None = typer.Option(
        None, "--screen-pixels", help="Screen width in pixels (adds parallax_px)."
    ),
    display_preset: str | None = typer.Option(
        None, "--display", help=f"Display preset instead of the three lengths: {', '.join(sorted(DISPLAY_PRESETS))}."
    ),
    depth: list[float] | None = typer.Option(
        None, "--depth", help="Scene depth z (m), inf allowed; repeat. Default: 0.5, 0.75, 1, 1.5, 2, 3, 5 and 10 times H."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print only the JSON on stdout."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Write a PNG of perceived depth and roundness against depth."
    ),
) -> None:
    """Depth budget of a rig on a display: divergence and roundness baselines, z' and roundness per depth (S0 §2)."""
    with options_named(**OPTION_NAMES):
        shooting = _shooting(baseline, convergence, window, focal_mm, sensor_mm)
        display = display_from_options(display_preset, eye_separation, viewing_distance, screen_width, screen_pixels)
        result = depth_budget(shooting, display, depth if depth else None)
        if plot is not None:
            from vergence.report.budget_plot import plot_budget  # matplotlib only when a plot is asked for

            depths = [s.depth for s in result.samples if math.isfinite(s.depth)] or [shooting.convergence]
            near, far = min(depths), max(depths)
            if near == far:  # a single depth: show a range around it
                near, far = near / 2.0, far * 2.0
            plot_budget(shooting, display, near=near, far=far, path=plot)
    print_warnings(result.warnings)
    if as_json:
        print_json(result.to_dict())
        if plot is not None:
            err_console.print(f"plot written to {plot}", highlight=False)
        return
    _table(result, shooting, display)
    if plot is not None:
        console.print(f"plot written to {plot}", highlight=False)
