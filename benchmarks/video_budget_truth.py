"""Does `vergence convert --budget-arcmin 30` use the budget on a clip of wide disparity, and keep the truth's order?

Issue 28's clip: full SBS, two shots, true disparities 36-95 px at 480 px per view. This script makes one
from real images with ground truth, with the library's own tools, then runs `analyze` and `convert` with
their defaults and measures against the truth:

1. **The clip.** Two Middlebury 2005/2006 scenes (``../shared/data/multiview``: dolls, then aloe; view1 and
   its disparity disp1, Scharstein & Pal 2007) resized to 560 px wide; the truth is their disparity mapped
   linearly onto 36..95 px (dolls) and 40..92 px (aloe) at that size (a monotone map of a disparity is the
   disparity of another shifted-sensor rig). The right view is the left one forward-warped by it
   (:func:`vergence.synthesis.forward_warp`, holes filled from the background:
   :func:`vergence.synthesis.fill_holes`); each frame is a 480 x 272 window of the pair panning 2 px a
   frame (less in long shots, to stay inside). H.264 crf 16 (:class:`vergence.video.VideoWriter`). The
   truth of a frame is NaN where the scene's disparity is unknown or the match falls left of the right
   view (``x - D < 0``).
2. **analyze** (defaults: the search range from the content): each shot's p50 and p95 against the
   truth's, with issue 28's tolerance max(3 px, 5 %).
3. **convert** ``--budget-arcmin 30`` on tv-55 (defaults): the output matched again (``vergence analyze``
   on every second frame: its 1st-99th percentiles against the budget, the share of it they span), and
   the rank correlation (Spearman) of the output's re-matched disparity with the truth, per shot, on the
   middle frame of each shot (issue 28: r >= 0.8).

Run: ``python benchmarks/video_budget_truth.py [FOLDER] [--frames-per-shot 12] [--floating-window]``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "multiview"
SCENES = (("dolls", 36.0, 95.0), ("aloe", 40.0, 92.0))
WIDTH, HEIGHT, RESIZED, PAN_PX = 480, 272, 560, 2


def _scene(name: str, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, truth) of a scene at RESIZED px wide: the truth mapped onto [lo, hi], NaN where unknown."""
    import cv2

    from vergence.io import read_image
    from vergence.synthesis import fill_disparity, fill_holes, forward_warp

    image = read_image(DATA / name / "view1.png")
    raw = read_image(DATA / name / "disp1.png")
    raw = (raw if raw.ndim == 2 else raw[..., 0]).astype(np.float64) * 255.0 / 2.0  # PNG value / 2 (SOURCES.md)
    raw[raw == 0] = np.nan
    k = RESIZED / image.shape[1]
    size = (RESIZED, int(round(image.shape[0] * k)))
    left = cv2.resize(image, size, interpolation=cv2.INTER_AREA).astype(np.float32)
    d = cv2.resize(raw, size, interpolation=cv2.INTER_NEAREST)
    known = np.isfinite(d)
    a, b = np.nanpercentile(d, [0.5, 99.5])
    truth = np.where(known, lo + (np.clip(d, a, b) - a) * (hi - lo) / (b - a), np.nan)
    warped = forward_warp(left, fill_disparity(truth), scale=1.0)
    right, _ = fill_holes(warped.image, np.nan_to_num(warped.nearness, nan=0.0), warped.holes)
    return left, np.clip(right, 0.0, 1.0).astype(np.float32), truth


def write_clip(path: Path, frames_per_shot: int) -> np.ndarray:
    """Write the clip (module docstring) and return its truth, (N, HEIGHT, WIDTH) float64."""
    from vergence.video import VideoWriter

    truths = []
    with VideoWriter(path, fps=24, width=2 * WIDTH, height=HEIGHT, crf=16) as writer:
        for name, lo, hi in SCENES:
            left, right, truth = _scene(name, lo, hi)
            y0 = (left.shape[0] - HEIGHT) // 2
            pan = min(PAN_PX, (left.shape[1] - WIDTH) / max(1, frames_per_shot - 1))  # the window stays inside
            for f in range(frames_per_shot):
                x0 = int(round(pan * f))
                window = (slice(y0, y0 + HEIGHT), slice(x0, x0 + WIDTH))
                writer.write(np.concatenate([left[window], right[window]], axis=1))
                t = truth[window].copy()
                x = np.arange(WIDTH)[None, :]
                t[~(x - t >= 0)] = np.nan  # no match inside the right view
                truths.append(t)
    return np.stack(truths)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path)
    parser.add_argument("--frames-per-shot", type=int, default=12)
    parser.add_argument("--floating-window", action="store_true")
    args = parser.parse_args()
    if not DATA.is_dir():
        sys.exit(f"the Middlebury scenes are not there: {DATA}")
    folder = args.folder or Path(tempfile.mkdtemp())
    folder.mkdir(parents=True, exist_ok=True)

    from scipy.stats import spearmanr

    from vergence.video import open_stereo
    from vergence.video._matching import match_padded
    from vergence.video.analysis import analyze_clip
    from vergence.video.convert import convert_clip
    from vergence.viewing import DISPLAY_PRESETS, pixels_from_arcmin

    display = DISPLAY_PRESETS["tv-55"]
    source = folder / "middlebury_LRF_Full_SBS.mp4"
    truth = write_clip(source, args.frames_per_shot)
    print(f"clip: {len(truth)} frames, {WIDTH}x{HEIGHT} per view, true disparity "
          f"{np.nanmin(truth):.1f} .. {np.nanmax(truth):.1f} px ({source})")

    t0 = time.perf_counter()
    analysis = analyze_clip(open_stereo(source), display, vertical=False)
    print(f"analyze (defaults): {len(analysis.shots)} shots, cuts at {[s.start for s in analysis.shots[1:]]}, "
          f"{time.perf_counter() - t0:.1f} s")
    for k, shot in enumerate(analysis.shots):
        values = truth[shot.start:shot.end][np.isfinite(truth[shot.start:shot.end])]
        for p in (50, 95):
            true, got = float(np.percentile(values, p)), shot.disparity_px[f"p{p}"]
            tol = max(3.0, 0.05 * abs(true))
            print(f"  shot {k} p{p}: truth {true:+7.2f}, analyze {got:+7.2f} px (|error| {abs(got - true):.2f}, "
                  f"tolerance {tol:.2f}: {'ok' if abs(got - true) <= tol else 'FAILS'})")

    t0 = time.perf_counter()
    out = folder / ("fw_LRF_Full_SBS.mp4" if args.floating_window else "out_LRF_Full_SBS.mp4")
    result = convert_clip(open_stereo(source), out, display, budget_arcmin=30.0, floating_window=args.floating_window,
                          force=True)  # fmt: skip
    print(f"convert --budget-arcmin 30 (defaults): {result.frames} frames in {time.perf_counter() - t0:.1f} s")
    view_px = WIDTH / display.resolution
    lo = -float(pixels_from_arcmin(30.0, display)) * view_px  # the budget in D of the views: behind ...
    hi = -float(pixels_from_arcmin(-30.0, display)) * view_px  # ... and in front
    measured = analyze_clip(open_stereo(result.out), display, every=2, vertical=False)
    output = open_stereo(result.out)
    for k, (shot, again) in enumerate(zip(result.shots, measured.shots)):
        d = again.disparity_px
        inside = lo - 0.75 <= d["p1"] and d["p99"] <= hi + 0.75
        span = (d["p99"] - d["p1"]) / (hi - lo)
        middle = (shot.start + shot.end - 1) // 2
        left, right = next(iter(output.pairs(middle, middle + 1)))
        s_lo, s_hi = again.search["search_px"]
        matched = match_padded(left, right, s_lo, s_hi, "sgbm")
        both = np.isfinite(matched) & np.isfinite(truth[middle])
        r = float(spearmanr(matched[both], truth[middle][both]).statistic)
        window = shot.window or {}
        print(f"  shot {k}: source {shot.range_in[0]:+.2f} .. {shot.range_in[1]:+.2f} px (1-99 %) -> output "
              f"{d['p1']:+.2f} .. {d['p99']:+.2f} px (1-99 %, re-matched) in a budget of {lo:+.2f} .. {hi:+.2f} px: "
              f"{'inside' if inside else 'OUTSIDE'}, spans {100 * span:.0f} % of it; rank correlation with the truth "
              f"r = {r:.3f} (frame {middle}, {100 * both.mean():.0f} % of the pixels); floating window "
              f"{window.get('left_px', 0)} / {window.get('right_px', 0)} px")  # fmt: skip
    print(f"  flicker on static content: {result.flicker_before.mean_px:.4f} px before, "
          f"{result.flicker_after.mean_px:.4f} px after stabilisation (the filtered disparity); "
          f"{result.flicker_output.mean_px:.4f} px measured on the output")
    for line in result.warnings:
        print(f"  warning: {line}")


if __name__ == "__main__":
    main()
