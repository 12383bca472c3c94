"""The Vergence workbench: a local web page and its JSON API (``vergence serve``).

Needs the ``web`` extra (FastAPI, uvicorn): ``pip install 'vergence[web]'``. The API, documented by
the OpenAPI schema at ``/openapi.json`` (and ``/docs``):

- ``GET /``: the page (``static/index.html``); ``/static/...``: its scripts and styles.
- ``GET /api/health``: ``{"status": "ok", "version": ..., "kernels": {"state", "done", "total"}}``: the
  pages' kernels compiled in the background at start (``cold``, ``warming``, ``ready`` or ``failed``;
  :mod:`vergence.web.warmup`), which the page shows as a banner until ready.
- ``GET /api/displays``: ``{"displays": [{"name", "eye_separation", "distance", "width",
  "resolution"}, ...]}``, the presets of :data:`vergence.viewing.DISPLAY_PRESETS` sorted by name.
- ``GET /api/data``: ``{"collections": [...], "scenes": [...], "skipped": n}``, each ``{"id", "kind",
  "name", "format"}``; ``GET /api/data/{id}`` one of them. A client names data by these ids only.
  The folders are indexed at start and walked again for each ``GET /api/data`` (and when an id is
  unknown or its file changed); ``skipped`` counts what could not be read (a link loop) or leads
  outside the data folders (a link out, a scene's texture out), never named
  (:mod:`vergence.web.data`).
- ``POST /api/<command>`` (``budget``, ``mapping``): the command's options as JSON fields, the
  answer exactly what ``vergence <command> ... --json`` prints (:mod:`vergence.web.twins`).
- ``POST /api/uploads[?name=...]``: the body is the file itself (no multipart), Content-Type
  ``image/png``, ``image/jpeg``, ``image/x-portable-floatmap`` or ``application/octet-stream`` (.npy);
  the format is told by content (PNG, JPEG, PFM, NPY magic bytes), never by name. Answers 201
  ``{"id", "kind", "width", "height", "channels", "dtype", "bytes", "name"}``; 413 over
  :data:`MAX_UPLOAD_BYTES` (from Content-Length, unread, or as the bytes arrive) or over
  :data:`MAX_UPLOAD_PIXELS` declared by the header (nothing decoded), 415 another Content-Type, 422
  unknown or corrupt content or a ``name`` with a control character (NUL, a line break).
  ``GET /api/uploads/{id}``: that metadata. Jobs take these ids, never paths
  (:mod:`vergence.web.uploads`).
- ``GET /api/jobs``: ``{"kinds": [{"name", "summary", "parameters"}], "jobs": [...]}``.
  ``POST /api/jobs/{kind}`` (``render``: a scene id of ``/api/data``, width, height, depth,
  samples): starts a job on the worker pool, 202, or returns the job already submitted with the same
  kind, parameters and inputs, 200, ``"cached": true``. ``GET /api/jobs/{id}``: ``{"id", "kind",
  "state", "progress", "message", "error", "result", "files"}`` (state queued, running, done, failed
  or cancelled). ``GET /api/jobs/{id}/events``: server-sent events, ``progress`` at each change then
  one ``end``. ``DELETE /api/jobs/{id}``: cancel (202; 409 once finished). ``GET
  /api/jobs/{id}/files/{name}``: a file the job lists (409 until done). See :mod:`vergence.web.jobs`.
- ``POST /api/jobs/stereospace`` (a collection id of ``/api/data``), then on the done job
  ``POST /api/stereospace/{id}/move`` ``{state, pan, zoom}`` (S2 §4.1: moved, jumped or stopped),
  ``POST /api/stereospace/{id}/pair`` ``{state, format, width}`` (the pair's PNG URLs) and
  ``GET /api/stereospace/{id}/views/{name}``: page 3, :mod:`vergence.web.stereospace_page`.

Only this machine's pages may use it (:mod:`vergence.web._guard`, before any route): a request whose
``Host`` is not a loopback name (``localhost``, 127.0.0.0/8, ``[::1]``) or the address served is
refused on every path, 400 (DNS rebinding); a POST, PUT, PATCH or DELETE with an ``Origin`` other
than the request's own ``http(s)://Host`` or with ``Sec-Fetch-Site: cross-site``/``same-site`` is
refused, 403; a POST, PUT or PATCH whose Content-Type is not ``application/json`` (uploads: their own
list), none included, is refused, 415. ``vergence serve --allow-remote`` on a non-loopback host
prints a URL with a token, which every request must carry (``?token=``, then a cookie, or
``Authorization: Bearer``), 401 otherwise.

Every refusal is ``{"error": "<one line>"}``: 400 a foreign Host (or a Content-Length that is no
number), 401 no token, 403 another origin, 415 a body not sent as JSON, 422 bad parameter, 404
unknown id or endpoint, 405 wrong method, 409 a job in the wrong state, 413 a JSON body over
:data:`MAX_JSON_BODY` bytes or an upload over its limits, 429 too many jobs at once. No answer names
a server path: the data folders are ``<data>``, the app's temporary folder ``<workdir>``. Results and
uploads live in that temporary folder, removed at shutdown.
"""

from __future__ import annotations

try:
    import fastapi  # noqa: F401
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        f"vergence.web needs FastAPI ({exc.name or 'fastapi'} is missing): pip install 'vergence[web]'"
    ) from exc

from vergence.web.app import MAX_JSON_BODY, create_app
from vergence.web.jobs import JobCancelled
from vergence.web.uploads import MAX_UPLOAD_BYTES, MAX_UPLOAD_PIXELS

__all__ = ["JobCancelled", "MAX_JSON_BODY", "MAX_UPLOAD_BYTES", "MAX_UPLOAD_PIXELS", "create_app"]
