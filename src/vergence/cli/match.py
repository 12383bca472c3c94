"""``vergence match``: disparity of a rectified pair (OpenCV SGBM/BM or window matching, then refinement)."""

from __future__ import annotations

import math
import sys
import time
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, check_output_path, console, err_console, options_named, print_json
from vergence.depth import (
    MATCHERS,
    MAX_BLOCK_SIZE,
    SMOOTHING_METHODS,
    PatchMatchParameters,
    compute_disparity,
    disparity_preview,
)
from vergence.io import atomic_write, read_image, stores_integers, write_disparity, write_image

__all__ = ["match"]

_PM = PatchMatchParameters()  # the defaults the help text shows


# The largest value of a 16-bit PNG/PGM sample: stored disparity x scale must not exceed it.
_MAX_SAMPLE = 65535
# The formats write_image takes for an RGB preview and for a grey confidence map.
_PREVIEW_SUFFIXES = (".png", ".jpg", ".jpeg", ".ppm", ".pfm", ".npy", ".hdr")
_CONFIDENCE_SUFFIXES = (".png", ".pgm", ".jpg", ".jpeg", ".pfm", ".npy")


def _check_outputs(out: Path, scale: float | None, preview: Path | None, confidence: Path | None, min_disparity: int,
                   max_disparity: int) -> bool:
    """Refuse, before any matching, an output that cannot be written as asked; whether it stores integers."""
    extra = [p for p in (preview, confidence) if p is not None]
    try:
        integers = stores_integers(out)
    except ValueError:
        raise ValueError(f"--out must be a .pfm, .npy, or .png/.pgm (with --scale) file; got {out.name!r}") from None
    if integers and scale is None:
        raise ValueError(f"--out {out.name} stores integers: give --scale (stored value = disparity x scale; 0 = unknown)")
    if not integers and scale is not None:
        raise ValueError(f"--scale applies to .png/.pgm outputs only; {out.name} stores float disparity")
    if integers:
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f"--scale must be a finite number > 0; got {scale:g}")
        if min_disparity < 0:
            raise ValueError(f"--out {out.name} stores disparities >= 0 only, and --min-disparity {min_disparity} "
                             "searches negative ones: write .pfm or .npy")
        if max_disparity * scale > _MAX_SAMPLE + 0.5:
            raise ValueError(f"--max-disparity {max_disparity} x --scale {scale:g} exceeds {_MAX_SAMPLE}, the largest "
                             f"16-bit value of {out.name}: lower --scale, or write .pfm or .npy")
    for option, path, suffixes in (("--preview", preview, _PREVIEW_SUFFIXES),
                                   ("--confidence", confidence, _CONFIDENCE_SUFFIXES)):
        if path is not None and path.suffix.lower() not in suffixes:
            raise ValueError(f"{option} must be a {', '.join(suffixes)} file; got {path.name!r}")
    if integers and max_disparity * scale < 1:
        raise ValueError(f"--scale {scale:g} stores the whole range up to --max-disparity {max_disparity} in less than "
                         "one step: give a scale of at least 1 / max disparity")
    for path in (out, *extra):
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
        if path.is_dir():
            raise IsADirectoryError(f"cannot write {path}: it is a folder")
    resolved = [p.resolve() for p in (out, *extra)]
    if len(set(resolved)) != len(resolved):
        raise ValueError("--out, --preview and --confidence must name different files")
    return integers


def _storable(disparity: np.ndarray, scale: float) -> tuple[np.ndarray, str | None]:
    """The map a 16-bit PNG/PGM can hold (0 = unknown there), and a warning when it had to differ.

    A known disparity that rounds to 0 at ``scale`` (a point at infinity, or one within half a step of
    it) would read back as unknown: it is stored as 1, the smallest known value (1/scale px).
    """
    zero = np.isfinite(disparity) & (np.rint(np.nan_to_num(disparity) * scale) == 0)
    count = int(np.count_nonzero(zero))
    if not count:
        return disparity, None
    stored = disparity.copy()
    stored[zero] = 1.0 / scale
    return stored, (f"{count} pixels of disparity 0 (below {0.5 / scale:g} px) are stored as 1/{scale:g} px, the "
                    "smallest value a PNG/PGM disparity can hold (0 means unknown there); write .pfm or .npy "
                    "to keep them exact")


def _write_all(out: Path, disparity: np.ndarray, scale: float | None, pictures: dict[Path, np.ndarray]) -> None:
    """Write the disparity and the pictures into hidden temporary files, then rename them all into place.

    All outputs or none. An error names the file the user asked for, never the temporary one.
    """
    temporary: dict[Path, Path] = {}
    try:
        with ExitStack() as stack:
            temporary[out] = stack.enter_context(atomic_write(out))
            write_disparity(temporary[out], disparity, scale=scale)
            for path, picture in pictures.items():
                temporary[path] = stack.enter_context(atomic_write(path))
                write_image(temporary[path], picture)
            raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM: commit nothing
    except (ValueError, OSError) as exc:
        message = str(exc)
        for final, tmp in temporary.items():
            message = message.replace(str(tmp), str(final)).replace(tmp.name, final.name)
        raise type(exc)(message) from exc


def _mask(path: Path, hw: tuple[int, ...]) -> np.ndarray:
    """The ``--mask`` image as a boolean (H, W) mask of LEFT's size: True above one half (255 of 8 bits)."""
    m = read_image(path)
    if m.ndim != 2:
        raise ValueError(f"--mask {path.name} must be a grey image; got {m.shape[2]} channels")
    if m.shape != hw:
        raise ValueError(f"--mask {path.name} must have the size of LEFT ({hw[1]}x{hw[0]}); got {m.shape[1]}x{m.shape[0]}")
    if not (m > 0.5).any():
        raise ValueError(f"--mask {path.name} selects no pixel (all below one half)")
    return m > 0.5


@app.command("match")
def match(
    left: Path = typer.Argument(..., help="Left image of a rectified pair."),
    right: Path = typer.Argument(..., help="Right image (same size; both grey or both colour)."),
    max_disparity: int = typer.Option(..., "--max-disparity", help="Largest disparity searched (px)."),
    min_disparity: int = typer.Option(0, "--min-disparity", help="Smallest disparity searched (px)."),
    method: str = typer.Option("sgbm", "--method", help=f"Matcher: {', '.join(MATCHERS)} (patchmatch: PatchMatch "
                               "Stereo, slanted windows, Bleyer et al. 2011; slower, see the README's table)."),
    smoothing: str = typer.Option(
        "median", "--smoothing", help=f"Edge-aware smoothing: {', '.join(SMOOTHING_METHODS)}."
    ),
    keep_invalid: bool = typer.Option(
        False, "--keep-invalid", help="Leave unmatched pixels unknown: NaN in .npy, inf in .pfm, 0 in .png/.pgm "
        "(there a true disparity 0 is stored as 1/scale px, with a warning)."
    ),
    planes: bool = typer.Option(
        False, "--planes", help="Fill unmatched pixels of planar colour segments from robust disparity planes "
        "(large weakly textured surfaces); with patchmatch, where its left-right check failed."
    ),
    block_size: int | None = typer.Option(
        None, "--block-size", help=f"Matching window (odd, px, at most {MAX_BLOCK_SIZE} and the image's smaller side)."
    ),
    out: Path = typer.Option(..., "--out", help="Disparity output: .pfm, .npy, or .png with --scale."),
    scale: float | None = typer.Option(None, "--scale", help="PNG: stored value = disparity x scale (16-bit)."),
    mask: Path | None = typer.Option(
        None, "--mask", help="Validity mask of LEFT (rectify's left_valid.png): where it is below one half "
        "(the black borders of a rectified image) the disparity is unknown, not extrapolated."
    ),
    preview: Path | None = typer.Option(
        None, "--preview", help="Also write a colour preview here (turbo, --min-disparity to --max-disparity, with its "
        "colour bar; black = unknown)."
    ),
    confidence: Path | None = typer.Option(None, "--confidence", help="Also write the confidence map (grey image)."),
    as_json: bool = typer.Option(False, "--json", help="Print a summary as JSON."),
    pm_step: int | None = typer.Option(
        None, "--pm-step", help=f"patchmatch: sample the window every N px (default {_PM.step}; 1 = every pixel)."),
    pm_iterations: int | None = typer.Option(
        None, "--pm-iterations", help=f"patchmatch: propagation iterations (default {_PM.iterations})."),
    pm_gamma: float | None = typer.Option(
        None, "--pm-gamma",
        help=f"patchmatch: colour scale of the support weights, 8-bit levels (default {_PM.gamma:g})."),
    pm_alpha: float | None = typer.Option(
        None, "--pm-alpha", help=f"patchmatch: weight of the gradient cost, 0 to 1 (default {_PM.alpha:g})."),
    pm_tau_color: float | None = typer.Option(
        None, "--pm-tau-color", help=f"patchmatch: colour cost truncation, 8-bit levels (default {_PM.tau_color:g})."),
    pm_tau_gradient: float | None = typer.Option(
        None, "--pm-tau-gradient", help=f"patchmatch: gradient cost truncation (default {_PM.tau_gradient:g})."),
) -> None:
    """Compute the disparity map of LEFT (x_left - x_right, px) and write it to --out."""
    if block_size is not None and not (1 <= block_size <= MAX_BLOCK_SIZE and block_size % 2 == 1):
        raise ValueError(f"--block-size must be an odd number of pixels in [1, {MAX_BLOCK_SIZE}]; got {block_size}")
    pm_given = {"step": pm_step, "iterations": pm_iterations, "gamma": pm_gamma, "alpha": pm_alpha,
                "tau_color": pm_tau_color, "tau_gradient": pm_tau_gradient}
    pm_given = {k: v for k, v in pm_given.items() if v is not None}
    pm_options = {k: "--pm-" + k.replace("_", "-") for k in ("step", "iterations", "gamma", "alpha", "tau_color",
                                                               "tau_gradient")}
    patchmatch = None
    if pm_given:
        if method != "patchmatch":
            raise ValueError(f"{', '.join(pm_options[k] for k in pm_given)}: for --method patchmatch only; "
                             f"got --method {method}")
        with options_named(**pm_options):
            patchmatch = PatchMatchParameters(**pm_given)
    extra = [p for p in (preview, confidence) if p is not None]
    integers = _check_outputs(out, scale, preview, confidence, min_disparity, max_disparity)
    for o in (out, *extra):
        check_output_path(o, left, right, *([mask] if mask is not None else []))
    start = time.perf_counter()
    names = {"block_size": "--block-size", "max_disparity": "--max-disparity", "min_disparity": "--min-disparity",
             "method": "--method", "smoothing": "--smoothing", "left and right": "LEFT and RIGHT", "left": "LEFT",
             "right": "RIGHT", "valid": "--mask", "planes": "--planes", "window": "--block-size", **pm_options}
    with err_console.status(f"matching ({method})", spinner="dots"), options_named(**names):
        a, b = read_image(left), read_image(right)
        valid = _mask(mask, a.shape[:2]) if mask is not None else None
        result = compute_disparity(a, b, max_disparity=max_disparity, min_disparity=min_disparity, method=method,
                                   smoothing=smoothing, keep_invalid=keep_invalid, block_size=block_size, valid=valid,
                                   patchmatch=patchmatch, planes=planes)
    seconds = time.perf_counter() - start
    disparity, stored_warning = _storable(result.disparity, scale) if integers else (result.disparity, None)
    warnings = [*result.warnings, *([stored_warning] if stored_warning else [])]
    for warning in warnings:
        sys.stderr.write(f"warning: {warning}\n")
    pictures = {}
    if preview is not None:
        pictures[preview] = disparity_preview(result.disparity, lo=float(min_disparity), hi=float(max_disparity),
                                              colour_bar=True)
    if confidence is not None:
        pictures[confidence] = result.confidence
    _write_all(out, disparity, scale, pictures)
    summary = {"left": str(left), "right": str(right), "mask": None if mask is None else str(mask), "out": str(out),
               "method": method, "smoothing": smoothing, "planes": planes,
               **result.to_dict(), "warnings": warnings, "seconds": seconds}
    if as_json:
        print_json(summary)
        return
    console.print(f"{method} + {smoothing}: {summary['width']}x{summary['height']}, "
                  f"{summary['matched_percent']:.1f} % matched, {summary['known_percent']:.1f} % with a disparity, "
                  f"in {seconds:.2f} s -> {out}")
