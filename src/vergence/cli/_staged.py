"""All-or-nothing output for commands that write several files: the library's
:func:`vergence.commands._outputs.staged_outputs`, with the console script's Ctrl-C check before the
renames (a Ctrl-C seen but not yet raised, while Numba was inside LLVM, commits nothing). This name
stays until ``synthesize`` takes the library's with ``before_commit``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from vergence.cli import raise_if_interrupted
from vergence.commands._outputs import staged_outputs as _staged_outputs

__all__ = ["staged_outputs"]


@contextmanager
def staged_outputs(targets: Sequence[Path], *, folder: Path | None = None) -> Iterator[list[Path]]:
    """:func:`vergence.commands._outputs.staged_outputs` with ``before_commit=raise_if_interrupted``."""
    with _staged_outputs(targets, folder=folder, before_commit=raise_if_interrupted) as temps:
        yield temps
