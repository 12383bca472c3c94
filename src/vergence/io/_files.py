"""Private helpers shared by the readers: checked paths and whole-file reads with clear errors."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["check_not_empty", "input_path", "read_bytes", "suffix_of"]


def input_path(path: object) -> Path:
    """Return ``path`` as a Path, or raise if it is not a str/PathLike naming an existing file."""
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    if str(path) == "":
        raise ValueError("path must name a file; got ''")
    if p.is_dir():
        raise IsADirectoryError(f"cannot read {p}: it is a directory")
    if not p.exists():
        raise FileNotFoundError(f"cannot read {p}: no such file")
    return p


def read_bytes(path: Path) -> bytes:
    """Read a whole file; an empty file is a ``ValueError`` naming the path."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise OSError(f"cannot read {path}: {exc.strerror or exc}") from exc
    if not data:
        raise ValueError(f"cannot read {path}: the file is empty")
    return data


def suffix_of(path: Path) -> str:
    """Lower-case extension with its dot (``'.png'``), ``''`` when there is none."""
    return path.suffix.lower()


def check_not_empty(path: Path) -> None:
    """Raise a ``ValueError`` naming the path when the file has no bytes."""
    if path.stat().st_size == 0:
        raise ValueError(f"cannot read {path}: the file is empty")
