"""``vergence interpolate``'s work: a view between two rectified references with disparities (S1 §IV.B)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from vergence.commands._naming import literal
from vergence.commands._outputs import check_scale, staged_outputs
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.io import read_disparity, read_image, stores_integers, write_image, write_json
from vergence.io.atomic import check_output_path
from vergence.synthesis import FILL_METHODS, WarpedView, holes_warnings, interpolate_view

__all__ = ["INTERPOLATE", "SIXTEEN_BIT_SUFFIXES", "InterpolateReport", "interpolate"]

# Output formats written with 16 bits per sample unless bit_depth says otherwise: the README's
# Dolls figures (37.11 dB, SSIM 0.981) are those of the float view, which 16 bits keep (37.105 dB
# through the CLI) and 8 bits do not (37.05 dB).
SIXTEEN_BIT_SUFFIXES = (".png", ".pgm", ".ppm")


@dataclass(frozen=True, slots=True)
class InterpolateReport:
    """The interpolated view, the files and parameters it was made from, and where it was written."""

    view: WarpedView
    left: Path
    left_disparity: Path
    right: Path
    right_disparity: Path
    disparity_scale: float | None
    position: float
    fill: str
    edge_dilation: int
    out: Path

    @property
    def warnings(self) -> tuple[str, ...]:
        return tuple(holes_warnings([self.view.holes]))

    def to_dict(self) -> dict[str, object]:
        return {
            "left": str(self.left),
            "left_disparity": str(self.left_disparity),
            "right": str(self.right),
            "right_disparity": str(self.right_disparity),
            "disparity_scale": self.disparity_scale,
            "position": self.position,
            "fill": self.fill,
            "edge_dilation": self.edge_dilation,
            **self.view.to_dict(),
            "warnings": list(self.warnings),
            "output": str(self.out),
        }


def _disparity(path: Path, scale: float | None):
    """PNG/PGM: value / scale (0 = unknown); PFM/NPY: pixels as stored (NaN, inf = unknown; 0 is a
    real disparity, a point at infinity). The scale applies to PNG/PGM only."""
    if stores_integers(path):
        return read_disparity(path, scale=scale)
    if scale is not None and scale != 1.0:
        raise ParameterError("{disparity_scale} applies to PNG/PGM disparity files only; " + literal(path)
                             + f" holds pixels (got {scale:g})")
    return read_disparity(path)


def interpolate(*, left: Path, left_disparity: Path, right: Path, right_disparity: Path,
                disparity_scale: float | None = None, position: float, out: Path, fill: str = "background",
                edge_dilation: int = 1, bit_depth: int | None = None, json_out: Path | None = None,
                progress: Callable[[float, str], None] | None = None,
                before_commit: Callable[[], None] | None = None) -> InterpolateReport:  # fmt: skip
    """The view at ``position`` between two rectified references, written to ``out`` (and the report
    to ``json_out``), both files or neither; see :func:`vergence.synthesis.interpolate_view`.

    ``bit_depth`` (8 or 16) applies to PNG/PGM/PPM; by default they are written with 16 bits
    (:data:`SIXTEEN_BIT_SUFFIXES`), other formats with 8.

    Hooks: ``progress(0, "reading inputs")``, ``progress(0.5, "interpolating T = ...")`` and
    ``progress(1, ...)`` when the view is made; ``before_commit()`` once both files are written,
    before either appears (what it raises commits nothing).

    Raises
    ------
    ParameterError
        A value the views, the disparities or the outputs refuse, naming its parameter.
    OSError
        An input that cannot be read, an output that cannot be written.
    """
    left, left_disparity, right, right_disparity, out = map(Path, (left, left_disparity, right, right_disparity, out))
    json_out = None if json_out is None else Path(json_out)
    if disparity_scale is not None:
        with naming(disparity_scale="disparity_scale"):
            check_scale("disparity_scale", disparity_scale)
    if bit_depth is None:
        bit_depth = 16 if out.suffix.lower() in SIXTEEN_BIT_SUFFIXES else 8
    elif bit_depth not in (8, 16):
        raise ParameterError("{bit_depth} must be 8 or 16; " + f"got {bit_depth}")
    inputs = (left, left_disparity, right, right_disparity)
    for parameter, target in (("out", out), ("json_out", json_out)):
        if target is None:
            continue
        check_output_path(target, *inputs)
        if target.is_dir():
            raise ParameterError("{" + parameter + "} " + literal(target) + " is a folder; give a file")
        if not target.parent.is_dir():
            raise ParameterError("{" + parameter + "} " + literal(target) + ": folder " + literal(target.parent)
                                 + " does not exist")
    if json_out is not None and json_out.resolve() == out.resolve():
        raise ParameterError("{json_out} must differ from {out}; got " + literal(json_out) + " for both")
    if progress is not None:
        progress(0.0, "reading inputs")
    views = read_image(left), read_image(right)
    disparities = _disparity(left_disparity, disparity_scale), _disparity(right_disparity, disparity_scale)
    if progress is not None:
        progress(0.5, f"interpolating T = {position:g}")
    with naming(left="left", right="right", position="position", fill="fill", edge_dilation="edge_dilation",
                left_disparity="left_disparity", right_disparity="right_disparity"):
        view = interpolate_view(views[0], disparities[0], views[1], disparities[1], position, fill=fill,
                                edge_dilation=edge_dilation)
    if progress is not None:
        progress(1.0, f"interpolated T = {position:g}")
    report = InterpolateReport(view, left, left_disparity, right, right_disparity, disparity_scale, position, fill,
                               edge_dilation, out)
    # All or nothing: the view and its JSON appear together, or not at all.
    targets = [out] if json_out is None else [out, json_out]
    with staged_outputs(targets, before_commit=before_commit) as temps:
        write_image(temps[0], view.image, bit_depth=bit_depth)
        if json_out is not None:
            write_json(temps[1], report.to_dict())
    return report


INTERPOLATE = Command(
    name="interpolate",
    summary="Synthesize the view at position T between two rectified references (view interpolation).",
    parameters=(
        Parameter("left", "file", "Left reference view."),
        Parameter("left_disparity", "file", "Its disparity map (PNG/PGM, PFM, NPY)."),
        Parameter("right", "file", "Right reference view."),
        Parameter("right_disparity", "file", "Its disparity map."),
        Parameter("disparity_scale", "number", "PNG/PGM disparity = value / scale (e.g. 2 for Middlebury Dolls); "
                  "required for them, not used for PFM/NPY, which hold pixels.", None),
        Parameter("position", "number", "T in [0, 1]: 0 = left view, 1 = right view."),
        Parameter("out", "output", "Output image (extension picks the format)."),
        Parameter("fill", "text", f"Hole filling: {', '.join(FILL_METHODS)}.", "background"),
        Parameter("edge_dilation", "integer", "Pixels to grow the near side of depth edges.", 1),
        Parameter("bit_depth", "integer", "PNG/PGM/PPM bit depth (8 or 16); default 16, which keeps the view's "
                  "figures (8-bit rounding costs 0.06 dB on Dolls). JPEG is 8-bit; PFM/NPY are float.", None),
        Parameter("json_out", "output", "Also write the parameters and hole share here.", None),
    ),
    work=interpolate,
    hooks=("progress", "before_commit"),
)
