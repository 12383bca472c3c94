"""`vergence convert` at 1920x1080 per view: frames per second end to end, against its stages alone.

Synthetic clips are written to a temporary folder: an iw3-style RGBD video (3840x1080: a texture on a
depth ramp, a nearer textured square moving across it) and the full side-by-side stereo video of the
same scene (the square 24 px, the background 8 px apart). The texture is noise summed over octaves
(amplitude halving with each finer octave: closer to a photograph's spectrum than white noise, which
no codec compresses); x264's speed depends on the content, so the figures are for this one. Then, in this process, interleaved:

- ``convert_clip`` 2D + depth -> full SBS H.264 (decode of both passes, cut detection, stabilisation,
  synthesis, packing, encoding with x264's default preset and with ``veryfast`` and ``ultrafast``, the join), and the reference: ``synthesize_stereo`` alone on frames
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
# x264 presets timed for 2D + depth (the default, and two faster ones: larger files at the same CRF)
PRESETS = ("medium", "veryfast", "ultrafast")


def _texture(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """Noise summed over octaves (1/2 the amplitude per finer octave), in [0, 1]."""
    import cv2

    out = np.zeros((h, w, 3), np.float32)
    for octave in range(7):
        step = 2**octave
        coarse = rng.random((-(-h // step), -(-w // step), 3)).astype(np.float32)
        out += cv2.resize(coarse, (w, h), interpolation=cv2.INTER_LINEAR) * np.float32(2.0 ** (octave - 7))
    out -= out.min()
    return out / out.max()


def _scene(frames: int):
    """(left, right, inverse depth) per frame, made as they are taken (a 1080p frame is 56 MB in float32)."""
    rng = np.random.default_rng(0)
    texture = _texture(rng, H, W + 64)
    square = _texture(rng, 300, 300)
    ramp = np.tile(np.linspace(0.0, 0.4, W, dtype=np.float32), (H, 1))
    for k in range(frames):
        x = 200 + (24 * k) % (W - 600)  # back and forth across the frame on long clips
        left, right = texture[:, :W].copy(), texture[:, 8:8 + W].copy()
        left[400:700, x + 24:x + 324] = square
        right[400:700, x:x + 300] = square
        depth = ramp.copy()
        depth[400:700, x + 24:x + 324] = 0.9
        yield left, right, depth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=48, help="frames of the 2D + depth clip")
    parser.add_argument("--stereo-frames", type=int, default=4, help="frames of the stereo clip")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    rgbd_path, stereo_path = folder / layout_video_name("bench", "rgbd"), folder / layout_video_name("bench", "sbs")
    with VideoWriter(rgbd_path, fps=24, width=2 * W, height=H) as rgbd:
        for left, _, depth in _scene(args.frames):
            rgbd.write(np.concatenate([left, np.repeat(depth[:, :, None], 3, axis=2)], axis=1))
    with VideoWriter(stereo_path, fps=24, width=2 * W, height=H) as stereo:
        for left, right, _ in _scene(args.stereo_frames):
            stereo.write(np.concatenate([left, right], axis=1))
    display = Display.preset("tv-55")
    # the references run on frames in memory: the first 8 (their time per frame is what is compared)
    reference_frames = min(args.frames, 8)
    frames_2d = [(left, depth) for left, _, depth in _scene(reference_frames)]
    pairs = [(left, right) for left, right, _ in _scene(args.stereo_frames)]

    def convert(clip, name, preset="medium"):
        out = folder / layout_video_name(name, "sbs")
        convert_clip(clip, out, display, budget_arcmin=30.0, min_disparity=-SEARCH, max_disparity=SEARCH,
                     preset=preset)  # fmt: skip
        out.unlink()

    def synthesize_only():
        for image, depth in frames_2d:
            synthesize_stereo(image, depth, kind="inverse", display=display, budget_arcmin=30.0)

    def match_only():
        for left, right in pairs:
            compute_disparity(left, right, min_disparity=-SEARCH, max_disparity=SEARCH)

    cases = {f"convert 2D+depth -> SBS, x264 {p}": (lambda p=p: convert(open_depth_clip(rgbd_path), "out_2d", p),
                                                     args.frames) for p in PRESETS}  # fmt: skip
    cases["synthesize_stereo only"] = (synthesize_only, reference_frames)
    cases["convert stereo -> SBS, x264 medium"] = (lambda: convert(open_stereo(stereo_path), "out_stereo"),
                                                   args.stereo_frames)  # fmt: skip
    cases["compute_disparity only"] = (match_only, args.stereo_frames)
    for fn, _ in cases.values():  # warm-up: Numba kernels, OpenCV, x264
        fn()
    runs: dict[str, list] = {name: [] for name in cases}
    for _ in range(args.repeats):
        for name, (fn, _) in cases.items():
            runs[name].append(timed(fn))
    print(f"1920x1080 per view, {args.frames} frames (2D + depth), {args.stereo_frames} frames (stereo); "
          f"medians of {args.repeats}")
    for name, (_, frames) in cases.items():
        wall = report(name, runs[name], width=48)
        print(f"{'':48s} = {frames / wall:6.2f} frames/s")
    shutil.rmtree(folder)


if __name__ == "__main__":
    main()
