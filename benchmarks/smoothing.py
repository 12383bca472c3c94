"""Edge-aware smoothing of the default pipeline on held-out Middlebury scenes: none and median.

Data: ``../shared/data`` (Scharstein & Szeliski 2002; Scharstein & Pal 2007; Hirschmüller &
Scharstein 2007; see ``shared/data/SOURCES.md``). Held out: neither tsukuba nor venus (the scenes the
pipeline was tuned and tested on) but the four 2001 scenes (barn2, bull, poster, sawtooth: im2/im6,
truth / 8, over 32 disparities) and the twelve 2005/2006 half-size scenes (view1/view5, truth / 2,
over the multiple of 16 above their largest true disparity). One SGBM matching per scene
(``match_sgbm``), then ``refine_disparity`` with each smoothing; regions computed from the two
ground truths (``middlebury_regions``); bad = |error| > 1 px over nonocc (Scharstein & Szeliski 2002).

Run: ``.venv/bin/python benchmarks/smoothing.py [METHOD ...]`` (default: none median)

Measured for issue 9 (``wls`` was then OpenCV ximgproc's DisparityWLSFilter, lambda 8000, sigma 1.5,
on the filled map), % bad nonocc, none / median / wls: barn2 2.68 / 1.12 / 2.74, bull 2.00 / 1.33 /
1.99, poster 2.95 / 1.28 / 2.27, sawtooth 1.33 / 0.78 / 1.85; the twelve 2005/2006 scenes from
aloe 11.44 / 14.22 / 19.89 to wood1 1.38 / 5.48 / 26.02; mean over the sixteen 13.21 / 13.15 / 27.20.
WLS beat no smoothing on 2 scenes of 16 (the median on 10): it was dropped.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

from vergence.depth import evaluate_disparity, match_sgbm, middlebury_regions, refine_disparity
from vergence.io import read_disparity, read_image

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
# scene: folder, left, right, truth, right truth, scale, max disparity (None: from the truth)
SCENES = {
    **{n: (DATA / "stereo" / n, "im2.png", "im6.png", "disp2.png", "disp6.png", 8, 31)
       for n in ("barn2", "bull", "poster", "sawtooth")},
    **{n: (DATA / "multiview" / n, "view1.png", "view5.png", "disp1.png", "disp5.png", 2, None)
       for n in ("aloe", "baby1", "bowling1", "cloth1", "dolls", "flowerpots", "lampshade1", "midd1", "monopoly",
                 "plastic", "rocks1", "wood1")},
}


def main(argv: list[str]) -> int:
    methods = argv or ["none", "median"]
    if not DATA.is_dir():
        print(f"shared data not found at {DATA}; see shared/data/SOURCES.md", file=sys.stderr)
        return 1
    print(f"{'scene':11s} {'range':>5s} | " + " ".join(f"{m:>7s}" for m in methods) + "   (% bad nonocc)")
    totals = {m: [] for m in methods}
    seconds = {m: 0.0 for m in methods}
    for name, (folder, lf, rf, tf, trf, scale, hi) in SCENES.items():
        left, right = read_image(folder / lf), read_image(folder / rf)
        truth = read_disparity(folder / tf, scale=scale)
        truth_right = read_disparity(folder / trf, scale=scale)
        if hi is None:
            hi = 16 * math.ceil((float(np.nanmax(truth)) + 1) / 16) - 1
        regions = {"nonocc": middlebury_regions(truth, truth_right=truth_right)["nonocc"]}
        raw = match_sgbm(left, right, max_disparity=hi)
        row = []
        for m in methods:
            start = time.perf_counter()
            d = refine_disparity(raw, left, smoothing=m).disparity
            seconds[m] += time.perf_counter() - start
            bad = evaluate_disparity(d, truth, masks=regions)["nonocc"].bad
            totals[m].append(bad)
            row.append(bad)
        print(f"{name:11s} {hi + 1:5d} | " + " ".join(f"{b:7.2f}" for b in row), flush=True)
    print(f"{'mean':11s} {'':5s} | " + " ".join(f"{np.mean(totals[m]):7.2f}" for m in methods))
    print(f"{'refine s':11s} {'':5s} | " + " ".join(f"{seconds[m]:7.1f}" for m in methods))
    for m in methods:
        if m != "none":
            wins = sum(b < n for b, n in zip(totals[m], totals["none"])) if "none" in totals else 0
            print(f"{m}: fewer bad pixels than none on {wins} of {len(SCENES)} scenes")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
