"""``vergence warm``: compile the kernels of the commands and the workbench before their first use.

Runs the groups of :data:`vergence.warm.WARM_GROUPS` (:func:`vergence.warm.warm`) one at a time: a
line per group with its time (a spinner while it runs, on a terminal), then the total. The machine
code lands in Numba's cache, in the user's folder (:func:`vergence._cache.numba_cache_dir`), where
every later command loads it in milliseconds. ``make setup`` runs it last.
"""

from __future__ import annotations

import os
import time

import typer

from vergence.cli._app import app, console, err_console
from vergence.warm import WARM_GROUPS

__all__ = ["warm"]


@app.command("warm")
def warm(
    group: list[str] = typer.Option(
        [], "--group", metavar="NAME",
        help=f"Warm only this group (repeatable): {', '.join(WARM_GROUPS)}. Default: every group whose extras "
             "are installed.",
    ),
) -> None:
    """Compile the kernels of the commands and the workbench ahead of their first use (Numba's cache)."""
    from vergence import warm as warm_up
    from vergence.cli import _compile_notice

    _compile_notice.silence()  # this command says what it compiles, group by group
    groups = WARM_GROUPS
    for name in group:
        if name not in groups:
            raise ValueError(f"--group must be one of {', '.join(groups)}; got {name!r}")
        why = groups[name].missing()
        if why is not None:
            raise ValueError(f"--group {name} {why}")
    if len(set(group)) != len(group):
        raise ValueError(f"--group names a group twice: {' '.join(group)}")
    names = list(group) or list(groups)
    cache = os.environ.get("NUMBA_CACHE_DIR") or "Numba's default cache (beside the package)"
    console.print(f"warming {len(names)} kernel group(s) into {cache}: minutes the first time, seconds once "
                  "cached", highlight=False)  # fmt: skip
    start = time.perf_counter()
    for i, name in enumerate(names, 1):
        entry = groups[name]
        label = f"{name:<12}"
        why = entry.missing()
        if why is not None:  # only by default: a --group of a missing extra was refused above
            console.print(f"{label} skipped: {why}", highlight=False, markup=False)
            continue
        with err_console.status(f"warming {name} ({i}/{len(names)}): {', '.join(entry.uses)}", spinner="dots"):
            seconds = warm_up.warm([name])[name]
        console.print(f"{label} {seconds:7.1f} s  ({', '.join(entry.uses)})", highlight=False)
    console.print(f"kernels ready in {time.perf_counter() - start:.1f} s", highlight=False)
