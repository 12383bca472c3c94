"""The ``vergence`` command group: commands load on demand, and help reads as usage lines do.

``vergence --help`` lists the commands of :data:`vergence.cli.COMMANDS` without importing them, and
``vergence X`` imports only the module of X: Numba, SciPy, OpenCV and Mitsuba load only for the
commands that use them (measured on 2 shared cores, load 6: ``vergence --help`` 1.5-2.9 s -> 0.6-0.9 s,
``import vergence.cli`` 3.2 s -> 0.04 s).

Parameters read as in POSIX usage lines (IEEE Std 1003.1, 12.1 "Utility Argument Syntax"): a flag
shows no value type (``--json``, not ``--json <bool>``), a repeatable option its element type
(``--depth <float>``, not ``<list[float]>``), text is ``<text>`` (not Python's ``<str>``), arguments are upper-case (``IMAGE DEPTH``),
and a float default shows at most :data:`DEFAULT_DIGITS` significant digits. An empty value
(``--out ""``) is refused, naming the option.
"""

from __future__ import annotations

import copy
import difflib
import importlib
import re
from collections.abc import Sequence
from typing import Any

import typer
from typer._click.exceptions import UsageError  # Typer vendors click; this is its UsageError
from typer.core import TyperArgument, TyperCommand, TyperGroup, TyperOption
from typer.main import get_command_from_info, get_command_name, get_group_from_info

__all__ = ["DEFAULT_DIGITS", "LazyGroup", "app", "tidy_parameters"]

# Significant digits of a float default in --help: 3/255 shows as 0.0117647, enough to tell apart
# any two defaults a person would type, short enough to read (repr gives 17 digits).
DEFAULT_DIGITS = 6


def _default_text(value: object) -> str | None:
    """A float default with at most DEFAULT_DIGITS significant digits (``repr`` keeps ``10.0``)."""
    if isinstance(value, float):
        return repr(float(format(value, f".{DEFAULT_DIGITS}g")))
    return None


def _refuse_empty(param: TyperOption | TyperArgument, ctx: Any, value: object) -> None:
    """An empty string is no file name, number or choice: name the parameter as the user typed it."""
    values = value if isinstance(value, list | tuple) else [value]
    if any(isinstance(v, str) and v == "" for v in values):
        raise typer.BadParameter("must not be empty", ctx=ctx, param=param)


def _plain_type(text: str | None) -> str | None:
    """A value type in a user's words: ``<list[float]>`` (one value per use) -> ``<float>``, ``<str>`` -> ``<text>``."""
    if text is None:
        return None
    text = re.sub(r"^<list\[(.*)\]>$", r"<\1>", text)
    text = re.sub(r"^<(int|float) range>$", r"<\1>", text)  # the range itself follows: [x >= 0]
    return "<text>" if text == "<str>" else text


class _TidyOption(TyperOption):
    def display_type_rich(self, ctx: Any) -> str | None:
        return None if self.is_flag else _plain_type(super().display_type_rich(ctx))

    def _get_number_range_help_str(self) -> str | None:
        text = super()._get_number_range_help_str()
        return None if text is None else re.sub(r"\s*(<=|>=|<|>)\s*", r" \1 ", text)

    def _get_default_string(self, *, ctx: Any, show_default_is_str: bool, default_value: Any) -> str:
        text = None if show_default_is_str else _default_text(default_value)
        if text is not None:
            return text
        return super()._get_default_string(ctx=ctx, show_default_is_str=show_default_is_str,
                                           default_value=default_value)

    def process_value(self, ctx: Any, value: Any) -> Any:
        _refuse_empty(self, ctx, value)
        return super().process_value(ctx, value)


class _TidyArgument(TyperArgument):
    def display_type_rich(self, ctx: Any) -> str | None:
        return _plain_type(super().display_type_rich(ctx))

    @property
    def display_name_raw(self) -> str:
        return self.metavar if self.metavar is not None else self.name.upper()

    def _usage_display_name(self) -> str:
        name = self.display_name_raw if self.required else f"[{self.display_name_raw}]"
        return name + ("..." if self.nargs != 1 else "")

    def _get_default_string(self, *, ctx: Any, show_default_is_str: bool, default_value: Any) -> str:
        text = None if show_default_is_str else _default_text(default_value)
        if text is not None:
            return text
        return super()._get_default_string(ctx=ctx, show_default_is_str=show_default_is_str,
                                           default_value=default_value)

    def process_value(self, ctx: Any, value: Any) -> Any:
        _refuse_empty(self, ctx, value)
        return super().process_value(ctx, value)


def tidy_parameters(params: Sequence[object]) -> None:
    """Give Typer's parameters the display and checks described in the module docstring, in place.

    The objects keep their state; only their class changes, to a subclass that overrides the help
    display and refuses empty values.
    """
    for p in params:
        if type(p) is TyperOption:
            p.__class__ = _TidyOption
        elif type(p) is TyperArgument:
            p.__class__ = _TidyArgument


class _TidyCommand(TyperCommand):
    def get_params(self, ctx: Any) -> list[Any]:
        params = super().get_params(ctx)
        tidy_parameters(params)
        return params


class _TidyGroup(TyperGroup):
    """A command group's own parameters (its ``--help``) read as the commands' do."""

    def get_params(self, ctx: Any) -> list[Any]:
        params = super().get_params(ctx)
        tidy_parameters(params)
        return params


def _command_table() -> dict[str, tuple[str, str]]:
    from vergence.cli import COMMANDS

    return COMMANDS


def _load(name: str, module: str) -> TyperCommand:
    """Import ``vergence.cli.<module>`` and build the click command it registered as ``name``."""
    from vergence.cli import pause_for_test

    pause_for_test("IMPORT")
    importlib.import_module(f"vergence.cli.{module}")
    infos = [i for i in app.registered_commands
             if (i.name or get_command_name(i.callback.__name__)) == name]  # type: ignore[union-attr]
    groups = [g for g in app.registered_groups if g.name == name]
    if not infos and groups:  # a command with subcommands (`vergence rig plan`): a Typer of its own
        group = get_group_from_info(copy.copy(groups[-1]), pretty_exceptions_short=app.pretty_exceptions_short,
                                    suggest_commands=True, rich_markup_mode=app.rich_markup_mode)  # fmt: skip
        for sub in group.commands.values():  # the subcommands read as the others do
            if type(sub) is TyperCommand:
                sub.__class__ = _TidyCommand
        if type(group) is TyperGroup:
            group.__class__ = _TidyGroup
        return group
    if not infos:
        raise RuntimeError(f"vergence.cli.{module} registers no command or group {name!r} (see vergence.cli.COMMANDS)")
    info = copy.copy(infos[-1])
    if info.cls in (None, TyperCommand):  # Typer's default; a command's own class is left alone
        info.cls = _TidyCommand
    return get_command_from_info(info, pretty_exceptions_short=app.pretty_exceptions_short,
                                 rich_markup_mode=app.rich_markup_mode)


class LazyGroup(TyperGroup):
    """A Typer group whose commands come from ``vergence.cli.COMMANDS`` and load when first used.

    The commands Typer built from already imported modules are set aside: every command is built
    here, once per group, with the tidy parameters.
    """

    def __init__(self, *, commands: object = None, **attrs: Any) -> None:
        super().__init__(commands=None, **attrs)
        self._listing = False

    def list_commands(self, ctx: Any) -> list[str]:
        return list(_command_table())

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        table = _command_table()
        if cmd_name not in table:
            return None
        module, summary = table[cmd_name]
        if self._listing:  # the group's help: the one-line summary, no import
            return TyperCommand(cmd_name, short_help=summary)
        if cmd_name not in self.commands:
            self.commands[cmd_name] = _load(cmd_name, module)
        return self.commands[cmd_name]

    def resolve_command(self, ctx: Any, args: list[str]) -> Any:
        try:
            return self._click_resolve_command(ctx, args)
        except UsageError as exc:
            close = difflib.get_close_matches(args[0], list(_command_table())) if args else []
            if close:
                exc.message = f"{exc.message.rstrip('.')}. Did you mean {', '.join(close)}?"
            raise

    def format_help(self, ctx: Any, formatter: Any) -> None:
        self._listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False

    def get_params(self, ctx: Any) -> list[Any]:
        params = super().get_params(ctx)
        tidy_parameters(params)
        return params


# Commands register here with ``@app.command(name)``; LazyGroup imports a command's module (listed
# in vergence.cli.COMMANDS) only when that command runs or shows its help.
app = typer.Typer(
    name="vergence",
    cls=LazyGroup,
    help="Stereoscopic 3D images that look right on a given display.",
    no_args_is_help=True,
    context_settings={"help_option_names": ["-h", "--help"]},  # no command uses -h for anything else
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root() -> None:
    """The group itself: no options of its own (a callback makes Typer build a group, always)."""
