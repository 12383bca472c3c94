"""Retarget the test clips into a budget and check it: flicker before/after and the analysis of the output.

    python examples/video/convert_clips.py OUT [--frames-per-shot 24] [--budget-arcmin 30] [--display tv-55]

Renders the test clips twice into OUT (``moving``: the camera moves sideways, as make_clips.py; ``static``:
the same shots with the camera still), converts the RGBD and the stereo clip of each with
``convert_clip`` (full SBS), prints the flicker of the output parallax on static content without and with
the stabilisation, then analyses each output with ``analyze_clip`` and prints every shot's 1st-99th
percentile range in arcmin against the budget.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from vergence.video import CLIP_SHOTS, analyze_clip, convert_clip, make_test_clips, open_depth_clip, open_stereo
from vergence.viewing import Display


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--frames-per-shot", type=int, default=24)
    parser.add_argument("--budget-arcmin", type=float, default=30.0)
    parser.add_argument("--display", default="tv-55")
    args = parser.parse_args()
    display = Display.preset(args.display)
    for name, shots in (("moving", CLIP_SHOTS), ("static", tuple(dataclasses.replace(s, travel=0.0) for s in CLIP_SHOTS))):
        folder = args.out / name
        folder.mkdir(parents=True, exist_ok=True)
        clips = make_test_clips(folder, frames_per_shot=args.frames_per_shot, shots=shots, name=name)
        for kind, clip_of in (("2d+depth", lambda: open_depth_clip(clips.rgbd)), ("stereo", lambda: open_stereo(clips.stereo))):
            out = folder / f"{name}_{kind.replace('+', '_')}_LRF_Full_SBS.mp4"
            start = time.perf_counter()
            result = convert_clip(clip_of(), out, display, budget_arcmin=args.budget_arcmin, force=True)  # a rerun replaces
            seconds = time.perf_counter() - start
            off = convert_clip(clip_of(), folder / f"{name}_{kind.replace('+', '_')}_raw_LRF_Full_SBS.mp4", display,
                               budget_arcmin=args.budget_arcmin, stabilize=False, force=True)  # fmt: skip
            print(f"{name:6s} {kind:8s}: {result.frames} frames in {seconds:.1f} s; flicker on static content "
                  f"{result.flicker_before.mean_px:.4f} px before, {result.flicker_after.mean_px:.4f} px after "
                  f"(static share {result.flicker_after.static_share:.2f}; the unstabilised output: "
                  f"{off.flicker_after.mean_px:.4f} px)")  # fmt: skip
            analysis = analyze_clip(open_stereo(out), display, vertical=False)
            for shot in analysis.shots:
                a = shot.disparity_arcmin
                print(f"    shot {shot.start}-{shot.end - 1}: analysed {a['p1']:+.1f} .. {a['p99']:+.1f} arcmin "
                      f"(1-99 %), budget +-{args.budget_arcmin:g}")


if __name__ == "__main__":
    main()
