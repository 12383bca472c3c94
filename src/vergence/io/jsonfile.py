"""Reading JSON input files with their size and nesting refused before parsing.

Python's ``json`` parser recurses once per nested array or object: a few hundred kilobytes of
``[[[[...`` raise ``RecursionError`` deep inside it. :func:`read_json` measures the file and its
nesting first, in one linear scan, and refuses what passes :data:`MAX_JSON_BYTES` or
:data:`MAX_JSON_DEPTH` with one line naming the limit.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from vergence.io._files import input_path, read_bytes

__all__ = ["MAX_JSON_BYTES", "MAX_JSON_DEPTH", "read_json"]

#: Largest JSON input file, in bytes (16 MiB). Scene and camera files hold a few kilobytes
#: (meshes and images live in their own files); a thousand-camera set stays under 1 MiB.
MAX_JSON_BYTES = 16 * 2**20

#: Deepest nesting of arrays and objects in a JSON input. Our deepest format (a scene's
#: ``objects[i].transform`` rows) nests 4 levels; 64 leaves room for any extension and stays far
#: below Python's recursion limit (1000), which ``json`` would otherwise hit.
MAX_JSON_DEPTH = 64

# A JSON string (with escapes) or one bracket: strings are skipped so brackets inside them don't count.
_TOKEN = re.compile(rb'"(?:[^"\\]|\\.)*"|[\[\]{}]')


def _nesting(data: bytes) -> int:
    """Deepest nesting of arrays/objects in ``data`` (an upper bound on malformed input)."""
    depth = deepest = 0
    for m in _TOKEN.finditer(data):
        c = m.group()
        if c in (b"[", b"{"):
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > MAX_JSON_DEPTH:
                    break
        elif c in (b"]", b"}"):
            depth -= 1
    return deepest


def read_json(path: str | os.PathLike[str], *, what: str = "JSON file") -> object:
    """Parse a UTF-8 JSON file after checking its size and nesting.

    Parameters
    ----------
    path : str or os.PathLike
        The file (a byte-order mark is allowed).
    what : str
        How messages call the file, e.g. ``"scene file"``.

    Returns
    -------
    object
        The parsed data.

    Raises
    ------
    ValueError
        If the file is larger than :data:`MAX_JSON_BYTES`, nests deeper than
        :data:`MAX_JSON_DEPTH`, is not UTF-8 or not valid JSON (one line naming the file).
    FileNotFoundError, IsADirectoryError
        If ``path`` does not name an existing file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "a.json"
    >>> _ = f.write_text('{"a": [1, 2]}')
    >>> read_json(f)
    {'a': [1, 2]}
    """
    p = input_path(path)
    size = p.stat().st_size
    if size > MAX_JSON_BYTES:
        raise ValueError(f"{what} {p} is {size:,} bytes; the limit is {MAX_JSON_BYTES:,} (MAX_JSON_BYTES)")
    data = read_bytes(p)
    depth = _nesting(data)
    if depth > MAX_JSON_DEPTH:
        raise ValueError(f"{what} {p} nests arrays/objects more than {MAX_JSON_DEPTH} levels deep "
                         "(MAX_JSON_DEPTH)")  # fmt: skip
    try:
        return json.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise ValueError(f"{what} {p} is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} {p} is not valid JSON: {exc}") from None
