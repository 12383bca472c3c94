"""Seeking in the video reader: the last frames of a clip, from their keyframe vs decoded from frame 0.

Two synthetic H.264 clips (960x540, 240 frames at 24 frames/s, x264 ``medium`` with its B-frames: a smooth
texture panning 4 px per frame, a nearer square crossing it) are written to a temporary folder, one with
x264's default keyframe interval (250: frame 0 is the only keyframe) and one with a keyframe every 24
frames. Then, interleaved, for each clip: ``FrameReader.frames(230, 240)`` as it runs now (a seek to the
keyframe at or before frame 230), and the reference, the same call made to decode from frame 0 (the
reader's path where seeking is not reliable, and its only path before it sought: ``_seek`` patched to
refuse; it then opens the file a second time, about 6 ms). With one keyframe there is nothing to gain:
that row shows what the check costs (the packets from the last keyframe to the end read, not decoded).

Run: ``.venv/bin/python benchmarks/video_seek.py [--frames N] [--last N] [--repeats N] [--width W --height H]``
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402

from vergence.video import VideoWriter, open_frames  # noqa: E402
from vergence.video import reader as reader_module  # noqa: E402



def _frames(n: int, W: int, H: int):
    """A smooth random texture panning 4 px per frame, a nearer square crossing it 8 px per frame; uint8."""
    rng = np.random.default_rng(0)
    coarse = rng.integers(0, 256, (H // 8 + 1, (W + 4 * n) // 8 + 1, 3), dtype=np.uint8)
    texture = np.repeat(np.repeat(coarse, 8, axis=0), 8, axis=1)[:H]
    square = rng.integers(0, 256, (120, 120, 3), dtype=np.uint8)
    for k in range(n):
        frame = texture[:, 4 * k:4 * k + W].copy()
        x = (100 + 8 * k) % (W - 120)
        frame[200:320, x:x + 120] = square
        yield frame


def _write(path: Path, n: int, gop: int | None, W: int, H: int) -> Path:
    video = VideoWriter(path, fps=24, width=W, height=H)
    if gop is not None:
        video._x264_options = {"g": str(gop)}
    with video:
        for frame in _frames(n, W, H):
            video.write(frame)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=240, help="frames of each clip")
    parser.add_argument("--last", type=int, default=10, help="frames read at the end of the clip")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=540)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    n, start = args.frames, args.frames - args.last
    size = args.width, args.height
    clips = {"GOP 250 (x264 default)": _write(folder / "gop250.mp4", n, None, *size),
             "GOP 24": _write(folder / "gop24.mp4", n, 24, *size)}

    def seeking(path):
        return lambda: list(open_frames(path).frames(start, n))

    def from_frame_0(path):
        def run():
            with mock.patch.object(reader_module, "_seek", lambda *args: None):
                return list(open_frames(path).frames(start, n))
        return run

    for path in clips.values():  # warm-up, and the two paths give the same frames
        for a, b in zip(seeking(path)(), from_frame_0(path)(), strict=True):
            np.testing.assert_array_equal(a, b)
    runs = {(name, way): [] for name in clips for way in ("seek", "from frame 0")}
    for _ in range(args.repeats):
        for name, path in clips.items():
            runs[name, "seek"].append(timed(seeking(path)))
            runs[name, "from frame 0"].append(timed(from_frame_0(path)))
    print(f"{args.width}x{args.height}, {n} frames, frames [{start}, {n}); medians of {args.repeats}")
    for name in clips:
        wall_seek = report(f"{name}: seek", runs[name, "seek"])
        wall_0 = report(f"{name}: from frame 0", runs[name, "from frame 0"])
        print(f"{'':44s} = seek / from frame 0 {wall_seek / wall_0:.3f} ({wall_0 / wall_seek:.1f}x faster)")
    shutil.rmtree(folder)


if __name__ == "__main__":
    main()
