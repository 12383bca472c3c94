"""The Typer application and the shared helpers of every ``vergence`` command.

Commands parse arguments, call one public function, write output atomically and show progress.
A ``ValueError``/``TypeError``/``OSError`` from the library is a user mistake: one line on stderr
and exit code 2, never a traceback.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer
from rich.console import Console

app = typer.Typer(
    name="vergence",
    help="Stereoscopic 3D images that look right on a given display.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

console = Console()
err_console = Console(stderr=True)


def fail(message: str) -> typer.Exit:
    """Print ``error: message`` on stderr and return the exit (code 2) to raise."""
    err_console.print(f"[bold red]error:[/] {message}", highlight=False, soft_wrap=True)
    return typer.Exit(code=2)


def print_json(data: object) -> None:
    """Print ``data`` as JSON on stdout (no Rich markup, machine-readable)."""
    sys.stdout.write(json.dumps(data, indent=2, allow_nan=False) + "\n")
    sys.stdout.flush()


def check_output_path(out: Path, *inputs: Path) -> None:
    """Refuse to write ``out`` over one of the ``inputs``."""
    for p in inputs:
        if p is not None and Path(p).exists() and Path(out).exists() and Path(out).resolve() == Path(p).resolve():
            raise ValueError(f"output {out} would overwrite input {p}")
