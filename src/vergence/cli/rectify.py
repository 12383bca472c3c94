"""``vergence rectify``: Fusiello-Trucco-Verri rectification of a calibrated pair (Fusiello et al. 2000; S2 §3.2).

Writes ``DIR/left.png``, ``DIR/right.png``, their validity masks ``DIR/left_valid.png`` and
``DIR/right_valid.png`` (255 where the rectified pixel comes from inside the original image, 0 in the
black borders; ``vergence match --mask`` takes the left one) and ``DIR/rectification.json`` (rectified
cameras, homographies, baseline, focal length, doffs and, with ``--check``, the measured row alignment).
All five files or none: the work is :func:`vergence.commands.rectify.rectify`.
"""

from __future__ import annotations

from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, console, err_console, option, print_json, run_command
from vergence.cli._spinner import Spinner
from vergence.commands.rectify import RECTIFY

__all__ = ["rectify"]


def _note(line: str) -> None:
    err_console.print(f"[yellow]note:[/] {line}", highlight=False, soft_wrap=True)


@app.command("rectify")
def rectify(
    left: Path = option(RECTIFY, "left"),
    right: Path = option(RECTIFY, "right"),
    cameras: Path = option(RECTIFY, "cameras"),
    out: Path = option(RECTIFY, "out"),
    image_list: Path | None = option(RECTIFY, "image_list"),
    common_principal_point: bool = option(RECTIFY, "common_principal_point"),
    check: bool = option(RECTIFY, "check"),
    as_json: bool = typer.Option(False, "--json", help="Print rectification.json on stdout."),
) -> None:
    """Rectify LEFT and RIGHT with their calibrated cameras: row-aligned images, cameras, homographies."""
    with Spinner() as progress:
        report = run_command(RECTIFY, left=left, right=right, cameras=cameras, out=out, image_list=image_list,
                             common_principal_point=common_principal_point, check=check, progress=progress,
                             note=_note, before_commit=raise_if_interrupted)
    data = report.to_dict()
    if as_json:
        print_json(data)
        return
    rectification = report.rectification
    cam = rectification.left_camera
    console.print(f"rectified {left.name} + {right.name}: {cam.width}x{cam.height}, baseline "
                  f"{rectification.baseline:.6g}, f = {rectification.focal_px:.6g} px, "
                  f"doffs = {rectification.doffs_px:.3f} px -> {out}")
    if check:
        r = data["row_alignment"]
        console.print(f"row alignment: median |dy| = {r['median_abs_dy_px']:.3f} px, 90th percentile "
                      f"{r['p90_abs_dy_px']:.3f} px over {r['matches']} SIFT matches")
