"""Atomic file output: write to a temporary file in the destination folder, then rename.

A reader never sees a half-written output: the file appears under its final name only once it is
complete (``os.replace`` is atomic on POSIX and Windows when both paths are on one file system,
which a temporary file in the same folder guarantees).
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import uuid
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["atomic_folder", "atomic_write", "check_output_path", "describe_os_error", "write_json"]


def _output_path(path: object) -> Path:
    """Validate an output path: a str or PathLike whose folder exists and which is not a folder."""
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    out = Path(path)
    if str(path) == "" or out.name == "":
        raise ValueError(f"path must name a file; got {str(path)!r}")
    if out.is_dir():
        raise IsADirectoryError(f"cannot write {out}: it is a directory")
    parent = out.parent if str(out.parent) != "" else Path(".")
    if not parent.is_dir():
        raise FileNotFoundError(f"cannot write {out}: folder {parent} does not exist")
    return out


def check_output_path(out: str | os.PathLike[str], *inputs: str | os.PathLike[str]) -> None:
    """Refuse to write ``out`` over one of the ``inputs`` (an existing file reached by either path).

    Raises
    ------
    ValueError
        ``output OUT would overwrite input IN``.
    """
    if not Path(out).exists():
        return
    target = Path(out).resolve()
    for p in inputs:
        if Path(p).resolve() == target:
            raise ValueError(f"output {out} would overwrite input {p}")


def atomic_write(path: str | os.PathLike[str], *, replace: bool = True) -> AbstractContextManager[Path]:
    """Yield a temporary path beside ``path``; rename it to ``path`` when the block succeeds.

    The temporary file has the same extension as ``path`` (writers that choose the format by
    extension, such as OpenCV, work unchanged) and a hidden, unique name in the same folder. It does
    not exist yet when yielded: the caller creates it. If the block raises, the temporary file is
    removed and ``path`` is left untouched (an existing file keeps its old content).

    Parameters
    ----------
    path : str or os.PathLike
        Final output file. Its folder must exist. An existing file is replaced.
    replace : bool
        False: never replace a file: ``path`` existing when the block starts or appearing while it
        runs is refused (:class:`FileExistsError`), the commit being a hard link that fails on an
        existing name (a check and a rename where the file system has no hard links).

    Returns
    -------
    contextlib.AbstractContextManager of pathlib.Path
        Its ``with`` block gets the temporary file to write, in the folder of ``path``.

    Raises
    ------
    TypeError
        If ``path`` is not a str or path-like.
    FileNotFoundError
        If the folder of ``path`` does not exist.
    IsADirectoryError
        If ``path`` is a directory.
    FileNotFoundError
        If the block finished without creating the temporary file.
    FileExistsError
        With ``replace=False``, if ``path`` exists (``cannot write PATH: it exists``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_write(folder / "note.txt") as tmp:
    ...     _ = tmp.write_text("done")
    >>> (folder / "note.txt").read_text()
    'done'
    """
    out = _output_path(path)
    if not replace and (out.exists() or out.is_symlink()):
        raise FileExistsError(f"cannot write {out}: it exists")
    return _atomic_write(out, replace=bool(replace))


def _commit_new(tmp: Path, out: Path) -> None:
    """Rename ``tmp`` to ``out`` unless ``out`` exists (atomically where hard links exist)."""
    try:
        os.link(tmp, out)  # fails with EEXIST on an existing name, whoever created it meanwhile
    except FileExistsError:
        raise FileExistsError(f"cannot write {out}: it exists") from None
    except OSError:  # no hard links on this file system
        if out.exists() or out.is_symlink():
            raise FileExistsError(f"cannot write {out}: it exists") from None
        os.replace(tmp, out)
        return
    tmp.unlink()


@contextmanager
def _atomic_write(out: Path, *, replace: bool = True) -> Iterator[Path]:
    tmp = out.with_name(f".{out.stem}.tmp-{uuid.uuid4().hex[:12]}{out.suffix}")
    try:
        yield tmp
        if not tmp.is_file():
            raise FileNotFoundError(f"cannot write {out}: the writer created no file")
        if replace:
            os.replace(tmp, out)
        else:
            _commit_new(tmp, out)
    except OSError as exc:
        raise _os_error(exc, out, tmp) from None
    finally:
        if tmp.exists():
            tmp.unlink()


def _os_error(exc: OSError, out: Path, tmp: Path) -> OSError:
    """``exc`` told about ``out``: one line, the system's reason, no errno and no temporary name."""
    if str(exc).startswith(f"cannot write {out}"):
        return exc
    reason = exc.strerror or str(exc)
    reason = reason.replace(str(tmp), str(out)).replace(tmp.name, out.name)
    error = OSError(f"cannot write {out}: {reason}")
    error.errno = exc.errno
    return error


def atomic_folder(path: str | os.PathLike[str]) -> AbstractContextManager[Path]:
    """Yield a hidden temporary folder beside ``path``; its files appear in ``path`` only if the block succeeds.

    All or nothing: when the block raises (an error, ``KeyboardInterrupt``), the temporary folder is
    removed and ``path`` is left as it was; no empty output folder is created. On success a new
    ``path`` is the temporary folder renamed; an existing one receives each file by ``os.replace``
    (files of the same names are replaced, others are kept). ``path`` is checked when this function
    is called, before any ``with`` block starts.

    Parameters
    ----------
    path : str or os.PathLike
        The output folder. Missing parent folders are created.

    Returns
    -------
    contextlib.AbstractContextManager of pathlib.Path
        Its ``with`` block gets the temporary folder to write into; subfolders are merged into the
        existing ones of ``path`` file by file.

    Raises
    ------
    TypeError
        If ``path`` is not a str or path-like.
    ValueError
        If ``path`` is empty.
    NotADirectoryError
        If ``path`` exists and is not a folder.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "out"
    >>> with atomic_folder(target) as tmp:
    ...     _ = (tmp / "a.txt").write_text("done")
    >>> sorted(p.name for p in target.iterdir())
    ['a.txt']
    """
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    if str(path) == "":
        raise ValueError("path must name a folder; got ''")
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"cannot write into {out}: it exists and is not a folder")
    return _atomic_folder(out)


def _merge_into(src: Path, dst: Path) -> None:
    """Move every file of ``src`` to the same place under ``dst`` (folders created as needed)."""
    for f in sorted(src.iterdir()):
        if f.is_dir() and not f.is_symlink():
            target = dst / f.name
            if target.exists() and not target.is_dir():
                raise OSError(f"{target} exists and is not a folder")
            if not target.exists():
                os.rename(f, target)
            else:
                _merge_into(f, target)
        else:
            os.replace(f, dst / f.name)


@contextmanager
def _atomic_folder(out: Path) -> Iterator[Path]:
    tmp = out.absolute().parent / f".{out.name}.tmp-{uuid.uuid4().hex[:12]}"
    try:
        out.absolute().parent.mkdir(parents=True, exist_ok=True)
        tmp.mkdir()
    except OSError as exc:  # a parent that is a file, a read-only file system, no permission
        raise OSError(f"cannot create the output folder {out}: {exc.strerror or exc}") from None
    try:
        yield tmp
        try:
            if not out.exists():
                os.rename(tmp, out)
            else:
                _merge_into(tmp, out)
        except OSError as exc:
            raise OSError(f"cannot write into {out}: {exc.strerror or exc}") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _json_default(obj: object) -> Any:
    """Convert numpy scalars and arrays to Python numbers and lists for ``json``."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(f"object of type {type(obj).__name__} is not JSON serialisable")


def write_json(path: str | os.PathLike[str], obj: object) -> None:
    """Write ``obj`` as JSON (UTF-8, indent 2, trailing newline) atomically; NaN and inf are refused.

    numpy scalars and arrays become numbers and lists; paths become strings. ``allow_nan=False``:
    strict JSON has no NaN or Infinity, so a non-finite float is an error rather than an invalid file.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist. An existing file is replaced.
    obj : object
        JSON-serialisable data (dict, list, str, int, float, bool, None, numpy values).

    Raises
    ------
    ValueError
        If ``obj`` holds NaN or inf (the message names the path).
    TypeError
        If ``obj`` holds a value JSON cannot represent.
    FileNotFoundError, IsADirectoryError
        As :func:`atomic_write`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "r.json"
    >>> write_json(target, {"psnr": 31.5, "n": np.int64(3)})
    >>> target.read_text().split()
    ['{', '"psnr":', '31.5,', '"n":', '3', '}']
    """
    out = _output_path(path)
    try:
        text = json.dumps(obj, indent=2, allow_nan=False, default=_json_default)
    except ValueError as exc:
        raise ValueError(f"cannot write {out} as JSON: {exc} (NaN and inf are not valid JSON)") from exc
    except TypeError as exc:
        raise TypeError(f"cannot write {out} as JSON: {exc}") from exc
    with atomic_write(out) as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")


_TEMPORARY = re.compile(r"^\.(?P<stem>.*)\.tmp-[0-9a-f]{12}(?P<suffix>\.[^.]*)?$")  # vergence.io.atomic's names
_TEMPORARY_IN_TEXT = re.compile(r"(?P<dir>[^\s'\"]*/)?\.(?P<stem>[^\s/'\"]*)\.tmp-[0-9a-f]{12}(?P<suffix>\.\w+)?")
# The operation a system error most likely interrupted, when no temporary file says "write".
_VERBS = {errno.EEXIST: "create", errno.EROFS: "write", errno.ENOSPC: "write", errno.EDQUOT: "write",
          errno.EFBIG: "write"}


def _target(name: str) -> str | None:
    """The file a temporary file of ``vergence.io.atomic_write`` stands for, or None."""
    path = Path(name)
    m = _TEMPORARY.match(path.name)
    return None if m is None else str(path.with_name(m["stem"] + (m["suffix"] or "")))


def _untemporary(m: re.Match[str]) -> str:
    return f"{m['dir'] or ''}{m['stem']}{m['suffix'] or ''}"


def describe_os_error(exc: OSError) -> str:
    """An ``OSError`` as ``cannot <verb> PATH: reason`` or ``PATH is a folder``: no errno, no temporary name.

    Our own messages (an ``OSError`` raised with one string) keep their words; a temporary name in
    them becomes its target. A system error gives its ``strerror`` in lower case and the path the
    user named: a temporary file of ``atomic_write`` (``os.replace(tmp, out)`` names both) is
    reported as its target, being written.
    """
    if exc.errno is None or not exc.strerror:
        return _TEMPORARY_IN_TEXT.sub(_untemporary, str(exc)) or type(exc).__name__
    reason = exc.strerror[:1].lower() + exc.strerror[1:]
    names = [os.fsdecode(n) for n in (exc.filename, exc.filename2) if isinstance(n, str | bytes | os.PathLike)]
    if not names:
        return reason
    targets = [t for t in map(_target, names) if t is not None]
    if targets:
        return f"cannot write {targets[0]}: {reason}"
    path = names[0]
    if exc.errno == errno.EISDIR:
        return f"{path} is a folder"
    if exc.errno == errno.EEXIST and Path(path).is_file():
        return f"cannot create folder {path}: a file of that name exists"
    return f"cannot {_VERBS.get(exc.errno, 'open')} {path}: {reason}"
