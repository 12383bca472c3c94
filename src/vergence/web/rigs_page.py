"""Page 4 of the workbench, "Rig planner" (issue 13): the Quadri-Rig and the Tri-Rig of S0 §5–6.

- ``GET /api/rigs/shots``: the presets: :data:`vergence.rigs.EXAMPLE_SHOTS` (built-in scenes, no
  source tree needed), then the shot files of the data folders (``vergence serve --data examples``
  adds ``examples/shots/*.json``) whose scene the server can open, the scene given by its data id.
- ``POST /api/rigs/plan``: the shot as JSON (``docs/shots.md``) -> exactly the JSON that
  ``vergence rig plan SHOT --json`` prints (:func:`vergence.rigs.plan_document`), ``"shot": null``
  (no file). Synchronous and fast (pure geometry): the page redraws its top view as the form changes.
- job kind ``rig``: :func:`vergence.rigs.shoot.render_shot` (as ``vergence rig render``) at a small
  size: the real cameras ray-traced, the director's pair synthesised and measured against the truth;
  the pair, truth, error images and each real camera as PNG, and the figures of ``report.json``.

A shot's ``scene`` is a built-in scene name or a scene id of ``GET /api/data``: never a path (the
shot format's relative scene file is what a data folder's shot file names, resolved by the server).
Refusals: the library's one-line messages, those ``vergence rig plan`` prints (422); an unknown data
id 404; a render past :data:`MAX_RENDER_JOB_RAYS` 422.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import pydantic
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response

from vergence.web._errors import refusal
from vergence.web._models import RequestModel
from vergence.web._slots import Busy, run_in_slot
from vergence.web.job_kinds import MAX_RENDER_JOB_RAYS
from vergence.web.jobs import JobContext, JobKind, JobResult, Prepared

if TYPE_CHECKING:
    from vergence.rigs import Shot
    from vergence.web.data import DataIndex
    from vergence.web.job_kinds import JobEnv
    from vergence.web.jobs import JobManager

__all__ = ["CURVED_TRUTH_VIEWS", "KINDS", "MAX_RIG_JOB_SIDE", "MAX_RIG_JOB_SUPERSAMPLE", "RigJob", "add_routes",
           "example_shots", "request_shot"]

#: Largest render width of a ``rig`` job, pixels: a preview of the shot (``vergence rig render`` for frames).
MAX_RIG_JOB_SIDE = 640

#: Largest k (k x k rays per pixel) of a ``rig`` job.
MAX_RIG_JOB_SUPERSAMPLE = 4

#: What the Tri-Rig's curved-ray truth costs, in plain views of its size: measured 2.9 s against 0.32 s
#: per ray-traced camera (stadium-tri at 160x90, 2x2 rays per pixel, 4 AO samples, two cores).
CURVED_TRUTH_VIEWS = 10

# Renders of Tracer.render's default depth (render_shot keeps it): 2 specular bounces.
_SHOT_MAX_DEPTH = 2

# Data ids (vergence.web.data): "scene:<builtin>" or "<kind>-<hash>".
_ID_PREFIXES = ("scene:", "scene-", "collection-", "shot-")


def _scene_value(value: str, index: DataIndex) -> tuple[str, tuple[str, ...]]:
    """A shot's ``scene`` as :func:`~vergence.rigs.shot_from_dict` reads it, and its cache-key inputs."""
    from vergence.render import BUILTIN_SCENES

    if value in BUILTIN_SCENES:
        return value, (f"scene:{value}",)
    if not value.startswith(_ID_PREFIXES):
        raise ValueError(f"scene must be a built-in scene ({', '.join(BUILTIN_SCENES)}) or a scene id of "
                         f"GET /api/data; got {value!r}")  # fmt: skip
    entry = index.get(value)  # KeyError: 404
    if entry.kind != "scene":
        raise ValueError(f"scene: {value!r} is a {entry.kind}, not a scene; GET /api/data lists the scenes")
    if entry.path is None:
        return entry.name, (entry.id,)
    return str(entry.path), (entry.id, hashlib.sha256(entry.path.read_bytes()).hexdigest())


def request_shot(data: object, index: DataIndex) -> tuple[Shot, tuple[str, ...]]:
    """The :class:`~vergence.rigs.Shot` of a request's JSON, its scene chosen by name or data id.

    Returns the shot and the ids (and a scene file's content hash) of its inputs, for a job's cache key.

    Raises
    ------
    KeyError
        An unknown data id (404).
    TypeError, ValueError
        The shot format's one-line refusals (:func:`vergence.rigs.shot_from_dict`), those of
        ``vergence rig plan`` without its ``shot file PATH:`` prefix; a scene that is neither a
        built-in name nor a scene id.
    """
    from vergence.rigs import shot_from_dict

    inputs: tuple[str, ...] = ()
    if isinstance(data, dict) and isinstance(data.get("scene"), str):
        scene, inputs = _scene_value(data["scene"], index)
        data = {**data, "scene": scene}
    return shot_from_dict(data), inputs


def example_shots(index: DataIndex) -> list[dict[str, Any]]:
    """The presets of ``GET /api/rigs/shots``: ``{"id", "name", "source", "shot"}`` each.

    :data:`vergence.rigs.EXAMPLE_SHOTS` first (``source`` "built-in"), then each shot file of the data
    folders (``source`` "data") that plans and whose scene is built in or a scene file the index lists;
    its ``scene`` becomes that scene's id. A data file equal to a built-in one is not listed twice.
    """
    import copy

    from vergence.io import read_json
    from vergence.render import BUILTIN_SCENES
    from vergence.rigs import EXAMPLE_SHOTS, shot_from_dict

    out = [{"id": f"example:{name}", "name": name, "source": "built-in", "shot": copy.deepcopy(shot)}
           for name, shot in EXAMPLE_SHOTS.items()]  # fmt: skip
    entries = index.entries()
    scene_ids = {e.path: e.id for e in entries if e.kind == "scene" and e.path is not None}
    for entry in entries:
        if entry.kind != "shot":
            continue
        try:
            data = read_json(entry.path, what="shot file")
            scene = data["scene"]
            if scene not in BUILTIN_SCENES:
                scene = scene_ids[(entry.path.parent / scene).resolve()]  # KeyError: outside the data folders
            shot = {**data, "scene": scene}
            request_shot(shot, index)[0].plan()
        except (OSError, KeyError, TypeError, ValueError):
            continue  # not a shot the page could plan: not a preset
        if any(shot == known["shot"] for known in out):
            continue
        stem = entry.name.rsplit("/", 1)[-1].removesuffix(".json")
        out.append({"id": entry.id, "name": stem, "source": "data", "shot": shot})
    return out


class RigJob(RequestModel):
    """Parameters of a ``rig`` job (as ``vergence rig render``'s options, at a preview size)."""

    model_config = pydantic.ConfigDict(extra="forbid")

    shot: dict[str, Any] = pydantic.Field(
        description="The shot as POST /api/rigs/plan takes it (docs/shots.md); scene: a built-in name or a scene "
                    "id of GET /api/data.")  # fmt: skip
    width: int = pydantic.Field(160, ge=1, le=MAX_RIG_JOB_SIDE,
                                description="Render width, pixels; the height keeps the shot camera's aspect.")
    weights: str = pydantic.Field("ulr", description="IBR blending weights: ulr, bayesian or both.")
    samples: int = pydantic.Field(4, ge=1, le=64, description="Ambient-occlusion rays per diffuse hit.")
    supersample: int = pydantic.Field(1, ge=1, le=MAX_RIG_JOB_SUPERSAMPLE,
                                      description="k: k x k rays per pixel in every ray-traced image.")


def _prepare_rig(params: pydantic.BaseModel, env: JobEnv) -> Prepared:
    from vergence.render import render_cost
    from vergence.rigs.shoot import RIG_WEIGHTS

    if not isinstance(params, RigJob):
        raise TypeError(f"params must be a RigJob; got {type(params).__name__}")
    if params.weights not in RIG_WEIGHTS:
        raise ValueError(f"weights must be one of {', '.join(RIG_WEIGHTS)}; got {params.weights!r}")
    shot, inputs = request_shot(params.shot, env.data)
    shot.plan()  # the planner's refusal before anything is queued
    width = params.width
    height = max(1, round(width * shot.view.height / shot.view.width))
    if height > MAX_RIG_JOB_SIDE:
        raise ValueError(f"width {width} gives a height of {height} pixels at the shot's aspect; the limit is "
                         f"{MAX_RIG_JOB_SIDE} (MAX_RIG_JOB_SIDE): lower width")  # fmt: skip
    shot = replace(shot, view=replace(shot.view, width=width, height=height))
    rig = shot.plan()
    views = len(rig.cameras) + (2 if shot.rig == "quadri" else CURVED_TRUTH_VIEWS)
    size = f"{width}x{height} pixels, samples {params.samples}, supersample {params.supersample}"
    # render_shot ray-traces the views one after the other: memory is one view's, rays all of them
    one = render_cost(width, height, max_depth=_SHOT_MAX_DEPTH, samples=params.samples,
                      supersample=params.supersample)  # fmt: skip
    if one.problem() is not None:
        raise ValueError(f"one view of this rig at {size} {one.problem()}")
    rays = one.rays * views
    if rays > MAX_RENDER_JOB_RAYS:
        raise ValueError(f"the {views} views of this rig at {size} may cast up to {rays:.3g} rays; a job's "
                         f"limit is {MAX_RENDER_JOB_RAYS:.0e} (MAX_RENDER_JOB_RAYS): lower width, samples or "
                         "supersample")  # fmt: skip
    scene_label = params.shot["scene"]

    def run(ctx: JobContext) -> JobResult:
        from vergence.display import anaglyph
        from vergence.io import write_image
        from vergence.rigs.shoot import render_shot

        result = render_shot(shot, weights=RIG_WEIGHTS[params.weights], samples=params.samples,
                             supersample=params.supersample, progress=ctx.progress)  # fmt: skip
        ctx.progress(1.0, "writing the images")
        images: dict[str, object] = {}
        for method, pair in result.images.items():
            for eye, image in pair.items():
                images[f"{method}_{eye}.png"] = image
            for eye in result.results[method]:
                images[f"{method}_error_{eye}.png"] = result.error_image(method, eye)
            images[f"{method}_anaglyph.png"] = anaglyph(pair["left"], pair["right"], method="dubois")
        for eye, image in result.truth.items():
            images[f"truth_{eye}.png"] = image
        for name, (image, _depth) in result.cameras.items():
            images[f"camera_{name}.png"] = image
        for name, image in images.items():
            write_image(ctx.folder / name, image)
        summary = {"rig": shot.rig, "scene": scene_label, "size": [width, height], "exposure": result.exposure,
                   "samples": params.samples, "supersample": params.supersample,
                   "cameras": list(result.cameras), **result.report}  # fmt: skip
        return JobResult(summary, tuple(images))

    return Prepared(inputs, run)


#: The kinds of this page (``POST /api/jobs/rig``).
KINDS = {
    "rig": JobKind("rig", "Render a shot's real cameras, synthesise the director's pair and measure it against the "
                   "truth (S0 §5–6, vergence rig render) at a preview size.", RigJob, _prepare_rig),
}

_SHOT_EXAMPLE = {"rig": "tri", "scene": "stadium", "display": "tv-55",
                 "camera": {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "fov_deg": 8.0,
                            "width": 480, "height": 270},
                 "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=6"]}  # fmt: skip


def add_routes(app: FastAPI, jobs: JobManager) -> None:
    """``GET /api/rigs/shots`` and ``POST /api/rigs/plan``."""
    index = jobs.env.data
    error = {"content": {"application/json": {"example": {"error": "one line"}}}}

    @app.get("/api/rigs/shots", summary="The rig planner's preset shots")
    def rig_shots() -> dict[str, list[dict[str, Any]]]:
        """``{"shots": [{"id", "name", "source", "shot"}]}``: the built-in example shots, then the shot files
        of the data folders whose scene the server can open (their ``scene`` given as its data id)."""
        return {"shots": example_shots(index)}

    @app.post("/api/rigs/plan", summary="Plan a shot's rig (the twin of vergence rig plan --json)",
              response_class=Response, responses={
                  200: {"description": "Exactly what `vergence rig plan SHOT --json` prints, with \"shot\": null.",
                        "content": {"application/json": {}}}, 404: error, 413: error, 422: error},
              openapi_extra={"requestBody": {"required": True, "content": {"application/json": {
                  "schema": {"type": "object", "description": "A shot (docs/shots.md); scene: a built-in name or "
                             "a scene id of GET /api/data."}, "example": _SHOT_EXAMPLE}}}})  # fmt: skip
    async def rig_plan(request: Request) -> Response:
        """The real cameras of the shot: positions, focal lengths, baselines (S0 §5–6); the planner's
        one-line refusal (422) as the command gives it."""
        body = await request.body()
        try:
            data = json.loads(body)
        except (ValueError, RecursionError) as exc:  # RecursionError: arrays or objects nested too deep
            return refusal(422, f"the body is not valid JSON ({exc})")

        def plan() -> dict[str, Any]:
            from vergence.rigs import plan_document

            return plan_document(request_shot(data, index)[0])

        try:
            doc = await run_in_slot(plan)
        except Busy as exc:
            return refusal(exc.status, exc.message)
        except KeyError as exc:
            return refusal(404, str(exc.args[0]))
        except (TypeError, ValueError) as exc:
            return refusal(422, index.redact(str(exc)))  # a scene file's message names no server path
        return JSONResponse(doc)
