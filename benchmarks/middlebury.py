"""Middlebury evaluation table: a plain OpenCV SGBM 3-way call vs our default pipeline.

Data: ``../shared/data/stereo`` (Scharstein & Szeliski 2002; see ``shared/data/SOURCES.md``).
tsukuba (im3/im4, truth / 16) and venus (im2/im6, truth / 8) are scored with the official v2 masks;
barn2, bull, poster and sawtooth (im2/im6, truth / 8) with the regions computed from the two
ground-truth disparities (``middlebury_regions``: nonocc, all, disc, textureless). Bad = |error|
> 1 px; an unknown estimate counts as bad (Middlebury tables). The raw matcher is one plain
OpenCV call on the colour images: OpenCV's sample settings (block 5, P1 = 8*3*25, P2 = 32*3*25,
uniqueness 10, disp12MaxDiff 1, 3-way) with the speckle filter as OpenCV's documentation advises
(window 100, range 2: "1 or 2 is good enough"), over numDisparities = 16 (tsukuba) or 32 (the
others). These are the settings that give the issue's baseline, 4.27 % (tsukuba) and 7.24 % (venus)
bad nonocc; the sample's speckle range 32 gives 4.15 % and 7.24 %. Ours is ``compute_disparity`` over the same
range with its defaults. ``--wide`` repeats everything with twice the range, a check that the
gains do not depend on a tight search range. The script also prints the agreement of the computed
regions with the official tsukuba and venus masks (our check of the evaluator), and the rectification
check: the 47 adjacent pairs of ``../shared/data/collections/dino`` (Seitz et al. 2006) are rectified
with FTV from ``dino_par.txt`` and the vertical offsets |dy| of their RANSAC-consistent SIFT matches are
pooled (before rectification they are 6-18 px apart).

Run: ``.venv/bin/python benchmarks/middlebury.py [--wide] [--no-dino]``
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from vergence.depth import (
    compute_disparity,
    evaluate_disparity,
    mask_agreement,
    measure_row_alignment,
    middlebury_regions,
    read_middlebury_masks,
    rectify_pair,
)
from vergence.io import read_disparity, read_image, read_middlebury_par

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "stereo"
DINO = DATA.parent / "collections" / "dino"
# scene: left, right, truth, right truth, scale, numDisparities
SCENES = {
    "tsukuba": ("im3.png", "im4.png", "groundtruth.png", None, 16, 16),
    "venus": ("im2.ppm", "im6.ppm", "disp2.pgm", "disp6.pgm", 8, 32),
    "barn2": ("im2.png", "im6.png", "disp2.png", "disp6.png", 8, 32),
    "bull": ("im2.png", "im6.png", "disp2.png", "disp6.png", 8, 32),
    "poster": ("im2.png", "im6.png", "disp2.png", "disp6.png", 8, 32),
    "sawtooth": ("im2.png", "im6.png", "disp2.png", "disp6.png", 8, 32),
}
OFFICIAL = ("tsukuba", "venus")


def raw_sgbm(left: np.ndarray, right: np.ndarray, num_disparities: int) -> np.ndarray:
    """One plain OpenCV call: the stereo_match sample's settings, speckle range 2 as documented, 3-way mode."""
    block = 5
    sgbm = cv2.StereoSGBM_create(
        minDisparity=0, numDisparities=num_disparities, blockSize=block, P1=8 * 3 * block**2, P2=32 * 3 * block**2,
        disp12MaxDiff=1, uniquenessRatio=10, speckleWindowSize=100, speckleRange=2, mode=cv2.StereoSGBM_MODE_SGBM_3WAY)
    to_u8 = lambda img: np.rint(img * 255).astype(np.uint8)
    fixed = sgbm.compute(to_u8(left), to_u8(right))
    d = fixed.astype(np.float32) / 16.0
    d[fixed < 0] = np.nan
    return d


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wide", action="store_true", help="search twice the disparity range")
    ap.add_argument("--no-dino", action="store_true", help="skip the rectification check on the dino pairs")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"shared data not found at {DATA}; see shared/data/SOURCES.md", file=sys.stderr)
        return 1
    factor = 2 if args.wide else 1
    print(f"{'scene':9s} {'regions':8s} {'range':>5s} | {'raw OpenCV SGBM 3-way':^29s} | {'our default pipeline':^29s} | nonocc cut")
    print(f"{'':9s} {'':8s} {'':>5s} | {'nonocc':>6s} {'all':>6s} {'disc':>6s} {'texl':>6s}  | "
          f"{'nonocc':>6s} {'all':>6s} {'disc':>6s} {'texl':>6s}  |")
    agreement = {}
    for name, (lf, rf, tf, trf, scale, ndisp) in SCENES.items():
        folder = DATA / name
        left, right = read_image(folder / lf), read_image(folder / rf)
        truth = read_disparity(folder / tf, scale=scale)
        truth_right = read_disparity(folder / trf, scale=scale) if trf else None
        ndisp *= factor
        if name in OFFICIAL:
            masks = read_middlebury_masks(folder)
            computed = middlebury_regions(truth, truth_right=truth_right)
            agreement[name] = {k: mask_agreement(computed[k], masks[k]) for k in masks}
            kw = {"masks": masks}
        else:
            kw = {"image": left, "truth_right": truth_right}
        raw = evaluate_disparity(raw_sgbm(left, right, ndisp), truth, **kw)
        ours = evaluate_disparity(compute_disparity(left, right, max_disparity=ndisp - 1).disparity, truth, **kw)

        def row(s: dict) -> str:
            return " ".join(f"{s[k].bad:6.2f}" if k in s else f"{'-':>6s}" for k in ("nonocc", "all", "disc", "textureless"))

        cut = 100.0 * (1.0 - ours["nonocc"].bad / raw["nonocc"].bad)
        kind = "official" if name in OFFICIAL else "computed"
        print(f"{name:9s} {kind:8s} {ndisp:5d} | {row(raw)}  | {row(ours)}  | {cut:5.1f} %")
    print("\nagreement of the computed regions with the official masks (% of pixels):")
    for name, agr in agreement.items():
        print(f"  {name:8s} " + "  ".join(f"{k} {v:.3f}" for k, v in agr.items()))
    if not args.no_dino:
        _dino()
    return 0


def _dino() -> None:
    """Rectify dino(k) (left) with dino(k-1) (right) for k = 2..48 and pool the SIFT |dy|."""
    cams = read_middlebury_par(DINO / "dino_par.txt", image_size=(640, 480))
    pooled, medians = [], []
    for k in range(2, 49):
        a, b = f"dino{k:04d}.png", f"dino{k - 1:04d}.png"
        pair = rectify_pair(read_image(DINO / a), read_image(DINO / b), cams.camera(a), cams.camera(b))
        rows = measure_row_alignment(pair.left, pair.right)
        pooled.append(rows.abs_dy_px)
        medians.append(rows.median_abs_dy_px)
    dy = np.concatenate(pooled)
    print(f"\nrectification, {len(medians)} adjacent dino pairs: median |dy| {np.median(dy):.3f} px, 90th percentile "
          f"{np.percentile(dy, 90):.3f} px over {dy.size} SIFT matches; per-pair medians "
          f"{min(medians):.3f}-{max(medians):.3f} px (median {np.median(medians):.3f})")


if __name__ == "__main__":
    sys.exit(main())
