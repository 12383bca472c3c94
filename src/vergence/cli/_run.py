"""Run the ``vergence`` group and turn what it raises into one line on stderr and an exit code.

A ``ValueError``/``TypeError``/``OSError`` from the library, or a usage error, is a user mistake:
one line naming the option or file, exit code 2. Anything else is a bug of ours: one line, exit
code 1. Messages speak the user's language: the option as typed (``--seed: must be >= 0 (got
-1)``), the file the user named (never our hidden temporary name), the reason in words (never an
errno). Python warnings and ``vergence`` log records raised while a command runs print as one
``warning: ...`` line each.
"""

from __future__ import annotations

import logging
import os
import re
import warnings

import typer
from rich.markup import escape
from typer._click.exceptions import BadOptionUsage, BadParameter, MissingParameter, NoSuchOption, UsageError

from vergence.cli import EXIT_INTERRUPTED, sigint_seen
from vergence.cli._app import app, console, err_console

__all__ = ["EXIT_INTERNAL", "EXIT_USAGE", "one_line_error", "run", "usage_message"]

# Exit status of a user mistake (bad option, bad input file), as click and argparse use.
EXIT_USAGE = 2
# Exit status of a bug of ours.
EXIT_INTERNAL = 1


def run(argv: list[str] | None) -> int:
    """Run the command line ``argv`` (``sys.argv[1:]`` when None) and return its exit code."""
    log = logging.getLogger("vergence")
    handler = _WarningLines(logging.WARNING)
    log.addHandler(handler)  # Python's last-resort handler would print the bare message
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning  # restored when the block ends
            try:
                result = app(args=argv, prog_name="vergence", standalone_mode=False)
            except Exception as exc:
                if sigint_seen():
                    return EXIT_INTERRUPTED
                return _report(exc)
    finally:
        log.removeHandler(handler)
    return int(result) if isinstance(result, int) else 0


def _warning_line(message: object) -> None:
    err_console.print(f"[yellow]warning:[/] {escape(' '.join(str(message).split()))}", highlight=False,
                      soft_wrap=True)


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: object = None, line: str | None = None) -> None:
    """``warnings.showwarning`` for the CLI: ``warning: <message>``, one line, no source line."""
    _warning_line(message)


class _WarningLines(logging.Handler):
    """Log records of the ``vergence`` loggers as ``warning: <message>`` lines, like Python warnings."""

    def emit(self, record: logging.LogRecord) -> None:
        _warning_line(record.getMessage())


def _report(exc: Exception) -> int:
    """Print ``exc`` as one line on stderr and return the exit code it deserves."""
    if isinstance(exc, typer.Exit):
        return int(exc.exit_code)
    if isinstance(exc, typer.Abort):
        return EXIT_INTERRUPTED
    if isinstance(exc, UsageError):  # click's usage errors (bad option, wrong type, missing value)
        if type(exc).__name__ == "NoArgsIsHelpError":
            console.print(exc.format_message())
            return 0
        one_line_error(usage_message(exc))
        return EXIT_USAGE
    if isinstance(exc, typer.TyperException):
        one_line_error(exc.format_message() if hasattr(exc, "format_message") else str(exc))
        return int(getattr(exc, "exit_code", EXIT_USAGE) or EXIT_USAGE)
    if isinstance(exc, OSError):
        from vergence.io.atomic import describe_os_error  # loads vergence.io: only when a file failed

        one_line_error(describe_os_error(exc))
        return EXIT_USAGE
    if isinstance(exc, ValueError | TypeError):
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


def _param_name(param: object) -> str:
    """The parameter as the user typed it: ``--seed`` for an option, ``IMAGE`` for an argument."""
    opts = [o for o in getattr(param, "opts", []) if o.startswith("--")]
    if getattr(param, "param_type_name", "") == "option" and opts:
        return max(opts, key=len)
    return str(getattr(param, "display_name_raw", None) or getattr(param, "name", "?")).upper()


# Typer checks option values with pydantic; its error types, in the words of a command line.
_CHECKS = {
    "greater_than_equal": ("ge", "must be >= {}"),
    "greater_than": ("gt", "must be > {}"),
    "less_than_equal": ("le", "must be <= {}"),
    "less_than": ("lt", "must be < {}"),
}
_PARSING = {
    "float_parsing": "expected a number",
    "float_type": "expected a number",
    "int_parsing": "expected a whole number",
    "int_type": "expected a whole number",
    "int_from_float": "expected a whole number",
    "bool_parsing": "expected true or false",
}


def _reason(exc: BadParameter) -> str:
    """The reason of a bad value, without the parser's wording (``Input should be ...``)."""
    cause = exc.__cause__
    errors = cause.errors() if cause is not None and hasattr(cause, "errors") else []
    if not errors:
        return exc.message
    e = errors[0]
    given = e.get("input")
    if e["type"] in _CHECKS:
        key, text = _CHECKS[e["type"]]
        return f"{text.format(e.get('ctx', {}).get(key))} (got {given})"
    if e["type"] in _PARSING:
        return f"{_PARSING[e['type']]} (got {given!r})"
    msg = str(e.get("msg", exc.message)).removeprefix("Input should be ").removeprefix("Value error, ")
    return f"{msg} (got {given!r})"


def usage_message(exc: UsageError) -> str:
    """A click usage error as one line that begins with the option or argument at fault."""
    param = getattr(exc, "param", None)
    if isinstance(exc, MissingParameter) and param is not None:
        if getattr(param, "param_type_name", "") == "argument" and exc.ctx is not None:
            usage = " ".join(exc.ctx.get_usage().split()).removeprefix("Usage: ")
            return f"missing argument {_param_name(param)} (usage: {usage})"
        return f"missing option {_param_name(param)}"
    if isinstance(exc, BadParameter) and param is not None:
        return f"{_param_name(param)}: {_reason(exc)}"
    if isinstance(exc, BadOptionUsage) and re.fullmatch(r"Option '.*' requires an argument\.", exc.message):
        return f"{exc.option_name}: needs a value"
    command = exc.ctx.command_path if exc.ctx is not None else "vergence"
    if isinstance(exc, NoSuchOption):
        close = f"did you mean {' or '.join(sorted(exc.possibilities))}? " if exc.possibilities else ""
        return f"no such option {exc.option_name} ({close}{command} --help lists the options)"
    extra = re.fullmatch(r"Got unexpected extra argument\(s\) \((.*)\)", exc.message)
    if extra is not None and exc.ctx is not None:
        usage = " ".join(exc.ctx.get_usage().split()).removeprefix("Usage: ")
        plural = "s" if len(extra[1].split()) > 1 else ""
        return f"unexpected argument{plural} {extra[1]} (usage: {usage})"
    return exc.format_message()
