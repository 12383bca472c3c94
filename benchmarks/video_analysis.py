"""`vergence analyze` per frame at 1920x1080 per view: the whole analysis vs its matching alone.

A synthetic full side-by-side H.264 clip (3840x1080, 6 frames: a random texture and a nearer
textured square 24 px apart, moving) is written to a temporary folder; then, in this process,
interleaved: ``analyze_clip`` on every frame (decode, cut detection, matching with the padded views,
the right view's edge strip, statistics and the shot histograms; vertical disparity off, then on)
and the reference, a bare ``compute_disparity`` call per pair on frames already in memory (what
``vergence match`` does). The difference is what the analysis adds around the matcher.

Run: ``.venv/bin/python benchmarks/video_analysis.py [--repeats N]``
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402

from vergence.depth import compute_disparity  # noqa: E402
from vergence.video import VideoWriter, analyze_clip, layout_video_name, open_stereo  # noqa: E402
from vergence.viewing import Display  # noqa: E402

H, W, FRAMES, SEARCH = 1080, 1920, 6, 48


def _pairs():
    rng = np.random.default_rng(0)
    texture = rng.random((H, W + 64, 3)).astype(np.float32)
    square = rng.random((300, 300, 3)).astype(np.float32)
    for k in range(FRAMES):
        right = texture[:, 8:8 + W].copy()
        left = texture[:, :W].copy()  # the background 8 px apart (left x = right x + 8)
        x = 600 + 40 * k
        left[400:700, x + 24:x + 324] = square  # the square 24 px apart
        right[400:700, x:x + 300] = square
        yield left, right


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    path = folder / layout_video_name("bench", "sbs")
    pairs = list(_pairs())
    with VideoWriter(path, fps=24, width=2 * W, height=H) as video:
        for left, right in pairs:
            video.write(np.concatenate([left, right], axis=1))
    display = Display.preset("tv-55")
    options = {"min_disparity": -SEARCH, "max_disparity": SEARCH}
    runs = {"analyze_clip": [], "analyze_clip + vertical": [], "compute_disparity only": []}
    analyze_clip(open_stereo(path), display, every=FRAMES, vertical=False, **options)  # warm-up (Numba, OpenCV)
    for _ in range(args.repeats):
        runs["analyze_clip"].append(timed(lambda: analyze_clip(open_stereo(path), display, vertical=False, **options)))
        runs["analyze_clip + vertical"].append(timed(lambda: analyze_clip(open_stereo(path), display, **options)))
        runs["compute_disparity only"].append(timed(lambda: [
            compute_disparity(a, b, keep_invalid=True, **options) for a, b in pairs]))  # fmt: skip
    print(f"{FRAMES} frames of 1920x1080 per view, +-{SEARCH} px searched, {args.repeats} repeats:")
    walls = {name: report(name, r) for name, r in runs.items()}
    ref = walls["compute_disparity only"]
    for name in ("analyze_clip", "analyze_clip + vertical"):
        print(f"{name}: {FRAMES / walls[name]:.2f} frames/s; {walls[name] / ref:.2f}x the bare matching "
              f"({FRAMES / ref:.2f} frames/s)")


if __name__ == "__main__":
    main()
