"""How the default matcher's SGBM settings were chosen (issue 15): a grid scored on the training scenes.

Each variant replaces the block size, the smoothness penalty ``P2 = k c b^2`` (``P1 = 8 c b^2`` kept)
and the uniqueness ratio of :func:`vergence.depth.sgbm_parameters`, and runs the whole default pipeline
(``compute_disparity``: SGBM, then the refinement) on the scenes of one set of
``benchmarks/stereo_split.json``; scoring as ``benchmarks/stereo_table.py`` (nonocc, bad > 1 px,
missing = bad). Choose on ``--scenes train``; ``--scenes heldout`` is for the one measurement of the
chosen variant against the old one, afterwards.

A variant may name OpenCV's mode too, ``K:UNIQUENESS:BLOCK:MODE`` with MODE one of ``3way`` (ours),
``hh`` (8 paths), ``hh4``, ``sgbm`` (5 paths).

Run: ``PYTHONPATH=src python benchmarks/stereo_sgbm_grid.py [--scenes train|heldout] [K:UNIQUENESS:BLOCK[:MODE] ...]``
(default grid: k in 16, 32, 64, 128, uniqueness 10, 5, 15, block 3, 5; about 5 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stereo_table import SPLIT, bad, load  # noqa: E402

import cv2  # noqa: E402

import vergence.depth.matching as matching  # noqa: E402
from vergence.depth import compute_disparity  # noqa: E402

DEFAULT_GRID = [(*v, "3way") for v in itertools.product((16, 32, 64, 128), (10, 5, 15), (3, 5))]
MODES = {"3way": cv2.StereoSGBM_MODE_SGBM_3WAY, "hh": cv2.StereoSGBM_MODE_HH, "hh4": cv2.StereoSGBM_MODE_HH4,
         "sgbm": cv2.StereoSGBM_MODE_SGBM}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", choices=("train", "heldout"), default="train")
    parser.add_argument("variants", nargs="*", help="K:UNIQUENESS:BLOCK[:MODE] (P2 = K c b^2)")
    args = parser.parse_args()
    grid = [(*(int(v) for v in g.split(":")[:3]), (g.split(":") + ["3way"])[3]) for g in args.variants] or DEFAULT_GRID
    scenes = {name: load(name) for name in SPLIT[args.scenes]}
    original = matching.sgbm_parameters, matching._block_and_penalties
    try:
        for k, uniqueness, block, mode in grid:
            def penalties(b, c, k=k, block=block):  # match_sgbm sets the block and penalties through this
                return {"blockSize": block, "P1": 8 * c * block * block, "P2": k * c * block * block}

            def parameters(h, w, n, c, uniqueness=uniqueness, penalties=penalties, mode=mode):
                return {**original[0](h, w, n, c), **penalties(0, c), "uniquenessRatio": uniqueness,
                        "mode": MODES[mode]}

            matching.sgbm_parameters, matching._block_and_penalties = parameters, penalties
            res = {name: bad(compute_disparity(left, right, max_disparity=ndisp - 1).disparity, truth, mask)
                   for name, (left, right, truth, mask, ndisp) in scenes.items()}  # fmt: skip
            print(f"P2={k} c b^2, uniqueness {uniqueness} %, block {block}, {mode}: mean {statistics.mean(res.values()):.2f}  "
                  + " ".join(f"{name} {v:.2f}" for name, v in res.items()), flush=True)
    finally:
        matching.sgbm_parameters, matching._block_and_penalties = original

if __name__ == "__main__":
    main()
