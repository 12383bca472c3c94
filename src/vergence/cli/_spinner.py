"""A Rich spinner on stderr as the ``progress(fraction, message)`` hook of a command's work.

The work calls ``progress(0, "matching (sgbm)")`` as a stage starts and ``progress(1, ...)`` as it
ends: the spinner shows the message while the fraction is below 1 and is gone at 1, so that what
the work prints between stages (warnings, notes) and the files it writes after are not under it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import TracebackType

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.status import Status

from vergence.cli._app import err_console

__all__ = ["ProgressLines", "Spinner", "progress_bar"]


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


class ProgressLines:
    """A ``progress(fraction, message)`` hook for long work with many steps, on stderr.

    On a terminal: one line that updates in place (``" 42 % leave-one-out view 20/48"``), gone when
    the work ends. Otherwise (a log file, a pipe): a line each time the work passes the next tenth
    (:data:`STEP`), and its last one: at most a dozen lines, however many steps (``stereospace
    build`` printed 146). Use it as a context manager, like :class:`Spinner`.
    """

    #: Fraction of the work between two lines when stderr is not a terminal.
    STEP = 0.1

    def __init__(self) -> None:
        self._status: Status | None = None
        self._next = 0.0
        self._last = -1.0

    def __call__(self, fraction: float, message: str) -> None:
        text = f"{100 * fraction:3.0f} % {message}"
        if fraction < self._last:  # a new stage starts from 0 again
            self._next = 0.0
        self._last = fraction
        if err_console.is_terminal:
            if self._status is None:
                self._status = err_console.status(text, spinner="dots")
                self._status.start()
            else:
                self._status.update(text)
            return
        if fraction >= self._next:
            err_console.print(text, highlight=False, markup=False, soft_wrap=True)
            self._next = float("inf") if fraction >= 1.0 else (int(fraction / self.STEP + 1e-9) + 1) * self.STEP

    def stop(self) -> None:
        if self._status is not None:
            self._status.stop()
            self._status = None

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.stop()


@contextmanager
def progress_bar(description: str, *, lines: bool = False) -> Iterator[Callable[[float, str], None]]:
    """A Rich bar on stderr as the ``progress(fraction, message)`` hook of a command's work, gone when
    the block ends: ``with progress_bar("rendering") as report: render(..., progress=report)``.

    The bar shows only on a terminal: piped or captured stderr stays empty (errors are one line), or,
    with ``lines``, gets :class:`ProgressLines`' dozen lines (for work that runs for minutes).
    """
    columns = (TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    with Progress(*columns, console=err_console, transient=True, disable=not err_console.is_terminal) as bar:
        task = bar.add_task(description, total=1.0)
        plain = ProgressLines() if lines and not err_console.is_terminal else None

        def report(fraction: float, message: str) -> None:
            bar.update(task, completed=fraction, description=message)
            if plain is not None:
                plain(fraction, message)

        yield report
