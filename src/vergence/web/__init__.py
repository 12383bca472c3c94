"""The Vergence workbench: a local web page and its JSON API (``vergence serve``).

Needs the ``web`` extra (FastAPI, uvicorn): ``pip install 'vergence[web]'``. The API, documented by
the OpenAPI schema at ``/openapi.json`` (and ``/docs``):

- ``GET /``: the page (``static/index.html``); ``/static/...``: its scripts and styles.
- ``GET /api/health``: ``{"status": "ok", "version": ...}``.
- ``GET /api/displays``: ``{"displays": [{"name", "eye_separation", "distance", "width",
  "resolution"}, ...]}``, the presets of :data:`vergence.viewing.DISPLAY_PRESETS` sorted by name.
- ``GET /api/data``: ``{"collections": [...], "scenes": [...]}``, each ``{"id", "kind", "name",
  "format"}``; ``GET /api/data/{id}`` one of them. A client names data by these ids only.
- ``POST /api/<command>`` (``budget``, ``mapping``): the command's options as JSON fields, the
  answer exactly what ``vergence <command> ... --json`` prints (:mod:`vergence.web.twins`).

Every refusal is ``{"error": "<one line>"}``: 422 bad parameter, 404 unknown id or endpoint, 405
wrong method, 413 body over :data:`MAX_JSON_BODY` bytes.
"""

from __future__ import annotations

try:
    import fastapi  # noqa: F401
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        f"vergence.web needs FastAPI ({exc.name or 'fastapi'} is missing): pip install 'vergence[web]'"
    ) from exc

from vergence.web.app import MAX_JSON_BODY, create_app

__all__ = ["MAX_JSON_BODY", "create_app"]
