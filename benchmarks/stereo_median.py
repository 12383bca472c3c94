"""How the refinement's weighted median was sized (issue 15): window radius and spatial weights on one split.

The default pipeline (``compute_disparity``: SGBM, then ``refine_disparity``) re-estimates the pixels
next to depth edges and the isolated outliers by a colour-weighted median of the matched pixels
around them. Its window was 1/24 of the image's larger side with every vote alike; this script
scores the whole pipeline on the scenes of one set of ``benchmarks/stereo_split.json`` for a grid of
radii (pixels, or ``image`` for the old size rule) and spatial scales (``sigma_space`` in pixels, or
``none``); the SGBM answer is computed once per scene. Scoring as ``benchmarks/stereo_table.py``
(nonocc, bad > 1 px, missing = bad). Choose on ``--scenes train``; ``--scenes heldout`` is for the one
measurement of the chosen setting afterwards.

Run: ``PYTHONPATH=src python benchmarks/stereo_median.py [--scenes train|heldout] [RADIUS:SIGMA ...]``
(default grid below; about a minute on 2 cores).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stereo_table import SPLIT, bad, load  # noqa: E402

from vergence.depth import match_sgbm, refine_disparity  # noqa: E402

DEFAULT_GRID = ["image:none", "4:none", "6:none", "9:none", "12:none", "image:5", "image:8", "16:6", "24:8", "32:8",
                "32:10"]  # fmt: skip


def _old_radius(h: int, w: int) -> int:
    """The size rule before: 1/24 of the larger side, at least 8 px."""
    return max(8, round(max(h, w) / 24.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", choices=("train", "heldout"), default="train")
    parser.add_argument("variants", nargs="*", help="RADIUS:SIGMA (RADIUS in px or 'image'; SIGMA in px or 'none')")
    args = parser.parse_args()
    scenes = {name: load(name) for name in SPLIT[args.scenes]}
    raw = {name: match_sgbm(left, right, max_disparity=ndisp - 1) for name, (left, right, _, _, ndisp) in scenes.items()}
    for variant in args.variants or DEFAULT_GRID:
        radius, sigma = variant.split(":")
        res = {}
        for name, (left, _, truth, mask, _) in scenes.items():
            r = _old_radius(*truth.shape) if radius == "image" else int(radius)
            refined = refine_disparity(raw[name], left, radius=r, sigma_space=None if sigma == "none" else float(sigma))
            res[name] = bad(refined.disparity, truth, mask)
        print(f"radius {radius:>5s}, sigma_space {sigma:>4s}: mean {statistics.mean(res.values()):.2f}  "
              + " ".join(f"{name} {v:.2f}" for name, v in res.items()), flush=True)


if __name__ == "__main__":
    main()
