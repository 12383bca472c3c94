"""Render the test clips of vergence.video: tabletop, a cut, stadium; SBS stereo, RGBD and the truth.

    python examples/video/make_clips.py OUT [--frames-per-shot 24] [--width 160 --height 90]

writes OUT/clips_LRF_Full_SBS.mp4, OUT/clips_RGBD.mp4 and OUT/clips_truth.npz (nothing is kept in
git: the tests render their own, smaller, clips in a temporary folder). Then, for example:

    vergence analyze OUT/clips_LRF_Full_SBS.mp4 --display tv-55 --report OUT/report
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from vergence.video import make_test_clips


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--frames-per-shot", type=int, default=24)
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=90)
    parser.add_argument("--crf", type=int, default=12)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    clips = make_test_clips(args.out, frames_per_shot=args.frames_per_shot, width=args.width, height=args.height,
                            crf=args.crf)
    print(f"{clips.frames} frames ({clips.width}x{clips.height} per view), cut at {clips.cuts}, "
          f"in {time.perf_counter() - start:.1f} s:")
    for path in (clips.stereo, clips.rgbd, clips.truth):
        print(f"  {path} ({path.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
