"""``vergence match``: disparity of a rectified pair (OpenCV SGBM/BM or window matching, then refinement)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, console, option, print_json, run_command
from vergence.cli._spinner import Spinner
from vergence.commands.match import MATCH

__all__ = ["match"]


def _warn(line: str) -> None:
    sys.stderr.write(f"warning: {line}\n")


@app.command("match")
def match(
    left: Path = option(MATCH, "left"),
    right: Path = option(MATCH, "right"),
    max_disparity: int = option(MATCH, "max_disparity"),
    min_disparity: int = option(MATCH, "min_disparity"),
    method: str = option(MATCH, "method"),
    smoothing: str = option(MATCH, "smoothing"),
    keep_invalid: bool = option(MATCH, "keep_invalid"),
    planes: bool = option(MATCH, "planes"),
    block_size: int | None = option(MATCH, "block_size"),
    out: Path = option(MATCH, "out"),
    scale: float | None = option(MATCH, "scale"),
    mask: Path | None = option(MATCH, "mask"),
    preview: Path | None = option(MATCH, "preview"),
    confidence: Path | None = option(MATCH, "confidence"),
    as_json: bool = typer.Option(False, "--json", help="Print a summary as JSON."),
    pm_step: int | None = option(MATCH, "pm_step"),
    pm_iterations: int | None = option(MATCH, "pm_iterations"),
    pm_gamma: float | None = option(MATCH, "pm_gamma"),
    pm_alpha: float | None = option(MATCH, "pm_alpha"),
    pm_tau_color: float | None = option(MATCH, "pm_tau_color"),
    pm_tau_gradient: float | None = option(MATCH, "pm_tau_gradient"),
) -> None:
    """Compute the disparity map of LEFT (x_left - x_right, px) and write it to --out."""
    with Spinner() as progress:
        report = run_command(MATCH, left=left, right=right, max_disparity=max_disparity, min_disparity=min_disparity,
                             method=method, smoothing=smoothing, keep_invalid=keep_invalid, planes=planes,
                             block_size=block_size, out=out, scale=scale, mask=mask, preview=preview,
                             confidence=confidence, pm_step=pm_step, pm_iterations=pm_iterations, pm_gamma=pm_gamma,
                             pm_alpha=pm_alpha, pm_tau_color=pm_tau_color, pm_tau_gradient=pm_tau_gradient,
                             progress=progress, warn=_warn, before_commit=raise_if_interrupted)
    if as_json:
        print_json(report.to_dict())
        return
    summary = report.result.to_dict()
    console.print(f"{method} + {smoothing}: {summary['width']}x{summary['height']}, "
                  f"{summary['matched_percent']:.1f} % matched, {summary['known_percent']:.1f} % with a disparity, "
                  f"in {report.seconds:.2f} s -> {out}")
