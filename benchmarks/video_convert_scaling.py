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

**1080p stereo.** ``--make-1080p DIR`` writes ``planes1080_LRF_Full_SBS.mp4`` instead: full SBS H.264 of
1920x1080 per view (3840x1080 frames), ``2 x --tile`` shots of ``--frames-per-shot`` frames of textured
planes at known disparities (``tests/support/stereo_planes.py``: -30 .. +60 px and -50 .. +40 px, a
typical 1080p range; no Mitsuba needed). ``--clips DIR --kinds planes1080`` times its conversion (search
range from the features, SGBM matching, stabilisation, synthesis, x264 ``medium``, the output measured).
Every run ends with a table: workers, wall seconds, seconds per frame, frames per second, the speed-up over
the serial run, and the efficiency (speed-up over the 1-worker cluster divided by the workers; give ``1``
in ``--workers``: ``--workers 1,2,4,8,16``).
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402

from vergence.video import VideoWriter, convert_clip, open_depth_clip, open_frames, open_stereo  # noqa: E402
from vergence.viewing import Display  # noqa: E402

NAMES = {"rgbd": "tiled_RGBD.mp4", "stereo": "tiled_LRF_Full_SBS.mp4", "planes1080": "planes1080_LRF_Full_SBS.mp4"}


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


def make_1080p(folder: Path, frames_per_shot: int, tile: int) -> None:
    """Textured planes at known disparities, 1920x1080 per view, full SBS (module docstring)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "support"))
    from stereo_planes import PlaneShot, write_planes_clip

    shots = (PlaneShot(-30.0, 20.0, 60.0, scale=12.0, tint=(1.0, 0.8, 0.5)),
             PlaneShot(-50.0, 10.0, 40.0, scale=16.0, tint=(0.3, 0.6, 1.0))) * tile  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    write_planes_clip(folder / NAMES["planes1080"], shots, width=1920, height=1080, frames_per_shot=frames_per_shot,
                      crf=16)  # fmt: skip
    print(f"wrote {len(shots)} shots of {frames_per_shot} frames, 1920x1080 per view, into {folder}")


def table(kind: str, frames: int, serial: float, walls: dict[int, float]) -> None:
    """Workers, wall, s/frame, frames/s, speed-up over the serial run, efficiency over the 1-worker cluster."""
    print(f"\n{kind}: {frames} frames, {os.cpu_count()} cores")
    print(f"{'run':>10s} {'wall s':>8s} {'s/frame':>8s} {'frames/s':>9s} {'vs serial':>10s} {'efficiency':>11s}")
    print(f"{'serial':>10s} {serial:8.2f} {serial / frames:8.3f} {frames / serial:9.2f} {1.0:9.2f}x {'':>11s}")
    one = walls.get(1)
    for n, wall in walls.items():
        eff = "" if one is None else f"{100 * one / (wall * n):10.0f}%"
        print(f"{f'{n} workers':>10s} {wall:8.2f} {wall / frames:8.3f} {frames / wall:9.2f} {serial / wall:9.2f}x "
              f"{eff:>11s}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--make", type=Path, help="render and tile the clips into this folder")
    parser.add_argument("--make-1080p", type=Path, help="write the 1080p stereo planes clip into this folder")
    parser.add_argument("--clips", type=Path, help="time the conversion of the clips of this folder")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--frames-per-shot", type=int, default=24)
    parser.add_argument("--tile", type=int, default=8)
    parser.add_argument("--workers", default="1,2,4,8,16", help="worker counts, comma-separated")
    parser.add_argument("--kinds", default="rgbd,stereo")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--no-warmup", action="store_true", help="no warm-up run (Numba's cache already filled)")
    args = parser.parse_args()
    if args.make is not None:
        make(args.make, args.width, args.frames_per_shot, args.tile)
        return
    if args.make_1080p is not None:
        make_1080p(args.make_1080p, args.frames_per_shot, args.tile)
        return
    if args.clips is None:
        parser.error("give --make DIR or --clips DIR")
    from distributed import LocalCluster

    counts = [int(n) for n in args.workers.split(",") if n]  # "": the serial run only
    display = Display.preset("tv-55")
    out_folder = Path(tempfile.mkdtemp())
    openers = {"rgbd": lambda: open_depth_clip(args.clips / NAMES["rgbd"]),
               "stereo": lambda: open_stereo(args.clips / NAMES["stereo"]),
               "planes1080": lambda: open_stereo(args.clips / NAMES["planes1080"])}  # fmt: skip
    for kind in args.kinds.split(","):
        frames = openers[kind]().frames

        def convert(scheduler=None, kind=kind):
            out = out_folder / f"{kind}_LRF_Full_SBS.mp4"
            convert_clip(openers[kind](), out, display, budget_arcmin=30.0, scheduler=scheduler)
            out.unlink()

        if not args.no_warmup:
            convert()
        serial = [timed(convert) for _ in range(args.repeats)]
        print(f"{kind}: {frames} frames, {os.cpu_count()} cores; medians of {args.repeats}", flush=True)
        base = report(f"{kind}, serial", serial, width=36)
        cpu = float(sorted(c for _, c in serial)[len(serial) // 2])
        print(f"{'':36s} = {base / frames:.3f} s a frame, {cpu / frames:.3f} CPU-s a frame (this process)", flush=True)
        print(f"{'':36s} = {frames / base:6.2f} frames/s", flush=True)
        walls: dict[int, float] = {}
        for n in counts:
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=logging.CRITICAL,
                                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})  # fmt: skip
            try:
                if not args.no_warmup:
                    convert(cluster.scheduler_address)
                runs = [timed(lambda: convert(cluster.scheduler_address)) for _ in range(args.repeats)]
            finally:
                cluster.close()
            wall = report(f"{kind}, Dask {n} workers", runs, width=36)
            print(f"{'':36s} = {frames / wall:6.2f} frames/s, {base / wall:.2f}x the serial run", flush=True)
            walls[n] = wall
        table(kind, frames, base, walls)
    shutil.rmtree(out_folder)


if __name__ == "__main__":
    main()
