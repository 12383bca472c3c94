"""`vergence convert` at 1920x1080 per view: frames per second end to end, against its stages alone.

Synthetic clips are written to a temporary folder: an iw3-style RGBD video (3840x1080: a random texture
on a depth ramp, a nearer textured square moving across it) and the full side-by-side stereo video of
the same scene (the square 24 px, the background 8 px apart). Then, in this process, interleaved:

- ``convert_clip`` 2D + depth -> full SBS H.264 (decode of both passes, cut detection, stabilisation,
  synthesis, packing, encoding with x264's default preset and with ``veryfast``, the join), and the reference: ``synthesize_stereo`` alone on frames
  already in memory with a fixed budget (what ``vergence synthesize`` does per image);
- ``convert_clip`` stereo -> retargeted SBS, and its reference: ``compute_disparity`` alone per pair
  (the matching that bounds it).

Frames per second = frames / median wall time. The issue's goal is 15 fps for 2D + depth -> 1080p SBS.

Run: ``.venv/bin/python benchmarks/video_convert.py [--frames N] [--stereo-frames N] [--repeats N]``
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402

from vergence.depth import compute_disparity  # noqa: E402
from vergence.synthesis import synthesize_stereo  # noqa: E402
from vergence.video import VideoWriter, convert_clip, layout_video_name, open_depth_clip, open_stereo  # noqa: E402
from vergence.viewing import Display  # noqa: E402

H, W, SEARCH = 1080, 1920, 48


def _scene(frames: int):
    """(left, right, colour, inverse depth) per frame."""
    rng = np.random.default_rng(0)
    texture = rng.random((H, W + 64, 3)).astype(np.float32)
    square = rng.random((300, 300, 3)).astype(np.float32)
    ramp = np.tile(np.linspace(0.0, 0.4, W, dtype=np.float32), (H, 1))
    for k in range(frames):
        x = 600 + 40 * k
        left, right = texture[:, :W].copy(), texture[:, 8:8 + W].copy()
        left[400:700, x + 24:x + 324] = square
        right[400:700, x:x + 300] = square
        depth = ramp.copy()
        depth[400:700, x + 24:x + 324] = 0.9
        yield left, right, depth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=12, help="frames of the 2D + depth clip")
    parser.add_argument("--stereo-frames", type=int, default=4, help="frames of the stereo clip")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    rgbd_path, stereo_path = folder / layout_video_name("bench", "rgbd"), folder / layout_video_name("bench", "sbs")
    scene = list(_scene(max(args.frames, args.stereo_frames)))
    with VideoWriter(rgbd_path, fps=24, width=2 * W, height=H) as rgbd:
        for left, _, depth in scene[: args.frames]:
            rgbd.write(np.concatenate([left, np.repeat(depth[:, :, None], 3, axis=2)], axis=1))
    with VideoWriter(stereo_path, fps=24, width=2 * W, height=H) as stereo:
        for left, right, _ in scene[: args.stereo_frames]:
            stereo.write(np.concatenate([left, right], axis=1))
    display = Display.preset("tv-55")
    frames_2d = [(left, depth) for left, _, depth in scene[: args.frames]]
    pairs = [(left, right) for left, right, _ in scene[: args.stereo_frames]]

    def convert(clip, name, preset="medium"):
        out = folder / layout_video_name(name, "sbs")
        convert_clip(clip, out, display, budget_arcmin=30.0, min_disparity=-SEARCH, max_disparity=SEARCH,
                     preset=preset)  # fmt: skip
        out.unlink()

    def convert_2d():
        convert(open_depth_clip(rgbd_path), "out_2d")

    def convert_2d_veryfast():
        convert(open_depth_clip(rgbd_path), "out_2d", "veryfast")

    def convert_stereo():
        convert(open_stereo(stereo_path), "out_stereo")

    def synthesize_only():
        for image, depth in frames_2d:
            synthesize_stereo(image, depth, kind="inverse", display=display, budget_arcmin=30.0)

    def match_only():
        for left, right in pairs:
            compute_disparity(left, right, min_disparity=-SEARCH, max_disparity=SEARCH)

    # warm-up: Numba kernels, OpenCV, x264
    for fn in (convert_2d, synthesize_only):
        fn()
    runs = {"convert 2D+depth -> SBS": [], "convert 2D+depth -> SBS, veryfast": [], "synthesize_stereo only": [], "convert stereo -> SBS": [],
            "compute_disparity only": []}
    for _ in range(args.repeats):
        runs["convert 2D+depth -> SBS"].append(timed(convert_2d))
        runs["convert 2D+depth -> SBS, veryfast"].append(timed(convert_2d_veryfast))
        runs["synthesize_stereo only"].append(timed(synthesize_only))
        runs["convert stereo -> SBS"].append(timed(convert_stereo))
        runs["compute_disparity only"].append(timed(match_only))
    print(f"1920x1080 per view, {args.frames} frames (2D + depth), {args.stereo_frames} frames (stereo); "
          f"medians of {args.repeats}")
    for name, frames in (("convert 2D+depth -> SBS", args.frames), ("convert 2D+depth -> SBS, veryfast", args.frames),
                         ("synthesize_stereo only", args.frames),
                         ("convert stereo -> SBS", args.stereo_frames), ("compute_disparity only", args.stereo_frames)):
        wall = report(name, runs[name])
        print(f"{'':44s} = {frames / wall:6.2f} frames/s")
    shutil.rmtree(folder)


if __name__ == "__main__":
    main()
