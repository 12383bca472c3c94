"""``vergence interpolate``: a view between two rectified references with disparities (S1 §IV.B)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, console, option, print_json, run_command
from vergence.cli._spinner import Spinner
from vergence.commands.interpolate import INTERPOLATE

__all__ = ["interpolate"]


@app.command("interpolate")
def interpolate(
    left: Path = option(INTERPOLATE, "left"),
    left_disparity: Path = option(INTERPOLATE, "left_disparity"),
    right: Path = option(INTERPOLATE, "right"),
    right_disparity: Path = option(INTERPOLATE, "right_disparity"),
    disparity_scale: float | None = option(INTERPOLATE, "disparity_scale"),
    position: float = option(INTERPOLATE, "position"),
    out: Path = option(INTERPOLATE, "out"),
    fill: str = option(INTERPOLATE, "fill"),
    edge_dilation: int = option(INTERPOLATE, "edge_dilation"),
    bit_depth: int | None = option(INTERPOLATE, "bit_depth"),
    json_out: Path | None = option(INTERPOLATE, "json_out"),
    as_json: bool = typer.Option(False, "--json", help="Print the parameters JSON on stdout."),
) -> None:
    """Synthesize the view at position T between two rectified references (view interpolation).

    A pixel at x in the left view with disparity d appears at x - T d; one at x in the right view
    at x + (1 - T) d. Unknown disparity: 0 in PNG/PGM files; NaN or inf in PFM/NPY files, where 0
    is a real disparity (a point at infinity). Unknown pixels take the disparity of their
    background neighbour on the row.
    """
    with Spinner() as progress:
        report = run_command(INTERPOLATE, left=left, left_disparity=left_disparity, right=right,
                             right_disparity=right_disparity, disparity_scale=disparity_scale, position=position,
                             out=out, fill=fill, edge_dilation=edge_dilation, bit_depth=bit_depth, json_out=json_out,
                             progress=progress, before_commit=raise_if_interrupted)
    data = report.to_dict()
    for line in data["warnings"]:
        sys.stderr.write(f"warning: {line}\n")
    if as_json:
        print_json(data)
        return
    console.print(f"view at T = {position:g} written to {out} ({data['holes_percent']:.3f} % of it seen by neither "
                  "reference)")
