"""All-or-nothing output for commands that write several files (``synthesize``, ``interpolate``).

Every output is first written under a hidden temporary name beside its final one; only when all of
them are complete are they renamed, together, with Ctrl-C (SIGINT) held back for the few
microseconds the renames take; a Ctrl-C seen but not yet raised (the console script waits while
Numba is inside LLVM) stops them too. On any error or interruption before that, the temporary
files are removed and a folder the command created is removed again: nothing partial is left, and
an existing file keeps its old content.
"""

from __future__ import annotations

import os
import signal
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from vergence.cli import raise_if_interrupted

__all__ = ["staged_outputs"]


@contextmanager
def _sigint_held() -> Iterator[None]:
    """Hold SIGINT back (delivered on exit) where the platform can block signals."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - Windows
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextmanager
def staged_outputs(targets: Sequence[Path], *, folder: Path | None = None) -> Iterator[list[Path]]:
    """Yield one temporary path per target (same folder and extension); rename them all on success.

    Parameters
    ----------
    targets : sequence of Path
        The final output files. Their folders must exist, except ``folder``.
    folder : Path, optional
        An output folder to create if missing (and to remove again, if this call created it, when
        the block fails).

    Yields
    ------
    list of Path
        Temporary paths to write, in the order of ``targets``.
    """
    created = None
    if folder is not None and not folder.exists():
        created = folder
        for parent in reversed(folder.parents):  # remember the first missing ancestor
            if not parent.exists():
                created = parent
                break
        folder.mkdir(parents=True)
    token = uuid.uuid4().hex[:12]
    temps = [t.with_name(f".{t.stem}.stage-{token}{t.suffix}") for t in targets]
    try:
        yield temps
        with _sigint_held():
            raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM
            for tmp, target in zip(temps, targets):
                os.replace(tmp, target)
    except BaseException:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        if created is not None:
            _remove_created(folder, created)
        raise


def _remove_created(folder: Path, created: Path) -> None:
    """Remove ``folder`` and its parents up to ``created`` while they are empty."""
    p = folder
    while True:
        try:
            p.rmdir()
        except OSError:  # not empty (another writer), or already gone
            return
        if p == created:
            return
        p = p.parent
