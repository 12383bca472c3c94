"""``vergence synthesize``'s work: 2D + depth to a stereo pair or N views (S1 §IV, depth controls §IV.C),
written all or nothing with their layout and parameters JSON."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from vergence.commands._naming import literal
from vergence.commands._outputs import check_scale, staged_outputs
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.display import LAYOUTS, pack, tile_views
from vergence.io import DEPTH_KINDS, read_depth, read_image, write_image, write_json
from vergence.io.atomic import check_output_path
from vergence.synthesis import FILL_METHODS, StereoResult, synthesize_stereo, views_offsets
from vergence.viewing.geometry import DISPLAY_PRESETS, Display

__all__ = ["FORMATS", "SYNTHESIS_BUDGET_ARCMIN", "SYNTHESIS_DISPLAY", "SYNTHESIZE", "SynthesisReport",
           "layout_file_name", "synthesize"]

# ``vergence synthesize`` (and the workbench's synthesize job) without any depth control: this vergence
# budget on this display. +-30 arcmin is half the usual +-1 degree comfort zone
# (vergence.viewing.comfort.ComfortZone), a safe start.
SYNTHESIS_DISPLAY = "desktop-24"
SYNTHESIS_BUDGET_ARCMIN = 30.0

#: The stereo-pair layouts of vergence.display, and all views tiled.
FORMATS = (*LAYOUTS, "views")

# The library's argument names and the parameters that set them (its messages begin with the name).
_NAMES = {
    "image": "image",
    "depth": "depth",
    "budget_arcmin": "budget_arcmin",
    "budget_px": "budget_px",
    "convergence": "convergence",
    "focal_px": "focal_px",
    "interaxial": "interaxial",
    "kind": "depth_kind",
    "views": "views",
    "origin": "origin",
    "smooth_sigma": "smooth_sigma",
    "fill": "fill",
}


def layout_file_name(layout: str) -> str:
    """The file ``vergence synthesize --format LAYOUT`` writes the packed pair (or tiled views) to:
    ``anaglyph.png``, ``views_tiled.png``, else ``stereo_<layout>.png``."""
    return {"anaglyph": "anaglyph.png", "views": "views_tiled.png"}.get(layout, f"stereo_{layout}.png")


@dataclass(frozen=True, slots=True)
class SynthesisReport:
    """The synthesized views, the parameters they were made with and the files written.

    ``budget_arcmin`` is the budget used (:data:`SYNTHESIS_BUDGET_ARCMIN` when no depth control was
    given), ``display_preset`` the display's name (:data:`SYNTHESIS_DISPLAY` when none was given);
    ``outputs`` the views, the layout and ``synthesis.json``, in that order.
    """

    result: StereoResult
    image: Path
    depth: Path
    depth_kind: str
    depth_scale: float | None
    budget_arcmin: float | None
    budget_px: float | None
    convergence: float | None
    focal_px: float | None
    interaxial: float | None
    display_preset: str
    display: Display
    views: int
    origin: str
    fill: str
    smooth_sigma: float | None
    format: str
    out: Path
    outputs: tuple[Path, ...]

    @property
    def warnings(self) -> tuple[str, ...]:
        return tuple(self.result.warnings)

    def to_dict(self) -> dict[str, object]:
        """The parameters JSON: what ``synthesis.json`` holds and ``--json`` prints."""
        return {
            "image": str(self.image),
            "depth": str(self.depth),
            "depth_kind": self.depth_kind,
            "depth_scale": self.depth_scale,
            "control": "shift-sensor" if self.focal_px is not None or self.interaxial is not None else "budget",
            "budget_arcmin": self.budget_arcmin,
            "budget_px": self.budget_px,
            "convergence": self.convergence,
            "focal_px": self.focal_px,
            "interaxial": self.interaxial,
            "display": {"preset": self.display_preset, **dataclasses.asdict(self.display)},
            "views": self.views,
            "origin": self.origin,
            "fill": self.fill,
            "smooth_sigma": self.smooth_sigma,
            "format": self.format,
            **self.result.to_dict(),
            "outputs": [str(t) for t in self.outputs],
        }


def _display(name: str) -> Display:
    try:
        return Display.preset(name)
    except ValueError as exc:  # the library's message names no argument
        raise ParameterError("{display}: " + literal(exc)) from exc


def synthesize(*, image: Path, depth: Path, out: Path, depth_kind: str = "metric", depth_scale: float | None = None,
               display: str | None = None, budget_arcmin: float | None = None, budget_px: float | None = None,
               convergence: float | None = None, focal_px: float | None = None, interaxial: float | None = None,
               format: str = "sbs", views: int = 2, origin: str = "center", fill: str = "background",
               smooth_sigma: float | None = None, bit_depth: int = 8,
               progress: Callable[[float, str], None] | None = None,
               before_commit: Callable[[], None] | None = None) -> SynthesisReport:
    """The views a display needs from ``image`` and its ``depth``
    (:func:`vergence.synthesis.synthesize_stereo`), written to the folder ``out`` with their layout
    (``format``) and the parameters JSON, all or nothing.

    Hooks: ``progress(0, "reading inputs")``, ``progress(0.1, "synthesizing views")``,
    ``progress(0.8, "writing outputs")`` and ``progress(1, "written")`` once the outputs are in place;
    ``before_commit()`` once every output is written, right before they are renamed into place (what
    it raises commits nothing).

    Raises
    ------
    ParameterError
        A value the command or the library refuses, naming its parameter.
    """
    if format not in FORMATS:
        raise ParameterError("{format} must be one of " + ", ".join(FORMATS) + "; got " + literal(repr(format)))
    if views != 2 and format != "views":
        raise ParameterError("{format} " + literal(format) + " shows a stereo pair: use {views} 2 or {format} views; "
                             "got {views} " + str(views))
    if bit_depth not in (8, 16):
        raise ParameterError("{bit_depth} must be 8 or 16; got " + str(bit_depth))
    control_given = any(v is not None for v in (budget_arcmin, budget_px, focal_px, interaxial))
    if not control_given:
        budget_arcmin = SYNTHESIS_BUDGET_ARCMIN
    display_preset = display or SYNTHESIS_DISPLAY  # the arcminute range is always reported
    chosen = _display(display_preset)
    if depth_scale is not None:
        with naming(depth_scale="depth_scale"):
            check_scale("depth_scale", depth_scale)
    with naming(views="views"):
        views_offsets(views)  # before naming that many outputs
    if out.exists() and not out.is_dir():
        raise ParameterError("{out} " + literal(out) + " is a file; give a folder")
    names = ["left.png", "right.png"] if views == 2 else [f"view_{k:02d}.png" for k in range(views)]
    targets = [out / n for n in [*names, layout_file_name(format), "synthesis.json"]]
    for target in targets:
        check_output_path(target, image, depth)
    if progress is not None:
        progress(0.0, "reading inputs")
    picture = read_image(image)
    with naming(kind="depth_kind", scale="depth_scale", depth="depth"):
        depth_map = read_depth(depth, kind=depth_kind, scale=depth_scale)
    if progress is not None:
        progress(0.1, "synthesizing views")
    with naming(**_NAMES):
        result = synthesize_stereo(picture, depth_map, kind=depth_kind, display=chosen, budget_arcmin=budget_arcmin,
                                   budget_px=budget_px, convergence=convergence, focal_px=focal_px,
                                   interaxial=interaxial, views=views, origin=origin, smooth_sigma=smooth_sigma,
                                   fill=fill)  # fmt: skip
    report = SynthesisReport(result, image, depth, depth_kind, depth_scale, budget_arcmin, budget_px, convergence,
                             focal_px, interaxial, display_preset, chosen, views, origin, fill, smooth_sigma, format,
                             out, tuple(targets))  # fmt: skip
    if progress is not None:
        progress(0.8, "writing outputs")
    # All or nothing: the views, the layout and the JSON appear together, or not at all.
    with staged_outputs(targets, folder=out, before_commit=before_commit) as temps:
        for temp, view in zip(temps, result.views):
            write_image(temp, view, bit_depth=bit_depth)
        packed = tile_views(result.views) if format == "views" else pack(result.left, result.right, layout=format)
        write_image(temps[len(names)], packed, bit_depth=bit_depth)
        write_json(temps[-1], report.to_dict())
    if progress is not None:
        progress(1.0, "written")
    return report


SYNTHESIZE = Command(
    name="synthesize",
    summary="Make the views a display needs from one image and its depth (writes views, layout, JSON).",
    parameters=(
        Parameter("image", "file", "The original view (PNG, JPEG, PPM, PFM, NPY).", option=""),
        Parameter("depth", "file", "Its depth map: PNG/PGM (value / {depth_scale}, 0 = unknown) or PFM/NPY (as "
                  "stored, NaN or inf = unknown; a metric depth must be > 0 where known).", option=""),
        Parameter("out", "output", "Output folder (created if missing)."),
        Parameter("depth_kind", "text", f"What the depth file holds: {', '.join(DEPTH_KINDS)}.", "metric"),
        Parameter("depth_scale", "number", "PNG/PGM: stored value / scale = metres (metric) or pixels (disparity), "
                  "default 1; 0 = unknown. Inverse depth: divides the [0, 1] values. Not used for PFM/NPY.", None),
        Parameter("display", "text", f"Display preset: {', '.join(sorted(DISPLAY_PRESETS))}; default "
                  f"{SYNTHESIS_DISPLAY}. The arcminute budget and the arcminute range in the JSON refer to it (the "
                  "image fills its width).", None),
        Parameter("budget_arcmin", "number", "Parallax budget +-A arcmin of vergence on the display.", None),
        Parameter("budget_px", "number", "Parallax budget +-P image pixels.", None),
        Parameter("convergence", "number", "Depth of the zero-parallax plane, in the depth map's unit.", None),
        Parameter("focal_px", "number", "Shift-sensor control: focal length (px).", None),
        Parameter("interaxial", "number", "Shift-sensor control: interaxial (m).", None),
        Parameter("format", "text", f"Output layout: {', '.join(FORMATS)}.", "sbs"),
        Parameter("views", "integer", "Number of views (>= 2); adjacent views form a stereo pair.", 2),
        Parameter("origin", "text", "The original image is the centre or the left view.", "center"),
        Parameter("fill", "text", f"Hole filling: {', '.join(FILL_METHODS)}.", "background"),
        Parameter("smooth_sigma", "number", "ATTEST Gaussian pre-smoothing of the parallax map (px); off by default.",
                  None),
        Parameter("bit_depth", "integer", "PNG bit depth of the outputs (8 or 16).", 8),
    ),
    work=synthesize,
    hooks=("progress", "before_commit"),
)
