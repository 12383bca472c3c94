"""Page 3 of the workbench, the StereoSpace browser (S2): the ``stereospace`` job and its follow-ups.

- ``POST /api/jobs/stereospace`` ``{collection, grid_step, display}``: a collection of ``GET /api/data``
  (by id) read by :func:`vergence.stereospace.load_collection` (sparse points matched and triangulated
  when the camera file has none), made ready for fast pairs by
  :class:`vergence.stereospace.PreparedCollection` (camera graph, StereoSpace, decoded images), and a
  start state chosen by :func:`vergence.stereospace.start_state` (three consecutive cameras
  of a capture path, smallest disparity range on ``display``). Its files: ``map.json``, the navigation
  map's data (S2 §4.3.1, Fig. 11: the top view of :func:`vergence.stereospace.map_frame` with the
  cameras, graph segments, capture paths and sparse points); its result: the start state as the page
  draws it. The prepared collection stays in memory (``live``) for the follow-ups. Nothing outside
  the collection's data folder is read: an image the camera file names that leads outside it (a
  symbolic link out, ``..``, an absolute name) is left out unread, as a missing image is, with a
  line in the result's ``warnings`` (``load_collection(within=)``); with fewer than two images left
  the job fails in one line. Warnings and errors name the entry, never a server path.
- ``POST /api/stereospace/{job_id}/move`` ``{state, pan, zoom}``: S2 §4.1's navigation,
  :func:`vergence.stereospace.pan` then :func:`vergence.stereospace.zoom` (collection units), jumping
  at a region's border to the closest point of another region in the cone, or stopping there.
- ``POST /api/stereospace/{job_id}/pair`` ``{state, format, width}``: the stereo pair of the state
  (:func:`vergence.stereospace.stereo_pair` at that working width, packed by
  :func:`vergence.display.pack`), written as PNG into the job's folder under names the server makes;
  ``GET /api/stereospace/{job_id}/views/{name}`` serves them (a name it did not make is 404).
- ``GET /api/stereospace/{job_id}/scene`` and ``/scene/{name}``: what the page needs to draw any state
  itself with WebGL2 (:mod:`vergence.web.stereospace_scene`, issue 30).

What a done job keeps, a state as the page shows it and the map's data are in
:mod:`vergence.web.stereospace_views`.

A state as the page shows it carries ``pan_right``, the sign of the pan towards the view's world right
(:func:`vergence.stereospace.pan_sign`: the arrow keys' direction, not the eyes' order ``swapped``, which
flips inside some regions), ``centre_world`` (the eyes' midpoint) and ``quality`` (the disparity range
on the job's display, as ``/pair`` answers it).

Speed (the shared two-core machine at load average 3-4 from other work, so ranges over three runs;
``POST`` through FastAPI's test client, medians of 12 nearby states): dino (48 views of 640 x 480,
6,487 triangulated points) prepares in 3.5-6 s (the triangulation is most of it). A pair at the
page's working width of 320 px: :func:`~vergence.stereospace.stereo_pair` 21-44 ms with
``grid_step`` 16 (the page's "fast"; 41-68 ms the whole request with the packed PNG, the disparity
range and the map data), 25-91 ms with grid 8 (the page's "fine", the library's default then; 43-140 ms
the request); at 640 px 35-83 ms
(16) and 66-185 ms (8). kermit (9 cameras), grid 8, 320 px: 15-44 ms. A move inside a region
takes 3-9 ms; one that jumps searches every region's tessellation (dino: 4,371 regions) in 76-141 ms.
The last :data:`PAIR_CACHE` pairs of a job are kept, so a change of format re-packs without
rendering again, and the left and right PNGs (for Enter VR) are written only when asked.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import pydantic
from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse, Response

from vergence.web._errors import refusal, validation_message
from vergence.web._models import RequestModel
from vergence.web._slots import Busy, run_in_slot
from vergence.web.jobs import JobContext, JobKind, JobManager, JobRefused, JobResult, Prepared
from vergence.web.stereospace_scene import scene_image, scene_of
from vergence.web.stereospace_views import MAX_MAP_POINTS, LiveSpace, map_data, quality_of, state_of, view_of

__all__ = ["DEFAULT_PAIR_WIDTH", "KIND", "KINDS", "MAX_MAP_POINTS", "MAX_MOVE_EXTENTS", "MAX_PAIR_FILES",
           "MAX_PAIR_WIDTH", "MIN_PAIR_WIDTH", "PAIR_CACHE", "MoveRequest", "PairRequest", "StateModel",
           "StereoSpaceJob", "add_routes"]

KIND = "stereospace"

#: Working width of a pair by default, pixels: half of a 640-wide collection, about 15 ms a pair.
DEFAULT_PAIR_WIDTH = 320
#: Narrowest and widest pair a request may ask (never wider than the collection's images either).
MIN_PAIR_WIDTH = 32
MAX_PAIR_WIDTH = 4096
#: Pairs of a job kept in memory (a change of format re-packs one without rendering it again).
PAIR_CACHE = 4
#: PNG files of a job's pairs kept on disk; the oldest are deleted beyond it.
MAX_PAIR_FILES = 96
#: Largest |pan| or |zoom| of one move, in extents of the collection (the diagonal of its cameras'
#: bounding box): a bigger step is no browsing move (and would only jump or stop).
MAX_MOVE_EXTENTS = 1.0
# Pan and zoom steps the page offers, as fractions of the start's interocular distance.
_PAN_STEP, _ZOOM_STEP = 0.25, 0.25


class StereoSpaceJob(RequestModel):
    """Parameters of a ``stereospace`` job."""

    model_config = pydantic.ConfigDict(extra="forbid")

    collection: str = pydantic.Field(description="A collection id of GET /api/data (a camera file and its images).")
    grid_step: int | None = pydantic.Field(None, ge=2, le=64, description="Grid spacing of the MLS maps of the pair's "
                                           "views, pixels (omitted: the library's default; 16 is about 2.5 times "
                                           "cheaper than it on dense points).")
    display: str = pydantic.Field("desktop-24", description="A display preset of GET /api/displays (with a "
                                  "resolution): the start state and the pairs' disparity range are judged on it.")


class StateModel(RequestModel):
    """A state of the StereoSpace: segments ``region = [i, j]`` and the eyes' parameters on them."""

    model_config = pydantic.ConfigDict(extra="forbid", allow_inf_nan=False)

    region: tuple[int, int] = pydantic.Field(description="Segments [i, j] of the first and second eye, i <= j.")
    li: float = pydantic.Field(ge=0.0, le=1.0, description="First eye's parameter on segment i.")
    lj: float = pydantic.Field(ge=0.0, le=1.0, description="Second eye's parameter on segment j (li <= lj if i == j).")


class MoveRequest(RequestModel):
    """A move of S2 §4.1 from a state: the pan, then the zoom."""

    model_config = pydantic.ConfigDict(extra="forbid", allow_inf_nan=False)

    state: StateModel
    pan: float = pydantic.Field(0.0, description="Move the view position by this (collection units) at constant "
                                "interocular distance; positive from the first eye towards the second.")
    zoom: float = pydantic.Field(0.0, description="Change the interocular distance by this (collection units).")


class PairRequest(RequestModel):
    """The stereo pair of a state in a display format."""

    model_config = pydantic.ConfigDict(extra="forbid", allow_inf_nan=False)

    state: StateModel
    format: str = pydantic.Field("anaglyph", description="A layout of vergence.display (anaglyph, sbs, tb, ...).")
    width: int = pydantic.Field(DEFAULT_PAIR_WIDTH, ge=MIN_PAIR_WIDTH, le=MAX_PAIR_WIDTH,
                                description="Working width of each view, pixels (at most the images' width).")


def _images_folder(path: Path, root: Path) -> Path:
    """The images of a collection: the camera file's folder (COLMAP's ``sparse/0/`` looks two up for
    ``images/``, when that is still inside the data folder ``root``)."""
    if path.name.lower() == "cameras.txt" and len(path.parents) > 2 and path.parents[2].is_relative_to(root) \
            and (path.parents[2] / "images").is_dir():
        return path.parents[2] / "images"
    return path.parent


def _without_paths(text: str, images: Path, entry: Any, data: Any) -> str:
    """A warning or error of the collection's reader in the page's words: its images folder named by the
    entry, ``within`` as the data folder, no server path."""
    text = text.replace(str(images), f"the images folder of {entry.name}")
    return data.redact(text.replace("the allowed folder (within)", "the data folder"))


def _prepare(params: pydantic.BaseModel, env: Any) -> Prepared:
    from vergence.viewing import Display

    if not isinstance(params, StereoSpaceJob):
        raise TypeError(f"params must be a StereoSpaceJob; got {type(params).__name__}")
    entry = env.data.get(params.collection)
    if entry.kind != "collection":
        raise ValueError(f"collection: {params.collection!r} is a {entry.kind}, not a collection; "
                         "GET /api/data lists the collections")  # fmt: skip
    try:
        display = Display.preset(params.display)
    except ValueError as exc:
        raise ValueError(f"display: {exc}") from None
    if display.resolution is None:
        raise ValueError(f"display: preset {params.display!r} has no resolution")
    if entry.path is None:  # a built-in collection: ray-traced by the job (the same for every run)
        inputs: tuple[str, ...] = (entry.id,)
    else:
        inputs = (entry.id, hashlib.sha256(entry.path.read_bytes()).hexdigest())

    def run(ctx: JobContext) -> JobResult:
        from vergence.stereospace import start_state
        from vergence.stereospace import PreparedCollection, StereoState, capture_paths, load_collection, map_frame

        t0 = time.perf_counter()
        if entry.path is None:
            from vergence.render import builtin_scene
            from vergence.stereospace import render_collection

            rendered = ctx.folder / "collection"
            rendered.mkdir()
            cameras_path = render_collection(builtin_scene(entry.id.split(":", 1)[1]), rendered,
                                             progress=lambda f, m: ctx.progress(0.3 * float(f), m))  # fmt: skip
            images, start = rendered, 0.3
        else:
            cameras_path, images, start = entry.path, _images_folder(entry.path, entry.root), 0.0
        ctx.progress(start, f"reading {entry.name}")
        try:  # an image that leads outside the data folder is left out, with a warning (load_collection)
            collection = load_collection(cameras_path, images=images, within=entry.root,
                                         progress=lambda f, m: ctx.progress(start + (0.6 - start) * float(f), m))
        except ValueError as exc:
            raise ValueError(_without_paths(str(exc), images, entry, env.data)) from None
        ctx.progress(0.6, f"decoding {len(collection)} images, projecting {collection.point_count} points")
        prepared = (PreparedCollection(collection) if params.grid_step is None
                    else PreparedCollection(collection, grid_step=params.grid_step))
        ctx.progress(0.9, "choosing the start state")
        note = ""
        try:
            start, _, _ = start_state(prepared, display)
        except ValueError as exc:  # no three consecutive cameras see a point: the first segment's two cameras
            start = StereoState(prepared.space.regions[0], 0.0, 1.0)
            note = f"start: {exc}; the first segment's two cameras are the start"
        extent = float(np.linalg.norm(np.ptp(collection.centers, axis=0))) or 1.0
        live = LiveSpace(prepared, map_frame(collection), display, ctx.folder / "views", extent)
        live.folder.mkdir()
        paths = [[int(k) for k in p] for p in capture_paths(prepared.graph)]
        (ctx.folder / "map.json").write_text(json.dumps(map_data(live, paths)))
        view = view_of(live, start)
        first = collection.cameras[0]
        summary = {"collection": params.collection, "name": entry.name, "cameras": len(collection),
                   "points": collection.point_count, "points_source": collection.points_source,
                   "segments": len(prepared.space.segments), "regions": len(prepared.space.regions),
                   "paths": len(paths), "image_width": first.width, "image_height": first.height,
                   "grid_step": prepared.grid_step, "display": params.display, "start": view,
                   "pan_step": _PAN_STEP * view["interocular"] or 0.01 * extent,
                   "zoom_step": _ZOOM_STEP * view["interocular"] or 0.01 * extent,
                   "max_move": MAX_MOVE_EXTENTS * extent, "formats": _formats(),
                   "default_width": min(DEFAULT_PAIR_WIDTH, first.width), "min_width": MIN_PAIR_WIDTH,
                   "warnings": [_without_paths(w, images, entry, env.data) for w in collection.warnings]
                               + ([note] if note else []),
                   "seconds": time.perf_counter() - t0}  # fmt: skip
        return JobResult(summary, ("map.json",), live=live)

    return Prepared(inputs, run)


def _formats() -> list[str]:
    from vergence.display import LAYOUTS

    return list(LAYOUTS)


#: The kinds of this module (``POST /api/jobs/stereospace``).
KINDS = {KIND: JobKind(KIND, "Prepare a photo collection for stereo browsing (S2, vergence.stereospace): camera "
                       "graph, StereoSpace, decoded images, start state and the navigation map.",
                       StereoSpaceJob, _prepare)}

_ERROR = {"content": {"application/json": {"example": {"error": "one line"}}}}


class _Refused(Exception):
    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status, self.message = status, message


def _checked_state(live: LiveSpace, model: StateModel) -> Any:
    from vergence.stereospace import StereoState

    try:
        return live.prepared.space.check_state(StereoState(tuple(model.region), model.li, model.lj))
    except (ValueError, TypeError) as exc:
        raise _Refused(422, f"state: {exc}") from None


def _move(live: LiveSpace, body: MoveRequest) -> dict[str, Any]:
    from vergence.stereospace import pan, zoom

    for name in ("pan", "zoom"):
        v = getattr(body, name)
        if abs(v) > MAX_MOVE_EXTENTS * live.extent:
            raise _Refused(422, f"{name} must be at most {MAX_MOVE_EXTENTS * live.extent:.4g} in size (the "
                                f"collection's extent, collection units); got {v:g}")  # fmt: skip
    state = _checked_state(live, body.state)
    steps = []
    for name, fn in (("pan", pan), ("zoom", zoom)):
        v = getattr(body, name)
        if v == 0.0:
            continue
        moved = fn(live.prepared.space, state, v)
        steps.append({"action": name, "by": v, "event": moved.event, "from": state_of(state),
                      "to": state_of(moved.state)})
        state = moved.state
    events = {s["event"] for s in steps}
    event = "jumped" if "jumped" in events else "stopped" if "stopped" in events else "moved"
    return {"event": event, "steps": steps, "state": view_of(live, state)}


def _pair(live: LiveSpace, job_id: str, body: PairRequest) -> dict[str, Any]:
    from vergence.display import LAYOUTS

    if body.format not in LAYOUTS:
        raise _Refused(422, f"format must be one of {', '.join(LAYOUTS)}; got {body.format!r}")
    full = live.prepared.collection.cameras[0].width
    if body.width > full:
        raise _Refused(422, f"width must be at most {full} (the collection's image width); got {body.width}")
    state = _checked_state(live, body.state)
    key = (state.region, state.li, state.lj, body.width)
    t0 = time.perf_counter()
    with live.lock:
        cached = key in live.pairs
        result = _result(live, key)
        t1 = time.perf_counter()
        stem = hashlib.sha256(json.dumps([list(state.region), state.li, state.lj, body.width]).encode())
        stem = stem.hexdigest()[:16]
        images = {}
        # the packed image now (the page shows it at once); each view when it is first asked (Enter VR)
        for role in ("packed", "left", "right"):
            name = f"{stem}-{body.format if role == 'packed' else role}.png"
            if name not in live.files:
                live.files[name] = (live.folder / name, key, body.format if role == "packed" else role)
                while len(live.files) > MAX_PAIR_FILES:
                    _, (old, _, _) = live.files.popitem(last=False)
                    old.unlink(missing_ok=True)
            live.files.move_to_end(name)
            if role == "packed":
                _write(live, name)
            images[role] = f"/api/stereospace/{job_id}/views/{name}"
        t2 = time.perf_counter()
    quality = quality_of(live, result.cameras) if result.rectification is not None else None
    height, width = result.left.shape[:2]
    return {"state": view_of(live, state), "format": body.format, "width": int(width), "height": int(height),
            "images": images, "swapped": result.swapped, "quality": quality, "cached": cached,
            "seconds": {"pair": t1 - t0, "files": t2 - t1}}  # fmt: skip


def _result(live: LiveSpace, key: tuple) -> Any:
    """The pair of ``key`` (region, li, lj, width) from the cache, else made (call under ``live.lock``)."""
    from vergence.stereospace import StereoState, stereo_pair

    result = live.pairs.get(key)
    if result is None:
        try:
            result = stereo_pair(live.prepared, StereoState(*key[:3]), width=key[3])
        except ValueError as exc:
            raise _Refused(422, f"this pair cannot be shown: {exc}") from None
        live.pairs[key] = result
        while len(live.pairs) > PAIR_CACHE:
            live.pairs.popitem(last=False)
    live.pairs.move_to_end(key)
    return result


def _write(live: LiveSpace, name: str) -> Path:
    """The PNG of a registered name, written if it is not yet (call under ``live.lock``)."""
    from vergence.display import pack
    from vergence.io import write_image

    path, key, role = live.files[name]
    if not path.is_file():
        result = _result(live, key)
        image = getattr(result, role) if role in ("left", "right") else pack(result.left, result.right, layout=role)
        write_image(path, np.clip(image, 0.0, 1.0))
    return path


def _body_schema(model: type[pydantic.BaseModel]) -> dict[str, Any]:
    """The OpenAPI request body of a route that validates ``model`` itself: its JSON schema with the
    nested models inlined (their ``$defs`` refs would not resolve inside the OpenAPI document)."""
    schema = model.model_json_schema()
    defs = schema.pop("$defs", {})

    def inline(node: Any) -> Any:
        if isinstance(node, dict):
            ref = node.get("$ref", "")
            if ref.startswith("#/$defs/"):
                return inline(defs[ref.removeprefix("#/$defs/")])
            return {k: inline(v) for k, v in node.items()}
        if isinstance(node, list):
            return [inline(v) for v in node]
        return node

    return {"requestBody": {"required": True, "content": {"application/json": {"schema": inline(schema)}}}}


def add_routes(app: FastAPI, jobs: JobManager) -> None:
    """``POST /api/stereospace/{job_id}/move`` and ``/pair``, ``GET /api/stereospace/{job_id}/views/{name}``,
    ``/scene`` and ``/scene/{name}``."""

    def live_of(job_id: str) -> LiveSpace:
        try:
            return jobs.live(job_id, KIND)
        except KeyError as exc:
            raise _Refused(404, str(exc.args[0])) from None
        except JobRefused as exc:
            raise _Refused(exc.status, exc.message) from None

    async def answer(job_id: str, request: Request, model: type[pydantic.BaseModel], work: Any) -> Response:
        try:
            body = model.model_validate_json(await request.body() or b"{}")
        except pydantic.ValidationError as exc:
            return refusal(422, validation_message(exc.errors(), list(model.model_fields)))
        try:
            live = live_of(job_id)
            return JSONResponse(await run_in_slot(work, live, body))
        except (_Refused, Busy) as exc:
            return refusal(exc.status, exc.message)

    @app.post(f"/api/{KIND}/{{job_id}}/move", summary="Pan and zoom through the StereoSpace (S2 §4.1)",
              responses={404: _ERROR, 409: _ERROR, 422: _ERROR}, openapi_extra=_body_schema(MoveRequest))
    async def move(job_id: str, request: Request) -> Response:
        """Body ``{state: {region, li, lj}, pan, zoom}`` (pan, then zoom, collection units; each at most
        ``max_move`` of the job's result). Answers ``{event, steps, state}``: event ``moved``, ``jumped``
        (to another region at its border) or ``stopped`` (no region in the cone), and the new state as
        the page shows it (parameters, stereo point, eyes and region on the map)."""
        return await answer(job_id, request, MoveRequest, _move)

    @app.post(f"/api/{KIND}/{{job_id}}/pair", summary="The stereo pair of a state, in a display format",
              responses={404: _ERROR, 409: _ERROR, 422: _ERROR}, openapi_extra=_body_schema(PairRequest))
    async def pair(job_id: str, request: Request) -> Response:
        """Body ``{state, format, width}``. Answers ``{state, format, width, height, images: {packed,
        left, right}, swapped, quality, cached, seconds}``: the images' URLs (PNG), the disparity
        range on the job's display (None for coincident eyes) and the time taken."""
        return await answer(job_id, request, PairRequest, lambda live, body: _pair(live, job_id, body))

    @app.get(f"/api/{KIND}/{{job_id}}/scene", summary="What the page needs to draw any state itself (WebGL2)",
             responses={404: _ERROR, 409: _ERROR})
    def scene(job_id: str) -> Response:  # sync: starlette runs it in its thread pool
        """Cameras, segments, up, sparse points, image URLs and S2's render parameters
        (:func:`vergence.web.stereospace_scene.scene_of`): the browser renders each eye from them."""
        try:
            live = live_of(job_id)
        except _Refused as exc:
            return refusal(exc.status, exc.message)
        width = min(DEFAULT_PAIR_WIDTH, live.prepared.collection.cameras[0].width)
        return JSONResponse(scene_of(live.prepared, image_url=f"/api/{KIND}/{job_id}/scene", default_width=width,
                                     map_frame=live.frame))

    @app.get(f"/api/{KIND}/{{job_id}}/scene/{{name}}", summary="A source image of the scene (a name /scene answered)",
             response_class=FileResponse, responses={404: _ERROR, 409: _ERROR})
    def scene_file(job_id: str, name: str) -> Response:
        """``source-{k}.png``: camera ``k``'s decoded image, 8-bit PNG; any other name is 404."""
        try:
            live = live_of(job_id)
        except _Refused as exc:
            return refusal(exc.status, exc.message)
        with live.lock:
            path = scene_image(live.prepared, live.folder.parent / "scene", name)
        if path is None:
            return refusal(404, f"job {job_id} has no scene image {name[:40]!r}: GET /api/{KIND}/{job_id}/scene names them")
        return FileResponse(path, media_type="image/png")

    @app.get(f"/api/{KIND}/{{job_id}}/views/{{name}}", summary="An image of a pair (a name /pair answered)",
             response_class=FileResponse, responses={404: _ERROR, 409: _ERROR})
    def view(job_id: str, name: str) -> Response:  # sync: starlette runs it in its thread pool
        """Only the names ``/pair`` answered and still kept (the last :data:`MAX_PAIR_FILES`)."""
        try:
            live = live_of(job_id)
        except _Refused as exc:
            return refusal(exc.status, exc.message)
        with live.lock:
            if name not in live.files:
                return refusal(404, f"job {job_id} has no pair image {name[:40]!r}: ask POST /api/{KIND}/{job_id}/pair")
            try:
                path = _write(live, name)
            except _Refused as exc:
                return refusal(exc.status, exc.message)
        return FileResponse(path, media_type="image/png", headers={"Cache-Control": "no-cache"})
