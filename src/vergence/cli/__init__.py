"""``vergence`` command line: each command lives in its own module and registers on ``app``."""

from __future__ import annotations

import os
import sys
from collections.abc import MutableMapping

import typer
from rich.markup import escape

from vergence.cli._app import app, console, err_console

# Command modules register themselves on import (one per line, keep sorted).
from vergence.cli import budget as _budget  # noqa: E402,F401
from vergence.cli import compare as _compare  # noqa: E402,F401
from vergence.cli import demo as _demo  # noqa: E402,F401
from vergence.cli import evaluate_disparity as _evaluate_disparity  # noqa: E402,F401
from vergence.cli import interpolate as _interpolate  # noqa: E402,F401
from vergence.cli import mapping as _mapping  # noqa: E402,F401
from vergence.cli import match as _match  # noqa: E402,F401
from vergence.cli import rectify as _rectify  # noqa: E402,F401
from vergence.cli import render as _render  # noqa: E402,F401
from vergence.cli import synthesize as _synthesize  # noqa: E402,F401

__all__ = ["app", "main"]


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code.

    Library errors (``ValueError``, ``TypeError``, ``OSError``) and command-line usage errors become
    one line on stderr and exit code 2; any other exception is a bug of ours: one line and exit code 1
    (set ``VERGENCE_DEBUG=1`` for the traceback). ``KeyboardInterrupt`` is left alone.
    """
    try:
        result = app(args=argv, standalone_mode=False)
    except typer.Exit as exc:
        return int(exc.exit_code)
    except typer.Abort:
        err_console.print("[bold red]error:[/] aborted", highlight=False)
        return 130
    except typer.TyperException as exc:  # click's usage errors (bad option, wrong type, missing value)
        if type(exc).__name__ == "NoArgsIsHelpError":
            console.print(exc.format_message())  # type: ignore[attr-defined]
            return 0
        message = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        _one_line_error(message)
        return int(getattr(exc, "exit_code", 2) or 2)
    except (ValueError, TypeError, OSError) as exc:
        _one_line_error(str(exc) or type(exc).__name__)
        return 2
    except Exception as exc:  # a bug of ours, not a user mistake: still one line, exit code 1
        if os.environ.get("VERGENCE_DEBUG"):
            raise
        _one_line_error(f"internal error, please report it (VERGENCE_DEBUG=1 shows the traceback): "
                        f"{type(exc).__name__}: {exc}")
        return 1
    return int(result) if isinstance(result, int) else 0


def _one_line_error(message: str) -> None:
    line = " ".join(message.split())
    err_console.print(f"[bold red]error:[/] {escape(line)}", highlight=False, soft_wrap=True)


def _prefer_passive_omp_wait(environ: MutableMapping[str, str]) -> None:
    """Let OpenMP threads sleep rather than spin while they wait, unless the user chose a policy.

    Numba reads ``OMP_WAIT_POLICY`` when its threading layer starts (the first parallel kernel), so
    the console script sets it before running a command. Spinning threads steal shared cores
    (measured: ``forward_warp`` 3.3x slower than with passive waiting under a load average of 5 on 2
    cores). The library itself never touches the environment of the program that imports it.
    """
    environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def _entry() -> None:  # pragma: no cover - console script shim
    _prefer_passive_omp_wait(os.environ)
    sys.exit(main())
