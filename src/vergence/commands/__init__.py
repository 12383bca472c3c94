"""The work of each ``vergence`` command, as library functions both faces call.

A :class:`Command` pairs a command's work (a function of its parameters returning a result with
``to_dict()``) with its :class:`Parameter` table. The command line (:mod:`vergence.cli`) builds its
options from the table, calls :meth:`Command.run` and prints; the workbench (:mod:`vergence.web`)
builds a JSON model from the same table, calls the same :meth:`Command.run` in a worker thread, and
answers :func:`to_json` of the result, the text ``--json`` prints. Neither face imports the other.

:data:`COMMANDS` names the commands that print ``--json``, by their name after ``vergence``; each
module loads when :func:`command` asks for it.
"""

from __future__ import annotations

import importlib

from vergence.commands._spec import KINDS, MAX_LIST_ITEMS, REQUIRED, Command, Parameter, ParameterError, naming, to_json

__all__ = ["COMMANDS", "KINDS", "MAX_LIST_ITEMS", "REQUIRED", "Command", "Parameter", "ParameterError", "command",
           "naming", "to_json"]

#: Command name -> (module of vergence.commands, the Command in it). Sorted by name.
COMMANDS: dict[str, tuple[str, str]] = {
    "analyze": ("analyze", "ANALYZE"),
    "budget": ("budget", "BUDGET"),
    "compare": ("compare", "COMPARE"),
    "evaluate-disparity": ("evaluate_disparity", "EVALUATE_DISPARITY"),
    "interpolate": ("interpolate", "INTERPOLATE"),
    "mapping": ("mapping", "MAPPING"),
    "match": ("match", "MATCH"),
    "rectify": ("rectify", "RECTIFY"),
    "rig plan": ("rig_plan", "RIG_PLAN"),
    "synthesize": ("synthesize", "SYNTHESIZE"),
}


def command(name: str) -> Command:
    """The :class:`Command` of ``name`` (``"budget"``, ``"rig plan"``).

    Raises
    ------
    KeyError
        If no command of that name prints ``--json`` (the message lists those that do).
    """
    try:
        module, attribute = COMMANDS[name]
    except KeyError:
        raise KeyError(f"no command {name!r} has a library twin; commands: {', '.join(COMMANDS)}") from None
    return getattr(importlib.import_module(f"vergence.commands.{module}"), attribute)
