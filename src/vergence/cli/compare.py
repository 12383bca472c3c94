"""``vergence compare``: PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from vergence.cli._app import app, console, option, print_json, run_command
from vergence.cli._spinner import Spinner
from vergence.commands.compare import COMPARE

__all__ = ["compare"]


@app.command("compare")
def compare(
    image: Path = option(COMPARE, "image"),
    reference: Path = option(COMPARE, "reference"),
    mask: Path | None = option(COMPARE, "mask"),
    radius: float = option(COMPARE, "radius"),
    min_contrast: float = option(COMPARE, "min_contrast"),
    error_path: Path | None = option(COMPARE, "error_image"),
    error_gain: float = option(COMPARE, "error_gain"),
    as_json: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
) -> None:
    """Compare a view with its reference: PSNR, SSIM, DSSIM, registration error (S1 §V.B)."""
    with Spinner() as progress:
        report = run_command(COMPARE, image=image, reference=reference, mask=mask, radius=radius,
                             min_contrast=min_contrast, error_image=error_path, error_gain=error_gain,
                             progress=progress)
    if as_json:
        print_json(report.to_dict())
        return
    quality = report.quality
    table = Table(title=f"{image.name} vs {reference.name}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_row("PSNR (dB)", "inf (identical)" if quality.identical else f"{quality.psnr_db:.3f}")
    table.add_row("SSIM", f"{quality.ssim:.4f}")
    table.add_row("DSSIM", f"{quality.dssim:.4f}")
    if quality.registration_pixels:
        table.add_row("registration RMS (px)", f"{quality.registration_rms_px:.3f}")
        table.add_row("registration median (px)", f"{quality.registration_median_px:.3f}")
        for k, v in quality.registration_ranked_px.items():
            table.add_row(f"registration d^{k:g} (px)" + (" = Hausdorff" if k == 1.0 else ""), f"{v:.3f}")
    else:
        table.add_row("registration error", "- (no textured pixel to register)")
    table.add_row("pixels", str(quality.pixels))
    table.add_row(
        f"registration pixels (contrast >= {quality.registration_min_contrast:.4g})",
        f"{quality.registration_pixels} ({100.0 * quality.registration_pixels / quality.pixels:.1f} %)",
    )
    console.print(table)
    if error_path is not None:
        console.print(f"error image written to {error_path}")
