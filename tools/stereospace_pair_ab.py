"""StereoSpace pairs of two trees side by side: the same images? how fast, each in fresh processes?

The figures of docs/stereospace.md that compare this tree with an older one (issue 27: the pairs move
by float32 rounding only; the CPU time per pair, processes of both trees taken in turns). The other
tree is a checkout of its own, e.g. ``git worktree add /tmp/old 8012fde``::

    PYTHONPATH=/tmp/old/src python -m tools.stereospace_pair_ab dump old.npz
    PYTHONPATH=src python -m tools.stereospace_pair_ab dump new.npz
    python -m tools.stereospace_pair_ab compare old.npz new.npz
    python -m tools.stereospace_pair_ab time --trees /tmp/old/src src --collection dino --rounds 5

``dump``: with whatever ``vergence`` is importable, the views and anaglyph of 4- and 2-source pairs
at 8 states a collection (the benchmark's two, then states drawn with a fixed seed; a state that
cannot be rectified is skipped and said). ``compare``: per collection, sources and image, the largest
and mean absolute difference, the least PSNR and how many are identical. ``time``: each round runs,
per tree, a fresh process timing ``stereo_pair(prepared, state, layout="anaglyph")`` (median of 9,
process CPU time of all threads and wall) on the benchmark's two states; printed: the medians of the
processes' medians and the least run. Collections from ``benchmarks/stereospace_pair.py``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
STATES_PER_COLLECTION = 8


def _bench():  # noqa: ANN202 - the benchmark module (COLLECTIONS, STATES, DATA, PAIR_METHODS)
    sys.path.insert(0, str(BENCHMARKS))
    import stereospace_pair

    return stereospace_pair


def _prepared(bench, name: str):  # noqa: ANN001, ANN202
    from vergence.stereospace import PreparedCollection, load_collection

    folder, camera_file = bench.COLLECTIONS[name]
    return PreparedCollection(load_collection(bench.DATA / folder / camera_file, images=bench.DATA / folder))


def dump(out: Path) -> None:
    from vergence.stereospace import StereoState, stereo_pair

    bench = _bench()
    arrays = {}
    for name in bench.COLLECTIONS:
        prepared = _prepared(bench, name)
        rng = np.random.default_rng(27)
        states, m = list(bench.STATES.values()), len(prepared.space.segments)
        while len(states) < STATES_PER_COLLECTION:
            i, j = sorted(rng.integers(0, m, 2).tolist())
            li, lj = rng.uniform(0, 1, 2).tolist()
            if i == j and li > lj:
                li, lj = lj, li
            try:
                prepared.space.check_state(StereoState((i, j), li, lj))
            except ValueError:
                continue
            states.append(StereoState((i, j), li, lj))
        methods = {"4": "mls", "2": lambda p, cam: bench.PAIR_METHODS["mls"](p, cam, sources=2)}
        for k, state in enumerate(states):
            for sources, method in methods.items():
                try:
                    pair = stereo_pair(prepared, state, layout="anaglyph", method=method)
                except ValueError as exc:
                    print(f"{name} state {k} ({sources} sources) skipped: {exc}")
                    continue
                for view in ("left", "right", "packed"):
                    arrays[f"{name}_{k}_{sources}_{view}"] = getattr(pair, view)
    np.savez_compressed(out, **arrays)
    print(f"wrote {len(arrays)} images to {out}")


def compare(a_path: Path, b_path: Path) -> None:
    a, b = np.load(a_path), np.load(b_path)
    if sorted(a.files) != sorted(b.files):
        raise SystemExit(f"{a_path} and {b_path} hold different images: dump both with the same collections")
    rows: dict[tuple[str, str, str], list[tuple[float, float, float]]] = {}
    for key in sorted(a.files):
        d = np.abs(a[key].astype(np.float64) - b[key].astype(np.float64))
        mse = float((d**2).mean())
        name, _, sources, view = key.split("_")
        rows.setdefault((name, sources, view), []).append((d.max(), d.mean(), np.inf if mse == 0 else 10 * np.log10(1 / mse)))
    for (name, sources, view), v in sorted(rows.items()):
        v = np.array(v)
        print(f"{name} {sources} sources {view:6s}: {len(v)} states, max |diff| {v[:, 0].max():.2e}, mean |diff| <= "
              f"{v[:, 1].max():.1e}, PSNR >= {v[:, 2].min():.1f} dB, identical {int((v[:, 0] == 0).sum())}")


def _time_one(name: str, repeat: int) -> None:
    """In this process: per benchmark state, median CPU and wall ms of a prepared anaglyph pair, and the least CPU."""
    from vergence.stereospace import stereo_pair

    bench = _bench()
    from _timing import timed

    prepared = _prepared(bench, name)
    out = []
    for state in bench.STATES.values():
        stereo_pair(prepared, state, layout="anaglyph")
        runs = 1e3 * np.array([timed(lambda s=state: stereo_pair(prepared, s, layout="anaglyph")) for _ in range(repeat)])
        out += [np.median(runs[:, 1]), runs[:, 1].min(), np.median(runs[:, 0])]
    print(" ".join(f"{v:.2f}" for v in out))


def time_trees(trees: list[str], name: str, rounds: int, repeat: int) -> None:
    res: dict[str, list[list[float]]] = {t: [] for t in trees}
    for _ in range(rounds):  # in turns: the load of a shared machine hits every tree alike
        for tree in trees:
            env = {**os.environ, "PYTHONPATH": tree, "OMP_WAIT_POLICY": "PASSIVE"}
            done = subprocess.run([sys.executable, "-m", "tools.stereospace_pair_ab", "_time-one", name, str(repeat)],
                                  env=env, capture_output=True, text=True, check=True,
                                  cwd=Path(__file__).resolve().parents[1])  # fmt: skip
            res[tree].append([float(x) for x in done.stdout.split()])
    labels = list(_bench().STATES)
    for tree, runs in res.items():
        v = np.array(runs)
        parts = [f"{label}: CPU {np.median(v[:, 3 * k]):.1f} ms (least {v[:, 3 * k + 1].min():.1f}), wall "
                 f"{np.median(v[:, 3 * k + 2]):.1f}" for k, label in enumerate(labels)]  # fmt: skip
        print(f"{name}, {tree} ({rounds} processes, medians of their medians): " + "; ".join(parts))
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("dump").add_argument("out", type=Path)
    cmp = sub.add_parser("compare")
    cmp.add_argument("a", type=Path)
    cmp.add_argument("b", type=Path)
    tim = sub.add_parser("time")
    tim.add_argument("--trees", nargs="+", required=True, help="the src folders to put on PYTHONPATH, in turn")
    tim.add_argument("--collection", default="dino")
    tim.add_argument("--rounds", type=int, default=5)
    tim.add_argument("--repeat", type=int, default=9)
    one = sub.add_parser("_time-one")
    one.add_argument("name")
    one.add_argument("repeat", type=int)
    args = parser.parse_args()
    if args.command == "dump":
        dump(args.out)
    elif args.command == "compare":
        compare(args.a, args.b)
    elif args.command == "time":
        time_trees(args.trees, args.collection, args.rounds, args.repeat)
    else:
        _time_one(args.name, args.repeat)


if __name__ == "__main__":
    main()
