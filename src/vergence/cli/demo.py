"""``vergence demo``: the main job on built-in data, as an HTML report."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import typer

from vergence.cli import EXIT_INTERRUPTED, note_if_interrupted
from vergence.cli._app import app, console


@app.command("demo")
def demo(
    out: Path = typer.Option(Path("demo-output"), "--out", help="Folder for index.html and its figures."),
) -> None:
    """Run the main job on built-in data and write OUT/index.html (all or nothing)."""
    from vergence.report.demo import run_demo

    # Ctrl-C is remembered as well as raised: a library that swallows the KeyboardInterrupt (Numba's cache
    # write did, and the demo then exited 0) cannot hide it, the next step raises it again.
    interrupted = threading.Event()

    def on_sigint(signum: int, frame: object) -> None:
        interrupted.set()
        raise KeyboardInterrupt

    note_if_interrupted(f"nothing was written to {out}")
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, on_sigint) if main_thread else None
    try:
        with console.status("vergence demo") as status:

            def step(msg: str) -> None:
                if interrupted.is_set():
                    raise KeyboardInterrupt
                status.update(f"vergence demo: {msg}")

            result = run_demo(out, progress=step)
    except KeyboardInterrupt:
        raise typer.Exit(EXIT_INTERRUPTED) from None  # the one "interrupted: ..." line is the console script's
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)
    console.print(f"wrote [bold]{result.index}[/]")
