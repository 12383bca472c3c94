"""The Typer application and the shared helpers of every ``vergence`` command.

Commands parse arguments, call one public function, write output atomically and show progress.
A ``ValueError``/``TypeError``/``OSError`` from the library is a user mistake: one line on stderr
and exit code 2, never a traceback (``vergence.cli._run``).
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console

from vergence.cli._group import app
from vergence.commands._spec import Command, ParameterError, to_json

if TYPE_CHECKING:
    from vergence.render import Scene
    from vergence.viewing.geometry import Display

console = Console(soft_wrap=True)
err_console = Console(stderr=True)


def print_json(data: object) -> None:
    """Print ``data`` as JSON on stdout (no Rich markup, machine-readable): :func:`vergence.commands.to_json`,
    the text the workbench answers."""
    sys.stdout.write(to_json(data))
    sys.stdout.flush()


@contextmanager
def options_named(**names: str) -> Iterator[None]:
    """Let a library error name the option the user typed, not the Python parameter behind it.

    The library's messages begin with the name of the argument at fault ("distance must be > 0").
    Inside ``with options_named(distance="--viewing-distance"):`` such a ``ValueError`` or
    ``TypeError`` is raised again, same type, with that leading name replaced by the option
    ("--viewing-distance must be > 0"). Other errors pass unchanged.
    """
    try:
        yield
    except (ValueError, TypeError) as exc:
        message = str(exc)
        for param, option in names.items():
            if message.startswith(param) and message[len(param):len(param) + 1] in (" ", ":", "="):
                raise type(exc)(option + message[len(param):]) from exc
        raise


def check_output_path(out: Path, *inputs: Path) -> None:
    """Refuse to write ``out`` over one of the ``inputs``: :func:`vergence.io.atomic.check_output_path`."""
    from vergence.io.atomic import check_output_path as check  # Pillow loads with vergence.io: not for --help

    check(out, *inputs)


# Moved to the library (vergence.commands.synthesize); read from there when asked for here (``convert``
# still does), so that ``vergence --help`` does not load the synthesis.
_MOVED_TO_SYNTHESIZE = ("SYNTHESIS_BUDGET_ARCMIN", "SYNTHESIS_DISPLAY", "layout_file_name")


def __getattr__(name: str) -> Any:
    if name in _MOVED_TO_SYNTHESIZE:
        from vergence.commands import synthesize

        return getattr(synthesize, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _cli_spelling(name: str) -> str:
    """A parameter the work names as ``{name}``, as a command line spells it: ``--name-with-dashes``."""
    return "--" + name.replace("_", "-")


def spoken(exc: ParameterError, command: Command | None = None) -> ValueError:
    """A :class:`~vergence.commands.ParameterError` in the command line's words (``--viewing-distance``)."""
    names = {} if command is None else command.cli_names
    return ValueError(exc.spelled(lambda name: names.get(name) or _cli_spelling(name)))


def option(command: Command, name: str, **extra: Any) -> Any:
    """The Typer option (or argument) of a parameter of ``command``: its spelling, default and help
    come from the library's table (:mod:`vergence.commands`); ``extra`` goes to Typer as is."""
    p = command.parameter(name)
    default = ... if p.required else p.default
    help_text = ParameterError(p.help).spelled(lambda n: command.cli_names.get(n) or _cli_spelling(n))
    if p.is_argument:
        return typer.Argument(default, help=help_text, metavar=p.cli, **extra)
    return typer.Option(default, p.cli, help=help_text, **extra)


def run_command(command: Command, **values: Any) -> Any:
    """``command.run(**values)``, its refusals naming the options as typed."""
    try:
        return command.run(**values)
    except ParameterError as exc:
        raise spoken(exc, command) from exc


def preset_display(name: str) -> Display:
    """The display of ``--display NAME``; an unknown name is refused with the option leading."""
    from vergence.viewing.geometry import Display  # SciPy loads with vergence.viewing: not for --help

    try:
        return Display.preset(name)
    except ValueError as exc:  # the library's message names no argument
        raise ValueError(f"--display: {exc}") from exc


def display_from_options(
    preset: str | None,
    eye_separation: float | None,
    distance: float | None,
    width: float | None,
    pixels: int | None = None,
) -> Display:
    """The display from ``--display PRESET`` or from the three lengths (exactly one of the two):
    :func:`vergence.commands.display_from`, its refusals naming the options."""
    from vergence.commands._display import display_from  # SciPy loads with vergence.viewing: not for --help

    try:
        return display_from(preset, eye_separation, distance, width, pixels)
    except ParameterError as exc:
        raise spoken(exc) from exc


def _drop(record: logging.LogRecord) -> bool:
    """A logging filter that lets nothing through."""
    return False


def open_scene_quietly(spec: str, width: int | None, height: int | None) -> Scene:
    """:func:`vergence.render.open_scene` without the library's log record of the scene's environment
    note (a missing HDR map): the command prints the note once, after every option has been checked,
    so that a refusal stays one line."""
    from vergence.render import open_scene

    quiet = logging.getLogger("vergence.render")
    quiet.addFilter(_drop)
    try:
        return open_scene(spec, width=width, height=height)
    finally:
        quiet.removeFilter(_drop)
