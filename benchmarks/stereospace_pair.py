"""A 640 x 480 stereo pair of the kermit collection, with and without the one-time preparation.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereospace_pair.py [--repeat 9]``
(reads ``../shared/data/collections/kermit``; see ``shared/data/SOURCES.md``). Prints the median
wall time of :class:`~vergence.stereospace.PreparedCollection` (once), of :func:`stereo_pair` on
the prepared collection and of the same pair from the bare collection (graph built and images
decoded for the pair), for S2's novel view from 4 sources and from the segment's 2 cameras, at a
rhomboid state and a triangle state; the issue's goal is 70 ms a pair on 2 cores. The numba
kernels are compiled (or loaded from their cache) by a first, untimed pair.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _timing import median_time

from vergence.stereospace import PAIR_METHODS, PreparedCollection, StereoState, load_collection, stereo_pair

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "collections"



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args()
    folder = args.data / "kermit"
    col = load_collection(folder / "bundle.out", images=folder)
    t_prep = 1000.0 * median_time(lambda: PreparedCollection(col), 3)[0]
    prep = PreparedCollection(col)
    mls = PAIR_METHODS["mls"]
    methods = {"mls, 4 sources": mls, "mls, 2 sources": lambda p, cam: mls(p, cam, sources=2)}
    states = {"rhomboid (0,1) at (0.5, 0.5)": StereoState((0, 1), 0.5, 0.5),
              "triangle (0,0) at (0.25, 0.75)": StereoState((0, 0), 0.25, 0.75)}
    first = stereo_pair(prep, states["rhomboid (0,1) at (0.5, 0.5)"])  # compile / load the numba caches
    h, w = first.left.shape[:2]
    print(f"kermit: {len(col)} cameras, {col.point_count} points, {len(prep.space.segments)} segments; "
          f"pair {w} x {h}; preparation {t_prep:.0f} ms (median of 3)")
    for m_name, method in methods.items():
        for s_name, state in states.items():
            a, b = stereo_pair(prep, state, method=method), stereo_pair(col, state, method=method)
            same = np.array_equal(a.left, b.left) and np.array_equal(a.right, b.right)
            t_p = 1000.0 * median_time(lambda: stereo_pair(prep, state, method=method, layout="anaglyph"), args.repeat)[0]
            t_u = 1000.0 * median_time(lambda: stereo_pair(col, state, method=method, layout="anaglyph"), args.repeat)[0]
            print(f"{m_name:15s} {s_name:31s} prepared {t_p:6.1f} ms  unprepared {t_u:6.1f} ms  "
                  f"(median of {args.repeat}; pairs equal: {same})")


if __name__ == "__main__":
    main()
