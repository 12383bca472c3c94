"""``python -m tools.sweep --out DIR [--quick] [--jobs N] [--only cli|api|sigint|random|web|NAME ...]``."""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

# The checkout's own package, not whichever ``vergence`` the interpreter has installed.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src"))

from tools.sweep import sweep  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.sweep", description=__doc__)
    parser.add_argument("--out", type=Path, required=True, help="folder for report.json and summary.md")
    parser.add_argument("--quick", action="store_true", help="sample a few hostile values per option (< 5 min)")
    parser.add_argument("--jobs", type=int, default=1, help="subprocesses at a time (default 1)")
    parser.add_argument("--only", nargs="+", default=(), metavar="KIND_OR_NAME",
                        help="cli, api, sigint, random, web, a command name, an API name or a route name "
                             "(e.g. match, roundness, health)")
    parser.add_argument("--seed", type=int, default=9, help="draws of --quick and of the random cases")
    parser.add_argument("--time-limit", type=float, default=60.0, help="seconds per subprocess call (60)")
    parser.add_argument("--api-time-limit", type=float, default=30.0, help="seconds per API call (30)")
    parser.add_argument("--web-time-limit", type=float, default=20.0, help="seconds per web request (20)")
    parser.add_argument("--memory-gb", type=float, default=8.0, help="address-space limit per subprocess (8)")
    parser.add_argument("--per-option", type=int, default=None,
                        help="hostile values drawn per option, per API parameter and per web body field "
                             "(default: all; --quick: 1, 2 and 2)")
    parser.add_argument("--sample", type=int, default=None,
                        help="command-line cases drawn besides the bases and the issue's cases (--quick: 40)")
    parser.add_argument("--limit", type=int, default=None, help="run at most this many cases (smoke tests)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error("--jobs must be >= 1")
    start = time.monotonic()
    totals = sweep(args.out, quick=args.quick, jobs=args.jobs, only=tuple(args.only), seed=args.seed,
                   time_limit_s=args.time_limit, api_time_limit_s=args.api_time_limit,
                   web_time_limit_s=args.web_time_limit, memory_gb=args.memory_gb,
                   limit=args.limit, per_option=args.per_option, sample=args.sample,
                   command="python -m tools.sweep " + shlex.join(sys.argv[1:] if argv is None else argv))
    print(f"{totals['cases']} cases in {totals['runs']} runs, {totals['failing']} failing, "
          f"{time.monotonic() - start:.0f} s; see {args.out / 'summary.md'}")
    for cls, n in totals["counts"].items():
        if n:
            print(f"  {cls}: {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
