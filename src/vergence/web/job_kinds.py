"""The kinds of job the workbench runs (:data:`KINDS`): each checks its request, then calls the library.

- ``render``: a scene of ``GET /api/data`` (built-in or a scene file, by id) ray-traced by
  :func:`vergence.render.render` at a small size; the beauty image as ``beauty.png`` (tone-mapped
  by :func:`vergence.render.tonemap`) and the layer count.
- ``specular``: a scene of ``GET /api/data`` with its stereo rig made fusible by
  :func:`vergence.specular.specular_stereo` (S3, issue 12) at a small size; the files of
  :func:`vergence.report.specular_outputs.write_specular_outputs` and, as the result,
  :meth:`SpecularResult.report() <vergence.specular.SpecularResult.report>` (``report.json``); also
  ``layer_<n>.png``, each layer of the physical left eye tone-mapped alone (the page paints on them),
  and the comfort overlay ``disparity_after.npy``.
  The result stays in memory (``live``) for:
- ``specular-reoptimise``: a done specular job's run again with new weights and painted per-layer
  maps (:meth:`SpecularResult.reoptimise <vergence.specular.SpecularResult.reoptimise>`: the table
  is reused, so this takes a solve and one render). The job is done once what the page shows first is
  written (:data:`SHOWN_FIRST`: the new left eye, its anaglyph, the comfort overlay
  ``disparity_after.npy``, ``report.json`` with ``web_seconds``); the other files of ``vergence
  specular`` are pending, written when one is first asked for (:class:`vergence.web.jobs.JobResult`).
  A map on a layer no weight can move (:func:`paintable_layers`) or a map of ones is refused.

``GET /api/specular/{job_id}/overlay`` (:func:`vergence.web.overlays.specular_overlay`) answers what the page's heat
map and histogram of ``disparity_after.npy`` need besides the array: the comfort zone, the divergence limit and the
colour scale in arcmin on the job's display as it is shown (its fit).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pydantic
from fastapi import FastAPI

from vergence.web._models import RequestModel
from vergence.web.jobs import JobContext, JobKind, JobManager, JobResult, Prepared
from vergence.web.overlays import add_specular_routes

if TYPE_CHECKING:
    from vergence.web.data import DataIndex
    from vergence.web.uploads import UploadStore

__all__ = ["KINDS", "MAX_RENDER_JOB_RAYS", "MAX_RENDER_JOB_SIDE", "MAX_SPECULAR_JOB_SIDE", "MAX_WEIGHT_MAPS",
           "SHOWN_FIRST", "JobEnv", "RenderJob", "SpecularJob", "SpecularReoptimiseJob", "WeightMap", "add_routes",
           "paintable_layers"]

#: Largest side of a render job, pixels: previews on the page, not final frames (``vergence render``).
MAX_RENDER_JOB_SIDE = 2048

#: Largest bound on the rays of a render job (:func:`vergence.render.render_cost`): 1e8, about 20 s
#: at the 4.5 million rays per second measured on two cores (vergence.render.limits).
MAX_RENDER_JOB_RAYS = 100_000_000

#: Largest side of a specular job, pixels: k + 3 renders and an offset table, for the page's previews.
MAX_SPECULAR_JOB_SIDE = 640


@dataclass(frozen=True, slots=True)
class JobEnv:
    """What a kind's ``prepare`` may look up: the data folders' entries, the uploads, and the live
    objects of a done job (``live(job_id, kind)``, :meth:`JobManager.live <vergence.web.jobs.JobManager.live>`)."""

    data: DataIndex
    uploads: UploadStore
    live: Callable[[str, str], Any]


class RenderJob(RequestModel):
    """Parameters of a ``render`` job."""

    model_config = pydantic.ConfigDict(extra="forbid")

    scene: str = pydantic.Field(description="A scene id of GET /api/data: 'scene:tabletop' or a scene file's id.")
    width: int = pydantic.Field(64, ge=1, le=MAX_RENDER_JOB_SIDE, description="Image width, pixels.")
    height: int = pydantic.Field(48, ge=1, le=MAX_RENDER_JOB_SIDE, description="Image height, pixels.")
    depth: int = pydantic.Field(2, ge=0, description="Maximum specular bounces D: 2^(D+1)-1 layers.")
    samples: int = pydantic.Field(16, ge=1, description="Ambient-occlusion rays per diffuse hit.")


def _open_scene_job(params: pydantic.BaseModel, env: JobEnv) -> tuple[object, tuple[str, ...]]:
    """The scene of a job's ``scene`` id at its width and height, and the inputs of its cache key
    (a scene file's content hash with its id); ``depth`` checked against the renderer's limit."""
    from vergence.render import MAX_DEPTH, builtin_scene, open_scene

    entry = env.data.get(params.scene)
    if entry.kind != "scene":
        raise ValueError(f"scene: {params.scene!r} is a {entry.kind}, not a scene; GET /api/data lists the scenes")
    if params.depth > MAX_DEPTH:
        raise ValueError(f"depth must be at most {MAX_DEPTH} (2^(D+1)-1 layers); got {params.depth}")
    if entry.path is None:
        return builtin_scene(entry.name, width=params.width, height=params.height), (entry.id,)
    scene = open_scene(entry.path, width=params.width, height=params.height)
    return scene, (entry.id, hashlib.sha256(entry.path.read_bytes()).hexdigest())


def _prepare_render(params: pydantic.BaseModel, env: JobEnv) -> Prepared:
    from vergence.render import render, render_cost, tonemap

    if not isinstance(params, RenderJob):
        raise TypeError(f"params must be a RenderJob; got {type(params).__name__}")
    scene, inputs = _open_scene_job(params, env)
    name = env.data.get(params.scene).name
    cost = render_cost(params.width, params.height, max_depth=params.depth, samples=params.samples)
    if cost.problem() is not None:
        raise ValueError(f"{params.width}x{params.height} pixels with depth {params.depth}, samples {params.samples} "
                         f"{cost.problem()}")  # fmt: skip
    if cost.rays > MAX_RENDER_JOB_RAYS:
        raise ValueError(f"{params.width}x{params.height} pixels with depth {params.depth}, samples {params.samples} "
                         f"may cast up to {cost.rays:.3g} rays; a render job's limit is {MAX_RENDER_JOB_RAYS:.0e} "
                         "(MAX_RENDER_JOB_RAYS): lower width, height, depth or samples")  # fmt: skip

    def run(ctx: JobContext) -> JobResult:
        from vergence.io import write_image

        result = render(scene, max_depth=params.depth, samples=params.samples, progress=ctx.progress)
        ctx.progress(1.0, "writing beauty.png")
        write_image(ctx.folder / "beauty.png", tonemap(result.beauty))
        return JobResult({"scene": name, "width": result.camera.width, "height": result.camera.height,
                          "layers": result.n_layers, "variant": result.settings.variant}, ("beauty.png",))  # fmt: skip

    return Prepared(inputs, run)


class SpecularJob(RequestModel):
    """Parameters of a ``specular`` job (as ``vergence specular``'s options)."""

    model_config = pydantic.ConfigDict(extra="forbid")

    scene: str = pydantic.Field(description="A scene id of GET /api/data with a stereo rig: 'scene:glasses'.")
    width: int = pydantic.Field(160, ge=1, le=MAX_SPECULAR_JOB_SIDE, description="Image width, pixels.")
    height: int = pydantic.Field(120, ge=1, le=MAX_SPECULAR_JOB_SIDE, description="Image height, pixels.")
    k: int = pydantic.Field(16, ge=2, le=32, description="Offset steps of the table (S3: 32): k + 1 left renders.")
    depth: int = pydantic.Field(2, ge=0, description="Maximum specular bounces D: 2^(D+1)-1 layers (S3: 2).")
    samples: int = pydantic.Field(4, ge=1, description="Ambient-occlusion rays per diffuse hit.")
    display: str = pydantic.Field("samsung-2233rz", description="A display preset of GET /api/displays.")
    fit: str = pydantic.Field("screen", description="How the image is shown on the display: 'screen' (stretched to "
                              "its width, full screen) or 'native' (one image pixel per display pixel).")
    variant: str = pydantic.Field("comfort", description="The absolute term: 'comfort' or 'screen' (S3's).")
    weights: tuple[float, float, float, float] = pydantic.Field(
        (1.0, 1.0, 10.0, 0.1), description="Cost weights absolute, relative, rivalry, data (S3 §4: 1, 1, 10, 0.1).")


#: Largest cost weight of a specular job (as ``vergence specular --weights``).
_MAX_WEIGHT = 1e6


def _prepare_specular(params: pydantic.BaseModel, env: JobEnv) -> Prepared:
    from vergence.commands._scene import scene_rig
    from vergence.render import render_cost
    from vergence.specular import ABSOLUTE_VARIANTS, DISPLAY_FITS, MAX_TABLE_BYTES, offset_table_bytes, specular_objects
    from vergence.viewing.geometry import Display

    if not isinstance(params, SpecularJob):
        raise TypeError(f"params must be a SpecularJob; got {type(params).__name__}")
    if params.fit not in DISPLAY_FITS:
        raise ValueError(f"fit must be one of {', '.join(DISPLAY_FITS)}; got {params.fit!r}")
    if params.variant not in ABSOLUTE_VARIANTS:
        raise ValueError(f"variant must be one of {', '.join(ABSOLUTE_VARIANTS)}; got {params.variant!r}")
    if not all(0 <= w <= _MAX_WEIGHT for w in params.weights):  # NaN fails too
        raise ValueError(f"weights must be four numbers in [0, {_MAX_WEIGHT:g}], absolute, relative, rivalry, data "
                         f"(e.g. 1, 1, 10, 0.1); got {list(params.weights)}")  # fmt: skip
    try:
        display = Display.preset(params.display)
    except ValueError as exc:
        raise ValueError(f"display: {exc}") from exc
    scene, inputs = _open_scene_job(params, env)
    if scene.stereo is None:
        raise ValueError(f"scene {params.scene!r} has no \"stereo\" block (baseline, convergence): a specular job "
                         "uses the scene's own rig (docs/scenes.md)")  # fmt: skip
    left, right, _, _ = scene_rig(scene, None, None, needed_by=f"scene {params.scene!r}: a specular job")
    if params.depth == 0 and specular_objects(scene):
        raise ValueError(f"depth 0 traces no specular layer (the first hit only), but scene {params.scene!r} has "
                         "mirror or glass objects: use depth 1 or more (S3: 2)")  # fmt: skip
    cost = render_cost(params.width, params.height, max_depth=params.depth, samples=params.samples)
    size = f"{params.width}x{params.height} pixels with depth {params.depth}"
    if cost.problem() is not None:
        raise ValueError(f"one render of {size}, samples {params.samples} {cost.problem()}")
    if cost.rays * (params.k + 3) > MAX_RENDER_JOB_RAYS:
        raise ValueError(f"{params.k + 3} renders of {size}, samples {params.samples} may cast up to "
                         f"{cost.rays * (params.k + 3):.3g} rays; a job's limit is {MAX_RENDER_JOB_RAYS:.0e} "
                         "(MAX_RENDER_JOB_RAYS): lower width, height, k, depth or samples")  # fmt: skip
    need = offset_table_bytes(params.width, params.height, k=params.k, max_depth=params.depth)
    if need > MAX_TABLE_BYTES:
        raise ValueError(f"the offset table of k {params.k} at {size} needs about {need / 2**30:.1f} GiB; the limit "
                         f"is {MAX_TABLE_BYTES / 2**30:g} GiB (MAX_TABLE_BYTES): lower k, width, height or depth")

    def run(ctx: JobContext) -> JobResult:
        from vergence.report.specular_outputs import write_specular_outputs
        from vergence.specular import specular_stereo

        result = specular_stereo(scene, left, right, display, k=params.k, max_depth=params.depth,
                                 samples=params.samples, alpha=params.weights, variant=params.variant,
                                 fit=params.fit, progress=ctx.progress)  # fmt: skip
        ctx.progress(1.0, "writing the outputs")
        return JobResult(result.report(), _write_specular(result, ctx.folder, layers=True), live=result)

    return Prepared(inputs, run)


def _write_specular(result: Any, folder: Any, *, layers: bool) -> tuple[str, ...]:
    """The files of ``vergence specular`` and, with ``layers``, ``layer_<n>.png`` per layer of the
    physical left eye (its radiance alone, the exposure of the whole image; grey: no surface)."""
    import numpy as np

    from vergence.io import write_image
    from vergence.render import tonemap
    from vergence.render.tonemap import auto_exposure
    from vergence.report.specular_outputs import write_specular_outputs

    names = [p.name for p in write_specular_outputs(result, folder)]
    _write_overlay(result, folder)
    names.append("disparity_after.npy")
    if layers:
        phys = result.physical_left
        exposure = auto_exposure(np.asarray(phys.beauty, dtype=np.float64))
        for i in range(phys.n_layers):
            image = tonemap(np.nan_to_num(phys.radiance[i]), exposure=exposure)
            image[~np.isfinite(phys.position[i]).all(axis=-1)] = _NO_SURFACE_GREY
            write_image(folder / f"layer_{i + 1}.png", image)
            names.append(f"layer_{i + 1}.png")
    return tuple(names)


#: Grey of the pixels without a surface in ``layer_<n>.png``.
_NO_SURFACE_GREY = 0.35

#: Most painted maps a re-optimise request sends (one per layer and cost term at most: 31 x 5).
MAX_WEIGHT_MAPS = 160


class WeightMap(RequestModel):
    """One painted map (as ``vergence specular --weight-map [TERM:]LAYER=FILE``)."""

    model_config = pydantic.ConfigDict(extra="forbid")

    layer: int = pydantic.Field(ge=1, description="The layer it weights, 1-based as report.json's \"layer\".")
    term: str | None = pydantic.Field(None, description="One cost term (absolute, relative, rivalry, data); "
                                                          "none: every term of the layer.")
    upload: str = pydantic.Field(description="An upload id (POST /api/uploads) of a grey image of the render's "
                                             "size: PNG values / max code, or .npy/.pfm float as stored, in [0, 1e6].")


class SpecularReoptimiseJob(RequestModel):
    """Parameters of a ``specular-reoptimise`` job: a done specular job, new weights and painted maps."""

    model_config = pydantic.ConfigDict(extra="forbid")

    job: str = pydantic.Field(description="The id of a done specular job (its table is reused).")
    weights: tuple[float, float, float, float] | None = pydantic.Field(
        None, description="Cost weights absolute, relative, rivalry, data; none: the specular job's.")
    variant: str | None = pydantic.Field(None, description="'comfort' or 'screen'; none: the specular job's.")
    weight_maps: list[WeightMap] = pydantic.Field(
        [], max_length=MAX_WEIGHT_MAPS, description="Painted maps; maps of the same term and layer multiply.")


def _prepare_reoptimise(params: pydantic.BaseModel, env: JobEnv) -> Prepared:
    from vergence.commands import ParameterError
    from vergence.commands._specular import weight_maps
    from vergence.specular import ABSOLUTE_VARIANTS, COST_TERMS

    if not isinstance(params, SpecularReoptimiseJob):
        raise TypeError(f"params must be a SpecularReoptimiseJob; got {type(params).__name__}")
    base = env.live(params.job, "specular")  # KeyError: 404; not done or no longer kept: 409
    if params.variant is not None and params.variant not in ABSOLUTE_VARIANTS:
        raise ValueError(f"variant must be one of {', '.join(ABSOLUTE_VARIANTS)}; got {params.variant!r}")
    if params.weights is not None and not all(0 <= w <= _MAX_WEIGHT for w in params.weights):
        raise ValueError(f"weights must be four numbers in [0, {_MAX_WEIGHT:g}], absolute, relative, rivalry, data "
                         f"(e.g. 1, 1, 10, 0.1); got {list(params.weights)}")  # fmt: skip
    n, h, w = base.y.shape
    specs, inputs = [], [params.job]
    paintable = paintable_layers(base)
    for painted in params.weight_maps:
        if painted.term is not None and painted.term not in COST_TERMS:
            raise ValueError(f"weight_maps: unknown cost term {painted.term!r}; the terms are {', '.join(COST_TERMS)}")
        if paintable.get(painted.layer) is not None:
            can = ", ".join(str(i) for i, why in paintable.items() if why is None) or "none"
            raise ValueError(f"weight_maps: {paintable[painted.layer]}; the layers a paint can change: {can}")
        upload = env.uploads.get(painted.upload)
        specs.append((f"{painted.term + ':' if painted.term else ''}{painted.layer}", upload))
        inputs.append(upload.sha256)
    try:
        maps = weight_maps([f"{spec}={upload.path}" for spec, upload in specs], n_layers=n, width=w, height=h)
    except ValueError as exc:  # name the upload, never its path on the server
        message = exc.spelled(lambda name: "weight_maps:" if name == "weight_map" else name) if isinstance(
            exc, ParameterError) else str(exc)
        for spec, upload in specs:
            message = message.replace(f"{spec}={upload.path}", f"{spec} (upload {upload.id})")
            message = message.replace(str(upload.path), f"upload {upload.id}")
        raise ValueError(message) from None
    for (spec, upload), painted in zip(specs, params.weight_maps, strict=True):  # a map of ones weighs nothing
        alone = weight_maps([f"{spec}={upload.path}"], n_layers=n, width=w, height=h)
        if all(np.all(m == 1.0) for m in alone.values()):
            raise ValueError(f"weight_maps: the map of layer {painted.layer} (upload {upload.id}) is 1 everywhere: "
                             "it changes no weight (1 is every pixel's weight unpainted)")  # fmt: skip

    def run(ctx: JobContext) -> JobResult:
        import time

        from vergence.report.specular_outputs import SPECULAR_OUTPUT_FILES

        t0 = time.perf_counter()
        with _numba_threads(1 if h * w <= SERIAL_REOPTIMISE_PIXELS else None):
            result = base.reoptimise(alpha=params.weights, variant=params.variant, maps=maps or None,
                                     progress=lambda f, m: ctx.progress(0.9 * f, m)).release()  # fmt: skip
        t1 = time.perf_counter()
        ctx.progress(0.9, "writing the new left eye")
        report = result.report()
        t2 = time.perf_counter()
        shown = _write_shown(result, report, ctx.folder)
        t3 = time.perf_counter()
        report["web_seconds"] = {"reoptimise": round(t1 - t0, 3), "report": round(t2 - t1, 3),
                                 "write_shown": round(t3 - t2, 3)}  # fmt: skip
        pending = tuple(n for n in SPECULAR_OUTPUT_FILES if n not in shown)
        return JobResult(report, shown, pending=pending,
                         write_pending=lambda folder: _write_specular(result, folder, layers=False))

    return Prepared(tuple(inputs), run)


#: Largest re-optimisation, pixels, run with one Numba thread on the job's thread: on two cores shared with
#: other work a parallel region of two threads waits for the slower one. Measured per re-optimisation of
#: glasses (k 16) at load 3-4, one thread against two: 0.56-0.80 s against 0.59-4.1 s at 160 x 120, 2.1-3.3 s
#: against 6.1-6.7 s at 320 x 240; larger sizes were not measured and keep every thread.
SERIAL_REOPTIMISE_PIXELS = 320 * 240


@contextmanager
def _numba_threads(threads: int | None) -> Iterator[None]:
    """The block with ``threads`` Numba threads on this thread (None: as they are), restored after."""
    if threads is None:
        yield
        return
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, before))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def _write_shown(result: Any, report: dict, folder: Any) -> tuple[str, ...]:
    """What the page shows first after a re-optimisation (:data:`SHOWN_FIRST`): the new left eye and its
    anaglyph (as ``vergence specular`` writes them: the physical left eye's exposure, Dubois), its
    comfort overlay ``disparity_after.npy`` and ``report.json``; the other outputs wait for a request."""
    from vergence.display import anaglyph
    from vergence.io import write_image, write_json
    from vergence.render import tonemap
    from vergence.render.tonemap import auto_exposure

    exposure = auto_exposure(np.asarray(result.physical_left.beauty, dtype=np.float64))
    left = tonemap(result.optimised_left.beauty, exposure=exposure)
    write_image(folder / "optimised_left.png", left)
    write_image(folder / "optimised_anaglyph.png",
                anaglyph(left, tonemap(result.right.beauty, exposure=exposure), method="dubois"))
    _write_overlay(result, folder)
    write_json(folder / "report.json", report)
    return SHOWN_FIRST


def _write_overlay(result: Any, folder: Any) -> None:
    """``disparity_after.npy``: ``(N, H, W)`` float32, the horizontal disparity (arcmin on the display, NaN:
    no match) of each layer of the optimised left eye against the right eye, as report.json measures it;
    the page marks a layer's pixels outside ``comfort_zone_arcmin``."""
    from vergence.io import atomic_write

    with atomic_write(folder / "disparity_after.npy") as tmp, open(tmp, "wb") as fh:
        np.save(fh, np.ascontiguousarray(result.after.disparity[..., 0], dtype=np.float32))


#: The files a ``specular-reoptimise`` job writes before it is done; the rest of ``vergence specular``'s
#: files (the npz archives, the analysis sheets, the other previews) are written when first asked for.
SHOWN_FIRST = ("optimised_left.png", "optimised_anaglyph.png", "disparity_after.npy", "report.json")


def paintable_layers(base: Any) -> dict[int, str | None]:
    """Per layer (1-based) of a specular result, None when a painted weight can move offsets, else why
    not: a layer with no matched pixel in the physical pair gives S3 Eq. 2 no disparity to weigh, so
    the solve leaves every offset where it was (checked against the solve in tests/web/test_specular_job.py).
    The first hit counts: its weights enter the other layers' solve. A run with nothing specular in view
    has no offsets to solve: no layer can be painted."""
    from vergence.specular.result_report import layer_labels

    out: dict[int, str | None] = {}
    for i, name in enumerate(layer_labels(base.y.shape[0])):
        out[i + 1] = None
        if not base.specular:
            out[i + 1] = "nothing specular is in view in this run: it has no offsets to solve"
        elif not base.before.matched[i].any():
            pixels = int(base.before.present[i].sum())
            out[i + 1] = (f"layer {i + 1} ({name}) has no matched pixel in the physical pair ({pixels} px with a "
                          "surface, none matched in the right eye): no weight can move its offsets")  # fmt: skip
    return out


#: The kinds of this module, by name (``POST /api/jobs/{name}``; the app gathers every page module's KINDS).
KINDS = {
    "render": JobKind("render", "Ray-trace a scene (vergence.render.render): the beauty image and the layer count.",
                      RenderJob, _prepare_render),
    "specular": JobKind("specular", "Make a scene's glass and mirrors fusible (S3, vergence.specular): offsets, the "
                        "four methods' anaglyphs, analysis sheets, report.", SpecularJob, _prepare_specular),
    "specular-reoptimise": JobKind("specular-reoptimise", "A done specular job with new weights and painted "
                                   "per-layer maps: the table is reused (S3 §3.4); the same files and report.",
                                   SpecularReoptimiseJob, _prepare_reoptimise),
}


def add_routes(app: FastAPI, jobs: JobManager) -> None:
    """``GET /api/specular/{job_id}/overlay`` (:func:`vergence.web.overlays.specular_overlay`)."""
    add_specular_routes(app, jobs)
