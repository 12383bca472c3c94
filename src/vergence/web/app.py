"""The workbench's server: the page, the JSON API and its refusals (``vergence serve`` runs it).

Every refusal is a JSON object ``{"error": "<one line>"}``: 400 for a foreign ``Host``, 401 without
the token (remote serving only), 403 for a foreign ``Origin`` and 415 for a body not sent as JSON
(:mod:`vergence.web._guard`), 422 for a bad parameter (FastAPI's own validation included, named by
its field), 404 for an unknown id or endpoint, 413 for a body over :data:`MAX_JSON_BODY`, refused
before it is parsed, 429 when :data:`vergence.web._slots.MAX_CALLS` computations are running. No CORS
headers: the page is served from the same origin, and no other site's script may call the API. No algorithm lives here: the twins call
the commands' library functions (:mod:`vergence.commands`, through :mod:`vergence.web.twins`) on
worker threads, the rest reads the library's tables.
"""

from __future__ import annotations

import contextlib
import inspect
import shutil
import tempfile
import weakref

from collections.abc import AsyncIterator, Callable, Sequence
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from vergence.web._errors import MAX_SHOWN as _MAX_SHOWN
from vergence.web._errors import scrub_paths as _scrub_paths
from vergence.web._guard import add_guards
from vergence.web._errors import refusal as _refusal
from vergence.web._errors import validation_message as _validation_message
from vergence.web.data import DataIndex
from vergence.web.job_kinds import JobEnv
from vergence.web.jobs import JobManager
from vergence.web.routes import add_job_routes, add_upload_routes
from vergence.web.uploads import UploadStore
from vergence.web._slots import MAX_CALLS, Busy, work_slot
from vergence.web.twins import Resolver, Twin, TwinError, build_twins
from vergence.web.warmup import KernelWarmup

__all__ = ["MAX_JSON_BODY", "STATIC_DIR", "create_app"]

# Largest request body (bytes) the JSON API reads: a command's options fit in a few hundred bytes;
# 1 MiB leaves room for long lists of depths or constraints and keeps a hostile body out of memory.
MAX_JSON_BODY = 1 << 20

# The page: index.html, common.js, xr.js, style.css and pages/<id>.html|js (no build step, no CDN).
STATIC_DIR = Path(__file__).parent / "static"

# The modules of the pages' own work: each has KINDS (job kinds by name) and may have
# add_routes(app, jobs) for the page's follow-up requests on a done job (``JobManager.live``).
_PAGE_MODULES = ("vergence.web.job_kinds", "vergence.web.stereo_page", "vergence.web.rigs_page",
                 "vergence.web.stereospace_page")


# The library packages the requests use, imported when the app is made: two first requests at once
# on worker threads would otherwise import the same package at once, and a package whose modules
# import each other can then be seen half-initialised by one of them (a circular-import error).
_LIBRARY_PACKAGES = ("vergence.render", "vergence.specular", "vergence.synthesis", "vergence.rigs",
                     "vergence.stereospace", "vergence.depth", "vergence.display", "vergence.viewing")


def _page_modules() -> list[Any]:
    import importlib

    for name in _LIBRARY_PACKAGES:
        importlib.import_module(name)
    return [importlib.import_module(name) for name in _PAGE_MODULES]


class ErrorBody(BaseModel):
    """Every refusal: one line saying what was wrong, naming the field or option."""

    error: str


_ERRORS: dict[int | str, dict[str, Any]] = {
    422: {"model": ErrorBody, "description": "A bad parameter: one line naming the field or option."},
    413: {"model": ErrorBody, "description": f"The body is over {MAX_JSON_BODY} bytes (MAX_JSON_BODY)."},
}


class _BodyLimit:
    """ASGI middleware: a body over ``limit`` bytes is answered 413 before anyone parses it.

    A declared ``Content-Length`` over the limit is refused unread; a body without one is read
    up to the limit, then handed on whole. The paths in ``own_limit`` (``POST /api/uploads``)
    pass through unread: they stream their body under a limit of their own.
    """

    def __init__(self, app: ASGIApp, limit: int, own_limit: frozenset[str] = frozenset()) -> None:
        self.app, self.limit, self.own_limit = app, limit, own_limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope.get("path") in self.own_limit:
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers", []))
        declared = headers.get(b"content-length")
        if declared is not None:
            if not declared.isdigit():
                await _refusal(400, f"Content-Length must be a number of bytes; got {declared[:_MAX_SHOWN]!r}")(
                    scope, receive, send)
                return
            if int(declared) > self.limit:
                await self._too_large(scope, receive, send, f"{int(declared)} bytes")
                return
        chunks, size = [], 0
        while True:
            message = await receive()
            if message["type"] != "http.request":
                break  # the client left
            chunks.append(message.get("body", b""))
            size += len(chunks[-1])
            if size > self.limit:
                await self._too_large(scope, receive, send, f"more than {self.limit} bytes")
                return
            if not message.get("more_body", False):
                break
        body, replayed = b"".join(chunks), False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)

    async def _too_large(self, scope: Scope, receive: Receive, send: Send, size: str) -> None:
        await _refusal(413, f"request body too large: {size}; the limit is {self.limit} bytes (MAX_JSON_BODY)")(
            scope, receive, send)


def _twin_endpoint(twin: Twin, resolve: Resolver, tmp_root: Path, redact: Callable[[str], str]) -> Any:
    """The route function of a twin: its body is the twin's model (documented in OpenAPI). A refusal
    passes through ``redact``: no server path (a data folder, the app's own) leaves the server."""

    def endpoint(options: BaseModel) -> Response:
        try:
            with work_slot():
                text = twin.run(options, resolve, tmp_root=tmp_root)
        except Busy as exc:
            return _refusal(exc.status, exc.message)
        except KeyError as exc:
            return _refusal(404, redact(str(exc.args[0])))
        except TwinError as exc:
            return _refusal(exc.status, redact(exc.message))
        return Response(text, media_type="application/json")

    endpoint.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [inspect.Parameter("options", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=twin.model)])
    endpoint.__name__ = f"twin_{twin.name.replace('-', '_').replace(' ', '_')}"
    files = (" Files are ids: an upload's (POST /api/uploads) or a data entry's (GET /api/data); the answer "
             "names them so." if twin.reads_files else "")
    endpoint.__doc__ = (f"{twin.summary}\n\nThe twin of `vergence {twin.name} --json`: the options as JSON "
                        f"fields, the answer exactly the JSON the command prints (429 when "
                        f"{MAX_CALLS} calls are running).{files}")
    return endpoint


def _resolver(index: DataIndex, uploads: UploadStore) -> Resolver:
    """An id of a twin's request -> the file: an upload's stored file (seen under the name the page
    gave it, when that is a plain file name with the upload's extension), else a data entry's file."""

    def resolve(ident: str) -> tuple[Path, str, str]:
        try:
            upload = uploads.get(ident)
        except KeyError:
            pass
        else:
            name = upload.name
            plain = name == Path(name).name and not name.startswith(".") and "\\" not in name
            same_kind = Path(name).suffix.lower().replace(".jpeg", ".jpg") == upload.path.suffix.lower()
            return upload.path, ident, name if plain and same_kind else ""
        try:
            entry = index.get(ident)
        except KeyError:
            raise KeyError(f"unknown id {ident!r}: neither an upload (POST /api/uploads) nor a data entry "
                           "(GET /api/data)") from None
        if entry.path is None:
            raise KeyError(f"{ident!r} is a built-in {entry.kind}, not a file")
        return entry.path, ident, ""

    return resolve


def create_app(data_dirs: Sequence[str | Path] = (), *, allowed_hosts: Sequence[str] = (),
               token: str | None = None, warm_kernels: bool = False) -> FastAPI:
    """The workbench application: the page at ``/``, the JSON API under ``/api``.

    Parameters
    ----------
    data_dirs : sequence of str or Path
        The folders whose collections and scenes the API lists by id (``vergence serve --data``);
        nothing else on disk is reachable from a request.
    allowed_hosts : sequence of str
        Host names or addresses served besides the loopback ones (``vergence serve`` passes the host
        it binds; ``0.0.0.0`` or ``::`` admit any IP address): any other ``Host`` is refused, 400
        (:mod:`vergence.web._guard`).
    token : str, optional
        A token every request must carry (``?token=``, its cookie, or ``Authorization: Bearer``),
        401 otherwise; ``vergence serve`` makes one when it binds a non-loopback host.
    warm_kernels : bool
        Compile the pages' kernels in a background thread when the app starts (its lifespan), as
        ``vergence serve`` does (:mod:`vergence.web.warmup`); ``GET /api/health`` reports the state.

    Raises
    ------
    ValueError
        If a data folder does not exist or is not a folder.
    """
    from vergence import __version__

    index = DataIndex(data_dirs)
    twins = build_twins()
    workdir = Path(tempfile.mkdtemp(prefix="vergence-web-"))
    uploads = UploadStore(workdir / "uploads")
    modules = _page_modules()
    kinds = {name: kind for module in modules for name, kind in module.KINDS.items()}
    # a kind may reuse the live objects of another done job (the specular job's planner): late-bound
    env = JobEnv(index, uploads, lambda job_id, kind: jobs.live(job_id, kind))
    jobs = JobManager(workdir / "jobs", env, kinds, redact=lambda text: _scrub_paths(index.redact(text), workdir))
    # removed at shutdown (the lifespan below); also at exit, for an app run without its lifespan
    cleanup = weakref.finalize(jobs, shutil.rmtree, workdir, ignore_errors=True)
    kernels = KernelWarmup()

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if warm_kernels:
            kernels.start()
        yield
        await run_in_threadpool(jobs.shutdown)
        cleanup()

    app = FastAPI(title="Vergence workbench", version=__version__, lifespan=lifespan,
                  description="The JSON API of `vergence serve`: every command that prints `--json` has its twin.")
    app.add_middleware(_BodyLimit, limit=MAX_JSON_BODY, own_limit=frozenset({"/api/uploads"}))
    add_guards(app, allowed_hosts=allowed_hosts, token=token)  # outermost: Host, token, Origin and Content-Type

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        twin = twins.get(request.url.path.removeprefix("/api/"))
        fields = list(twin.model.model_fields) if twin is not None else []
        return _refusal(422, _validation_message(exc.errors(), fields))

    @app.exception_handler(HTTPException)
    async def _http(request: Request, exc: HTTPException) -> JSONResponse:
        if exc.status_code == 404 and exc.detail == "Not Found":
            message = f"no such page or endpoint: {request.method} {request.url.path}"
        elif exc.status_code == 405:
            message = f"{request.method} is not allowed on {request.url.path}"
        else:
            message = str(exc.detail)
        return _refusal(exc.status_code, message)

    @app.exception_handler(Exception)
    async def _bug(request: Request, exc: Exception) -> JSONResponse:
        # a bug of ours, as the command line reports one: one line, status 500
        return _refusal(500, jobs.redact(f"internal error, please report it: {type(exc).__name__}: {exc}"))

    @app.get("/", include_in_schema=False)
    def page() -> Response:
        path = STATIC_DIR / "index.html"
        if not path.is_file():
            return _refusal(404, "the workbench page is not installed (vergence/web/static/index.html is missing)")
        return FileResponse(path, media_type="text/html")

    if STATIC_DIR.is_dir():  # the page's files (a source tree without them still serves the API)
        app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    @app.get("/api/health", summary="The server is up")
    def health() -> dict[str, Any]:
        """``{"status": "ok", "version": ..., "kernels": {"state", "done", "total"}}``: the background
        warm-up of the pages' kernels (:class:`vergence.web.warmup.KernelWarmup`)."""
        return {"status": "ok", "version": __version__, "kernels": kernels.status()}

    @app.get("/api/displays", summary="The display presets of vergence.viewing")
    def displays() -> dict[str, list[dict[str, Any]]]:
        """The presets of :data:`vergence.viewing.DISPLAY_PRESETS`, sorted by name: eye separation b',
        viewing distance H' and screen width W' in metres, horizontal resolution in pixels."""
        from vergence.viewing import DISPLAY_PRESETS

        return {"displays": [{"name": name, "eye_separation": d.eye_separation, "distance": d.distance,
                              "width": d.width, "resolution": d.resolution}
                             for name, d in sorted(DISPLAY_PRESETS.items())]}

    @app.get("/api/data", summary="The collections and scenes the server can open, by id")
    def data() -> dict[str, Any]:
        """The built-in scenes, then the collections (camera files) and scene files of the data
        folders, walked again for this answer. Choose one by its ``id``: no request names a path.
        ``skipped``: how many files and folders could not be read or lead outside (never named)."""
        entries = index.refresh()
        return {"collections": [e.to_dict() for e in entries if e.kind == "collection"],
                "scenes": [e.to_dict() for e in entries if e.kind == "scene"], "skipped": index.skipped}

    @app.get("/api/data/{entry_id}", summary="One entry of /api/data", responses={404: _ERRORS[422] | {
        "description": "No entry has this id."}})
    def data_entry(entry_id: str) -> dict[str, str]:
        """The entry of an id that ``GET /api/data`` listed."""
        try:
            return index.get(entry_id).to_dict()
        except KeyError as exc:
            raise HTTPException(404, exc.args[0]) from None

    resolve = _resolver(index, uploads)
    twin_root = workdir / "twins"  # each request's temporary folder, removed when it answers
    twin_root.mkdir()
    for path, twin in twins.items():
        extra = {404: _ERRORS[422] | {"description": "An id stands for no file."}} if twin.reads_files else {}
        endpoint = _twin_endpoint(twin, resolve, twin_root, jobs.redact)
        app.post(f"/api/{path}", summary=twin.summary, response_class=Response, responses={
            200: {"description": f"Exactly what `vergence {twin.name} --json` prints.",
                  "content": {"application/json": {}}}, **_ERRORS, **extra})(endpoint)

    add_job_routes(app, jobs)
    add_upload_routes(app, uploads)
    for module in modules:
        if hasattr(module, "add_routes"):
            module.add_routes(app, jobs)

    @app.api_route("/api/{command}", methods=["GET", "POST"], include_in_schema=False)
    def no_twin(command: str, request: Request) -> Response:
        if request.method == "GET":
            if command in twins:
                return _refusal(405, f"GET is not allowed on /api/{command}: POST its options as a JSON object")
            return _refusal(404, f"no such page or endpoint: GET /api/{command}")
        subs = [path for path in twins if path.startswith(f"{command}/")]
        if subs:
            return _refusal(404, f"vergence {command} is a group: POST to its commands' twins: "
                                 f"{', '.join('/api/' + p for p in subs)}")
        return _refusal(404, f"no command {command!r} has a JSON twin; twins: {', '.join(twins)}")

    app.state.twins = twins
    app.state.data_index = index
    app.state.jobs = jobs
    app.state.uploads = uploads
    app.state.workdir = workdir
    app.state.kernels = kernels
    return app


