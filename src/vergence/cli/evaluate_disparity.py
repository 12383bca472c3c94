"""``vergence evaluate-disparity``: Middlebury bad-pixel and RMS figures (S1 Eq. 9-10; Scharstein & Szeliski 2002)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, options_named, print_json
from vergence.depth import evaluate_disparity as evaluate
from vergence.depth import read_middlebury_masks
from vergence.io import read_disparity, read_image, stores_integers

__all__ = ["evaluate_disparity"]


@app.command("evaluate-disparity")
def evaluate_disparity(
    estimate: Path = typer.Argument(..., help="Computed disparity (.pfm, .npy, or .png/.pgm with --estimate-scale)."),
    truth: Path = typer.Argument(..., help="Ground-truth disparity (.png/.pgm with --truth-scale, .pfm, .npy)."),
    estimate_scale: float | None = typer.Option(None, "--estimate-scale", help="PNG/PGM estimate: value / scale."),
    truth_scale: float | None = typer.Option(None, "--truth-scale", help="PNG/PGM truth: value / scale."),
    masks: Path | None = typer.Option(None, "--masks", help="Folder with Middlebury nonocc.png, all.png, disc.png."),
    truth_right: Path | None = typer.Option(
        None, "--truth-right", help="Right ground truth for the computed nonocc (Middlebury 2005/2006: disp5.png "
        "beside disp1.png, with --truth-scale 2 --border 0)."
    ),
    border: int | None = typer.Option(
        None, "--border", help="Pixels ignored at each edge by the computed regions (default 10, as StereoMatcher)."
    ),
    image: Path | None = typer.Option(None, "--image", help="Left image: adds the computed textureless region."),
    threshold: float = typer.Option(1.0, "--threshold", help="Bad pixel: |error| > threshold (px)."),
    as_json: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
) -> None:
    """Score ESTIMATE against TRUTH: % bad pixels and RMS over nonocc / all / disc (/ textureless)."""
    if masks is not None and (truth_right is not None or image is not None or border is not None):
        raise ValueError("--masks replaces the computed regions; do not combine it with --truth-right, --image "
                         "or --border")
    with options_named(scale="--estimate-scale"):
        est = read_disparity(estimate, scale=estimate_scale)
    with options_named(scale="--truth-scale"):
        gt = read_disparity(truth, scale=truth_scale)
        # --truth-scale reads both truths; a float right truth beside an integer left one takes none
        right = (read_disparity(truth_right, scale=truth_scale if stores_integers(truth_right) else None)
                 if truth_right is not None else None)
    official = read_middlebury_masks(masks) if masks is not None else None
    img = read_image(image) if image is not None else None
    with options_named(threshold="--threshold", image="--image", truth_right="--truth-right", estimate="ESTIMATE",
                       truth="TRUTH", mask="--masks", border="--border"):
        scores = evaluate(est, gt, masks=official, image=img, truth_right=right, threshold=threshold, border=border)
    data = {name: s.to_dict() for name, s in scores.items()}
    if as_json:
        print_json(data)
        return
    source = f"official masks in {masks}" if masks is not None else "regions computed from the ground truth"
    table = Table(title=f"{estimate.name} vs {truth.name} ({source}; bad = |error| > {threshold:g} px)")
    for col in ("region", "bad %", "RMS (px)", "pixels"):
        table.add_column(col, justify="left" if col == "region" else "right")
    for name, s in scores.items():
        table.add_row(name, f"{s.bad:.2f}", f"{s.rms:.3f}", str(s.pixels))
    console.print(table)
