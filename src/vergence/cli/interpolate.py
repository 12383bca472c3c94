"""``vergence interpolate``: a view between two rectified references with disparities (S1 §IV.B)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from vergence.cli._app import app, check_output_path, console, err_console, options_named, print_json
from vergence.cli._scales import check_scale
from vergence.cli._staged import staged_outputs
from vergence.io import read_disparity, read_image, stores_integers, write_image, write_json
from vergence.synthesis import FILL_METHODS, holes_warnings, interpolate_view

__all__ = ["interpolate"]

# Output formats written with 16 bits per sample unless --bit-depth says otherwise: the README's
# Dolls figures (37.11 dB, SSIM 0.981) are those of the float view, which 16 bits keep (37.105 dB
# through the CLI) and 8 bits do not (37.05 dB).
SIXTEEN_BIT_SUFFIXES = (".png", ".pgm", ".ppm")


def _disparity(path: Path, scale: float | None):
    """PNG/PGM: value / scale (0 = unknown); PFM/NPY: pixels as stored (NaN, inf = unknown; 0 is a
    real disparity, a point at infinity). The scale applies to PNG/PGM only."""
    if stores_integers(path):
        return read_disparity(path, scale=scale)
    if scale is not None and scale != 1.0:
        raise ValueError(f"--disparity-scale applies to PNG/PGM disparity files only; {path} holds pixels (got {scale:g})")
    return read_disparity(path)


@app.command("interpolate")
def interpolate(
    left: Path = typer.Option(..., "--left", help="Left reference view."),
    left_disparity: Path = typer.Option(..., "--left-disparity", help="Its disparity map (PNG/PGM, PFM, NPY)."),
    right: Path = typer.Option(..., "--right", help="Right reference view."),
    right_disparity: Path = typer.Option(..., "--right-disparity", help="Its disparity map."),
    disparity_scale: float | None = typer.Option(
        None,
        "--disparity-scale",
        help="PNG/PGM disparity = value / scale (e.g. 2 for Middlebury Dolls); required for them, "
        "not used for PFM/NPY, which hold pixels.",
    ),
    position: float = typer.Option(..., "--position", help="T in [0, 1]: 0 = left view, 1 = right view."),
    out: Path = typer.Option(..., "--out", help="Output image (extension picks the format)."),
    fill: str = typer.Option("background", "--fill", help=f"Hole filling: {', '.join(FILL_METHODS)}."),
    edge_dilation: int = typer.Option(1, "--edge-dilation", help="Pixels to grow the near side of depth edges."),
    bit_depth: int | None = typer.Option(
        None,
        "--bit-depth",
        help="PNG/PGM/PPM bit depth (8 or 16); default 16, which keeps the view's figures (8-bit rounding "
        "costs 0.06 dB on Dolls). JPEG is 8-bit; PFM/NPY are float.",
    ),
    json_out: Path | None = typer.Option(None, "--json-out", help="Also write the parameters and hole share here."),
    as_json: bool = typer.Option(False, "--json", help="Print the parameters JSON on stdout."),
) -> None:
    """Synthesize the view at position T between two rectified references (view interpolation).

    A pixel at x in the left view with disparity d appears at x - T d; one at x in the right view
    at x + (1 - T) d. Unknown disparity: 0 in PNG/PGM files; NaN or inf in PFM/NPY files, where 0
    is a real disparity (a point at infinity). Unknown pixels take the disparity of their
    background neighbour on the row.
    """
    if disparity_scale is not None:
        check_scale("--disparity-scale", disparity_scale)
    if bit_depth is None:
        bit_depth = 16 if out.suffix.lower() in SIXTEEN_BIT_SUFFIXES else 8
    elif bit_depth not in (8, 16):
        raise ValueError(f"--bit-depth must be 8 or 16; got {bit_depth}")
    inputs = (left, left_disparity, right, right_disparity)
    for option, target in (("--out", out), ("--json-out", json_out)):
        if target is None:
            continue
        check_output_path(target, *inputs)
        if target.is_dir():
            raise ValueError(f"{option} {target} is a folder; give a file")
        if not target.parent.is_dir():
            raise ValueError(f"{option} {target}: folder {target.parent} does not exist")
    if json_out is not None and json_out.resolve() == out.resolve():
        raise ValueError(f"--json-out must differ from --out; got {json_out} for both")
    with err_console.status("reading inputs", spinner="dots"):
        views = read_image(left), read_image(right)
        disparities = _disparity(left_disparity, disparity_scale), _disparity(right_disparity, disparity_scale)
    names = options_named(
        left="--left",
        right="--right",
        position="--position",
        fill="--fill",
        edge_dilation="--edge-dilation",
        left_disparity="--left-disparity",
        right_disparity="--right-disparity",
    )
    with err_console.status(f"interpolating T = {position:g}", spinner="dots"), names:
        result = interpolate_view(
            views[0], disparities[0], views[1], disparities[1], position, fill=fill, edge_dilation=edge_dilation
        )
    report = {
        "left": str(left),
        "left_disparity": str(left_disparity),
        "right": str(right),
        "right_disparity": str(right_disparity),
        "disparity_scale": disparity_scale,
        "position": position,
        "fill": fill,
        "edge_dilation": edge_dilation,
        **result.to_dict(),
        "warnings": list(holes_warnings([result.holes])),
        "output": str(out),
    }
    # All or nothing: the view and its JSON appear together, or not at all.
    targets = [out] if json_out is None else [out, json_out]
    with staged_outputs(targets) as temps:
        write_image(temps[0], result.image, bit_depth=bit_depth)
        if json_out is not None:
            write_json(temps[1], report)
    for line in report["warnings"]:
        sys.stderr.write(f"warning: {line}\n")
    if as_json:
        print_json(report)
        return
    console.print(f"view at T = {position:g} written to {out} ({report['holes_percent']:.3f} % of it seen by neither reference)")
