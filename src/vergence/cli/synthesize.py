"""``vergence synthesize``: 2D + depth to a stereo pair or N views (S1 §IV, depth controls §IV.C)."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import typer

from vergence.cli._app import (
    SYNTHESIS_BUDGET_ARCMIN as DEFAULT_BUDGET_ARCMIN,
    SYNTHESIS_DISPLAY as DEFAULT_DISPLAY,
    app,
    check_output_path,
    console,
    err_console,
    layout_file_name,
    options_named,
    preset_display,
    print_json,
)
from vergence.cli._scales import check_scale
from vergence.cli._staged import staged_outputs
from vergence.display import LAYOUTS, pack, tile_views
from vergence.io import DEPTH_KINDS, read_depth, read_image, write_image, write_json
from vergence.synthesis import FILL_METHODS, synthesize_stereo, views_offsets
from vergence.viewing.geometry import DISPLAY_PRESETS

__all__ = ["synthesize"]

# The stereo-pair layouts of vergence.display, and all views tiled.
FORMATS = (*LAYOUTS, "views")
# The library's argument names and the options or arguments that set them (its messages begin
# with the name): a message about ``depth`` speaks of DEPTH, the file the user typed.
_OPTIONS = {
    "image": "IMAGE",
    "depth": "DEPTH",
    "budget_arcmin": "--budget-arcmin",
    "budget_px": "--budget-px",
    "convergence": "--convergence",
    "focal_px": "--focal-px",
    "interaxial": "--interaxial",
    "kind": "--depth-kind",
    "views": "--views",
    "origin": "--origin",
    "smooth_sigma": "--smooth-sigma",
    "fill": "--fill",
}


@app.command("synthesize")
def synthesize(
    image: Path = typer.Argument(..., help="The original view (PNG, JPEG, PPM, PFM, NPY)."),
    depth: Path = typer.Argument(
        ...,
        help="Its depth map: PNG/PGM (value / --depth-scale, 0 = unknown) or PFM/NPY (as stored, NaN or inf "
        "= unknown; a metric depth must be > 0 where known).",
    ),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing)."),
    depth_kind: str = typer.Option(
        "metric", "--depth-kind", help=f"What the depth file holds: {', '.join(DEPTH_KINDS)}."
    ),
    depth_scale: float | None = typer.Option(
        None,
        "--depth-scale",
        help="PNG/PGM: stored value / scale = metres (metric) or pixels (disparity), default 1; 0 = unknown. "
        "Inverse depth: divides the [0, 1] values. Not used for PFM/NPY.",
    ),
    display_preset: str | None = typer.Option(
        None,
        "--display",
        help=f"Display preset: {', '.join(sorted(DISPLAY_PRESETS))}; default {DEFAULT_DISPLAY}. The arcminute "
        "budget and the arcminute range in the JSON refer to it (the image fills its width).",
    ),
    budget_arcmin: float | None = typer.Option(
        None, "--budget-arcmin", help="Parallax budget +-A arcmin of vergence on the display."
    ),
    budget_px: float | None = typer.Option(None, "--budget-px", help="Parallax budget +-P image pixels."),
    convergence: float | None = typer.Option(
        None, "--convergence", help="Depth of the zero-parallax plane, in the depth map's unit."
    ),
    focal_px: float | None = typer.Option(None, "--focal-px", help="Shift-sensor control: focal length (px)."),
    interaxial: float | None = typer.Option(None, "--interaxial", help="Shift-sensor control: interaxial (m)."),
    fmt: str = typer.Option("sbs", "--format", help=f"Output layout: {', '.join(FORMATS)}."),
    views: int = typer.Option(2, "--views", help="Number of views (>= 2); adjacent views form a stereo pair."),
    origin: str = typer.Option("center", "--origin", help="The original image is the centre or the left view."),
    fill: str = typer.Option("background", "--fill", help=f"Hole filling: {', '.join(FILL_METHODS)}."),
    smooth_sigma: float | None = typer.Option(
        None, "--smooth-sigma", help="ATTEST Gaussian pre-smoothing of the parallax map (px); off by default."
    ),
    bit_depth: int = typer.Option(8, "--bit-depth", help="PNG bit depth of the outputs (8 or 16)."),
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
    if fmt not in FORMATS:
        raise ValueError(f"--format must be one of {', '.join(FORMATS)}; got {fmt!r}")
    if views != 2 and fmt != "views":
        raise ValueError(f"--format {fmt} shows a stereo pair: use --views 2 or --format views; got --views {views}")
    if bit_depth not in (8, 16):
        raise ValueError(f"--bit-depth must be 8 or 16; got {bit_depth}")
    control_given = any(v is not None for v in (budget_arcmin, budget_px, focal_px, interaxial))
    if not control_given:
        budget_arcmin = DEFAULT_BUDGET_ARCMIN
    display_preset = display_preset or DEFAULT_DISPLAY  # the arcminute range is always reported
    display = preset_display(display_preset)
    if depth_scale is not None:
        check_scale("--depth-scale", depth_scale)
    with options_named(views="--views"):
        views_offsets(views)  # before naming that many outputs
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder")
    names = ["left.png", "right.png"] if views == 2 else [f"view_{k:02d}.png" for k in range(views)]
    layout = layout_file_name(fmt)
    targets = [out / n for n in [*names, layout, "synthesis.json"]]
    for target in targets:
        check_output_path(target, image, depth)
    with err_console.status("reading inputs", spinner="dots"):
        picture = read_image(image)
        with options_named(kind="--depth-kind", scale="--depth-scale", depth="DEPTH"):
            depth_map = read_depth(depth, kind=depth_kind, scale=depth_scale)
    with err_console.status("synthesizing views", spinner="dots"), options_named(**_OPTIONS):
        result = synthesize_stereo(
            picture,
            depth_map,
            kind=depth_kind,
            display=display,
            budget_arcmin=budget_arcmin,
            budget_px=budget_px,
            convergence=convergence,
            focal_px=focal_px,
            interaxial=interaxial,
            views=views,
            origin=origin,
            smooth_sigma=smooth_sigma,
            fill=fill,
        )
    params = {
        "image": str(image),
        "depth": str(depth),
        "depth_kind": depth_kind,
        "depth_scale": depth_scale,
        "control": "shift-sensor" if focal_px is not None or interaxial is not None else "budget",
        "budget_arcmin": budget_arcmin,
        "budget_px": budget_px,
        "convergence": convergence,
        "focal_px": focal_px,
        "interaxial": interaxial,
        "display": {"preset": display_preset, **dataclasses.asdict(display)},
        "views": views,
        "origin": origin,
        "fill": fill,
        "smooth_sigma": smooth_sigma,
        "format": fmt,
        **result.to_dict(),
        "outputs": [str(t) for t in targets],
    }
    # All or nothing: the views, the layout and the JSON appear together, or not at all.
    staging = staged_outputs(targets, folder=out)
    with err_console.status("writing outputs", spinner="dots"), staging as temps:
        for temp, view in zip(temps, result.views):
            write_image(temp, view, bit_depth=bit_depth)
        packed = tile_views(result.views) if fmt == "views" else pack(result.left, result.right, layout=fmt)
        write_image(temps[len(names)], packed, bit_depth=bit_depth)
        write_json(temps[-1], params)
    plan = result.plan
    for line in result.warnings:  # also in the JSON ("warnings")
        sys.stderr.write(f"warning: {line}\n")
    if as_json:
        print_json(params)
        return
    (lo, hi), (lo_arcmin, hi_arcmin) = plan.range_px, plan.range_arcmin
    console.print(
        f"{views} views, parallax {lo:+.2f} .. {hi:+.2f} px = {lo_arcmin:+.1f} .. {hi_arcmin:+.1f} arcmin; "
        f"wrote {', '.join(t.name for t in targets)} to {out}"
    )
