"""The command line's options are the library's parameter tables (vergence.commands, issue 29): each
parameter of a command that prints --json is one option (or argument) of that command, spelled,
typed, repeatable, required and defaulted as the table says, so the CLI and the web's JSON fields
cannot drift apart."""

from __future__ import annotations

import enum
import typing
from pathlib import Path

import pytest
from typer.main import get_command

from vergence.cli import app
from vergence.commands import COMMANDS, command

# The Python type of one value of each kind of parameter, as the command's signature declares it.
VALUE_TYPES = {"number": float, "numbers": float, "integer": int, "integers": int, "text": str, "texts": str,
               "flag": bool, "file": Path, "output": Path}


def _value_type(annotation: object) -> object:
    """``float`` of ``float``, ``float | None``, ``list[float]`` and ``list[float] | None``; an enum as ``str``."""
    while typing.get_args(annotation):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        annotation = args[0]
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return str
    return annotation


def _click_command(name: str):  # noqa: ANN202 - a click command
    group = get_command(app)
    ctx = group.context_class(group, info_name="vergence")
    found = group
    for part in name.split():
        found = found.get_command(ctx, part)
    return found


def _check(table, name: str) -> None:  # noqa: ANN001 - a vergence.commands.Command
    params = _click_command(name).params
    by_option = {opt: q for q in params if q.param_type_name == "option" for opt in q.opts}
    by_argument = {(q.metavar or q.name.upper()): q for q in params if q.param_type_name == "argument"}
    for p in table.parameters:
        option = (by_argument if p.is_argument else by_option).get(p.cli)
        assert option is not None, f"vergence {name} has no {p.cli} for the library's parameter {p.name!r}"
        assert option.required == p.required, p.name
        assert bool(option.multiple) == p.repeatable, p.name
        assert _value_type(option.type_descriptor.annotation) is VALUE_TYPES[p.kind], \
            (p.name, option.type_descriptor.annotation)
        if not p.required and not p.repeatable:
            assert option.default == p.default, (p.name, option.default, p.default)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_parameter_is_the_option_the_table_says(name):
    _check(command(name), name)


def test_the_check_sees_a_drift():
    import dataclasses

    table = command("budget")
    drifted = dataclasses.replace(table, parameters=tuple(
        dataclasses.replace(p, default=2.0) if p.name == "window" else p for p in table.parameters))
    with pytest.raises(AssertionError, match="window"):
        _check(drifted, "budget")
