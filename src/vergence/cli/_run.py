"""Run the ``vergence`` group and turn what it raises into one line on stderr and an exit code.

A ``ValueError``/``TypeError``/``OSError`` from the library, or a usage error, is a user mistake:
one line, exit code 2. Anything else is a bug of ours: one line, exit code 1.
"""

from __future__ import annotations

import os

import typer
from rich.markup import escape

from vergence.cli import EXIT_INTERRUPTED, sigint_seen
from vergence.cli._app import app, console, err_console

__all__ = ["run"]

# Exit status of a user mistake (bad option, bad input file), as click and argparse use.
EXIT_USAGE = 2
# Exit status of a bug of ours.
EXIT_INTERNAL = 1


def run(argv: list[str] | None) -> int:
    """Run the command line ``argv`` (``sys.argv[1:]`` when None) and return its exit code."""
    try:
        result = app(args=argv, prog_name="vergence", standalone_mode=False)
    except Exception as exc:
        if sigint_seen():
            return EXIT_INTERRUPTED
        return _report(exc)
    return int(result) if isinstance(result, int) else 0


def _report(exc: Exception) -> int:
    """Print ``exc`` as one line on stderr and return the exit code it deserves."""
    if isinstance(exc, typer.Exit):
        return int(exc.exit_code)
    if isinstance(exc, typer.Abort):
        return EXIT_INTERRUPTED
    if isinstance(exc, typer.TyperException):  # click's usage errors (bad option, wrong type, missing value)
        if type(exc).__name__ == "NoArgsIsHelpError":
            console.print(exc.format_message())  # type: ignore[attr-defined]
            return 0
        message = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        one_line_error(message)
        return int(getattr(exc, "exit_code", EXIT_USAGE) or EXIT_USAGE)
    if isinstance(exc, ValueError | TypeError | OSError):
        one_line_error(str(exc) or type(exc).__name__)
        return EXIT_USAGE
    if os.environ.get("VERGENCE_DEBUG"):
        raise exc
    one_line_error(f"internal error, please report it (VERGENCE_DEBUG=1 shows the traceback): "
                   f"{type(exc).__name__}: {exc}")
    return EXIT_INTERNAL


def one_line_error(message: str) -> None:
    """Print ``error: message`` on stderr, its whitespace folded onto one line."""
    line = " ".join(message.split())
    err_console.print(f"[bold red]error:[/] {escape(line)}", highlight=False, soft_wrap=True)
