"""The JSON twins of the ``vergence`` commands: ``POST /api/<command>`` answers what ``--json`` prints.

A twin is built from the command's own definition (its Typer/Click parameters): one JSON field per
option, named as the option in snake_case (``--viewing-distance`` -> ``viewing_distance``), a list
for a repeatable option, a boolean for a flag, with the option's help as the field's description
in the OpenAPI schema. A request becomes the command line (``--option=value`` ... ``--json``), run
in this process by :func:`vergence.cli.main`; the answer is its standard output, or its one-line
error. No algorithm lives here: the command does the work, and its checks are the twin's.

Files: a client never names a path. An input file (an argument such as ``IMAGE``, or an option such
as ``--mask``) is a field holding an id: an upload's (``POST /api/uploads``) or a data entry's
(``GET /api/data``), which the server resolves to the file it stored or listed. A required output
(``--out``) goes to a temporary folder of the request, removed once the command has answered; the
optional ones (``--plot``, ``--preview``, ...: :data:`OUTPUT_OPTIONS`) are never exposed. The command
sees an upload under the name the page gave it (a link in the temporary folder: ``vergence rectify``
finds each image's camera by its file name). In the answer, the command's own words about these
files name them as the client knows them: an input by its id, an output by its name in the
temporary folder (``disparity.pfm``); nothing else changes.
Options that name a folder or a side file no id can stand for (:data:`UNREACHABLE_INPUTS`) are not
exposed. A subcommand's twin is ``POST /api/<group>/<command>`` (``/api/rig/plan``).
"""

from __future__ import annotations

import enum
import io
import json
import re
import tempfile
import threading
from collections.abc import Callable, Sequence
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import pydantic

__all__ = ["OUTPUT_NAMES", "OUTPUT_OPTIONS", "UNREACHABLE_INPUTS", "Resolver", "Twin", "TwinError", "build_twins",
           "command_params", "twin_names"]

# Options that write files on the server: never exposed by a twin (the answer is the JSON).
OUTPUT_OPTIONS = frozenset({"--out", "--plot", "--json-out", "--error-image", "--preview", "--confidence", "--report"})

# Input options that name a folder (--masks: Middlebury's nonocc/all/disc) or a side file (--image-list:
# Bundler's list.txt) that no upload or data id stands for: not exposed (the command's default applies).
UNREACHABLE_INPUTS = frozenset({"--masks", "--image-list"})

# The name a required output gets in the request's temporary folder, by command and option (its
# extension picks the format); any other required output is a folder named "out".
OUTPUT_NAMES = {("match", "--out"): "disparity.pfm", ("interpolate", "--out"): "view.png"}

#: Resolves an id of a request to the file it stands for, how the answer names it, and the file name the
#: command should see ("" to keep the file's own); raises ``KeyError`` (one line naming the id) for an
#: unknown id.
Resolver = Callable[[str], tuple[Path, str, str]]

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

    name: str  # snake_case JSON name ("" for an output: not a field)
    option: str | None  # the long option, e.g. "--viewing-distance"; None for an argument
    negative: str | None  # the "--no-..." form of a flag, if it has one
    kind: str  # "value", "list", "flag", "input" (an id standing for a file) or "output"
    out_name: str = ""  # an output's name in the request's temporary folder


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

    @property
    def reads_files(self) -> bool:
        """Whether a request names files (ids resolved by the server)."""
        return any(f.kind == "input" for f in self.fields)

    def argv(self, request: pydantic.BaseModel, resolve: Callable[[str], str] | None = None,
             outdir: Path | None = None) -> list[str]:  # fmt: skip
        """The command line of a validated request: ``[name, ARG..., --option=value, ..., --json]``;
        ``resolve`` turns an input's id into a path, ``outdir`` holds the required outputs."""
        args = self.name.split()
        values = request.model_dump()
        for f in self.fields:
            if f.kind == "output":
                if outdir is None:
                    raise TwinError(f"vergence {self.name} writes {f.option}: the twin needs a temporary folder", 1)
                args.append(f"{f.option}={outdir / f.out_name}")
                continue
            value = values[f.name]
            if value is None:
                continue
            if f.kind == "input":
                if resolve is None:
                    raise TwinError(f"{f.name}: vergence {self.name} reads files, and ids need the server to resolve", 1)
                path = resolve(value)
                args.append(path if f.option is None else f"{f.option}={path}")
            elif f.kind == "flag":
                if value:
                    args.append(f.option)
                elif f.negative is not None:
                    args.append(f.negative)
            elif f.kind == "list":
                args += [f"{f.option}={_text(v)}" for v in value]
            else:
                args.append(f"{f.option}={_text(value)}")
        return [*args, _JSON_OPTION]

    def run(self, request: pydantic.BaseModel, resolve: Resolver | None = None, *, tmp_root: Path | None = None) -> str:
        """Run the command for ``request`` and return the JSON it printed (text, as printed, files
        named as the module's text says). The request's temporary folder is made in ``tmp_root``
        (the system's by default) and removed before this returns.

        Raises
        ------
        KeyError
            From ``resolve``: an id that stands for no file.
        TwinError
            With the command's one-line error (``error: `` removed) and its exit code when it
            fails, or when what it printed is not one JSON document.
        """
        from vergence.cli import main

        named: dict[str, str] = {}

        def path_of(ident: str) -> str:
            path, label, name = resolve(ident)  # type: ignore[misc]  # argv checks it is given
            if name:  # the command sees the client's file name (rectify finds a camera by its image's name)
                staged = Path(tmp) / "inputs" / str(len(named)) / name
                staged.parent.mkdir(parents=True)
                staged.symlink_to(path)
                path = staged
            named[str(path)] = label
            return str(path)

        out, err = io.StringIO(), io.StringIO()
        with tempfile.TemporaryDirectory(prefix="vergence-twin-", dir=tmp_root) as tmp:
            argv = self.argv(request, None if resolve is None else path_of, Path(tmp))
            with _RUN_LOCK, redirect_stdout(out), redirect_stderr(err):
                code = main(argv)
        text, error = out.getvalue(), err.getvalue()
        # the files as the client knows them: outputs by their name in the folder, inputs by their id
        renames = [*sorted(named.items(), key=lambda kv: -len(kv[0])), (f"{tmp}/", ""), (tmp, ".")]
        for old, new in renames:
            text = text.replace(json.dumps(old)[1:-1], json.dumps(new)[1:-1])
            error = error.replace(old, new)
        if code != 0:
            raise TwinError(_error_line(error, code), code)
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
    """The twin of a command (``name`` as typed after ``vergence``, e.g. ``"rig plan"``), or None
    when it prints no ``--json``."""
    params = command_params(command)
    if not any(p.param_type_name == "option" and _JSON_OPTION in p.opts for p in params):
        return None
    definitions: dict[str, Any] = {}
    fields = []
    for p in params:
        annotation = _annotation(p)
        option = None if p.param_type_name == "argument" else _long_option(p)
        if option == _JSON_OPTION:
            continue
        if option in OUTPUT_OPTIONS or option == "--out":
            if p.required:  # written to the request's temporary folder, then removed
                fields.append(_Field("", option, None, "output", OUTPUT_NAMES.get((name, option), "out")))
            continue
        if option in UNREACHABLE_INPUTS:
            continue
        if p.nargs != 1:
            raise ValueError(f"vergence {name}: {p.name} takes {p.nargs} values; a twin has no field for it")
        field = p.name if option is None else _field_name(option)
        if field in definitions:
            raise ValueError(f"vergence {name}: two parameters are named {field!r} in JSON")
        what = f"the argument {p.metavar or p.name.upper()}" if option is None else option
        help_text = " ".join((p.help or "").split())
        if _is_path(annotation):
            kind, annotation = "input", str
            default: Any = ... if p.required else None
            annotation = annotation if default is ... else annotation | None
            help_text += (" An id standing for the file: an upload's (POST /api/uploads) or a data entry's "
                          "(GET /api/data).")
        elif p.is_flag:
            kind, annotation = "flag", bool
            default = bool(p.default)
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
        help_text += f" Command line: {what}."
        definitions[field] = (annotation, pydantic.Field(default, description=help_text.strip()))
        negative = next((o for o in getattr(p, "secondary_opts", []) if o.startswith("--")), None)
        fields.append(_Field(field, option, negative, kind))
    model = pydantic.create_model(  # type: ignore[call-overload]
        "".join(part.capitalize() for part in re.split(r"[-_ ]", name)) + "Options",
        __config__=pydantic.ConfigDict(extra="forbid"),
        __doc__=(f"The options of `vergence {name}`, as JSON fields (snake_case option names, a list for a "
                 f"repeatable option, true/false for a flag, an upload or data id for a file). JSON has no "
                 f"infinity: send \"inf\" as text."),
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
    :data:`vergence.cli.COMMANDS`), keyed by their path under ``/api/``: ``"budget"``, and
    ``"rig/plan"`` for a subcommand; commands that print no ``--json`` are left out.

    Loading a command imports its module (as ``vergence <command> --help`` does).
    """
    from vergence.cli import COMMANDS

    group, ctx = _group()
    twins = {}
    for name in COMMANDS if names is None else names:
        command = group.get_command(ctx, name)
        if command is None:
            raise ValueError(f"unknown command {name!r}; valid commands: {', '.join(COMMANDS)}")
        subcommands = command.commands.items() if hasattr(command, "commands") else [(None, command)]
        for sub, definition in subcommands:
            full = name if sub is None else f"{name} {sub}"
            twin = _twin_of(full, definition)
            if twin is not None:
                twins[full.replace(" ", "/")] = twin
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
