"""The first run's cost (issue 31): `vergence render` + `vergence synthesize`, first and second time.

Each case uses a new, empty Numba cache folder (``NUMBA_CACHE_DIR`` in a temporary folder) and runs,
in fresh processes, ``vergence render tabletop --width 160 --height 120`` then ``vergence synthesize``
on its output, twice; with ``--warm`` the case first runs ``vergence warm`` into the same empty folder
(minutes). Mitsuba's own cache (``~/.drjit``) is left as it is. Printed: the wall time of each pair and the ratio first / second (the issue's goal: at
most 3x after ``make setup``). Run: ``.venv/bin/python benchmarks/first_run.py [--warm]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

VERGENCE = Path(sys.executable).with_name("vergence")


def _run(args: list[str], env: dict[str, str], cwd: Path) -> float:
    start = time.perf_counter()
    subprocess.run([str(VERGENCE), *args], env=env, cwd=cwd, check=True, capture_output=True)
    return time.perf_counter() - start


def _pair(env: dict[str, str], cwd: Path, tag: str) -> float:
    render = _run(["render", "tabletop", "--width", "160", "--height", "120", "--out", f"r{tag}"], env, cwd)
    synth = _run(["synthesize", f"r{tag}/render_beauty.png", f"r{tag}/render_depth.pfm", "--out", f"v{tag}"], env, cwd)
    return render + synth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--warm", action="store_true", help="run `vergence warm` into the empty cache first")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="vergence-first-run-") as tmp:
        folder = Path(tmp)
        env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "numba")}
        warm = _run(["warm"], env, folder) if args.warm else None
        first, second = _pair(env, folder, "1"), _pair(env, folder, "2")
    what = f"after vergence warm ({warm:.1f} s)" if warm is not None else "empty cache"
    print(f"{what}: render + synthesize first {first:.1f} s, second {second:.1f} s, ratio {first / second:.2f}")


if __name__ == "__main__":
    main()
