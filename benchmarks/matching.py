"""Matching speed at 1920x1080 with 128 disparities: a plain OpenCV SGBM 3-way call vs our pipeline and PatchMatch.

The pair is synthetic but built from real photographs (``../shared/data/stereo``, Middlebury 2001
scenes, Scharstein & Szeliski 2002): a slanted background textured with ``poster`` and three
fronto-parallel foreground layers (``bull``, ``sawtooth`` and a flat, textureless card) at
disparities up to 118 px, rendered for both eyes with occlusions. Both contestants run in this
process, interleaved, several times; the script prints the medians (and the spread), their
ratio, the time our refinement adds on top of our own SGBM call, and the bad-pixel rates
(|error| > 1 px over the whole image minus a 10 px border) on this scene.

PatchMatch Stereo (``compute_disparity(method="patchmatch")``, Bleyer et al. 2011) is timed on the same
scene (``--pm-repeats`` runs, default 1: it takes minutes) and, with the raw SGBM call and our default
again, on a Middlebury pair at half size (dolls view1 / view5, 695 x 555, 128 disparities;
Scharstein & Pal 2007), all in this process.

``--sgbm-mode hh4`` (or ``hh``, ``sgbm``) runs our pipeline with another OpenCV SGBM mode instead of
3-way, to weigh the modes' time (``benchmarks/stereo_sgbm_grid.py`` scores them on the training scenes).

Run: ``.venv/bin/python benchmarks/matching.py [--repeats N] [--pm-repeats N] [--no-patchmatch] [--sgbm-mode M]``
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import cv2
import numpy as np

import vergence.depth.matching as matching
from vergence.depth import compute_disparity, fill_occlusions, match_sgbm, unreliable_pixels
from vergence.io import read_image

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "stereo"
DOLLS = DATA.parent / "multiview" / "dolls"
H, W, NUM_DISPARITIES = 1080, 1920, 128
SGBM_MODES = {"3way": cv2.StereoSGBM_MODE_SGBM_3WAY, "hh4": cv2.StereoSGBM_MODE_HH4, "hh": cv2.StereoSGBM_MODE_HH,
              "sgbm": cv2.StereoSGBM_MODE_SGBM}
BORDER = 10  # pixels ignored at the image edges when scoring, as in the Middlebury evaluation


def _texture(name: str, width: int) -> np.ndarray:
    img = read_image(DATA / name / "im2.png")
    return cv2.resize(img, (width, H), interpolation=cv2.INTER_CUBIC).clip(0.0, 1.0)


def _scene() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Left image, right image and the left ground-truth disparity of the synthetic scene."""
    pad = W + NUM_DISPARITIES + 8
    ys = np.arange(H, dtype=np.float32)
    # (texture, disparity of each row, left-image mask): background first, nearer layers after.
    card = np.full((H, pad, 3), (0.55, 0.5, 0.45), np.float32)
    layers = [
        (_texture("poster", pad), 12.0 + 40.0 * ys / (H - 1), np.ones((H, W), bool)),
        (_texture("bull", pad), np.full(H, 70.5, np.float32), None),
        (card, np.full(H, 95.25, np.float32), None),
        (_texture("sawtooth", pad), np.full(H, 118.0, np.float32), None),
    ]
    boxes = {1: (120, 620, 300, 900), 2: (650, 1000, 1000, 1450), 3: (200, 520, 1300, 1750)}
    for k, (y0, y1, x0, x1) in boxes.items():
        m = np.zeros((H, W), bool)
        m[y0:y1, x0:x1] = True
        layers[k] = (layers[k][0], layers[k][1], m)
    left = np.zeros((H, W, 3), np.float32)
    right = np.zeros((H, W, 3), np.float32)
    truth = np.zeros((H, W), np.float32)
    xs = np.arange(W, dtype=np.float32)[None, :].repeat(H, 0)
    yy = ys[:, None].repeat(W, 1)
    for tex, d_row, mask in layers:
        d = d_row[:, None].repeat(W, 1)
        # the layer's texture is attached to left coordinates; the right eye sees it shifted by -d
        left[mask] = tex[:, :W][mask]
        truth[mask] = d[mask]
        mx = xs + d  # right pixel x_r shows the left-coordinate point x_r + d
        tex_r = cv2.remap(tex, mx, yy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        mask_r = cv2.remap(mask.astype(np.uint8), mx, yy, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT) > 0
        right[mask_r] = tex_r[mask_r]
    return left, right, truth


def _bad(estimate: np.ndarray, truth: np.ndarray) -> float:
    region = np.zeros(truth.shape, bool)
    region[BORDER:-BORDER, BORDER:-BORDER] = True
    err = np.abs(estimate - truth)
    return float(100.0 * np.mean(~(err[region] <= 1.0)))  # NaN (unknown) counts as bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--pm-repeats", type=int, default=1, help="PatchMatch runs per scene (minutes each at 1080p)")
    ap.add_argument("--no-patchmatch", action="store_true", help="time the SGBM pipelines only")
    ap.add_argument("--sgbm-mode", choices=tuple(SGBM_MODES), default="3way",
                    help="OpenCV SGBM mode of our pipeline (the raw baseline stays 3-way)")
    args = ap.parse_args(argv)
    if args.sgbm_mode != "3way":
        original = matching.sgbm_parameters
        matching.sgbm_parameters = lambda *a: {**original(*a), "mode": SGBM_MODES[args.sgbm_mode]}
    if not DATA.is_dir():
        print(f"shared data not found at {DATA}; see shared/data/SOURCES.md", file=sys.stderr)
        return 1
    left, right, truth = _scene()
    lu = np.rint(left * 255).astype(np.uint8)
    ru = np.rint(right * 255).astype(np.uint8)
    block = 5
    raw_matcher = cv2.StereoSGBM_create(  # the raw baseline of benchmarks/middlebury.py, 3-way mode
        minDisparity=0, numDisparities=NUM_DISPARITIES, blockSize=block, P1=8 * 3 * block**2, P2=32 * 3 * block**2,
        disp12MaxDiff=1, uniquenessRatio=10, speckleWindowSize=100, speckleRange=2, mode=cv2.StereoSGBM_MODE_SGBM_3WAY)
    compute_disparity(left[:64, :256], right[:64, :256], max_disparity=31)  # compile the Numba kernels first
    t_raw, t_ours, t_match, t_planes = [], [], [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        raw = raw_matcher.compute(lu, ru)
        t_raw.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        ours = compute_disparity(left, right, max_disparity=NUM_DISPARITIES - 1)
        t_ours.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        matched = match_sgbm(left, right, max_disparity=NUM_DISPARITIES - 1)
        t_match.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        planar = compute_disparity(left, right, max_disparity=NUM_DISPARITIES - 1, planes=True)
        t_planes.append(time.perf_counter() - t0)
    raw_d = raw.astype(np.float32) / 16.0
    raw_d[raw < 0] = np.nan
    med = statistics.median
    refine = med(t_ours) - med(t_match)
    frac = float(np.mean(unreliable_pixels(fill_occlusions(matched))))
    print(f"scene {W}x{H}, {NUM_DISPARITIES} disparities, {args.repeats} interleaved runs (median [min-max] s)"
          + (f"; our pipeline in SGBM mode {args.sgbm_mode}" if args.sgbm_mode != "3way" else ""))
    print(f"  raw OpenCV SGBM 3-way   {med(t_raw):.3f} [{min(t_raw):.3f}-{max(t_raw):.3f}]")
    print(f"  our default pipeline    {med(t_ours):.3f} [{min(t_ours):.3f}-{max(t_ours):.3f}]")
    print(f"    of which our SGBM call {med(t_match):.3f}, refinement {refine:.3f} "
          f"({refine / med(t_match):.2f} x the matching; {100 * frac:.1f} % of pixels re-estimated)")
    print(f"  ratio ours / raw        {med(t_ours) / med(t_raw):.2f}")
    print(f"  default + planes        {med(t_planes):.3f} [{min(t_planes):.3f}-{max(t_planes):.3f}]; "
          f"ratio / raw {med(t_planes) / med(t_raw):.2f}")
    print(f"  bad pixels (>1 px)      raw {_bad(raw_d, truth):.2f} %   ours {_bad(ours.disparity, truth):.2f} %   "
          f"ours + planes {_bad(planar.disparity, truth):.2f} %")
    if args.no_patchmatch:
        return 0
    compute_disparity(left[:64, :256], right[:64, :256], max_disparity=31, method="patchmatch")  # compile
    t_pm = []
    for _ in range(args.pm_repeats):
        t0 = time.perf_counter()
        pm = compute_disparity(left, right, max_disparity=NUM_DISPARITIES - 1, method="patchmatch")
        t_pm.append(time.perf_counter() - t0)
    print(f"  patchmatch              {med(t_pm):.3f} ({args.pm_repeats} run{'s' if args.pm_repeats > 1 else ''}); "
          f"ratio patchmatch / raw {med(t_pm) / med(t_raw):.1f}; bad pixels {_bad(pm.disparity, truth):.2f} %")
    _half_size(args, raw_matcher)
    return 0


def _half_size(args: argparse.Namespace, raw_matcher: cv2.StereoSGBM) -> None:
    """The three contestants on a Middlebury 2005 pair at half size (dolls view1 / view5, 128 disparities)."""
    left, right = read_image(DOLLS / "view1.png"), read_image(DOLLS / "view5.png")
    lu, ru = np.rint(left * 255).astype(np.uint8), np.rint(right * 255).astype(np.uint8)
    times: dict[str, list[float]] = {"raw": [], "default": [], "patchmatch": []}
    for k in range(max(args.repeats, args.pm_repeats)):
        t0 = time.perf_counter()
        raw_matcher.compute(lu, ru)
        times["raw"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        compute_disparity(left, right, max_disparity=NUM_DISPARITIES - 1)
        times["default"].append(time.perf_counter() - t0)
        if k < args.pm_repeats:
            t0 = time.perf_counter()
            compute_disparity(left, right, max_disparity=NUM_DISPARITIES - 1, method="patchmatch")
            times["patchmatch"].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"dolls view1/view5 {left.shape[1]}x{left.shape[0]}, {NUM_DISPARITIES} disparities (median s)")
    print(f"  raw OpenCV SGBM 3-way {med['raw']:.3f}   default {med['default']:.3f} "
          f"(ratio {med['default'] / med['raw']:.2f})   patchmatch {med['patchmatch']:.2f} "
          f"(ratio {med['patchmatch'] / med['raw']:.1f})")


if __name__ == "__main__":
    sys.exit(main())
