"""The one-line JSON refusals of the workbench's API, shared by every route (:mod:`vergence.web.app`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

from fastapi.responses import JSONResponse

__all__ = ["MAX_SHOWN", "refusal", "scrub_paths", "validation_message"]

# Longest rendering of a refused value in a message: the line stays one line a person reads.
MAX_SHOWN = 40


def refusal(status: int, message: str) -> JSONResponse:
    return JSONResponse({"error": " ".join(message.split())}, status_code=status)


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= MAX_SHOWN else text[:MAX_SHOWN - 3] + "..."


# pydantic's error types, in the words the command line uses for the same mistakes.
_EXPECTED = {
    "float_parsing": "expected a number", "float_type": "expected a number",
    "int_parsing": "expected a whole number", "int_type": "expected a whole number",
    "int_from_float": "expected a whole number", "bool_parsing": "expected true or false",
    "bool_type": "expected true or false", "string_type": "expected text", "list_type": "expected a list",
}


def validation_message(errors: Sequence[dict[str, Any]], fields: Sequence[str]) -> str:
    """The first validation error as one line that begins with the field at fault."""
    e = errors[0]
    loc = [str(p) for p in e.get("loc", ()) if p != "body"]
    kind = e.get("type", "")
    given = e.get("input")
    if kind == "json_invalid":
        return f"the body is not valid JSON ({e.get('ctx', {}).get('error', e.get('msg', ''))})"
    if isinstance(given, bytes):
        return "the body must be JSON, sent with Content-Type: application/json"
    if not loc:
        if kind == "missing":
            return "the body is missing: send the options as a JSON object"
        return f"the body must be a JSON object of options; got {type(given).__name__}"
    field = loc[0] + "".join(f"[{p}]" for p in loc[1:])
    if kind == "extra_forbidden":
        return f"unknown field {loc[0]!r}; valid fields: {', '.join(fields)}"
    if kind == "missing":
        return f"missing field {field}"
    if kind in _EXPECTED:
        return f"{field}: {_EXPECTED[kind]} (got {_shown(given)})"
    if kind == "too_long" and isinstance(given, list):  # a list field over MAX_LIST_ITEMS
        return f"{field}: at most {e.get('ctx', {}).get('max_length')} values (MAX_LIST_ITEMS); got {len(given)}"
    msg = str(e.get("msg", kind)).removeprefix("Input should be ").removeprefix("Value error, ")
    return f"{field}: {msg} (got {_shown(given)})"


def scrub_paths(text: str, *folders: str | os.PathLike[str]) -> str:
    """``text`` with each folder's server path (as given and resolved) replaced by ``<workdir>``.

    For messages that may quote a path under the app's temporary folder (a job's file, an upload):
    the answer names no server path. Longer paths are replaced first.
    """
    forms = {form for f in folders for form in (os.fspath(f), os.path.realpath(f))}
    for form in sorted(forms, key=len, reverse=True):
        text = text.replace(form, "<workdir>")
    return text
