"""How OpenCV's blind left band is matched (issue 15): margins of the two views, scored on one split.

OpenCV's StereoBM and StereoSGBM give no disparity in the ``min_disparity + num_disparities``
leftmost columns, where part of the search range falls outside the right view: at 128 disparities a
fifth of a half-size 2005/2006 scene, left to the row filling. ``match_sgbm`` now matches the views
with margins added on the left (and on the right for a negative ``min_disparity``) and cuts the
answer back; this script scores the whole default pipeline (``compute_disparity``) with each kind of
margin: none (the old behaviour), repeated edge, mirrored (``BORDER_REFLECT_101``, the one chosen)
and black. Scoring as ``benchmarks/stereo_table.py`` (nonocc, bad > 1 px, missing = bad). Choose on
``--scenes train``; ``--scenes heldout`` is for the one measurement afterwards.

Run: ``PYTHONPATH=src python benchmarks/stereo_border.py [--scenes train|heldout]`` (about a minute).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stereo_table import SPLIT, bad, load  # noqa: E402

import vergence.depth.matching as matching  # noqa: E402
from vergence.depth import compute_disparity  # noqa: E402

BORDERS = {"none": None, "repeated": cv2.BORDER_REPLICATE, "mirrored": cv2.BORDER_REFLECT_101,
           "black": cv2.BORDER_CONSTANT}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", choices=("train", "heldout"), default="train")
    args = parser.parse_args()
    scenes = {name: load(name) for name in SPLIT[args.scenes]}
    original = matching._mirror_padded
    try:
        for label, border in BORDERS.items():
            def padded(a, b, lo, count, border=border):  # match_sgbm adds its margins through this
                if border is None:
                    return a, b, 0, 0
                left, right = max(lo + count, 0), max(-lo, 0)
                return (cv2.copyMakeBorder(a, 0, 0, left, right, border),
                        cv2.copyMakeBorder(b, 0, 0, left, right, border), left, right)  # fmt: skip

            matching._mirror_padded = padded
            res = {name: bad(compute_disparity(left, right, max_disparity=ndisp - 1).disparity, truth, mask)
                   for name, (left, right, truth, mask, ndisp) in scenes.items()}  # fmt: skip
            print(f"{label:9s} mean {statistics.mean(res.values()):.2f}  "
                  + " ".join(f"{name} {v:.2f}" for name, v in res.items()), flush=True)
    finally:
        matching._mirror_padded = original


if __name__ == "__main__":
    main()
