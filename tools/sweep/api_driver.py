"""Subprocess that makes the API calls of a batch: ``python -m tools.sweep.api_driver CASES.json FOLDER START``.

It reports on a private copy of stdout, one JSON line per event: ``{"start": i}`` before case ``i`` and
``{"done": i, ...}`` after it, so that the parent knows which case hung or crashed the process. File
descriptors 1 and 2 are redirected into a file around each call: what the library prints (numpy or
libpng warnings, stray prints) is recorded as the case's stderr.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from tools.sweep.api_cases import ALL_ARRAYS, EXTRA_KWARGS, Values, annotations_of, param_kind

EXPECTED_ERRORS = (ValueError, TypeError, OSError)


def _numbers(obj, depth: int = 0):
    """Every numeric array or number inside a result (arrays, numbers, tuples, dicts, dataclasses)."""
    if depth > 4:
        return
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc":
            yield obj
    elif isinstance(obj, float):
        yield np.asarray(obj)
    elif isinstance(obj, (tuple, list)):
        for item in obj:
            yield from _numbers(item, depth + 1)
    elif isinstance(obj, dict):
        for item in obj.values():
            yield from _numbers(item, depth + 1)
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            yield from _numbers(getattr(obj, f.name, None), depth + 1)


def degenerate(result, *, from_empty: bool = False, from_nan: bool = False) -> str | None:
    """Why ``result`` carries no information, or None.

    No finite number at all is degenerate; so is a single number computed from an empty array
    (``from_empty``: a mean or a score of nothing), while an empty array from an empty array is not;
    and so is a constant image made of an all-NaN one (``from_nan``: a black tone map of nothing).
    """
    arrays = list(_numbers(result))
    if not arrays:
        return None
    if from_empty and any(a.ndim == 0 for a in arrays):
        return "a number computed from an empty array"
    finite = [a for a in arrays if a.size > 1 and np.isfinite(a).all()]
    if from_nan and finite and all(a.min() == a.max() for a in finite):
        return f"a constant {finite[0].flat[0]:g} made of an all-NaN array"
    if all(a.size == 0 for a in arrays):
        return None
    if not any(np.isfinite(a).any() for a in arrays if a.size):
        return "no finite value in the result"
    return None


def _fingerprint(value) -> str | None:
    if isinstance(value, np.ndarray):
        return hashlib.sha1(value.tobytes() + str(value.shape).encode()).hexdigest()
    if isinstance(value, (str, os.PathLike)) and os.path.isfile(value):
        return hashlib.sha1(Path(value).read_bytes()).hexdigest()
    return None


def _listing(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")} if folder.is_dir() else set()


def run_case(spec: dict, values: Values) -> dict:
    """Make one call and describe what happened (never raises)."""
    module = importlib.import_module(spec["module"])
    func = getattr(module, spec["name"])
    kwargs = {}
    params = annotations_of(func)
    try:
        for pname, (annotation, required, _) in params.items():
            if required:
                kwargs[pname] = values.valid(spec["name"], pname, annotation)
        kwargs.update(EXTRA_KWARGS.get(spec["name"], {}))
        if spec["param"] == ALL_ARRAYS:  # every required array argument gets the same hostile value
            for pname, (annotation, required, _) in params.items():
                if required and param_kind(spec["name"], pname, annotation) == "array":
                    kwargs[pname] = values.hostile_value(spec["name"], pname, annotation, spec["token"])
        elif spec["param"] is not None:
            annotation = params[spec["param"]][0]
            kwargs[spec["param"]] = values.hostile_value(spec["name"], spec["param"], annotation, spec["token"])
    except Exception as exc:  # noqa: BLE001 - our guess of a valid argument failed: not a finding
        return {"done": spec["id"], "status": "setup_error", "message": f"{type(exc).__name__}: {exc}"[:300]}
    # Inputs only: an output path is meant to change.
    before = {k: _fingerprint(v) for k, v in kwargs.items()
              if param_kind(spec["name"], k, params[k][0]) != "out_path"}
    out_before = _listing(values.out)
    record = {"done": spec["id"], "status": "returned", "exc_type": None, "message": "", "warnings": [],
              "inputs_changed": [], "leftovers": [], "degenerate": None}
    with tempfile.TemporaryFile() as capture, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        saved = os.dup(1), os.dup(2)
        sys.stdout.flush(), sys.stderr.flush()
        os.dup2(capture.fileno(), 1), os.dup2(capture.fileno(), 2)
        start = time.perf_counter()
        try:
            result = func(**kwargs)
            token = (spec["token"] or "").rstrip("!")
            contentless = spec.get("kind") in ("array", "sequence")  # an empty string is not an empty array
            record["degenerate"] = degenerate(result, from_empty=contentless and token == "empty",
                                              from_nan=contentless and token == "all_nan")
        except BaseException as exc:  # noqa: BLE001 - the harness records every exception, KeyboardInterrupt aside
            if isinstance(exc, KeyboardInterrupt):
                raise
            record["status"] = "raised"
            record["exc_type"] = type(exc).__name__
            record["expected"] = isinstance(exc, EXPECTED_ERRORS) and not isinstance(exc, RecursionError)
            record["message"] = str(exc)[:500]
        finally:
            record["seconds"] = round(time.perf_counter() - start, 3)
            sys.stdout.flush(), sys.stderr.flush()
            os.dup2(saved[0], 1), os.dup2(saved[1], 2)
            os.close(saved[0]), os.close(saved[1])
        capture.seek(0)
        record["stderr"] = capture.read().decode("utf-8", "replace")[-2000:]
        record["warnings"] = [f"{w.category.__name__}: {w.message}"[:300] for w in caught]
    record["inputs_changed"] = [k for k, v in kwargs.items()
                                if before.get(k) is not None and _fingerprint(v) != before[k]]
    new = sorted(_listing(values.out) - out_before)
    hidden = [n for n in new if Path(n).name.startswith(".")]
    record["leftovers"] = new if record["status"] == "raised" else hidden
    return record


def main(argv: list[str]) -> int:
    cases_path, folder, start = argv[0], Path(argv[1]), int(argv[2])
    specs = json.loads(Path(cases_path).read_text())
    channel = os.fdopen(os.dup(1), "w", buffering=1)
    values = Values(folder)
    (values.out / "existing_dir").mkdir(parents=True, exist_ok=True)
    for i in range(start, len(specs)):
        channel.write(json.dumps({"start": i}) + "\n")
        record = run_case(specs[i], values)
        record["index"] = i
        channel.write(json.dumps(record, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
