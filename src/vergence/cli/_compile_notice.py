"""One line on stderr when a command has to compile Numba kernels: :data:`NOTICE`, once per process.

A kernel found in Numba's cache loads in milliseconds; one that is not compiles for seconds to
minutes. Numba announces each real compilation (not a cache load) as a ``numba:compile`` event
(``numba.core.event``); the console script listens for the first one. So that commands which never
use Numba do not pay for importing it, the listener is registered the moment Numba loads its event
module, by a finder on ``sys.meta_path`` that steps aside once it has done so. The warm path costs
nothing: events are raised only when something compiles.

This module imports only the standard library (the console script installs it before anything heavy).
"""

from __future__ import annotations

import sys
from types import ModuleType

__all__ = ["NOTICE", "install", "silence"]

#: What a command prints (stderr) before its first compilation.
NOTICE = "compiling kernels (first run only; `vergence warm` does it ahead)"

_EVENT_MODULE = "numba.core.event"
_state = {"said": False, "silent": False}


def silence() -> None:
    """Print no notice in this process (``vergence warm`` reports its own progress)."""
    _state["silent"] = True


def install() -> None:
    """Print :data:`NOTICE` before the first Numba compilation of this process (nothing for cache loads)."""
    module = sys.modules.get(_EVENT_MODULE)
    if module is not None:
        _listen(module)
    elif not any(isinstance(f, _EventModuleFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _EventModuleFinder())


def _say() -> None:
    if not (_state["said"] or _state["silent"]):
        _state["said"] = True
        sys.stderr.write(NOTICE + "\n")
        sys.stderr.flush()


def _listen(event: ModuleType) -> None:
    """Register a listener of ``numba:compile`` with Numba's event module."""

    class _Notice(event.Listener):  # type: ignore[name-defined, misc]
        def on_start(self, ev: object) -> None:
            _say()

        def on_end(self, ev: object) -> None:
            pass

    event.register("numba:compile", _Notice())


class _EventModuleFinder:
    """A ``sys.meta_path`` finder that lets Numba's event module load, then registers the listener."""

    def find_spec(self, name: str, path: object = None, target: object = None) -> object:
        if name != _EVENT_MODULE:
            return None
        sys.meta_path.remove(self)  # one module, once: from now on imports go past us
        from importlib.machinery import PathFinder

        spec = PathFinder.find_spec(name, path)  # type: ignore[arg-type]
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        load = spec.loader.exec_module

        def exec_module(module: ModuleType) -> None:
            load(module)
            _listen(module)

        spec.loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec
