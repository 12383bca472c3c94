"""``vergence synthesize``: 2D + depth to a stereo pair or N views (S1 §IV, depth controls §IV.C)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, console, option, print_json, run_command
from vergence.cli._spinner import Spinner
from vergence.commands.synthesize import SYNTHESIZE

__all__ = ["synthesize"]


@app.command("synthesize")
def synthesize(
    image: Path = option(SYNTHESIZE, "image"),
    depth: Path = option(SYNTHESIZE, "depth"),
    out: Path = option(SYNTHESIZE, "out"),
    depth_kind: str = option(SYNTHESIZE, "depth_kind"),
    depth_scale: float | None = option(SYNTHESIZE, "depth_scale"),
    display_preset: str | None = option(SYNTHESIZE, "display"),
    budget_arcmin: float | None = option(SYNTHESIZE, "budget_arcmin"),
    budget_px: float | None = option(SYNTHESIZE, "budget_px"),
    convergence: float | None = option(SYNTHESIZE, "convergence"),
    focal_px: float | None = option(SYNTHESIZE, "focal_px"),
    interaxial: float | None = option(SYNTHESIZE, "interaxial"),
    fmt: str = option(SYNTHESIZE, "format"),
    views: int = option(SYNTHESIZE, "views"),
    origin: str = option(SYNTHESIZE, "origin"),
    fill: str = option(SYNTHESIZE, "fill"),
    smooth_sigma: float | None = option(SYNTHESIZE, "smooth_sigma"),
    bit_depth: int = option(SYNTHESIZE, "bit_depth"),
    as_json: bool = typer.Option(False, "--json", help="Print the parameters JSON on stdout."),
) -> None:
    """Make the views a display needs from one image and its depth (writes views, layout, JSON).

    Exactly one depth control: --budget-arcmin (on --display), --budget-px, or --focal-px with
    --interaxial and --convergence. Without any, +-30 arcmin on the display (desktop-24 unless
    given) is used. The JSON gives the parallax range between adjacent views in pixels and in
    arcminutes of vergence on the display. Parallax that cannot fit the image (the outer views a
    whole image width apart, MAX_PARALLAX_WIDTHS) is refused; a result that leaves the display's
    comfort zone (+-60 arcmin), passes divergence or is mostly filled-in holes gets a warning on
    stderr and in the JSON.
    """
    with Spinner() as progress:
        report = run_command(SYNTHESIZE, image=image, depth=depth, out=out, depth_kind=depth_kind,
                             depth_scale=depth_scale, display=display_preset, budget_arcmin=budget_arcmin,
                             budget_px=budget_px, convergence=convergence, focal_px=focal_px, interaxial=interaxial,
                             format=fmt, views=views, origin=origin, fill=fill, smooth_sigma=smooth_sigma,
                             bit_depth=bit_depth, progress=progress, before_commit=raise_if_interrupted)
    # also in the JSON ("warnings", with the display under "display"); on the terminal a warning about
    # the display's zone or divergence says which display it judged (issue 31: the default one, unsaid)
    shown = f"display {report.display_preset}" + (", the default: --display names yours" if display_preset is None
                                                  else "")
    for line in report.warnings:
        judged = "comfort zone" in line or "diverge" in line
        sys.stderr.write(f"warning: {line}{f' (on the {shown})' if judged else ''}\n")
    if as_json:
        print_json(report.to_dict())
        return
    (lo, hi), (lo_arcmin, hi_arcmin) = report.result.plan.range_px, report.result.plan.range_arcmin
    console.print(
        f"{views} views, parallax {lo:+.2f} .. {hi:+.2f} px = {lo_arcmin:+.1f} .. {hi_arcmin:+.1f} arcmin; "
        f"wrote {', '.join(t.name for t in report.outputs)} to {out}"
    )
