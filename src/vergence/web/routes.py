"""The routes of the jobs (``/api/jobs``) and the uploads (``/api/uploads``); see :mod:`vergence.web`."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import AsyncIterator
from typing import Any

import pydantic
from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.concurrency import run_in_threadpool

from vergence.web._errors import refusal, validation_message
from vergence.web.jobs import FINAL_STATES, JobManager, JobRefused
from vergence.web.uploads import UPLOAD_CONTENT_TYPES, UploadError, UploadStore

__all__ = ["EVENT_KEEPALIVE_S", "EVENT_POLL_S", "add_job_routes", "add_upload_routes"]

#: Seconds between two looks at a job's state by its event stream (progress is coalesced to this).
EVENT_POLL_S = 0.05

#: Seconds after which a quiet event stream sends a comment line, so that proxies keep it open.
EVENT_KEEPALIVE_S = 15.0

_ERROR = {"content": {"application/json": {"example": {"error": "one line"}}}}

_MEDIA = {".png": "image/png", ".jpg": "image/jpeg", ".json": "application/json"}


def add_job_routes(app: FastAPI, jobs: JobManager) -> None:
    """``GET /api/jobs``, ``POST /api/jobs/{kind}``, ``GET``/``DELETE /api/jobs/{id}``, its events and files."""

    def refused(exc: JobRefused | KeyError) -> JSONResponse:
        if isinstance(exc, KeyError):
            return refusal(404, str(exc.args[0]))
        return refusal(exc.status, exc.message)

    @app.get("/api/jobs", summary="The kinds of job and the jobs kept")
    def list_jobs() -> dict[str, Any]:
        """``{"kinds": [{"name", "summary", "parameters"}], "jobs": [status, ...]}``: each kind's
        parameters as a JSON schema; the jobs queued, running or kept in the cache."""
        kinds = [{"name": k.name, "summary": k.summary, "parameters": k.model.model_json_schema()}
                 for k in sorted(jobs.kinds.values(), key=lambda k: k.name)]
        return {"kinds": kinds, "jobs": [jobs.status(j)[0] for j in jobs.jobs()]}

    @app.post("/api/jobs/{kind}", summary="Start a job (or find the same one in the cache)",
              responses={404: _ERROR, 413: _ERROR, 422: _ERROR, 429: _ERROR})
    async def submit(kind: str, request: Request) -> Response:
        """The kind's parameters as a JSON object (``GET /api/jobs`` gives their schema). Answers
        the job's status (``GET /api/jobs/{id}``) and ``"cached"``: true when the same kind,
        parameters and inputs were already submitted (that job is returned, not run again);
        status 202 for a new job, 200 for a cached one."""
        if kind not in jobs.kinds:
            return refused(JobRefused(404, f"no job kind {kind!r}; kinds: {', '.join(sorted(jobs.kinds)) or 'none'}"))
        model = jobs.kinds[kind].model
        body = await request.body()
        try:
            params = model.model_validate_json(body or b"{}")
        except pydantic.ValidationError as exc:
            return refusal(422, validation_message(exc.errors(), list(model.model_fields)))
        try:
            job, cached = await run_in_threadpool(jobs.submit, kind, params)
        except JobRefused as exc:
            return refused(exc)
        return JSONResponse({**jobs.status(job)[0], "cached": cached}, status_code=200 if cached else 202)

    @app.get("/api/jobs/{job_id}", summary="A job's state, progress and result",
             responses={404: _ERROR})
    def job_status(job_id: str) -> Response:
        """``{"id", "kind", "state", "progress", "message", "error", "result", "files"}``: state one of
        queued, running, done, failed, cancelled; progress in [0, 1]; error one line (failed only);
        result the kind's JSON summary and files the names ``/files/{name}`` serves (done only)."""
        try:
            return JSONResponse(jobs.status(jobs.get(job_id))[0])
        except KeyError as exc:
            return refused(exc)

    @app.get("/api/jobs/{job_id}/events", summary="A job's progress as server-sent events",
             response_class=StreamingResponse, responses={404: _ERROR, 200: {"content": {"text/event-stream": {}}}})
    async def job_events(job_id: str) -> Response:
        """``text/event-stream``: an ``event: progress`` with the status JSON at each change, then
        one ``event: end`` with the final status (done, failed or cancelled), and the stream ends."""
        try:
            job = jobs.get(job_id)
        except KeyError as exc:
            return refused(exc)

        async def stream() -> AsyncIterator[bytes]:
            seen, quiet_since = -1, time.monotonic()
            while True:
                status, version = jobs.status(job)
                final = status["state"] in FINAL_STATES
                if version != seen or final:
                    name = "end" if final else "progress"
                    yield f"event: {name}\ndata: {json.dumps(status)}\n\n".encode()
                    seen, quiet_since = version, time.monotonic()
                    if final:
                        return
                elif time.monotonic() - quiet_since > EVENT_KEEPALIVE_S:
                    yield b": keep-alive\n\n"
                    quiet_since = time.monotonic()
                await asyncio.sleep(EVENT_POLL_S)

        return StreamingResponse(stream(), media_type="text/event-stream", headers={"Cache-Control": "no-cache"})

    @app.delete("/api/jobs/{job_id}", summary="Cancel a job", responses={404: _ERROR, 409: _ERROR})
    def job_cancel(job_id: str) -> Response:
        """A queued job is cancelled at once; a running one stops at its next progress report
        (its state says ``running`` with message ``cancelling`` until then). 409 if it is finished."""
        try:
            return JSONResponse(jobs.status(jobs.cancel(job_id))[0], status_code=202)
        except (KeyError, JobRefused) as exc:
            return refused(exc)

    @app.get("/api/jobs/{job_id}/files/{name}", summary="A result file of a done job",
             response_class=FileResponse, responses={404: _ERROR, 409: _ERROR})
    def job_file(job_id: str, name: str) -> Response:
        """One of the names the job's ``files`` lists; anything else is 404 (never a path)."""
        try:
            path = jobs.file(job_id, name)
        except (KeyError, JobRefused) as exc:
            return refused(exc)
        return FileResponse(path, media_type=_MEDIA.get(path.suffix.lower(), "application/octet-stream"))


def add_upload_routes(app: FastAPI, uploads: UploadStore) -> None:
    """``POST /api/uploads`` and ``GET /api/uploads/{id}``."""

    @app.post("/api/uploads", summary="Upload an image or a depth/disparity map", status_code=201,
              responses={413: _ERROR, 415: _ERROR, 422: _ERROR},
              openapi_extra={"requestBody": {"required": True, "content": {
                  t: {"schema": {"type": "string", "format": "binary"}} for t in UPLOAD_CONTENT_TYPES}}})
    async def upload(request: Request, name: str = "") -> Response:
        """The file itself as the body (PNG, JPEG, PFM, or NPY as application/octet-stream); its
        format is told by content. ``name``: shown back only. Answers the metadata
        (``GET /api/uploads/{id}``), status 201; 413 over the bytes or pixels limit, 415 a Content-Type
        not in the list, 422 otherwise (a ``name`` with a control character included)."""
        try:
            uploads.check_name(name)
            uploads.check_declared(request.headers.get("content-type"), request.headers.get("content-length"))
            part = await uploads.receive(request.stream())
            stored = await run_in_threadpool(uploads.store, part, name)
        except UploadError as exc:
            return refusal(exc.status, exc.message)
        return JSONResponse(stored.to_dict(), status_code=201)

    @app.get("/api/uploads/{upload_id}", summary="An upload's metadata", responses={404: _ERROR})
    def upload_info(upload_id: str) -> Response:
        """``{"id", "kind", "width", "height", "channels", "dtype", "bytes", "name"}``: kind the
        format found in the content (png, jpeg, pfm, npy)."""
        try:
            return JSONResponse(uploads.get(upload_id).to_dict())
        except KeyError as exc:
            return refusal(404, str(exc.args[0]))
