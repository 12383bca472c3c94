"""A Rich spinner on stderr as the ``progress(fraction, message)`` hook of a command's work.

The work calls ``progress(0, "matching (sgbm)")`` as a stage starts and ``progress(1, ...)`` as it
ends: the spinner shows the message while the fraction is below 1 and is gone at 1, so that what
the work prints between stages (warnings, notes) and the files it writes after are not under it.
"""

from __future__ import annotations

from types import TracebackType

from rich.status import Status

from vergence.cli._app import err_console

__all__ = ["Spinner"]


class Spinner:
    """The ``progress`` hook of a work: ``with Spinner() as progress: run_command(CMD, ..., progress=progress)``.

    Leaving the ``with`` block (an error included) stops a spinner still turning.
    """

    def __init__(self) -> None:
        self._status: Status | None = None

    def __call__(self, fraction: float, message: str) -> None:
        if fraction >= 1.0:
            self.stop()
        elif self._status is None:
            self._status = err_console.status(message, spinner="dots")
            self._status.start()
        else:
            self._status.update(message)

    def stop(self) -> None:
        if self._status is not None:
            self._status.stop()
            self._status = None

    def __enter__(self) -> Spinner:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.stop()
