"""The workbench's browser JavaScript (``src/vergence/web/static/**/*.js``: plain scripts, no build step) keeps
the style of the Python code (lines of at most 120 columns, STYLE.md) and parses (``node --check``).

Every ``.js`` file under the static folder is checked, found by globbing, so a new page's script is covered
without editing this file.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

NODE = shutil.which("node")
STATIC = Path(__file__).resolve().parents[2] / "src" / "vergence" / "web" / "static"
SCRIPTS = sorted(STATIC.rglob("*.js"))
MAX_COLUMNS = 120  # STYLE.md's limit for the Python code
NODE_TIMEOUT_S = 60


def _ids(paths: list[Path]) -> list[str]:
    return [path.relative_to(STATIC).as_posix() for path in paths]


def long_lines(path: Path, limit: int = MAX_COLUMNS) -> list[str]:
    """``file:line (N columns)`` for each line of ``path`` longer than ``limit`` characters."""
    name = path.relative_to(STATIC).as_posix() if path.is_relative_to(STATIC) else str(path)
    lines = path.read_text(encoding="utf-8").split("\n")
    return [f"{name}:{number} ({len(line)} columns)"
            for number, line in enumerate((line.rstrip("\r") for line in lines), start=1) if len(line) > limit]


def test_scripts_are_found():
    # The globbing must see the pages' scripts; an empty list would leave the tests below with nothing to check.
    names = set(_ids(SCRIPTS))
    assert {"common.js", "pages/budget.js", "pages/stereo.js"} <= names, sorted(names)


@pytest.mark.parametrize("path", SCRIPTS, ids=_ids(SCRIPTS))
def test_line_length(path):
    over = long_lines(path)
    assert not over, f"{len(over)} line(s) over {MAX_COLUMNS} columns:\n" + "\n".join(over)


@pytest.mark.skipif(NODE is None, reason="node (Node.js) is not installed: the scripts' syntax cannot be "
                                         "checked outside the browser here")
@pytest.mark.parametrize("path", SCRIPTS, ids=_ids(SCRIPTS))
def test_node_check(path):
    done = subprocess.run([NODE, "--check", str(path)], capture_output=True, text=True, timeout=NODE_TIMEOUT_S)
    assert done.returncode == 0, f"node --check {path.relative_to(STATIC)} failed:\n{done.stderr}"
