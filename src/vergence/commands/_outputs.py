"""What the commands that read and write files share: the check of a scale of stored values, and
all-or-nothing output of several files (the check of an output against the inputs is
:func:`vergence.io.atomic.check_output_path`).

:func:`staged_outputs` writes every output under a hidden temporary name beside its final one; only
when all of them are complete are they renamed, together, with Ctrl-C (SIGINT) held back for the
few microseconds the renames take, after the caller's ``before_commit()`` (the command line raises
there a Ctrl-C seen but not yet raised: the console script waits while Numba is inside LLVM). On any
error or interruption before that, the temporary files are removed and a folder the call created is
removed again: nothing partial is left, and an existing file keeps its old content.
"""

from __future__ import annotations

import os
import signal
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from vergence._validate import check_positive

__all__ = ["SCALE_RANGE", "check_scale", "staged_outputs"]

# A scale divides the stored values in float32: over this range every value of a 16-bit file over the
# scale stays a normal float32 (65535 / 1e-30 = 6.6e34 < 3.4e38; 1 / 1e30 = 1e-30 > 1.2e-38). Outside
# it the division overflowed or underflowed with numpy warnings; Middlebury and KITTI use 1 to 256,
# millimetre depth 1000.
SCALE_RANGE = (1e-30, 1e30)


def check_scale(name: str, scale: float) -> float:
    """A scale of stored values (``disparity_scale``, ``depth_scale``) within :data:`SCALE_RANGE`.

    Raises
    ------
    ValueError
        Beginning with ``name``: not finite, not > 0, or outside :data:`SCALE_RANGE`.
    """
    check_positive(name, scale)
    lo, hi = SCALE_RANGE
    if not lo <= scale <= hi:
        raise ValueError(f"{name} must lie in [{lo:g}, {hi:g}] (it divides float32 values); got {scale:g}")
    return scale


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
def staged_outputs(targets: Sequence[Path], *, folder: Path | None = None,
                   before_commit: Callable[[], None] | None = None) -> Iterator[list[Path]]:  # fmt: skip
    """Yield one temporary path per target (same folder and extension); rename them all on success.

    Parameters
    ----------
    targets : sequence of Path
        The final output files. Their folders must exist, except ``folder``.
    folder : Path, optional
        An output folder to create if missing (and to remove again, if this call created it, when
        the block fails).
    before_commit : callable, optional
        Called with SIGINT held, right before the renames: what it raises commits nothing.

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
            if before_commit is not None:
                before_commit()
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
