"""The Vergence workbench: a local web page and its JSON API (``vergence serve``).

Needs the ``web`` extra (FastAPI, uvicorn): ``pip install 'vergence[web]'``.
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
