"""Bad-pixel table of the plane filling (issue 15): the default pipeline with and without ``planes=True``.

Scenes, masks, search ranges and scoring as ``benchmarks/stereo_table.py`` (Middlebury v2 rule: bad when
|error| > 1 px over nonocc, a missing estimate counts as bad); train and held-out scenes from
``benchmarks/stereo_split.json``, with a mean for each set apart. The plane settings
(:data:`~vergence.depth.planes.PLANE_SCALES`, :data:`~vergence.depth.planes.MIN_INLIER_SHARE`) were chosen
with ``--tune``, which scores variants on the training scenes only.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereo_planes.py [--scenes train|heldout|all] [--patchmatch]
[--tune]`` (about a minute; with ``--patchmatch`` about half an hour on 2 cores).
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stereo_table import DATA, SPLIT, STEREO, bad, load  # noqa: E402

from vergence.depth import (  # noqa: E402
    SMOOTHING_METHODS,
    compute_disparity,
    fill_occlusions,
    match_sgbm,
    refine_disparity,
    remove_speckles,
)
from vergence.depth.refine import MEDIAN_SIGMA_SPACE, default_radius  # noqa: E402
from vergence.depth.planes import fill_from_planes  # noqa: E402


def table(which: str, with_patchmatch: bool) -> None:
    names = {"train": SPLIT["train"], "heldout": SPLIT["heldout"], "all": SPLIT["train"] + SPLIT["heldout"]}[which]
    cols = ("default (sgbm)", "default + planes", *(("patchmatch", "patchmatch + planes") if with_patchmatch else ()))
    print(f"| scene | set | {' | '.join(cols)} | default s | + planes s |")
    print("|---|---|" + "---:|" * (len(cols) + 2))
    means = {"train": {c: [] for c in cols}, "held-out": {c: [] for c in cols}}
    left, right, _, _, _ = load(names[0])  # load the compiled kernels before any timing
    compute_disparity(left[:80, :120], right[:80, :120], max_disparity=15, planes=True)
    for name in names:
        left, right, truth, nonocc, ndisp = load(name)
        t0 = time.perf_counter()
        base = compute_disparity(left, right, max_disparity=ndisp - 1).disparity
        t1 = time.perf_counter()
        planes = compute_disparity(left, right, max_disparity=ndisp - 1, planes=True).disparity
        seconds = (t1 - t0, time.perf_counter() - t1)
        figures = {cols[0]: bad(base, truth, nonocc), cols[1]: bad(planes, truth, nonocc)}
        if with_patchmatch:
            for c, p in zip(cols[2:], (False, True), strict=True):
                pm = compute_disparity(left, right, max_disparity=ndisp - 1, method="patchmatch", planes=p)
                figures[c] = bad(pm.disparity, truth, nonocc)
        split = "train" if name in SPLIT["train"] else "held-out"
        for c in cols:
            means[split][c].append(figures[c])
        print(f"| {name} | {split} | " + " | ".join(f"{figures[c]:.2f}" for c in cols) + f" | {seconds[0]:.1f} | {seconds[1]:.1f} |",
              flush=True)
    for split, m in means.items():
        if m[cols[0]]:
            print(f"| **{split} mean** ({len(m[cols[0]])} scenes) | | "
                  + " | ".join(f"**{statistics.mean(m[c]):.2f}**" for c in cols) + " | | |")
    held = [n for n in names if n not in SPLIT["train"]]
    multiview = [i for i, n in enumerate(held) if n not in STEREO]
    if multiview:  # issue 15's goal is set on the held-out 2005/2006 scenes
        print(f"| **held-out 2005/2006 mean** ({len(multiview)} scenes) | | "
              + " | ".join(f"**{statistics.mean(means['held-out'][c][i] for i in multiview):.2f}**" for c in cols)
              + " | | |")


def tune() -> None:
    """Score plane settings on the training scenes only (SGBM matched once per scene)."""
    scenes = []
    for name in SPLIT["train"]:
        left, right, truth, nonocc, ndisp = load(name)
        scenes.append((name, left, match_sgbm(left, right, max_disparity=ndisp - 1), truth, nonocc))
    cascades = ((200.0,), (1000.0,), (2000.0,), (2000.0, 1000.0, 500.0), (2000.0, 1000.0, 500.0, 200.0),
                (200.0, 500.0, 1000.0, 2000.0), (4000.0, 2000.0, 1000.0))
    rows = [("no planes", None, None)] + [(f"scales {c} share {s}", c, s)
                                          for c, s in itertools.product(cascades, (0.5, 0.7, 0.85))]
    for label, scales, share in rows:
        figures = []
        for _, left, raw, truth, nonocc in scenes:
            if scales is None:
                out = refine_disparity(raw, left).disparity
            else:
                h, w = raw.shape
                kept = remove_speckles(raw, max_size=max(20, h * w // 2000))
                planar = fill_from_planes(kept, left, scales=scales, min_inlier_share=share)
                out = _refined(kept, planar, left)
            figures.append(bad(out, truth, nonocc))
        print(f"{label:55s} mean {statistics.mean(figures):6.2f} | "
              + " ".join(f"{n} {b:.2f}" for (n, *_), b in zip(scenes, figures, strict=True)), flush=True)


def _refined(kept: np.ndarray, planar: np.ndarray, left: np.ndarray) -> np.ndarray:
    """What ``refine_disparity(planes=True)`` does with the planes given (speckles already removed)."""
    h, w = kept.shape
    support = np.isfinite(planar)
    filled = np.where(support, planar, fill_occlusions(kept)).astype(np.float32)
    return SMOOTHING_METHODS["median"](filled, left, support, radius=default_radius(h, w), sigma_color=12.0,
                                       sigma_space=MEDIAN_SIGMA_SPACE,
                                       keep_invalid=False)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", choices=("train", "heldout", "all"), default="all")
    ap.add_argument("--tune", action="store_true", help="score plane settings on the training scenes only")
    ap.add_argument("--patchmatch", action="store_true",
                    help="also patchmatch without and with planes (15-80 s per scene and column)")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"shared data not found at {DATA}; see shared/data/SOURCES.md", file=sys.stderr)
        return 1
    if args.tune:
        tune()
    else:
        table(args.scenes, args.patchmatch)
    return 0


if __name__ == "__main__":
    sys.exit(main())
