"""`vergence convert` serial against shots as Dask tasks (a 2-worker ``LocalCluster``), same process.

The rendered test clips (:func:`vergence.video.make_test_clips`; their shots repeated so there are
more shots than workers) are converted to full SBS H.264, 2D + depth and stereo, by ``convert_clip``
serially (Numba's threads over all cores, x264 in a second thread) and with ``workers=2`` (one
single-thread process per worker, Numba/OpenCV limited to its share of the cores; the cluster's start
and stop are inside the time, as on the command line), and on a 2-worker cluster already running
(``scheduler=ADDRESS``: the tasks alone). Medians of interleaved runs.

Run: ``.venv/bin/python benchmarks/video_convert_dask.py [--frames-per-shot N] [--width W] [--repeats N]``
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

from vergence.video import convert_clip, make_test_clips, open_depth_clip, open_stereo  # noqa: E402
from vergence.video.clips import CLIP_SHOTS  # noqa: E402
from vergence.viewing import Display  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames-per-shot", type=int, default=12)
    parser.add_argument("--width", type=int, default=320, help="width of one view (height 9/16 of it)")
    parser.add_argument("--shots", type=int, default=4, help="shots (the test clips' shots repeated)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    shots = tuple(CLIP_SHOTS[k % len(CLIP_SHOTS)] for k in range(args.shots))
    height = (args.width * 9 // 16) // 2 * 2
    clips = make_test_clips(folder, frames_per_shot=args.frames_per_shot, width=args.width, height=height,
                            shots=shots)  # fmt: skip
    display = Display.preset("tv-55")

    from distributed import LocalCluster

    # A cluster already running (--scheduler ADDRESS): the tasks without the cluster's start and stop.
    running = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})  # fmt: skip

    def convert(open_clip, name, workers, scheduler=None):
        out = folder / f"{name}_LRF_Full_SBS.mp4"
        result = convert_clip(open_clip(), out, display, budget_arcmin=30.0, workers=workers, scheduler=scheduler)
        assert len(result.shots) == args.shots, result.shots
        out.unlink()

    cases = {
        "2D+depth, serial": lambda: convert(lambda: open_depth_clip(clips.rgbd), "rgbd", 1),
        f"2D+depth, Dask {args.workers} workers": lambda: convert(lambda: open_depth_clip(clips.rgbd), "rgbd",
                                                                  args.workers),
        f"2D+depth, running {args.workers}-worker cluster": lambda: convert(lambda: open_depth_clip(clips.rgbd),
                                                                            "rgbd", 1, running.scheduler_address),
        "stereo, serial": lambda: convert(lambda: open_stereo(clips.stereo), "stereo", 1),
        f"stereo, Dask {args.workers} workers": lambda: convert(lambda: open_stereo(clips.stereo), "stereo",
                                                                args.workers),
        f"stereo, running {args.workers}-worker cluster": lambda: convert(lambda: open_stereo(clips.stereo), "stereo",
                                                                          1, running.scheduler_address),
    }  # fmt: skip
    for fn in cases.values():  # warm-up: Numba caches, x264, the workers' imports
        fn()
    runs = {name: [] for name in cases}
    for _ in range(args.repeats):
        for name, fn in cases.items():
            runs[name].append(timed(fn))
    print(f"{clips.frames} frames ({args.shots} shots), {args.width}x{height} per view, {os.cpu_count()} cores; "
          f"medians of {args.repeats} (CPU is this process only)")
    for name in cases:
        wall = report(name, runs[name])
        print(f"{'':44s} = {clips.frames / wall:6.2f} frames/s")
    running.close()
    shutil.rmtree(folder)


if __name__ == "__main__":
    main()
