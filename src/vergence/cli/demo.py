"""``vergence demo``: the main job on built-in data, as an HTML report."""

from __future__ import annotations

from pathlib import Path

import typer

from vergence.cli._app import app, console


@app.command("demo")
def demo(
    out: Path = typer.Option(Path("demo-output"), "--out", help="Folder for index.html and its figures."),
) -> None:
    """Run the main job on built-in data and write OUT/index.html."""
    from vergence.report.demo import run_demo

    with console.status("vergence demo") as status:
        result = run_demo(out, progress=lambda msg: status.update(f"vergence demo: {msg}"))
    console.print(f"wrote [bold]{result.index}[/]")
