"""``vergence match``: disparity of a rectified pair (OpenCV SGBM/BM or window matching, then refinement)."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import typer

from vergence.cli._app import app, check_output_path, console, err_console, print_json
from vergence.depth import METHODS, compute_disparity
from vergence.io import read_image, write_disparity, write_image

__all__ = ["match"]

_SMOOTHING = ("median", "wls", "none")
# Disparity file types of ``--out`` and whether they store integers (and so need ``--scale``).
_OUT_NEEDS_SCALE = {".npy": False, ".pfm": False, ".pgm": True, ".png": True}


def _check_outputs(out: Path, scale: float | None, extra: list[Path]) -> None:
    """Refuse, before any matching, an output that cannot be written as asked."""
    suffix = out.suffix.lower()
    if suffix not in _OUT_NEEDS_SCALE:
        raise ValueError(f"--out must be a .pfm, .npy, or .png/.pgm (with --scale) file; got {out.name!r}")
    if _OUT_NEEDS_SCALE[suffix] and scale is None:
        raise ValueError(f"--out {out.name} stores integers: give --scale (stored value = disparity x scale; 0 = unknown)")
    if not _OUT_NEEDS_SCALE[suffix] and scale is not None:
        raise ValueError(f"--scale applies to .png/.pgm outputs only; {out.name} stores float disparity")
    resolved = [p.resolve() for p in (out, *extra)]
    if len(set(resolved)) != len(resolved):
        raise ValueError("--out, --preview and --confidence must name different files")


def _preview(disparity: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Colour preview: turbo colour map over [lo, hi] (``hi > lo``, as the matcher checked), black where unknown."""
    scaled = np.clip((np.nan_to_num(disparity, nan=lo) - lo) / (hi - lo), 0.0, 1.0)
    rgb = cv2.applyColorMap(np.rint(scaled * 255).astype(np.uint8), cv2.COLORMAP_TURBO)[:, :, ::-1]
    rgb = rgb.astype(np.float32) / 255.0
    rgb[~np.isfinite(disparity)] = 0.0
    return rgb


@app.command("match")
def match(
    left: Path = typer.Argument(..., help="Left image of a rectified pair."),
    right: Path = typer.Argument(..., help="Right image (same size; both grey or both colour)."),
    max_disparity: int = typer.Option(..., "--max-disparity", help="Largest disparity searched (px)."),
    min_disparity: int = typer.Option(0, "--min-disparity", help="Smallest disparity searched (px)."),
    method: str = typer.Option("sgbm", "--method", help=f"Matcher: {', '.join(METHODS)}."),
    smoothing: str = typer.Option("median", "--smoothing", help=f"Edge-aware smoothing: {', '.join(_SMOOTHING)}."),
    keep_invalid: bool = typer.Option(False, "--keep-invalid", help="Keep unmatched pixels as NaN (0 in PNG)."),
    block_size: int | None = typer.Option(None, "--block-size", help="Matching window (odd, px)."),
    out: Path = typer.Option(..., "--out", help="Disparity output: .pfm, .npy, or .png with --scale."),
    scale: float | None = typer.Option(None, "--scale", help="PNG: stored value = disparity x scale (16-bit)."),
    preview: Path | None = typer.Option(None, "--preview", help="Also write a colour preview image here."),
    confidence: Path | None = typer.Option(None, "--confidence", help="Also write the confidence map (grey image)."),
    as_json: bool = typer.Option(False, "--json", help="Print a summary as JSON."),
) -> None:
    """Compute the disparity map of LEFT (x_left - x_right, px) and write it to --out."""
    extra = [p for p in (preview, confidence) if p is not None]
    _check_outputs(out, scale, extra)
    for o in (out, *extra):
        check_output_path(o, left, right)
    start = time.perf_counter()
    with err_console.status(f"matching ({method})", spinner="dots"):
        a, b = read_image(left), read_image(right)
        result = compute_disparity(a, b, max_disparity=max_disparity, min_disparity=min_disparity, method=method,
                                   smoothing=smoothing, keep_invalid=keep_invalid, block_size=block_size)
    seconds = time.perf_counter() - start
    write_disparity(out, result.disparity, scale=scale)
    if preview is not None:
        write_image(preview, _preview(result.disparity, float(min_disparity), float(max_disparity)))
    if confidence is not None:
        write_image(confidence, result.confidence)
    d = result.disparity
    known = np.isfinite(d)
    summary = {
        "left": str(left), "right": str(right), "out": str(out), "method": method, "smoothing": smoothing,
        "width": int(d.shape[1]), "height": int(d.shape[0]),
        "matched_percent": float(100.0 * result.matched.mean()),
        "known_percent": float(100.0 * known.mean()),
        "disparity_min": float(d[known].min()) if known.any() else None,
        "disparity_max": float(d[known].max()) if known.any() else None,
        "seconds": seconds,
    }
    if as_json:
        print_json(summary)
        return
    console.print(f"{method} + {smoothing}: {d.shape[1]}x{d.shape[0]}, {summary['matched_percent']:.1f} % matched, "
                  f"{summary['known_percent']:.1f} % with a disparity, in {seconds:.2f} s -> {out}")
