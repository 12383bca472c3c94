"""Speed of ``bayesian_weights`` for 4 sources into a 1920 x 1080 target, against plain numpy.

The scene is synthetic (a ground plane from 8 m to 2 m, discs at several depths, a textured
estimate), fixed by a seed; the four sources stand around the target with other focal lengths.
Timed: the first pass (``estimate=None``: resolution weights only) and a later pass (with the
estimate's gradient), each against a plain vectorised numpy implementation of the same weights
(same process, same inputs, interleaved runs; medians of ``--repeats`` after one warm-up run that
compiles the kernels). The numpy version is checked to agree before timing.
Run: ``.venv/bin/python benchmarks/ibr_bayes.py [--repeats N] [--threads N]``.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before Numba starts its OpenMP threads

import numba  # noqa: E402
import numpy as np  # noqa: E402

from _timing import median_time  # noqa: E402
from vergence.camera import Camera  # noqa: E402
from vergence.synthesis import (  # noqa: E402
    BAYES_DEPTH_CONTINUITY,
    BAYES_MIN_DEFORMATION,
    BAYES_SIGMA_DEPTH,
    BAYES_SIGMA_SENSOR,
    bayesian_weights,
)

WIDTH, HEIGHT = 1920, 1080
F_PX = 1600.0


def camera(center: list[float], f: float) -> Camera:
    K = [[f, 0.0, (WIDTH - 1) / 2], [0.0, f, (HEIGHT - 1) / 2], [0.0, 0.0, 1.0]]
    return Camera(K=K, R=np.eye(3), t=-np.asarray(center, float), width=WIDTH, height=HEIGHT)


def make_scene(rng: np.random.Generator):
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    depth = 2.0 + 6.0 * (1.0 - ys / HEIGHT)
    for _ in range(12):
        cx, cy, r = rng.uniform(0, WIDTH), rng.uniform(0, HEIGHT), rng.uniform(60, 250)
        depth = np.where((xs - cx) ** 2 + (ys - cy) ** 2 < r * r, np.minimum(depth, rng.uniform(1.0, 4.0)), depth)
    target = camera([0.0, 0.0, 0.0], F_PX)
    sources = [camera([0.1, 0.0, 0.0], 1.2 * F_PX), camera([-0.1, 0.0, 0.0], 1.2 * F_PX),
               camera([0.3, 0.05, -0.5], 0.9 * F_PX), camera([-0.3, -0.05, -0.5], 0.9 * F_PX)]
    points = target.backproject_depth(depth)
    pixels, visible = [], []
    for cam in sources:
        pix, z = cam.project(points)
        visible.append((z > 0) & (pix[..., 0] >= -0.5) & (pix[..., 0] <= WIDTH - 0.5) & (pix[..., 1] >= -0.5) & (pix[..., 1] <= HEIGHT - 0.5))
        pixels.append(pix)
    base = rng.random((HEIGHT // 8, WIDTH // 8, 3))
    estimate = np.repeat(np.repeat(base, 8, axis=0), 8, axis=1).astype(np.float32)
    return estimate, points, np.stack(pixels), np.stack(visible), target, sources


def numpy_weights(estimate, points, pixels, visible, target, sources, *, sigma_s=BAYES_SIGMA_SENSOR, sigma_z=BAYES_SIGMA_DEPTH,
                  cap=20.0, thr=0.01, gcap=0.5):
    """Plain vectorised numpy version of the same weights (no distortion)."""
    h, w = points.shape[:2]
    if estimate is not None:
        lum = np.pad(estimate @ np.array([0.2126, 0.7152, 0.0722]), 1, mode="edge")
        smooth_y = lum[:-2] + 2 * lum[1:-1] + lum[2:]
        smooth_x = lum[:, :-2] + 2 * lum[:, 1:-1] + lum[:, 2:]
        gx = (smooth_y[:, 2:] - smooth_y[:, :-2]) / 8
        gy = (smooth_x[2:] - smooth_x[:-2]) / 8
        gx[:, [0, -1]] *= 2  # one-sided span at the border
        gy[[0, -1]] *= 2
        norm = np.hypot(gx, gy)
        scale = np.where(norm > thr, thr / np.maximum(norm, thr), 1.0)
        gx, gy = gx * scale, gy * scale
        cam = points @ target.R.T + target.t
        z = cam[..., 2]
        pix = (cam @ target.K.T)[..., :2] / z[..., None]
        J = (target.K[None, None, :2, :] - pix[..., :, None] * target.K[2]) / z[..., None, None] @ target.R
    out = np.zeros(visible.shape, np.float32)
    for i, src in enumerate(sources):
        d = points - src.center
        r = np.linalg.norm(d, axis=-1)
        b = pixels[i]
        cols = []
        for axis in (1, 0):
            pad_b = np.pad(b, [(1, 1) if a == axis else (0, 0) for a in range(2)] + [(0, 0)], constant_values=np.nan)
            pad_r = np.pad(r, [(1, 1) if a == axis else (0, 0) for a in range(2)], constant_values=np.nan)
            take = (lambda a, k: a[:, k : k + w] if axis == 1 else a[k : k + h])
            with np.errstate(invalid="ignore"):
                fwd = np.abs(take(pad_r, 2) - r) <= BAYES_DEPTH_CONTINUITY * r
                bwd = np.abs(take(pad_r, 0) - r) <= BAYES_DEPTH_CONTINUITY * r
            fwd &= np.isfinite(take(pad_b, 2)).all(-1)
            bwd &= np.isfinite(take(pad_b, 0)).all(-1)
            diff = np.where((fwd & bwd)[..., None], (take(pad_b, 2) - take(pad_b, 0)) / 2,
                            np.where(fwd[..., None], take(pad_b, 2) - b, b - take(pad_b, 0)))
            cols.append((diff, fwd | bwd))
        det = np.abs(cols[0][0][..., 0] * cols[1][0][..., 1] - cols[1][0][..., 0] * cols[0][0][..., 1])
        det = np.where(cols[0][1] & cols[1][1], det, 1.0)
        weight = np.clip(det, BAYES_MIN_DEFORMATION, cap) / sigma_s**2
        if estimate is not None:
            v = np.einsum("hwij,hwj->hwi", J, d)
            s_geom = np.minimum(sigma_z * np.abs(gx * v[..., 0] + gy * v[..., 1]), gcap)
            weight = np.clip(det, BAYES_MIN_DEFORMATION, cap) / (sigma_s**2 + s_geom**2)
        out[i] = np.where(visible[i], weight, 0.0)
    return out



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--threads", type=int, default=None)
    args = parser.parse_args()
    if args.threads:
        numba.set_num_threads(args.threads)
    estimate, points, pixels, visible, target, sources = make_scene(np.random.default_rng(1))
    for name, est in (("first pass (estimate=None)", None), ("later pass (with estimate)", estimate)):
        fast = lambda est=est: bayesian_weights(est, points, pixels, visible, target, sources)  # noqa: E731
        slow = lambda est=est: numpy_weights(est, points, pixels, visible, target, sources)  # noqa: E731
        np.testing.assert_allclose(fast(), slow(), rtol=1e-4)  # warm-up and agreement
        cpu0 = time.process_time()
        t_fast = median_time(fast, args.repeats)[0]
        cpu = (time.process_time() - cpu0) / args.repeats
        t_slow = median_time(slow, args.repeats)[0]
        print(f"{name}: bayesian_weights {1e3 * t_fast:.0f} ms (cpu {1e3 * cpu:.0f} ms/run), "
              f"numpy {1e3 * t_slow:.0f} ms, speed-up {t_slow / t_fast:.1f}x  "
              f"[4 sources, {WIDTH}x{HEIGHT}, {numba.get_num_threads()} threads]")


if __name__ == "__main__":
    main()
