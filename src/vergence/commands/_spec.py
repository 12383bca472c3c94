"""What a command is, once for every face: its parameters, its work, and the errors that name them.

A :class:`Command` is one ``vergence`` command's work as a library function (``run(**values)``
returning a result with ``to_dict()``) and the :class:`Parameter` table it takes. The command line
(``vergence.cli``) spells a parameter as its option (``--viewing-distance``), the workbench's JSON
API (``vergence.web``) as its field (``viewing_distance``); both are made from this table, and
neither face imports the other.

A refusal names the parameter at fault in the caller's language: the work raises
:class:`ParameterError` with ``{name}`` fields in its message, and each face spells them
(:meth:`ParameterError.spelled`); ``str()`` of the error spells them as the parameter names.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

__all__ = ["KINDS", "MAX_LIST_ITEMS", "REQUIRED", "Command", "Parameter", "ParameterError", "literal", "naming",
           "to_json"]

#: The default of a parameter that has none: the caller must give it.
REQUIRED: Any = ...

#: Most values a repeatable parameter takes (``--depth`` ... or a JSON list): a budget of 1,000 depths
#: answers in about 0.2 s; 100,000 took 23 s and is a denial of service, not a request.
MAX_LIST_ITEMS = 1000

#: The kinds of parameter and the Python type of one value. ``file``: a path the work reads (the
#: web's field holds an id the server resolves); ``output``: a path the work writes (the web gives a
#: temporary one and exposes no field); ``*s``: repeatable.
KINDS: dict[str, type] = {"number": float, "integer": int, "text": str, "flag": bool, "file": str,
                          "output": str, "numbers": float, "integers": int, "texts": str}


@dataclass(frozen=True, slots=True)
class Parameter:
    """One parameter of a command.

    Attributes
    ----------
    name : str
        The work's keyword and the JSON field (snake_case).
    kind : str
        One of :data:`KINDS`.
    help : str
        One or two sentences, shown by ``--help`` and in the OpenAPI schema.
    default : object
        :data:`REQUIRED` when the caller must give it; a list parameter's default is None.
    option : str or None
        The command line's spelling: ``--name-with-dashes`` unless given; ``""`` for an argument.
    metavar : str
        An argument's name on the command line (``LEFT``); by default the name in capitals.
    web : bool
        Whether the workbench's JSON API has a field for it. False for what no upload or data id can
        stand for (a folder, a text side file): the work then takes the default.
    """

    name: str
    kind: str
    help: str
    default: Any = REQUIRED
    option: str | None = None
    metavar: str = ""
    web: bool = True

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"parameter {self.name}: kind must be one of {', '.join(KINDS)}; got {self.kind!r}")

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    @property
    def repeatable(self) -> bool:
        return self.kind in ("numbers", "integers", "texts")

    @property
    def is_argument(self) -> bool:
        return self.option == ""

    @property
    def cli(self) -> str:
        """The parameter as the command line spells it: ``--viewing-distance`` or ``IMAGE``."""
        if self.is_argument:
            return self.metavar or self.name.upper()
        return self.option or "--" + self.name.replace("_", "-")


class ParameterError(ValueError):
    """A refused value whose message names parameters as ``{name}`` fields, spelled by each face.

    Parameters
    ----------
    template : str
        The message with ``{name}`` for each parameter it names (``"{far} must be > {near} 90; got 80"``);
        a literal brace is doubled.
    """

    def __init__(self, template: str) -> None:
        self.template = template
        super().__init__(self.spelled(lambda name: name))

    def spelled(self, spell: Callable[[str], str]) -> str:
        """The message with each ``{name}`` spelled by ``spell(name)``."""
        return self.template.format_map(_Spelling(spell))


class _Spelling(dict):  # type: ignore[type-arg]
    def __init__(self, spell: Callable[[str], str]) -> None:
        super().__init__()
        self.spell = spell

    def __missing__(self, key: str) -> str:
        return self.spell(key)


def literal(text: object) -> str:
    """``str(text)`` inside a :class:`ParameterError` template: its braces doubled."""
    return str(text).replace("{", "{{").replace("}", "}}")


@contextmanager
def naming(**names: str) -> Iterator[None]:
    """Let an error of the library below name the parameter the caller gave, not the argument behind it.

    The library's messages begin with the argument at fault (``"distance must be > 0"``). Inside
    ``with naming(distance="viewing_distance"):`` such a ``ValueError`` or ``TypeError`` becomes a
    :class:`ParameterError` (a ``ValueError``) whose leading name is the parameter
    (``"{viewing_distance} must be > 0"``). A :class:`ParameterError` and any other error pass unchanged.
    """
    try:
        yield
    except ParameterError:
        raise
    except (ValueError, TypeError) as exc:
        message = str(exc)
        for argument, parameter in names.items():
            if message.startswith(argument) and message[len(argument):len(argument) + 1] in (" ", ":", "="):
                raise ParameterError("{" + parameter + "}" + literal(message[len(argument):])) from exc
        raise


@dataclass(frozen=True, slots=True)
class Command:
    """A command's work and its parameters.

    Attributes
    ----------
    name : str
        As typed after ``vergence`` (``"budget"``, ``"rig plan"``).
    summary : str
        One line (``vergence --help``, the OpenAPI operation).
    parameters : tuple of Parameter
        In the order the command line lists them.
    work : callable
        ``work(**values)``: every parameter by name; returns a result with ``to_dict()``.
    hooks : tuple of str
        Keywords the work also takes that are no parameter: callables of the face, such as
        ``progress(fraction, message)`` or ``before_commit()`` (the CLI raises there after Ctrl-C,
        so that no output is committed). A face that gives none gets the work's defaults.
    """

    name: str
    summary: str
    parameters: tuple[Parameter, ...]
    work: Callable[..., Any] = field(repr=False)
    hooks: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise ValueError(f"command {self.name}: two parameters share a name: {names}")

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(f"vergence {self.name} has no parameter {name!r}")

    @property
    def cli_names(self) -> Mapping[str, str]:
        """Each parameter's name -> its command-line spelling."""
        return {p.name: p.cli for p in self.parameters}

    def run(self, **values: Any) -> Any:
        """The work for ``values`` (missing optional parameters take their defaults).

        Raises
        ------
        ParameterError
            A value the work refuses (or an unknown or missing parameter, a list over
            :data:`MAX_LIST_ITEMS` values), naming the parameter as ``{name}``.
        """
        known = {p.name: p for p in self.parameters}
        hooks = {k: values.pop(k) for k in list(values) if k in self.hooks and k not in known}
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ParameterError(f"unknown parameter {literal(unknown[0])!r}; valid: "
                                 f"{literal(', '.join(known))}")
        given = {}
        for p in self.parameters:
            value = values.get(p.name, None if p.required else p.default)
            if value is None and p.required:
                raise ParameterError("missing {" + p.name + "}")
            if p.kind in ("text", "texts", "file") and value is not None and "" in (
                    value if p.repeatable else [value]):
                raise ParameterError("{" + p.name + "}: must not be empty")
            if p.repeatable and value is not None:
                value = list(value)
                if len(value) > MAX_LIST_ITEMS:
                    raise ParameterError("{" + p.name + "}" + f" takes at most {MAX_LIST_ITEMS} values "
                                         f"(MAX_LIST_ITEMS); got {len(value)}")
            given[p.name] = value
        return self.work(**given, **hooks)


def to_json(data: Any) -> str:
    """``data`` as the JSON text every face prints (indent 2, a newline at the end, no NaN or infinity).

    Raises
    ------
    ValueError
        If ``data`` holds a NaN or an infinity (a result's ``to_dict`` spells them).
    """
    return json.dumps(data, indent=2, allow_nan=False) + "\n"

