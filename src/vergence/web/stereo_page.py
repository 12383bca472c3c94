"""Page 2 of the workbench, "2D + depth to stereo" (issue 13): the ``synthesize`` job.

One job makes the stereo pair of an image and its depth as ``vergence synthesize`` does
(:func:`vergence.synthesis.synthesize_stereo`, S1 §IV; depth controls §IV.C), then writes it in every
layout of :data:`vergence.display.LAYOUTS` (anaglyphs, side by side, top-bottom, interleaved,
checkerboard, cross-eyed) and answers the comfort figures of the pair on the chosen display
(:func:`vergence.synthesis.plan_comfort`: the parallax range in arcmin of vergence against the
comfort zone, S3 §3, and the share of pixels outside it). Its input is one of:

- ``image`` + ``depth``: two uploads (``POST /api/uploads``), the depth of ``depth_kind``;
- ``left`` + ``right``: a rectified stereo pair (two uploads), matched first as ``vergence match``
  does (:func:`vergence.depth.compute_disparity`); the left view and its disparity are then
  synthesized as an image and a depth of kind ``disparity``;
- ``example``: a scene of ``GET /api/data`` (``scene:tabletop``) ray-traced at a small size as
  ``vergence render`` does (:func:`vergence.render.render`, written and read back through
  :func:`vergence.report.preview.save_render`), so that a fresh clone has an input.

The page runs two such jobs (parameter sets A and B, the same input) and wipes between them. Each job also
writes ``parallax.npy``, the pair's parallax map ``P = x_r - x_l`` (image px of the pair, float32, NaN where
unknown; :attr:`vergence.synthesis.ParallaxPlan.parallax_px`), and, for a stereo pair, the vertical disparity of
the pair as ``vergence rectify --check`` measures it (:func:`vergence.depth.measure_row_alignment`), the matched
pair's own parallax ``-d`` (``matched_parallax.npy``, ``d = x_l - x_r`` of :func:`vergence.depth.compute_disparity`)
and its two views as read (``input_left.png``, ``input_right.png``): the matching result's overlays.
``GET /api/stereo/{job_id}/overlay`` (:mod:`vergence.web.overlays`) answers what the page's overlays need besides
that map: the comfort zone, the divergence limit and a fixed colour scale in px of the pair, and the stereo-window
rule of :mod:`vergence.video` (docs/workbench.md, "Overlays").
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import tempfile
import threading
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pydantic
from fastapi import FastAPI

from vergence.web._models import RequestModel
from vergence.web.jobs import JobContext, JobKind, JobManager, JobResult, Prepared
from vergence.web.overlays import MATCHED_PARALLAX_FILE, PARALLAX_FILE, add_stereo_routes

if TYPE_CHECKING:
    import numpy as np

    from vergence.web.job_kinds import JobEnv
    from vergence.web.uploads import Upload

__all__ = ["EXAMPLE_DEPTH", "EXAMPLE_SAMPLES", "KINDS", "MAX_EXAMPLE_SIDE", "MAX_STEREO_JOB_PIXELS", "SynthesizeJob",
           "VERTICAL_WARN_PX", "add_routes"]

#: Largest input of a synthesize job, pixels (12 Mpx, 4000 x 3000): the pair and all its layouts
#: are written as PNG for the page; larger images are ``vergence synthesize``'s work.
MAX_STEREO_JOB_PIXELS = 12_000_000

#: Largest side of the built-in example's render, pixels: a preview input, rendered in seconds.
MAX_EXAMPLE_SIDE = 640

#: The example's render settings (``vergence render --depth 0 --samples 4``): the beauty image and
#: the depth of the first hit are all synthesis needs.
EXAMPLE_DEPTH = 0
EXAMPLE_SAMPLES = 4

#: A stereo pair's vertical disparity (median ``|y_r - y_l|`` of the SIFT matches, ``vergence rectify --check``'s
#: measure) above this many px of the pair is warned about: the matcher searches along rows, and a pixel of
#: vertical offset is where block matching starts to lose the match. ``rectify --check`` itself prints the
#: measure without a threshold.
VERTICAL_WARN_PX = 1.0

# The example renders kept in memory (scene, size -> image, depth): A and B of one input render once.
_EXAMPLES_KEPT = 4
_examples: OrderedDict[tuple[str, ...], tuple[np.ndarray, np.ndarray]] = OrderedDict()
_examples_lock = threading.Lock()

# Upload formats a depth map may come in (read by vergence.io.read_depth): JPEG's loss would invent depth.
_DEPTH_UPLOADS = ("png", "pfm", "npy")
_ORIGINS = ("center", "left")
# The depth controls of synthesize_stereo, as the job's fields name them.
_CONTROLS = ("budget_arcmin", "budget_px", "convergence", "focal_px", "interaxial")
_PAIR_FIELDS = ("max_disparity", "min_disparity", "method")
_EXAMPLE_FIELDS = ("example_width", "example_height")


def _choices(table: str) -> Any:
    """A field's valid values in its JSON schema (``enum``), read from the library's table when the schema
    is asked for (the page builds its menus from ``GET /api/jobs``); the job's own check refuses the rest."""

    def extra(schema: dict[str, Any]) -> None:
        from vergence.depth import MATCHERS
        from vergence.io import DEPTH_KINDS
        from vergence.synthesis import FILL_METHODS

        values = {"DEPTH_KINDS": DEPTH_KINDS, "MATCHERS": MATCHERS, "FILL_METHODS": FILL_METHODS,
                  "ORIGINS": _ORIGINS}[table]  # fmt: skip
        schema["enum"] = list(values)

    return extra


class SynthesizeJob(RequestModel):
    """Parameters of a ``synthesize`` job (as ``vergence synthesize``'s options, with ``vergence match``'s
    for a stereo pair). Give ``image`` and ``depth``, or ``left`` and ``right``, or ``example``."""

    model_config = pydantic.ConfigDict(extra="forbid")

    image: str | None = pydantic.Field(None, description="Upload id of the original view (POST /api/uploads).")
    depth: str | None = pydantic.Field(None, description="Upload id of its depth map (PNG, PFM or NPY, one channel).")
    left: str | None = pydantic.Field(None, description="Upload id of the left view of a rectified pair (matched).")
    right: str | None = pydantic.Field(None, description="Upload id of the right view of that pair.")
    example: str | None = pydantic.Field(
        None, description="A scene id of GET /api/data ('scene:tabletop'), rendered as the input.")
    example_width: int = pydantic.Field(160, ge=1, le=MAX_EXAMPLE_SIDE, description="The example's width, pixels.")
    example_height: int = pydantic.Field(120, ge=1, le=MAX_EXAMPLE_SIDE, description="The example's height, pixels.")
    depth_kind: str = pydantic.Field("metric", description="What the depth holds: disparity, inverse or metric.",
                                     json_schema_extra=_choices("DEPTH_KINDS"))
    depth_scale: float | None = pydantic.Field(
        None, description="PNG depth: stored value / scale = metres (metric) or pixels (disparity); default 1.")
    max_disparity: int = pydantic.Field(64, description="Stereo pair: largest disparity searched (px).")
    min_disparity: int = pydantic.Field(0, description="Stereo pair: smallest disparity searched (px).")
    method: str = pydantic.Field("sgbm", description="Stereo pair: the matcher (vergence match --method).",
                                 json_schema_extra=_choices("MATCHERS"))
    display: str = pydantic.Field("desktop-24", description="A display preset of GET /api/displays.")
    budget_arcmin: float | None = pydantic.Field(None, description="Parallax budget +-A arcmin of vergence.")
    budget_px: float | None = pydantic.Field(None, description="Parallax budget +-P image pixels.")
    convergence: float | None = pydantic.Field(
        None, description="Depth of the zero-parallax plane, in the depth map's unit.")
    focal_px: float | None = pydantic.Field(None, description="Shift-sensor control: focal length (px).")
    interaxial: float | None = pydantic.Field(None, description="Shift-sensor control: interaxial (m).")
    origin: str = pydantic.Field("center", description="The original image is the centre or the left view.",
                                 json_schema_extra=_choices("ORIGINS"))
    fill: str = pydantic.Field("background", description="Hole filling (vergence synthesize --fill).",
                               json_schema_extra=_choices("FILL_METHODS"))
    smooth_sigma: float | None = pydantic.Field(
        None, allow_inf_nan=False, description="ATTEST Gaussian pre-smoothing of the parallax map (px); off when null.")


def _layout_files() -> dict[str, str]:
    """Every layout of vergence.display.LAYOUTS and the file it is written to (as vergence synthesize names it)."""
    from vergence.commands.synthesize import layout_file_name
    from vergence.display import LAYOUTS

    return {layout: layout_file_name(layout) for layout in LAYOUTS}


def _source(params: SynthesizeJob) -> str:
    """Which input the request gives: "depth", "pair" or "example" (exactly one, complete)."""
    given = {name for name in ("image", "depth", "left", "right", "example") if getattr(params, name) is not None}
    groups = {"depth": {"image", "depth"}, "pair": {"left", "right"}, "example": {"example"}}
    for name, fields in groups.items():
        if given == fields:
            return name
    shown = ", ".join(sorted(given)) or "none"
    raise ValueError(f"give image and depth (upload ids), or left and right (a stereo pair), or example (a scene "
                     f"id); got {shown}")  # fmt: skip


def _check_unused(params: SynthesizeJob, source: str) -> None:
    """Refuse an option the chosen input does not use (it would be ignored in silence)."""
    unused = {"depth": (*_PAIR_FIELDS, *_EXAMPLE_FIELDS), "pair": (*_EXAMPLE_FIELDS, "depth_kind", "depth_scale"),
              "example": (*_PAIR_FIELDS, "depth_kind", "depth_scale")}[source]  # fmt: skip
    extra = [name for name in unused if name in params.model_fields_set]
    if extra:
        what = {"depth": "an image and its depth", "pair": "a stereo pair (its depth is the matched disparity)",
                "example": "the example (its depth is metric)"}[source]  # fmt: skip
        raise ValueError(f"{extra[0]} does not apply to {what}")


def _upload(env: JobEnv, field: str, upload_id: str) -> Upload:
    upload = env.uploads.get(upload_id)  # KeyError: 404
    if upload.width * upload.height > MAX_STEREO_JOB_PIXELS:
        raise ValueError(f"{field}: {upload.width}x{upload.height} is more than {MAX_STEREO_JOB_PIXELS:,} pixels "
                         "(MAX_STEREO_JOB_PIXELS): use vergence synthesize for large images")  # fmt: skip
    return upload


def _check_same_size(name_a: str, a: Upload, name_b: str, b: Upload) -> None:
    if (a.width, a.height) != (b.width, b.height):
        raise ValueError(f"{name_b} must have the size of {name_a} ({a.width}x{a.height}); got {b.width}x{b.height}")


def _shown(upload: Upload, field: str) -> str:
    return upload.name or f"{field}{upload.path.suffix}"


def _read(field: str, upload: Upload, reader: Any, **options: Any) -> np.ndarray:
    """Read an upload with a vergence.io reader; a message names the field and the upload, never the server's path."""
    try:
        return reader(upload.path, **options)
    except (ValueError, TypeError) as exc:
        message = str(exc).replace(str(upload.path), f"{field} upload {_shown(upload, field)!r}")
        raise type(exc)(message) from None


def _display(name: str) -> Any:
    from vergence.viewing.geometry import Display

    try:
        return Display.preset(name)
    except ValueError as exc:
        raise ValueError(f"display: {exc}") from exc


def _controls(params: SynthesizeJob) -> dict[str, float | None]:
    """The depth control as vergence synthesize takes it: without any, its default budget."""
    from vergence.commands.synthesize import SYNTHESIS_BUDGET_ARCMIN

    controls = {name: getattr(params, name) for name in _CONTROLS}
    if all(controls[name] is None for name in ("budget_arcmin", "budget_px", "focal_px", "interaxial")):
        controls["budget_arcmin"] = SYNTHESIS_BUDGET_ARCMIN
    return controls


def _check_plan(depth: object, kind: str, display: Any, controls: dict[str, float | None]) -> None:
    """The library's own check of the depth control (one-line refusal, named by the job's field)."""
    from vergence.commands import naming
    from vergence.synthesis import plan_parallax

    with naming(kind="depth_kind"):
        plan_parallax(depth, kind=kind, display=display, **controls)


def _probe(width: int) -> np.ndarray:
    """A one-row depth of the input's width, 1 to 2 (metres or pixels): the depth control is checked on
    it before the real depth exists (matched or rendered in the job); what depends on the data is
    checked again by the job itself."""
    import numpy as np

    return np.linspace(1.0, 2.0, max(width, 2))[None, :]


def _example(params: SynthesizeJob, env: JobEnv) -> tuple[tuple[str, ...], Any, str]:
    """The example's scene, its cache inputs and the name ``vergence render`` takes."""
    from vergence.render import builtin_scene, open_scene, render_cost

    entry = env.data.get(params.example)  # KeyError: 404
    if entry.kind != "scene":
        raise ValueError(f"example: {params.example!r} is a {entry.kind}, not a scene; GET /api/data lists the scenes")
    w, h = params.example_width, params.example_height
    cost = render_cost(w, h, max_depth=EXAMPLE_DEPTH, samples=EXAMPLE_SAMPLES)
    if cost.problem() is not None:
        raise ValueError(f"example: {w}x{h} pixels {cost.problem()}")
    if entry.path is None:
        return (entry.id, str(w), str(h)), builtin_scene(entry.name, width=w, height=h), entry.name
    scene = open_scene(entry.path, width=w, height=h)
    return (entry.id, hashlib.sha256(entry.path.read_bytes()).hexdigest(), str(w), str(h)), scene, entry.name


def _render_example(key: tuple[str, ...], scene: Any, ctx: JobContext) -> tuple[np.ndarray, np.ndarray]:
    """The example's beauty image and metric depth as ``vergence render`` writes them, read back."""
    from vergence.io import read_depth, read_image
    from vergence.render import render
    from vergence.report.preview import save_render

    with _examples_lock:
        if key in _examples:
            _examples.move_to_end(key)
            return _examples[key]
    result = render(scene, max_depth=EXAMPLE_DEPTH, samples=EXAMPLE_SAMPLES,
                    progress=lambda f, m: ctx.progress(0.4 * f, f"example: {m}"))  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        save_render(result, tmp, stem="render")
        arrays = read_image(Path(tmp) / "render_beauty.png"), read_depth(Path(tmp) / "render_depth.pfm")
    with _examples_lock:
        _examples[key] = arrays
        while len(_examples) > _EXAMPLES_KEPT:
            _examples.popitem(last=False)
    return arrays


def _prepare_synthesize(params: pydantic.BaseModel, env: JobEnv) -> Prepared:
    from vergence.depth import MATCHERS
    from vergence.io import DEPTH_KINDS, read_depth
    from vergence.synthesis import FILL_METHODS

    if not isinstance(params, SynthesizeJob):
        raise TypeError(f"params must be a SynthesizeJob; got {type(params).__name__}")
    source = _source(params)
    _check_unused(params, source)
    if params.depth_kind not in DEPTH_KINDS:
        raise ValueError(f"depth_kind must be one of {', '.join(DEPTH_KINDS)}; got {params.depth_kind!r}")
    if params.method not in MATCHERS:
        raise ValueError(f"method must be one of {', '.join(MATCHERS)}; got {params.method!r}")
    if params.fill not in FILL_METHODS:
        raise ValueError(f"fill must be one of {', '.join(FILL_METHODS)}; got {params.fill!r}")
    if params.origin not in _ORIGINS:
        raise ValueError(f"origin must be one of {', '.join(_ORIGINS)}; got {params.origin!r}")
    display = _display(params.display)
    controls = _controls(params)
    uploads: dict[str, Upload] = {}
    scene = None
    if source == "depth":
        uploads = {"image": _upload(env, "image", params.image), "depth": _upload(env, "depth", params.depth)}
        depth_up = uploads["depth"]
        if depth_up.kind not in _DEPTH_UPLOADS:
            raise ValueError(f"depth must be a PNG, PFM or NPY file (a lossy {depth_up.kind.upper()} would invent "
                             f"depth); got {_shown(depth_up, 'depth')!r}")  # fmt: skip
        if depth_up.channels != 1:
            raise ValueError(f"depth must be a single-channel map (grey PNG, 'Pf' PFM, (H, W) NPY); "
                             f"{_shown(depth_up, 'depth')!r} has {depth_up.channels} channels "
                             f"({'grey and alpha' if depth_up.channels == 2 else 'a colour image'})")
        _check_same_size("image", uploads["image"], "depth", depth_up)
        from vergence.commands import naming

        with naming(scale="depth_scale", kind="depth_kind"):
            depth_map = _read("depth", depth_up, read_depth, kind=params.depth_kind, scale=params.depth_scale)
        _check_plan(depth_map, params.depth_kind, display, controls)
        inputs = tuple(u.sha256 for u in uploads.values())
    elif source == "pair":
        uploads = {"left": _upload(env, "left", params.left), "right": _upload(env, "right", params.right)}
        _check_same_size("left", uploads["left"], "right", uploads["right"])
        if not 0 <= params.min_disparity < params.max_disparity < uploads["left"].width:
            raise ValueError(f"max_disparity must be > min_disparity >= 0 and below the width "
                             f"{uploads['left'].width}; got min {params.min_disparity}, max {params.max_disparity}")
        _check_plan(_probe(uploads["left"].width), "disparity", display, controls)  # the options alone
        inputs = tuple(u.sha256 for u in uploads.values())
    else:
        inputs, scene, scene_name = _example(params, env)
        _check_plan(_probe(params.example_width), "metric", display, controls)  # the options alone
    kind = {"depth": params.depth_kind, "pair": "disparity", "example": "metric"}[source]

    def run(ctx: JobContext) -> JobResult:
        import numpy as np

        from vergence.display import pack
        from vergence.io import read_image, write_image
        from vergence.synthesis import plan_comfort, synthesize_stereo
        from vergence.viewing import ComfortZone

        ctx.progress(0.0, "reading the input")
        summary: dict[str, Any] = {"source": source}
        if source == "depth":
            picture = _read("image", uploads["image"], read_image)
            depth = _read("depth", uploads["depth"], read_depth, kind=params.depth_kind, scale=params.depth_scale)
            summary["inputs"] = {field: _shown(u, field) for field, u in uploads.items()}
        elif source == "pair":
            from vergence.depth import compute_disparity

            picture = _read("left", uploads["left"], read_image)
            other = _read("right", uploads["right"], read_image)
            ctx.progress(0.1, f"matching the pair ({params.method})")
            matched = compute_disparity(picture, other, max_disparity=params.max_disparity,
                                        min_disparity=params.min_disparity, method=params.method)  # fmt: skip
            depth = matched.disparity
            summary["inputs"] = {field: _shown(u, field) for field, u in uploads.items()}
            summary["match"] = {"method": params.method, "max_disparity": params.max_disparity,
                                "min_disparity": params.min_disparity, **matched.to_dict()}  # fmt: skip
            ctx.progress(0.4, "measuring the vertical disparity (rectify --check)")
            summary["row_alignment"] = _row_alignment(picture, other)
        else:
            picture, depth = _render_example(inputs, scene, ctx)
            summary["inputs"] = {"scene": scene_name, "width": params.example_width, "height": params.example_height,
                                 "render_depth": EXAMPLE_DEPTH, "samples": EXAMPLE_SAMPLES}  # fmt: skip
        ctx.progress(0.45, "synthesizing the views")
        result = synthesize_stereo(picture, depth, kind=kind, display=display, views=2, origin=params.origin,
                                   smooth_sigma=params.smooth_sigma, fill=params.fill, **controls)  # fmt: skip
        zone = ComfortZone()
        report, outside = plan_comfort(result.plan, display, zone=zone)
        layouts = _layout_files()
        summary |= {
            "depth_kind": kind,
            "depth_scale": params.depth_scale,
            "control": "shift-sensor" if params.focal_px is not None or params.interaxial is not None else "budget",
            **controls,
            "display": {"preset": params.display, **dataclasses.asdict(display)},
            "views": 2,
            "origin": params.origin,
            "fill": params.fill,
            "smooth_sigma": params.smooth_sigma,
            **result.to_dict(),
            "comfort": {**report.to_dict(), "zone_min_arcmin": zone.min_arcmin, "zone_max_arcmin": zone.max_arcmin,
                        "outside_share": outside},  # fmt: skip
            "layouts": layouts,
        }
        names = ["left.png", "right.png", PARALLAX_FILE]
        write_image(ctx.folder / "left.png", result.left)
        write_image(ctx.folder / "right.png", result.right)
        np.save(ctx.folder / PARALLAX_FILE, result.plan.parallax_px.astype(np.float32))
        if source == "pair":  # the matching result: the input pair's parallax and its views
            np.save(ctx.folder / MATCHED_PARALLAX_FILE, np.negative(depth, dtype=np.float32))
            write_image(ctx.folder / "input_left.png", picture)
            write_image(ctx.folder / "input_right.png", other)
            names += [MATCHED_PARALLAX_FILE, "input_left.png", "input_right.png"]
        for k, (layout, name) in enumerate(layouts.items()):
            ctx.progress(0.6 + 0.4 * k / len(layouts), f"writing {name}")
            write_image(ctx.folder / name, pack(result.left, result.right, layout=layout))
            names.append(name)
        (ctx.folder / "synthesis.json").write_text(json.dumps(summary, indent=2, allow_nan=False))
        return JobResult(summary, (*names, "synthesis.json"))

    return Prepared(inputs, run)


#: The kinds of this page (``POST /api/jobs/{name}``).
KINDS = {
    "synthesize": JobKind(
        "synthesize", "2D + depth (or a matched stereo pair, or a rendered example) to a stereo pair in every layout "
        "of vergence.display, with its comfort figures on the display (vergence synthesize).",
        SynthesizeJob, _prepare_synthesize),
}


def _row_alignment(left: np.ndarray, right: np.ndarray) -> dict[str, Any]:
    """The pair's vertical disparity as ``vergence rectify --check`` measures it (median and 90th percentile of
    ``|y_r - y_l|`` over the SIFT + RANSAC matches, px of the pair), with :data:`VERTICAL_WARN_PX` and whether
    the median is above it; ``{"error": ...}`` when too few features match (the job goes on without it)."""
    import cv2

    from vergence.depth import measure_row_alignment

    try:
        found = measure_row_alignment(left, right)
    except (ValueError, cv2.error) as exc:  # too few features, or RANSAC found no model
        return {"error": " ".join(str(exc).split()), "threshold_px": VERTICAL_WARN_PX}
    return {**found.to_dict(), "threshold_px": VERTICAL_WARN_PX, "above": found.median_abs_dy_px > VERTICAL_WARN_PX}


def add_routes(app: FastAPI, jobs: JobManager) -> None:
    """``GET /api/stereo/{job_id}/overlay`` (:func:`vergence.web.overlays.stereo_overlay`)."""
    add_stereo_routes(app, jobs)
