"""The JSON twins of the ``vergence`` commands: ``POST /api/<command>`` answers what ``--json`` prints.

A twin is built from the command's own definition (its Typer/Click parameters): one JSON field per
option, named as the option in snake_case (``--viewing-distance`` -> ``viewing_distance``), a list
for a repeatable option, a boolean for a flag, with the option's help as the field's description
in the OpenAPI schema. A request becomes the command line (``--option=value`` ... ``--json``), run
in this process by :func:`vergence.cli.main`; the answer is its standard output, unchanged, or its
one-line error. No algorithm lives here: the command does the work, and its checks are the twin's.

Only commands whose every input is a value get a twin here: a file option (an image, a camera
file) would let a client name a path on the server, so those commands wait for the layer that
takes uploads and data ids. Output files (``--out``, ``--plot``) are never exposed.
"""

from __future__ import annotations

import enum
import io
import re
import threading
from collections.abc import Sequence
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import pydantic

__all__ = ["OUTPUT_OPTIONS", "Twin", "TwinError", "build_twins", "command_params", "twin_names"]

# Options that write files on the server: never exposed by a twin (the answer is the JSON).
OUTPUT_OPTIONS = frozenset({"--out", "--plot", "--json-out", "--error-image", "--preview", "--confidence"})

# The option every twin adds: the command prints its JSON on stdout.
_JSON_OPTION = "--json"

# The CLI writes to sys.stdout and sys.stderr (Rich consoles resolve them at each print): one
# command line at a time in this process.
_RUN_LOCK = threading.Lock()

_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


class TwinError(Exception):
    """A command line the command refused: its one-line message and the exit code."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.message = message
        self.code = code


@dataclass(frozen=True, slots=True)
class _Field:
    """One JSON field of a twin and the option it stands for."""

    name: str  # snake_case JSON name
    option: str  # the long option, e.g. "--viewing-distance"
    negative: str | None  # the "--no-..." form of a flag, if it has one
    kind: str  # "value", "list" or "flag"


@dataclass(frozen=True, slots=True)
class Twin:
    """The JSON twin of one command: its request model and how a request becomes a command line.

    Attributes
    ----------
    name : str
        The command, as typed after ``vergence`` (``"budget"``).
    summary : str
        The command's one-line summary (the OpenAPI operation's summary).
    model : type[pydantic.BaseModel]
        The request body: one field per exposed option, unknown fields refused.
    """

    name: str
    summary: str
    model: type[pydantic.BaseModel]
    fields: tuple[_Field, ...]

    def argv(self, request: pydantic.BaseModel) -> list[str]:
        """The command line of a validated request: ``[name, --option=value, ..., --json]``."""
        args = [self.name]
        values = request.model_dump()
        for f in self.fields:
            value = values[f.name]
            if value is None:
                continue
            if f.kind == "flag":
                if value:
                    args.append(f.option)
                elif f.negative is not None:
                    args.append(f.negative)
            elif f.kind == "list":
                args += [f"{f.option}={_text(v)}" for v in value]
            else:
                args.append(f"{f.option}={_text(value)}")
        return [*args, _JSON_OPTION]

    def run(self, request: pydantic.BaseModel) -> str:
        """Run the command for ``request`` and return the JSON it printed (text, as printed).

        Raises
        ------
        TwinError
            With the command's one-line error (``error: `` removed) and its exit code when it
            fails, or when what it printed is not one JSON document.
        """
        import json

        from vergence.cli import main

        out, err = io.StringIO(), io.StringIO()
        with _RUN_LOCK, redirect_stdout(out), redirect_stderr(err):
            code = main(self.argv(request))
        if code != 0:
            raise TwinError(_error_line(err.getvalue(), code), code)
        text = out.getvalue()
        try:
            json.loads(text)
        except ValueError:
            raise TwinError(f"vergence {self.name} --json printed no JSON document", 1) from None
        return text


def _text(value: object) -> str:
    """A validated value as the command line spells it (``repr`` keeps every digit of a float)."""
    if isinstance(value, enum.Enum):  # a choice: the command line takes its value
        value = value.value
    return repr(value) if isinstance(value, float) else str(value)


def _error_line(stderr: str, code: int) -> str:
    """The command's error line, without the ``error: `` prefix (warnings before it are dropped)."""
    lines = [_ANSI.sub("", ln).strip() for ln in stderr.splitlines() if ln.strip()]
    errors = [ln.removeprefix("error:").strip() for ln in lines if ln.startswith("error:")]
    if errors:
        return errors[-1]
    return lines[-1] if lines else f"the command failed with exit code {code}"


def _not_a_bool(value: object) -> object:
    """Refuse ``true``/``false`` for a number (pydantic would read them as 1 and 0)."""
    if isinstance(value, bool):
        raise ValueError("expected a number")
    return value


def _checked(annotation: Any) -> Any:
    """A number type that refuses booleans; other types as they are."""
    if annotation in (int, float):
        return Annotated[annotation, pydantic.BeforeValidator(_not_a_bool)]
    return annotation


def _field_name(option: str) -> str:
    return option.lstrip("-").replace("-", "_")


def command_params(command: Any) -> list[Any]:
    """The Click parameters of a built command that carry a value: no ``--help``, no eager option
    that acts and exits (``--install-completion``)."""
    return [p for p in command.params if p.name != "help" and p.expose_value and not p.is_eager]


def _annotation(param: Any) -> Any:
    """The Python type of a parameter's value, as the command declares it."""
    descriptor = getattr(param, "type_descriptor", None)
    if descriptor is not None:
        return descriptor.annotation
    return {"FLOAT": float, "INT": int, "BOOL": bool, "STRING": str}.get(str(param.type), str)


def _is_path(annotation: Any) -> bool:
    if annotation is Path:
        return True
    return any(a is Path for a in getattr(annotation, "__args__", ()))


def _long_option(param: Any) -> str:
    longs = [o for o in param.opts if o.startswith("--")]
    return max(longs, key=len) if longs else param.opts[0]


def _twin_of(name: str, command: Any) -> Twin | None:
    """The twin of a command, or None when it has none (no ``--json``, or it reads files)."""
    params = command_params(command)
    if not any(p.param_type_name == "option" and _JSON_OPTION in p.opts for p in params):
        return None
    definitions: dict[str, Any] = {}
    fields = []
    for p in params:
        annotation = _annotation(p)
        if p.param_type_name != "option":
            return None  # an argument: a file (IMAGE, SCENE): needs the upload / data-id layer
        option = _long_option(p)
        if option == _JSON_OPTION:
            continue
        if option in OUTPUT_OPTIONS:
            if p.required:
                return None  # writes files by design: not a twin
            continue
        if _is_path(annotation) or p.nargs != 1:
            return None  # an input file: needs the upload / data-id layer
        field = _field_name(option)
        if p.is_flag:
            kind, annotation = "flag", bool
            default: Any = bool(p.default)
        elif p.multiple:
            kind = "list"
            annotation = list[_checked(getattr(annotation, "__args__", (str,))[0])]
            default = ... if p.required else None
            annotation = annotation if default is ... else annotation | None
        else:
            kind = "value"
            annotation = _checked(annotation)
            default = ... if p.required else p.default
            annotation = annotation if default is ... else annotation | None
        help_text = " ".join((p.help or "").split()) + f" Command line: {option}."
        definitions[field] = (annotation, pydantic.Field(default, description=help_text.strip()))
        negative = next((o for o in getattr(p, "secondary_opts", []) if o.startswith("--")), None)
        fields.append(_Field(field, option, negative, kind))
    model = pydantic.create_model(  # type: ignore[call-overload]
        "".join(part.capitalize() for part in re.split(r"[-_ ]", name)) + "Options",
        __config__=pydantic.ConfigDict(extra="forbid"),
        __doc__=(f"The options of `vergence {name}`, as JSON fields (snake_case option names, a list for a "
                 f"repeatable option, true/false for a flag). JSON has no infinity: send \"inf\" as text."),
        **definitions,
    )
    summary = " ".join((command.help or command.short_help or "").split())
    return Twin(name=name, summary=summary, model=model, fields=tuple(fields))


def _group() -> tuple[Any, Any]:
    """The ``vergence`` Click group and a context to look commands up in."""
    from typer.main import get_command

    from vergence.cli import app

    group = get_command(app)
    return group, group.context_class(group, info_name="vergence")


def build_twins(names: Sequence[str] | None = None) -> dict[str, Twin]:
    """The twins of the ``vergence`` commands (those of ``names``, or every command of
    :data:`vergence.cli.COMMANDS`), keyed by command name; commands without one are left out.

    Loading a command imports its module (as ``vergence <command> --help`` does).
    """
    from vergence.cli import COMMANDS

    group, ctx = _group()
    twins = {}
    for name in COMMANDS if names is None else names:
        command = group.get_command(ctx, name)
        if command is None:
            raise ValueError(f"unknown command {name!r}; valid commands: {', '.join(COMMANDS)}")
        if hasattr(command, "commands"):
            continue  # a group of subcommands (`vergence rig plan`): each reads a file
        twin = _twin_of(name, command)
        if twin is not None:
            twins[name] = twin
    return twins


def twin_names() -> list[str]:
    """The commands that print ``--json`` (their own or a subcommand's), twinned or not."""
    from vergence.cli import COMMANDS

    group, ctx = _group()
    names = []
    for name in COMMANDS:
        command = group.get_command(ctx, name)
        commands = list(command.commands.values()) if hasattr(command, "commands") else [command]
        if any(_JSON_OPTION in p.opts for c in commands for p in command_params(c)):
            names.append(name)
    return names
