"""`vergence convert` on more cores: the serial run against Dask clusters of N single-thread workers.

The 2-core development machine cannot show what Dask gains (``video_convert_dask.py``: the serial run
already keeps both cores busy). This script measures it where there are more cores. Two steps, so the
clips can be rendered where Mitsuba is installed and timed elsewhere:

1. ``--make DIR``: render the test clips (:func:`vergence.video.make_test_clips`, two shots) at
   ``--width``, then write them ``--tile`` times back to back (``tiled_RGBD.mp4`` and
   ``tiled_LRF_Full_SBS.mp4``: 2 x tile shots, the cut detector finds every cut).
2. ``--clips DIR``: convert both to full SBS H.264 (budget +-30 arcmin on tv-55) serially (Numba's
   threads over every core, x264's own threads) and on a running ``LocalCluster`` of N one-thread
   workers for each N of ``--workers`` (``--scheduler ADDRESS``: the tasks alone, the cluster's start
   outside the time; each worker's Numba/OpenCV threads set to its share of the cores), and prints the
   wall time, frames per second and the speed-up over the serial run. One warm-up run of each first
   (Numba's on-disk caches, the workers' imports). Medians of ``--repeats``.

Run: ``python benchmarks/video_convert_scaling.py --make DIR [--width 640 --frames-per-shot 24 --tile 8]``,
then ``python benchmarks/video_convert_scaling.py --clips DIR [--workers 2,4,8,16] [--repeats 1]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402

from vergence.video import VideoWriter, convert_clip, open_depth_clip, open_frames, open_stereo  # noqa: E402
from vergence.viewing import Display  # noqa: E402

NAMES = {"rgbd": "tiled_RGBD.mp4", "stereo": "tiled_LRF_Full_SBS.mp4"}


def make(folder: Path, width: int, frames_per_shot: int, tile: int) -> None:
    from vergence.video import make_test_clips

    height = (width * 9 // 16) // 2 * 2
    clips = make_test_clips(Path(tempfile.mkdtemp()), frames_per_shot=frames_per_shot, width=width, height=height)
    folder.mkdir(parents=True, exist_ok=True)
    for source, name in ((clips.rgbd, NAMES["rgbd"]), (clips.stereo, NAMES["stereo"])):
        reader = open_frames(source)
        frames = list(reader.frames())
        with VideoWriter(folder / name, fps=reader.info.fps, width=reader.info.width, height=reader.info.height,
                         crf=12) as out:  # fmt: skip
            for _ in range(tile):
                for frame in frames:
                    out.write(frame)
    print(f"wrote {2 * tile} shots of {frames_per_shot} frames, {width}x{height} per view, into {folder}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--make", type=Path, help="render and tile the clips into this folder")
    parser.add_argument("--clips", type=Path, help="time the conversion of the clips of this folder")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--frames-per-shot", type=int, default=24)
    parser.add_argument("--tile", type=int, default=8)
    parser.add_argument("--workers", default="2,4,8,16", help="worker counts, comma-separated")
    parser.add_argument("--kinds", default="rgbd,stereo")
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    if args.make is not None:
        make(args.make, args.width, args.frames_per_shot, args.tile)
        return
    if args.clips is None:
        parser.error("give --make DIR or --clips DIR")
    from distributed import LocalCluster

    counts = [int(n) for n in args.workers.split(",")]
    display = Display.preset("tv-55")
    out_folder = Path(tempfile.mkdtemp())
    openers = {"rgbd": lambda: open_depth_clip(args.clips / NAMES["rgbd"]),
               "stereo": lambda: open_stereo(args.clips / NAMES["stereo"])}  # fmt: skip
    for kind in args.kinds.split(","):
        frames = openers[kind]().frames

        def convert(scheduler=None, kind=kind):
            out = out_folder / f"{kind}_LRF_Full_SBS.mp4"
            convert_clip(openers[kind](), out, display, budget_arcmin=30.0, scheduler=scheduler)
            out.unlink()

        convert()
        serial = [timed(convert) for _ in range(args.repeats)]
        print(f"{kind}: {frames} frames, {os.cpu_count()} cores; medians of {args.repeats}", flush=True)
        base = report(f"{kind}, serial", serial, width=36)
        print(f"{'':36s} = {frames / base:6.2f} frames/s", flush=True)
        for n in counts:
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})  # fmt: skip
            try:
                convert(cluster.scheduler_address)
                runs = [timed(lambda: convert(cluster.scheduler_address)) for _ in range(args.repeats)]
            finally:
                cluster.close()
            wall = report(f"{kind}, Dask {n} workers", runs, width=36)
            print(f"{'':36s} = {frames / wall:6.2f} frames/s, {base / wall:.2f}x the serial run", flush=True)
    shutil.rmtree(out_folder)


if __name__ == "__main__":
    main()
