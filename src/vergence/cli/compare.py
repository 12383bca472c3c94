"""``vergence compare``: PSNR, SSIM, DSSIM and the registration error of S1 Eq. (11)-(13)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from vergence.cli._app import app, check_output_path, console, err_console, options_named, print_json
from vergence.io import read_image, write_image
from vergence.metrics import MAX_REGISTRATION_RADIUS, MIN_CONTRAST
from vergence.synthesis import assess_view, error_image

__all__ = ["compare"]


def _mask(path: Path) -> np.ndarray:
    """A mask image: grey, True where the value is above one half (255 in an 8-bit mask)."""
    m = read_image(path)
    if m.ndim != 2:
        raise ValueError(f"--mask {path} must be a single-channel (grey) image; got shape {m.shape}")
    return m > 0.5


@app.command("compare")
def compare(
    image: Path = typer.Argument(..., help="The image to assess (e.g. a synthesized view)."),
    reference: Path = typer.Argument(..., help="The reference (the real view)."),
    mask: Path | None = typer.Option(None, "--mask", help="Grey mask: compare where it is above one half."),
    radius: float = typer.Option(10.0, "--radius", help="Registration-error search radius (px)."),
    min_contrast: float = typer.Option(
        MIN_CONTRAST, "--min-contrast",
        help="Registration error only where the image's 5x5 patch contrast (RMS, [0, 1] units) is at least "
        "this; 0: every pixel.",
    ),
    error_path: Path | None = typer.Option(
        None, "--error-image", help="Write |image - reference| (channel mean) times --error-gain here."
    ),
    error_gain: float = typer.Option(4.0, "--error-gain", help="Gain of the error image."),
    as_json: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
) -> None:
    """Compare a view with its reference: PSNR, SSIM, DSSIM, registration error (S1 §V.B)."""
    if not (math.isfinite(error_gain) and error_gain > 0):
        raise ValueError(f"--error-gain must be a finite number > 0; got {error_gain}")
    if not (math.isfinite(radius) and 0 < radius <= MAX_REGISTRATION_RADIUS):
        raise ValueError(f"--radius must be a number in (0, {MAX_REGISTRATION_RADIUS}] px; got {radius:g}")
    if error_path is not None:
        check_output_path(error_path, image, reference, *([mask] if mask is not None else []))
    with err_console.status("comparing", spinner="dots"):
        a, b = read_image(image), read_image(reference)
        m = _mask(mask) if mask is not None else None
        with options_named(min_contrast="--min-contrast", radius="--radius", mask="--mask", image="IMAGE",
                           reference="REFERENCE"):
            quality = assess_view(a, b, mask=m, radius=radius, min_contrast=min_contrast)
    if error_path is not None:
        write_image(error_path, error_image(a, b, gain=error_gain))
    data = {"image": str(image), "reference": str(reference), "mask": None if mask is None else str(mask), **quality.to_dict()}
    if as_json:
        print_json(data)
        return
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
