"""The JSON twins of the ``vergence`` commands: ``POST /api/<command>`` answers what ``--json`` prints.

A twin is built from the command's library definition (:mod:`vergence.commands`), the table the
command line builds its options from: one JSON field per parameter, named as the parameter
(``viewing_distance``, the option ``--viewing-distance``), a list for a repeatable one, a boolean for
a flag, with the parameter's help as the field's description in the OpenAPI schema. A request calls
the same library function the command calls (:meth:`vergence.commands.Command.run`) and answers
:func:`vergence.commands.to_json` of its result, the text ``--json`` prints. No algorithm lives
here, and nothing of the command line: calls run side by side on worker threads, at most
:data:`vergence.web._slots.MAX_CALLS` at once with the server's other computations (429 beyond).

Files: a client never names a path. An input file is a field holding an id: an upload's
(``POST /api/uploads``) or a data entry's (``GET /api/data``), which the server resolves to the file
it stored or listed. A required output goes to a temporary folder of the request, removed once the
call has answered. The work sees an upload under the name the page gave it (a link in the temporary
folder: ``rectify`` finds each image's camera by its file name). In the answer, the work's own words
about these files name them as the client knows them: an input by its id, an output by its name in
the temporary folder (``disparity.pfm``); nothing else changes. A refusal names the field at fault
(``viewing_distance must be > 0``). A subcommand's twin is ``POST /api/<group>/<command>``
(``/api/rig/plan``).
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import pydantic

from vergence.commands import KINDS, MAX_LIST_ITEMS, Command, ParameterError, to_json
from vergence.web._models import no_boolean

__all__ = ["OUTPUT_NAMES", "Resolver", "Twin", "TwinError", "build_twins", "twin_of"]

#: The name a required output gets in the request's temporary folder, by command and parameter (its
#: extension picks the format); any other required output is a folder named "out".
OUTPUT_NAMES = {("match", "out"): "disparity.pfm", ("interpolate", "out"): "view.png"}

#: Resolves an id of a request to the file it stands for, how the answer names it, and the file name the
#: work should see ("" to keep the file's own); raises ``KeyError`` (one line naming the id) for an
#: unknown id.
Resolver = Callable[[str], tuple[Path, str, str]]


class TwinError(Exception):
    """A call the work refused: its one-line message and the HTTP status (422 a bad value, 500 a bug)."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.message = message
        self.status = status


@dataclass(frozen=True, slots=True)
class Twin:
    """The JSON twin of one command: its request model and the library command it calls.

    Attributes
    ----------
    name : str
        The command, as typed after ``vergence`` (``"budget"``, ``"rig plan"``).
    command : Command
        The library's definition and work.
    model : type[pydantic.BaseModel]
        The request body: one field per parameter that is not an output, unknown fields refused.
    """

    name: str
    command: Command
    model: type[pydantic.BaseModel]

    @property
    def summary(self) -> str:
        return self.command.summary

    @property
    def reads_files(self) -> bool:
        """Whether a request names files (ids resolved by the server)."""
        return any(p.kind == "file" for p in self.command.parameters)

    def run(self, request: pydantic.BaseModel, resolve: Resolver | None = None, *, tmp_root: Path | None = None) -> str:
        """The JSON text of the work's result for ``request``, files named as the client knows them.
        The request's temporary folder is made in ``tmp_root`` (the system's by default) and removed
        before this returns.

        Raises
        ------
        KeyError
            From ``resolve``: an id that stands for no file.
        TwinError
            The work's one-line refusal (status 422), or a bug of ours (500).
        """
        with tempfile.TemporaryDirectory(prefix="vergence-twin-", dir=tmp_root) as tmp:
            named: dict[str, str] = {}
            values = self._values(request, resolve, Path(tmp), named)
            # the files as the client knows them: inputs by their id, outputs by their name in the folder
            renames = [*sorted(named.items(), key=lambda kv: -len(kv[0])), (f"{tmp}/", ""), (tmp, ".")]
            try:
                result = self.command.run(**values)
                text = to_json(result.to_dict())
            except ParameterError as exc:
                raise TwinError(_renamed(exc.spelled(str), renames), 422) from None
            except (ValueError, TypeError) as exc:
                raise TwinError(_renamed(str(exc) or type(exc).__name__, renames), 422) from None
            except OSError as exc:
                from vergence.io.atomic import describe_os_error

                raise TwinError(_renamed(describe_os_error(exc), renames), 422) from None
            except Exception as exc:  # a bug of ours: one line, as the CLI reports one
                raise TwinError(_renamed(f"internal error, please report it: {type(exc).__name__}: {exc}",
                                         renames), 500) from None
        for old, new in renames:
            text = text.replace(json.dumps(old)[1:-1], json.dumps(new)[1:-1])
        return text

    def _values(self, request: pydantic.BaseModel, resolve: Resolver | None, tmp: Path,
                named: dict[str, str]) -> dict[str, Any]:  # fmt: skip
        """The work's keyword arguments: ids resolved to paths, outputs in ``tmp``; ``named`` gets each
        path the answer must rename."""
        values = request.model_dump()
        for p in self.command.parameters:
            if p.kind == "output":
                if p.required:
                    values[p.name] = tmp / OUTPUT_NAMES.get((self.name, p.name), "out")
                continue
            if p.kind != "file" or values.get(p.name) is None:
                continue
            if resolve is None:
                raise TwinError(f"{p.name}: vergence {self.name} reads files, and ids need the server to resolve", 500)
            ident = values[p.name]
            path, label, name = resolve(ident)
            if name:  # the work sees the client's file name (rectify finds a camera by its image's name)
                staged = tmp / "inputs" / str(len(named)) / name
                staged.parent.mkdir(parents=True)
                staged.symlink_to(path)
                path = staged
            named[str(path)] = label
            values[p.name] = Path(path)
        return values


def _renamed(message: str, renames: Sequence[tuple[str, str]]) -> str:
    for old, new in renames:
        message = message.replace(old, new)
    return " ".join(message.split())


def _checked(annotation: Any) -> Any:
    """A number type that refuses booleans; other types as they are."""
    if annotation in (int, float):
        return Annotated[annotation, pydantic.BeforeValidator(no_boolean)]
    return annotation


def _described(command: Command, text: str) -> str:
    """A parameter's help with the parameters it names spelled as fields."""
    return " ".join(ParameterError(text).spelled(str).split())


def twin_of(command: Command) -> Twin:
    """The twin of a library :class:`~vergence.commands.Command`."""
    definitions: dict[str, Any] = {}
    for p in command.parameters:
        if p.kind == "output" or not p.web:
            continue  # an output goes to the request's temporary folder (when required), never a field
        annotation: Any = _checked(KINDS[p.kind])
        constraints: dict[str, Any] = {}
        help_text = _described(command, p.help)
        if p.kind == "file":
            help_text += (" An id standing for the file: an upload's (POST /api/uploads) or a data entry's "
                          "(GET /api/data).")
        if p.repeatable:
            annotation = list[annotation]
            constraints["max_length"] = MAX_LIST_ITEMS
        default: Any = ... if p.required else p.default
        if p.kind == "flag":
            default = bool(p.default)
        elif default is None:
            annotation = annotation | None
        what = f"the argument {p.cli}" if p.is_argument else p.cli
        help_text += f" Command line: {what}."
        definitions[p.name] = (annotation, pydantic.Field(default, description=help_text.strip(), **constraints))
    model = pydantic.create_model(  # type: ignore[call-overload]
        "".join(part.capitalize() for part in command.name.replace("-", " ").split()) + "Options",
        __config__=pydantic.ConfigDict(extra="forbid"),
        __doc__=(f"The parameters of `vergence {command.name}`, as JSON fields (snake_case option names, a list "
                 f"for a repeatable option, true/false for a flag, an upload or data id for a file). JSON has no "
                 f"infinity: send \"inf\" as text."),
        **definitions,
    )
    return Twin(name=command.name, command=command, model=model)


def build_twins(names: Sequence[str] | None = None) -> dict[str, Twin]:
    """The twins of the library's commands (those of ``names``, or every one of
    :data:`vergence.commands.COMMANDS`), keyed by their path under ``/api/``: ``"budget"``, and
    ``"rig/plan"`` for a subcommand.

    Raises
    ------
    ValueError
        For a name that is no command of :data:`vergence.commands.COMMANDS`.
    """
    from vergence.commands import COMMANDS, command

    twins = {}
    for name in COMMANDS if names is None else names:
        if name not in COMMANDS:
            raise ValueError(f"unknown command {name!r}; valid commands: {', '.join(COMMANDS)}")
        twins[name.replace(" ", "/")] = twin_of(command(name))
    return twins
