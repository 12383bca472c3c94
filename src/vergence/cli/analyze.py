"""``vergence analyze``: comfort of a stereo or 2D + depth clip (or image) on a display, per frame and per shot."""

from __future__ import annotations

from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, console, option, print_json, run_command
from vergence.cli._spinner import Spinner
from vergence.cli.budget import print_warnings
from vergence.commands.analyze import ANALYZE

__all__ = ["analyze"]


@app.command("analyze")
def analyze(
    input_path: Path = option(ANALYZE, "input_path"),
    display_preset: str = option(ANALYZE, "display"),
    depth: Path | None = option(ANALYZE, "depth"),
    kind: str | None = option(ANALYZE, "input_kind"),
    layout: str | None = option(ANALYZE, "layout"),
    depth_kind: str | None = option(ANALYZE, "depth_kind"),
    depth_scale: float | None = option(ANALYZE, "depth_scale"),
    budget_arcmin: float | None = option(ANALYZE, "budget_arcmin"),
    comfort_arcmin: float = option(ANALYZE, "comfort_arcmin"),
    every: int = option(ANALYZE, "every"),
    min_disparity: int | None = option(ANALYZE, "min_disparity"),
    max_disparity: int | None = option(ANALYZE, "max_disparity"),
    method: str | None = option(ANALYZE, "method"),
    no_vertical: bool = option(ANALYZE, "no_vertical"),
    fps: float | None = option(ANALYZE, "fps"),
    report: Path | None = option(ANALYZE, "report"),
    force: bool = option(ANALYZE, "force"),
    as_json: bool = typer.Option(False, "--json", help="Print the analysis as JSON."),
) -> None:
    """Comfort of a stereo or 2D + depth clip on a display: disparity percentiles, comfort, divergence,
    stereo window, vertical disparity and a suggested retargeting, per frame and per shot."""
    with Spinner() as progress:
        done = run_command(ANALYZE, input_path=input_path, display=display_preset, depth=depth, input_kind=kind,
                           layout=layout, depth_kind=depth_kind, depth_scale=depth_scale, budget_arcmin=budget_arcmin,
                           comfort_arcmin=comfort_arcmin, every=every, min_disparity=min_disparity,
                           max_disparity=max_disparity, method=method, no_vertical=no_vertical, fps=fps, report=report,
                           force=force, progress=progress, before_commit=raise_if_interrupted)  # fmt: skip
    print_warnings(done.analysis.warnings)  # stderr, before the figures (also in the JSON)
    if as_json:
        print_json(done.to_dict())
        return
    for k, shot in enumerate(done.analysis.shots):
        d, a, s = shot.disparity_px, shot.disparity_arcmin, shot.suggestion
        search = ""
        if shot.search is not None:
            (lo, hi), bound = shot.search["search_px"], " ".join(shot.on_bound)
            search = f"searched {lo} .. {hi} px ({shot.search['search_source']}{', on bound: ' + bound if bound else ''}), "
        console.print(f"shot {k}: frames {shot.start}-{shot.end - 1}, disparity {d['p1']:+.2f} .. {d['p99']:+.2f} px "
                      f"(1-99 %), median {d['p50']:+.2f} px, {search}= {a['p1']:+.1f} .. {a['p99']:+.1f} arcmin, "
                      f"{100 * shot.outside_comfort:.1f} % outside comfort, {100 * shot.diverging:.1f} % diverging, "
                      f"{shot.window_violations} window violations; suggestion into the comfort zone: {s['action']} "
                      f"(scale {s['scale']:.3f}, shift {s['shift_px']:+.2f} px){_convert_note(s['convert'])}")
    if report is not None:
        console.print(f"report: {report / 'index.html'}")


def _convert_note(convert: dict) -> str:
    """What vergence convert would do to the shot (its budget is a target, the comfort zone a limit)."""
    if convert["scale"] is None:
        return ""
    return (f"; vergence convert fills +-{convert['budget_arcmin']:g} arcmin: scale {convert['scale']:.3f}, shift "
            f"{convert['shift_px']:+.2f} px")
