"""``vergence match``'s work: the disparity of a rectified pair (OpenCV SGBM/BM, window matching or
PatchMatch Stereo, then refinement), written atomically with its preview and confidence map."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.commands._naming import literal, naming_both
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.depth import (
    MATCHERS,
    MAX_BLOCK_SIZE,
    SMOOTHING_METHODS,
    PatchMatchParameters,
    RefinedDisparity,
    compute_disparity,
    disparity_preview,
)
from vergence.io import atomic_write, read_image, stores_integers, write_disparity, write_image
from vergence.io.atomic import check_output_path

__all__ = ["MATCH", "MatchReport", "match"]

_PM = PatchMatchParameters()  # the defaults the help text shows

# The largest value of a 16-bit PNG/PGM sample: stored disparity x scale must not exceed it.
_MAX_SAMPLE = 65535
# The formats write_image takes for an RGB preview and for a grey confidence map.
_PREVIEW_SUFFIXES = (".png", ".jpg", ".jpeg", ".ppm", ".pfm", ".npy", ".hdr")
_CONFIDENCE_SUFFIXES = (".png", ".pgm", ".jpg", ".jpeg", ".pfm", ".npy")
# The PatchMatch parameters (PatchMatchParameters' fields) and the parameters of the command that set them.
_PM_FIELDS = ("step", "iterations", "gamma", "alpha", "tau_color", "tau_gradient")


@dataclass(frozen=True, slots=True)
class MatchReport:
    """The matched disparity, the files it was made from and written to, and the time it took.

    ``warnings`` are the matcher's and, for a PNG/PGM output, the one about disparities stored as
    1/scale px; ``seconds`` the time from reading the images to the end of the matching.
    """

    result: RefinedDisparity
    left: Path
    right: Path
    mask: Path | None
    out: Path
    method: str
    smoothing: str
    planes: bool
    warnings: tuple[str, ...]
    seconds: float

    def to_dict(self) -> dict[str, object]:
        return {"left": str(self.left), "right": str(self.right), "mask": None if self.mask is None else str(self.mask),
                "out": str(self.out), "method": self.method, "smoothing": self.smoothing, "planes": self.planes,
                **self.result.to_dict(), "warnings": list(self.warnings), "seconds": self.seconds}


def _check_outputs(out: Path, scale: float | None, preview: Path | None, confidence: Path | None, min_disparity: int,
                   max_disparity: int) -> bool:
    """Refuse, before any matching, an output that cannot be written as asked; whether it stores integers."""
    extra = [p for p in (preview, confidence) if p is not None]
    name = literal(out.name)
    try:
        integers = stores_integers(out)
    except ValueError:
        raise ParameterError("{out} must be a .pfm, .npy, or .png/.pgm (with {scale}) file; got "
                             + literal(repr(out.name))) from None
    if integers and scale is None:
        raise ParameterError("{out} " + name + " stores integers: give {scale} (stored value = disparity x scale; "
                             "0 = unknown)")
    if not integers and scale is not None:
        raise ParameterError("{scale} applies to .png/.pgm outputs only; " + name + " stores float disparity")
    if integers:
        if not (math.isfinite(scale) and scale > 0):
            raise ParameterError("{scale} must be a finite number > 0; got " + f"{scale:g}")
        if min_disparity < 0:
            raise ParameterError("{out} " + name + " stores disparities >= 0 only, and {min_disparity} "
                                 + f"{min_disparity} searches negative ones: write .pfm or .npy")
        if max_disparity * scale > _MAX_SAMPLE + 0.5:
            raise ParameterError("{max_disparity} " + f"{max_disparity} x " + "{scale} " + f"{scale:g} exceeds "
                                 f"{_MAX_SAMPLE}, the largest 16-bit value of " + name + ": lower {scale}, or write "
                                 ".pfm or .npy")
    for parameter, path, suffixes in (("preview", preview, _PREVIEW_SUFFIXES),
                                      ("confidence", confidence, _CONFIDENCE_SUFFIXES)):
        if path is not None and path.suffix.lower() not in suffixes:
            raise ParameterError("{" + parameter + "} must be a " + ", ".join(suffixes) + " file; got "
                                 + literal(repr(path.name)))
    if integers and max_disparity * scale < 1:
        raise ParameterError("{scale} " + f"{scale:g} stores the whole range up to " + "{max_disparity} "
                             + f"{max_disparity} in less than one step: give a scale of at least 1 / max disparity")
    for path in (out, *extra):
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
        if path.is_dir():
            raise IsADirectoryError(f"cannot write {path}: it is a folder")
    resolved = [p.resolve() for p in (out, *extra)]
    if len(set(resolved)) != len(resolved):
        raise ParameterError("{out}, {preview} and {confidence} must name different files")
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


def _write_all(out: Path, disparity: np.ndarray, scale: float | None, pictures: dict[Path, np.ndarray],
               before_commit: Callable[[], None] | None) -> None:
    """Write the disparity and the pictures into hidden temporary files, then rename them all into place.

    All outputs or none: ``before_commit()`` runs once every file is written, before any rename. An
    error names the file the caller asked for, never the temporary one.
    """
    temporary: dict[Path, Path] = {}
    try:
        with ExitStack() as stack:
            temporary[out] = stack.enter_context(atomic_write(out))
            write_disparity(temporary[out], disparity, scale=scale)
            for path, picture in pictures.items():
                temporary[path] = stack.enter_context(atomic_write(path))
                write_image(temporary[path], picture)
            if before_commit is not None:
                before_commit()
    except (ValueError, OSError) as exc:
        message = str(exc)
        for final, tmp in temporary.items():
            message = message.replace(str(tmp), str(final)).replace(tmp.name, final.name)
        raise type(exc)(message) from exc


def _mask(path: Path, hw: tuple[int, ...]) -> np.ndarray:
    """The ``mask`` image as a boolean (H, W) mask of ``left``'s size: True above one half (255 of 8 bits)."""
    m = read_image(path)
    name = literal(path.name)
    if m.ndim != 2:
        raise ParameterError("{mask} " + name + f" must be a grey image; got {m.shape[2]} channels")
    if m.shape != hw:
        raise ParameterError("{mask} " + name + " must have the size of {left} " + f"({hw[1]}x{hw[0]}); got "
                             f"{m.shape[1]}x{m.shape[0]}")
    if not (m > 0.5).any():
        raise ParameterError("{mask} " + name + " selects no pixel (all below one half)")
    return m > 0.5


def match(*, left: Path, right: Path, max_disparity: int, min_disparity: int = 0, method: str = "sgbm",
          smoothing: str = "median", keep_invalid: bool = False, planes: bool = False, block_size: int | None = None,
          out: Path, scale: float | None = None, mask: Path | None = None, preview: Path | None = None,
          confidence: Path | None = None, pm_step: int | None = None, pm_iterations: int | None = None,
          pm_gamma: float | None = None, pm_alpha: float | None = None, pm_tau_color: float | None = None,
          pm_tau_gradient: float | None = None, progress: Callable[[float, str], None] | None = None,
          warn: Callable[[str], None] | None = None,
          before_commit: Callable[[], None] | None = None) -> MatchReport:  # fmt: skip
    """The disparity of ``left`` (x_left - x_right, px) against ``right``, written to ``out`` (and the
    ``preview`` and ``confidence`` pictures), all files or none; see
    :func:`vergence.depth.compute_disparity`.

    Every output is checked before any matching. A PNG/PGM ``out`` stores ``disparity x scale`` in
    16 bits, 0 meaning unknown: a known disparity that would round to 0 is stored as 1/scale px, with
    a warning.

    Hooks: ``progress(0, message)`` as the matching starts and ``progress(1, message)`` when it ends;
    ``warn(line)`` for each warning, before the files are written (they are in the result too);
    ``before_commit()`` once every file is written, before any appears (what it raises commits nothing).

    Raises
    ------
    ParameterError
        A value the matcher, the images or the outputs refuse, naming its parameter.
    OSError
        An input that cannot be read, an output that cannot be written.
    """
    left, right, out = Path(left), Path(right), Path(out)
    mask, preview, confidence = (None if p is None else Path(p) for p in (mask, preview, confidence))
    if block_size is not None and not (1 <= block_size <= MAX_BLOCK_SIZE and block_size % 2 == 1):
        raise ParameterError("{block_size} must be an odd number of pixels in " + f"[1, {MAX_BLOCK_SIZE}]; got "
                             f"{block_size}")
    given = dict(zip(_PM_FIELDS, (pm_step, pm_iterations, pm_gamma, pm_alpha, pm_tau_color, pm_tau_gradient)))
    given = {k: v for k, v in given.items() if v is not None}
    pm_names = {k: "pm_" + k for k in _PM_FIELDS}
    patchmatch = None
    if given:
        if method != "patchmatch":
            raise ParameterError(", ".join("{" + pm_names[k] + "}" for k in given) + ": for {method} patchmatch "
                                 "only; got {method} " + literal(method))
        with naming(**pm_names):
            patchmatch = PatchMatchParameters(**given)
    extra = [p for p in (preview, confidence) if p is not None]
    integers = _check_outputs(out, scale, preview, confidence, min_disparity, max_disparity)
    for o in (out, *extra):
        check_output_path(o, left, right, *([mask] if mask is not None else []))
    start = time.perf_counter()
    if progress is not None:
        progress(0.0, f"matching ({method})")
    names = {"block_size": "block_size", "max_disparity": "max_disparity", "min_disparity": "min_disparity",
             "method": "method", "smoothing": "smoothing", "left": "left", "right": "right", "valid": "mask",
             "planes": "planes", "window": "block_size", **pm_names}
    with naming(**names), naming_both("left and right", "left", "right"):
        a, b = read_image(left), read_image(right)
        valid = _mask(mask, a.shape[:2]) if mask is not None else None
        result = compute_disparity(a, b, max_disparity=max_disparity, min_disparity=min_disparity, method=method,
                                   smoothing=smoothing, keep_invalid=keep_invalid, block_size=block_size, valid=valid,
                                   patchmatch=patchmatch, planes=planes)
    seconds = time.perf_counter() - start
    if progress is not None:
        progress(1.0, f"matched ({method})")
    disparity, stored_warning = _storable(result.disparity, scale) if integers else (result.disparity, None)
    warnings = (*result.warnings, *([stored_warning] if stored_warning else []))
    if warn is not None:
        for warning in warnings:
            warn(warning)
    pictures = {}
    if preview is not None:
        pictures[preview] = disparity_preview(result.disparity, lo=float(min_disparity), hi=float(max_disparity),
                                              colour_bar=True)
    if confidence is not None:
        pictures[confidence] = result.confidence
    _write_all(out, disparity, scale, pictures, before_commit)
    return MatchReport(result, left, right, mask, out, method, smoothing, planes, warnings, seconds)


MATCH = Command(
    name="match",
    summary="Compute the disparity map of LEFT (x_left - x_right, px) and write it to --out.",
    parameters=(
        Parameter("left", "file", "Left image of a rectified pair.", option=""),
        Parameter("right", "file", "Right image (same size; both grey or both colour).", option=""),
        Parameter("max_disparity", "integer", "Largest disparity searched (px)."),
        Parameter("min_disparity", "integer", "Smallest disparity searched (px).", 0),
        Parameter("method", "text", f"Matcher: {', '.join(MATCHERS)} (patchmatch: PatchMatch Stereo, slanted windows, "
                  "Bleyer et al. 2011; slower, see the README's table).", "sgbm"),
        Parameter("smoothing", "text", f"Edge-aware smoothing: {', '.join(SMOOTHING_METHODS)}.", "median"),
        Parameter("keep_invalid", "flag", "Leave unmatched pixels unknown: NaN in .npy, inf in .pfm, 0 in .png/.pgm "
                  "(there a true disparity 0 is stored as 1/scale px, with a warning).", False),
        Parameter("planes", "flag", "Fill unmatched pixels of planar colour segments from robust disparity planes "
                  "(large weakly textured surfaces); with patchmatch, where its left-right check failed.", False),
        Parameter("block_size", "integer", f"Matching window (odd, px, at most {MAX_BLOCK_SIZE} and the image's "
                  "smaller side).", None),
        Parameter("out", "output", "Disparity output: .pfm, .npy, or .png with {scale}."),
        Parameter("scale", "number", "PNG: stored value = disparity x scale (16-bit).", None),
        Parameter("mask", "file", "Validity mask of {left} (rectify's left_valid.png): where it is below one half "
                  "(the black borders of a rectified image) the disparity is unknown, not extrapolated.", None),
        Parameter("preview", "output", "Also write a colour preview here (turbo, {min_disparity} to {max_disparity}, "
                  "with its colour bar; black = unknown).", None),
        Parameter("confidence", "output", "Also write the confidence map (grey image).", None),
        Parameter("pm_step", "integer", f"patchmatch: sample the window every N px (default {_PM.step}; 1 = every "
                  "pixel).", None),
        Parameter("pm_iterations", "integer", f"patchmatch: propagation iterations (default {_PM.iterations}).", None),
        Parameter("pm_gamma", "number", "patchmatch: colour scale of the support weights, 8-bit levels "
                  f"(default {_PM.gamma:g}).", None),
        Parameter("pm_alpha", "number", f"patchmatch: weight of the gradient cost, 0 to 1 (default {_PM.alpha:g}).",
                  None),
        Parameter("pm_tau_color", "number", "patchmatch: colour cost truncation, 8-bit levels "
                  f"(default {_PM.tau_color:g}).", None),
        Parameter("pm_tau_gradient", "number", "patchmatch: gradient cost truncation "
                  f"(default {_PM.tau_gradient:g}).", None),
    ),
    work=match,
    hooks=("progress", "warn", "before_commit"),
)
