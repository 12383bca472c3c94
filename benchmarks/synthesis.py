"""Speed of view synthesis at 1920 x 1080: ``forward_warp`` vs a numpy z-buffer, and 2D + depth to stereo.

1. ``forward_warp`` (Numba, rows in parallel, gap filling included) against a plain numpy
   nearest-pixel z-buffer warp (``numpy.minimum.at`` on packed depth/index keys), same process,
   same inputs, interleaved runs; medians and their ratio.
2. The whole ``synthesize_stereo`` pipeline for a full 1080p stereo pair: metric depth to parallax
   (disparity budget), unknown depth filled, contour handling, two eyes warped, holes filled.

The scene is synthetic (textured slanted ground, discs at several depths, a few unknown pixels),
fixed by a seed. Timings are wall-clock medians of ``--repeats`` runs after one warm-up run that
compiles the kernels; the CPU time of the process is printed too, since the machine's cores may be
shared. Run: ``.venv/bin/python benchmarks/synthesis.py [--repeats N] [--threads N]``.

Threads: Numba's OpenMP layer spins its idle threads by default; on cores shared with other work
that spinning doubles the CPU time and, when the cores are oversubscribed, the wall time too. This
script asks for passive waiting (``OMP_WAIT_POLICY=PASSIVE``) unless the variable is already set;
run it with ``OMP_WAIT_POLICY=ACTIVE`` to see the default behaviour.
"""

from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before Numba starts its OpenMP threads

import numba  # noqa: E402
import numpy as np  # noqa: E402

from _timing import timed  # noqa: E402
from vergence.synthesis import forward_warp, synthesize_stereo

WIDTH, HEIGHT = 1920, 1080
BUDGET_PX = 40.0  # parallax budget of the stereo pair, image pixels (about 2 % of the width)


def make_scene(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A textured RGB image in [0, 1] and its metric depth (metres, a few NaN)."""
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float32)
    depth = 2.0 + 6.0 * (1.0 - ys / HEIGHT)  # ground from 8 m (top) to 2 m (bottom)
    for _ in range(12):
        cx, cy = rng.uniform(0, WIDTH), rng.uniform(0, HEIGHT)
        r = rng.uniform(60, 250)
        inside = (xs - cx) ** 2 + (ys - cy) ** 2 < r * r
        depth = np.where(inside, np.minimum(depth, rng.uniform(1.0, 4.0)), depth)
    base = rng.random((HEIGHT // 8, WIDTH // 8, 3)).astype(np.float32)
    texture = np.repeat(np.repeat(base, 8, axis=0), 8, axis=1)
    image = np.clip(0.6 * texture + 0.4 * rng.random((HEIGHT, WIDTH, 3), dtype=np.float32), 0.0, 1.0)
    depth = depth.astype(np.float32)
    depth[rng.random((HEIGHT, WIDTH)) < 0.002] = np.nan
    return image.astype(np.float32), depth


def numpy_zbuffer_warp(image: np.ndarray, disparity: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Reference: nearest-pixel forward warp with a z-buffer by ``numpy.minimum.at`` on packed keys.

    Key = (float32 bits of a depth that grows with distance) << 32 | source index: the minimum per
    target pixel is the nearest source pixel (larger disparity), ties to the lower index.
    """
    h, w = disparity.shape
    ys, xs = np.nonzero(~np.isnan(disparity))
    d = disparity[ys, xs]
    xt = np.rint(xs - scale * d).astype(np.int64)
    keep = (xt >= 0) & (xt < w)
    ys, xs, xt, d = ys[keep], xs[keep], xt[keep], d[keep]
    far = (np.float32(1.0) / (d - d.min() + np.float32(1.0))).astype(np.float32)  # > 0, smaller = nearer
    src = (ys * w + xs).astype(np.uint64)
    keys = (far.view(np.uint32).astype(np.uint64) << np.uint64(32)) | src
    buf = np.full(h * w, np.iinfo(np.uint64).max, dtype=np.uint64)
    np.minimum.at(buf, ys * w + xt, keys)
    hit = buf != np.iinfo(np.uint64).max
    winner = (buf[hit] & np.uint64(0xFFFFFFFF)).astype(np.int64)
    out = np.zeros((h * w, image.shape[2]), dtype=np.float32)
    out[hit] = image.reshape(-1, image.shape[2])[winner]
    return out.reshape(image.shape), ~hit.reshape(h, w)



def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--threads", type=int, default=None, help="Numba threads (default: all cores)")
    args = parser.parse_args(argv)
    if args.threads is not None:
        numba.set_num_threads(args.threads)
    rng = np.random.default_rng(20240601)
    image, depth = make_scene(rng)
    disparity = (60.0 / depth).astype(np.float32)  # 7.5 to 60 px: focal x baseline = 60 px m
    forward_warp(image, disparity, scale=1.0)  # compile / load the cached kernels
    numpy_zbuffer_warp(image, disparity, 1.0)
    print(f"{WIDTH}x{HEIGHT} RGB float32; cores: {os.cpu_count()}, Numba threads: {numba.get_num_threads()}, "
          f"layer: {numba.threading_layer()}, OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}")
    fw_runs, np_runs = [], []
    for _ in range(args.repeats):  # interleaved, so both see the same machine load
        fw_runs.append(timed(lambda: forward_warp(image, disparity, scale=1.0)))
        np_runs.append(timed(lambda: numpy_zbuffer_warp(image, disparity, 1.0)))
    (fw, fw_cpu), (npy, np_cpu) = np.median(fw_runs, axis=0), np.median(np_runs, axis=0)
    print(f"forward_warp (gap filling, Numba)      median {1e3 * fw:7.1f} ms  (CPU {1e3 * fw_cpu:7.1f} ms)")
    print(f"numpy minimum.at z-buffer (no gaps)    median {1e3 * npy:7.1f} ms  (CPU {1e3 * np_cpu:7.1f} ms)")
    print(f"speed-up: {npy / fw:.1f}x (goal >= 5x)")

    def pipeline() -> None:
        synthesize_stereo(image, depth, budget_px=BUDGET_PX)

    pipeline()
    runs = np.array([timed(pipeline) for _ in range(args.repeats)])
    (wall, cpu), (fastest, slowest) = np.median(runs, axis=0), (runs[:, 0].min(), runs[:, 0].max())
    print(f"synthesize_stereo, 1080p pair, filled  median {1e3 * wall:7.1f} ms  (CPU {1e3 * cpu:7.1f} ms; "
          f"min {1e3 * fastest:.1f}, max {1e3 * slowest:.1f} ms; goal < 100 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
