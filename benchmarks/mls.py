"""Speed and grid error of the MLS similarity warp (``vergence.stereospace.mls_warp``), S2 §3.1.

The scene is S2's case: 300 points on a bumpy surface 5 m away, projected into a 640 x 480 source
camera (the handles ``p_i``) and into a novel camera 0.3 m to its side (``q_i``); the source image
is warped to the novel view.

1. ``mls_warp`` per pixel (``grid_step=1``: the deformation at all 307,200 pixels, Numba) and on
   grids of step 8 and 16 (deformation at the nodes, bilinear in between), with the largest, 99th
   percentile and mean displacement error of the grid's source map against the per-pixel one.
2. A plain numpy MLS similarity per pixel (``numpy_mls`` below: the same formula, whole-array
   operations over chunks of pixels, as public NumPy MLS implementations do), same process, same
   handles: median times and the ratio.
3. The issue's reference point: a public NumPy MLS takes about 1 s for 500 x 500 pixels with 16
   handles; ``mls_warp`` is timed on that size too.

Timings are wall-clock medians of ``--repeats`` runs after a warm-up that compiles the kernel; the
CPU time is printed too, since the cores may be shared. Run:
``PYTHONPATH=src .venv/bin/python benchmarks/mls.py [--repeats N] [--threads N]``.
"""

from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before Numba starts its OpenMP threads

import numba  # noqa: E402
import numpy as np  # noqa: E402

from _timing import report, timed  # noqa: E402
from vergence.camera import look_at  # noqa: E402
from vergence.stereospace import mls_warp  # noqa: E402
from vergence.stereospace.mls import _source_map  # noqa: E402

WIDTH, HEIGHT = 640, 480
N_HANDLES = 300
CHUNK = 4096  # pixels per numpy chunk: (300, 4096) float64 arrays, ~10 MB each


def scene_handles(rng: np.random.Generator, n: int, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Handles: ``n`` surface points seen by both cameras, in the source (p) and the novel view (q)."""
    src = look_at([0.0, 0.0, 0.0], [0.0, 0.0, 5.0], [0.0, -1.0, 0.0], fov_deg=60.0, width=width, height=height)
    dst = look_at([0.3, 0.05, 0.0], [0.0, 0.0, 5.0], [0.0, -1.0, 0.0], fov_deg=60.0, width=width, height=height)
    x = rng.uniform(-2.4, 2.4, 4 * n)
    y = rng.uniform(-1.8, 1.8, 4 * n)
    z = 5.0 + 0.6 * np.sin(1.3 * x) * np.cos(1.1 * y)
    pts = np.column_stack([x, y, z])
    p, _ = src.project(pts)
    q, _ = dst.project(pts)
    inside = np.all((p >= 0) & (p <= [width - 1, height - 1]) & (q >= 0) & (q <= [width - 1, height - 1]), axis=1)
    return p[inside][:n], q[inside][:n]


def numpy_mls(points: np.ndarray, src: np.ndarray, dst: np.ndarray, alpha: float = 1.0) -> np.ndarray:
    """MLS similarity (Schaefer et al. 2006 §2.2, complex form) with numpy, chunks of pixels."""
    out = np.empty_like(points)
    for s in range(0, len(points), CHUNK):
        v = points[s:s + CHUNK]
        d2 = ((src[:, None, :] - v[None]) ** 2).sum(-1)  # (M, n)
        with np.errstate(divide="ignore"):
            w = 1.0 / d2**alpha
        hit = ~np.isfinite(w)
        w[:, hit.any(0)] = np.where(hit[:, hit.any(0)], 1.0, 0.0)  # a pixel on a handle takes q_i
        sw = w.sum(0)
        ps = (w.T @ src) / sw[:, None]
        qs = (w.T @ dst) / sw[:, None]
        phx, phy = src[:, 0:1] - ps[:, 0], src[:, 1:2] - ps[:, 1]
        qhx, qhy = dst[:, 0:1] - qs[:, 0], dst[:, 1:2] - qs[:, 1]
        mu = (w * (phx**2 + phy**2)).sum(0)
        ar = (w * (phx * qhx + phy * qhy)).sum(0) / mu
        ai = (w * (phx * qhy - phy * qhx)).sum(0) / mu
        ux, uy = v[:, 0] - ps[:, 0], v[:, 1] - ps[:, 1]
        out[s:s + CHUNK, 0] = ux * ar - uy * ai + qs[:, 0]
        out[s:s + CHUNK, 1] = ux * ai + uy * ar + qs[:, 1]
    return out


def _map64(p: np.ndarray, q: np.ndarray, step: int) -> np.ndarray:
    """mls_warp's source map (float64, (H, W, 2)) at a grid step."""
    return np.stack(_source_map(p, q, (HEIGHT, WIDTH), step, 1.0, dtype=np.float64), axis=-1)




def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--numpy-repeats", type=int, default=2, help="runs of the (slow) numpy reference")
    parser.add_argument("--threads", type=int, default=None, help="Numba threads (default: all cores)")
    args = parser.parse_args(argv)
    if args.threads is not None:
        numba.set_num_threads(args.threads)
    rng = np.random.default_rng(20261125)
    p, q = scene_handles(rng, N_HANDLES, WIDTH, HEIGHT)
    image = rng.uniform(0, 1, (HEIGHT, WIDTH, 3)).astype(np.float32)
    offsets = np.linalg.norm(q - p, axis=1)
    print(f"{WIDTH}x{HEIGHT} RGB, {len(p)} handles (offsets {offsets.min():.1f}-{offsets.max():.1f} px); cores: "
          f"{os.cpu_count()}, Numba threads: {numba.get_num_threads()}, OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}")

    exact = _map64(p, q, 1)  # also compiles the kernel
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH]
    pixels = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
    ref = numpy_mls(pixels, q, p).reshape(HEIGHT, WIDTH, 2)
    print(f"numpy vs Numba per-pixel source map: max |diff| {np.abs(ref - exact).max():.2e} px")
    for step in (8, 16):
        err = np.linalg.norm(_map64(p, q, step) - exact, axis=-1)
        print(f"grid step {step:2d}: displacement error vs per-pixel: max {err.max():.3f} px, "
              f"99th percentile {np.percentile(err, 99):.3f} px, mean {err.mean():.4f} px")

    timings = {}
    for step in (1, 8, 16):
        mls_warp(image, p, q, grid_step=step)
        runs = [timed(lambda s=step: mls_warp(image, p, q, grid_step=s)) for _ in range(args.repeats)]
        timings[step] = report(f"mls_warp grid_step={step} (Numba, with remap)", runs)
    t_np = report("numpy MLS per pixel (source map only)",
                   [timed(lambda: numpy_mls(pixels, q, p)) for _ in range(args.numpy_repeats)])
    t_map = report("Numba MLS per pixel (source map only)",
                    [timed(lambda: _source_map(p, q, (HEIGHT, WIDTH), 1, 1.0)) for _ in range(args.repeats)])
    print(f"speed-up per pixel, like for like: {t_np / t_map:.1f}x; "
          f"numpy per pixel / mls_warp step 8: {t_np / timings[8]:.0f}x, step 16: {t_np / timings[16]:.0f}x")

    # The quoted figure: a public NumPy MLS, 500 x 500 pixels, 16 handles, about 1 s.
    p16, q16 = scene_handles(np.random.default_rng(7), 16, 500, 500)
    img500 = rng.uniform(0, 1, (500, 500, 3)).astype(np.float32)
    for step in (1, 8):
        mls_warp(img500, p16, q16, grid_step=step)
        report(f"500x500, 16 handles: mls_warp grid_step={step}",
                [timed(lambda s=step: mls_warp(img500, p16, q16, grid_step=s)) for _ in range(args.repeats)],
                "  (public NumPy MLS: ~1000 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
