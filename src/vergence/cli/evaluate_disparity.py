"""``vergence evaluate-disparity``: Middlebury bad-pixel and RMS figures (S1 Eq. 9-10; Scharstein & Szeliski 2002)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, option, print_json, run_command
from vergence.commands.evaluate_disparity import EVALUATE_DISPARITY

__all__ = ["evaluate_disparity"]


@app.command("evaluate-disparity")
def evaluate_disparity(
    estimate: Path = option(EVALUATE_DISPARITY, "estimate"),
    truth: Path = option(EVALUATE_DISPARITY, "truth"),
    estimate_scale: float | None = option(EVALUATE_DISPARITY, "estimate_scale"),
    truth_scale: float | None = option(EVALUATE_DISPARITY, "truth_scale"),
    masks: Path | None = option(EVALUATE_DISPARITY, "masks"),
    truth_right: Path | None = option(EVALUATE_DISPARITY, "truth_right"),
    border: int | None = option(EVALUATE_DISPARITY, "border"),
    image: Path | None = option(EVALUATE_DISPARITY, "image"),
    threshold: float = option(EVALUATE_DISPARITY, "threshold"),
    as_json: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
) -> None:
    """Score ESTIMATE against TRUTH: % bad pixels and RMS over nonocc / all / disc (/ textureless)."""
    report = run_command(EVALUATE_DISPARITY, estimate=estimate, truth=truth, estimate_scale=estimate_scale,
                         truth_scale=truth_scale, masks=masks, truth_right=truth_right, border=border, image=image,
                         threshold=threshold)
    if as_json:
        print_json(report.to_dict())
        return
    source = f"official masks in {masks}" if masks is not None else "regions computed from the ground truth"
    table = Table(title=f"{estimate.name} vs {truth.name} ({source}; bad = |error| > {threshold:g} px)")
    for col in ("region", "bad %", "RMS (px)", "pixels"):
        table.add_column(col, justify="left" if col == "region" else "right")
    for name, s in report.scores.items():
        table.add_row(name, f"{s.bad:.2f}", f"{s.rms:.3f}", str(s.pixels))
    console.print(table)
