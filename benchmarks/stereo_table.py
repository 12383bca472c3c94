"""Bad-pixel table of every stereo scene: raw OpenCV SGBM, our default pipeline, PatchMatch Stereo.

Scenes (``../shared/data``, see ``shared/data/SOURCES.md``): tsukuba and venus (Middlebury v2, official
``nonocc`` masks), barn2, bull, poster, sawtooth (Middlebury 2001: nonocc computed from disp2 and disp6,
10 px border, as ``benchmarks/middlebury.py``), and the twelve 2005/2006 scenes at half size (view1 /
view5, nonocc computed from disp1 and disp5 by :func:`vergence.depth.nonoccluded_mask`, no border;
Scharstein & Pal 2007, Hirschmüller & Scharstein 2007). The official v2 rule: bad when |error| > 1 px
over nonocc, a missing estimate counts as bad. Search range: 16 disparities (tsukuba), 32 (the 2001
scenes and venus), 128 (the 2005/2006 ones, whose half-size disparities reach about 115 px).

Contestants: raw SGBM is one plain OpenCV StereoSGBM 3-way call with the sample's settings
(``benchmarks/middlebury.py``'s ``raw_sgbm``); the default is ``compute_disparity`` with its defaults;
patchmatch is ``compute_disparity(method="patchmatch")``. The split (``benchmarks/stereo_split.json``)
says which scenes parameters were chosen on: the table marks them, and the means are given for the
held-out scenes alone. ``--tune`` instead scores PatchMatch variants on the training scenes only.

Published: PatchMatch Stereo (Bleyer, Rhemann & Rother, BMVC 2011, Table 1: Middlebury v2 nonocc)
tsukuba 2.09, venus 0.21 (teddy 2.99 and cones 2.47 are scenes we do not have).

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereo_table.py [--scenes train|heldout|all] [--tune]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from middlebury import raw_sgbm  # noqa: E402  (the raw baseline of the existing table)

from vergence.depth import (  # noqa: E402
    PatchMatchParameters,
    compute_disparity,
    evaluate_disparity,
    middlebury_regions,
    patchmatch_stereo,
    read_middlebury_masks,
    refine_disparity,
)
from vergence.io import read_disparity, read_image  # noqa: E402

HERE = Path(__file__).resolve().parent
DATA = HERE.parent.parent / "shared" / "data"
SPLIT = json.loads((HERE / "stereo_split.json").read_text())
PUBLISHED = {"tsukuba": 2.09, "venus": 0.21}  # PMS, Bleyer et al. 2011, Table 1 (nonocc, > 1 px)
# scene: left, right, truth, right truth, truth scale, disparities searched
STEREO = {
    "tsukuba": ("im3.png", "im4.png", "groundtruth.png", None, 16, 16),
    "venus": ("im2.ppm", "im6.ppm", "disp2.pgm", "disp6.pgm", 8, 32),
    **{s: ("im2.png", "im6.png", "disp2.png", "disp6.png", 8, 32) for s in ("barn2", "bull", "poster", "sawtooth")},
}
OFFICIAL = ("tsukuba", "venus")
MULTIVIEW_DISPARITIES = 128


def load(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray], int]:
    """Left, right, truth, the nonocc mask and the number of disparities searched of one scene."""
    if name in STEREO:
        lf, rf, tf, trf, scale, ndisp = STEREO[name]
        folder = DATA / "stereo" / name
        truth = read_disparity(folder / tf, scale=scale)
        if name in OFFICIAL:
            nonocc = read_middlebury_masks(folder)["nonocc"]
        else:
            nonocc = middlebury_regions(truth, truth_right=read_disparity(folder / trf, scale=scale))["nonocc"]
    else:
        folder = DATA / "multiview" / name
        lf, rf, ndisp = "view1.png", "view5.png", MULTIVIEW_DISPARITIES
        truth = read_disparity(folder / "disp1.png", scale=2)
        truth_right = read_disparity(folder / "disp5.png", scale=2)
        nonocc = middlebury_regions(truth, truth_right=truth_right, border=0)["nonocc"]
    return read_image(folder / lf), read_image(folder / rf), truth, nonocc, ndisp


def bad(estimate: np.ndarray, truth: np.ndarray, nonocc: np.ndarray) -> float:
    """Middlebury v2: % of nonocc pixels with |error| > 1 px, missing = bad."""
    return evaluate_disparity(estimate, truth, masks={"nonocc": nonocc})["nonocc"].bad


def _scenes(which: str) -> list[str]:
    return {"train": SPLIT["train"], "heldout": SPLIT["heldout"], "all": SPLIT["train"] + SPLIT["heldout"]}[which]


def table(which: str, parameters: PatchMatchParameters) -> None:
    cols = ("raw SGBM 3-way", "default (sgbm)", "patchmatch", "published PMS")
    print(f"| scene | set | disparities | {' | '.join(cols)} | patchmatch s |")
    print("|---|---|---:|" + "---:|" * (len(cols) + 1))
    held = {c: [] for c in cols[:3]}
    for name in _scenes(which):
        left, right, truth, nonocc, ndisp = load(name)
        t0 = time.perf_counter()
        pm = compute_disparity(left, right, max_disparity=ndisp - 1, method="patchmatch", patchmatch=parameters)
        seconds = time.perf_counter() - t0
        figures = {
            cols[0]: bad(raw_sgbm(left, right, ndisp), truth, nonocc),
            cols[1]: bad(compute_disparity(left, right, max_disparity=ndisp - 1).disparity, truth, nonocc),
            cols[2]: bad(pm.disparity, truth, nonocc),
        }
        split = "train" if name in SPLIT["train"] else "held-out"
        if split == "held-out":
            for c in held:
                held[c].append(figures[c])
        pub = f"{PUBLISHED[name]:.2f}" if name in PUBLISHED else "—"
        print(f"| {name} | {split} | {ndisp} | " + " | ".join(f"{figures[c]:.2f}" for c in cols[:3])
              + f" | {pub} | {seconds:.1f} |", flush=True)
    if held[cols[0]]:
        print(f"| **held-out mean** ({len(held[cols[0]])} scenes) | | | "
              + " | ".join(f"**{statistics.mean(held[c]):.2f}**" for c in cols[:3]) + " | | |")


def tune(grid: list[PatchMatchParameters]) -> None:
    """Score PatchMatch variants on the training scenes only: the matcher's output as it is (PMS
    post-processing), and refined by our pipeline from the left-right checked map or from that output."""
    names = SPLIT["train"]
    for prm in grid:
        rows = {"pms": [], "pms-no-median": [], "refine(raw)": [], "refine(pms)": []}
        seconds = 0.0
        for name in names:
            left, right, truth, nonocc, ndisp = load(name)
            t0 = time.perf_counter()
            res = patchmatch_stereo(left, right, max_disparity=ndisp - 1, parameters=prm)
            seconds += time.perf_counter() - t0
            rows["pms"].append(bad(res.disparity, truth, nonocc))
            rows["pms-no-median"].append(bad(res.filled, truth, nonocc))
            rows["refine(raw)"].append(bad(refine_disparity(res.raw, left).disparity, truth, nonocc))
            rows["refine(pms)"].append(bad(refine_disparity(res.disparity, left).disparity, truth, nonocc))
        for k, v in rows.items():
            scenes = " ".join(f"{n} {b:.2f}" for n, b in zip(names, v, strict=True))
            print(f"{prm} {k:12s} mean {statistics.mean(v):6.2f} | {scenes} | {seconds:.0f} s", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", choices=("train", "heldout", "all"), default="all")
    ap.add_argument("--tune", action="store_true", help="score PatchMatch variants on the training scenes only")
    ap.add_argument("--step", type=int, nargs="*", default=None, help="--tune: the window steps to try")
    ap.add_argument("--window", type=int, nargs="*", default=None, help="--tune: the windows to try")
    ap.add_argument("--gamma", type=float, nargs="*", default=None, help="--tune: the gammas to try")
    ap.add_argument("--iterations", type=int, nargs="*", default=None, help="--tune: the iteration counts to try")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"shared data not found at {DATA}; see shared/data/SOURCES.md", file=sys.stderr)
        return 1
    left, right, _, _, _ = load("tsukuba")  # compile the Numba kernels before any timing
    patchmatch_stereo(left[:60, :90], right[:60, :90], max_disparity=15, parameters=PatchMatchParameters(window=9))
    if args.tune:
        steps = args.step or [PatchMatchParameters().step]
        windows = args.window or [PatchMatchParameters().window]
        gammas = args.gamma or [PatchMatchParameters().gamma]
        counts = args.iterations or [PatchMatchParameters().iterations]
        tune([PatchMatchParameters(window=w, step=s, gamma=g, iterations=n)
              for w in windows for s in steps for g in gammas for n in counts])
    else:
        table(args.scenes, PatchMatchParameters())
    return 0


if __name__ == "__main__":
    sys.exit(main())
