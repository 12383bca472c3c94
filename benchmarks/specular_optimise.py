"""Per-pixel offset optimisation speed (S3 §3.4): the Numba descent against a simple numpy search,
same process, on a synthetic table.

The table: N layers whose disparity scales with the offset (``d_i(y) = y * physical``, physical
disparities ~ N(0, 90') horizontally, 5 % of that vertically), rivalry growing away from ``y = 1``,
random importance; ``K + 1`` offsets. The reference is coordinate descent on the table's own offsets
written in numpy over whole images: for each free layer in turn, the cost
(:func:`vergence.specular.disparity_cost`) of every tabulated offset with the other layers held, the
best kept; two sweeps. Prints the median times, the per-pixel rate and the mean cost each reaches.

With ``--planner``, instead: the whole-image re-solve of S3 §3.4 that a weight change triggers,
:meth:`vergence.specular.OffsetPlanner.solve` (descent on the table reduced ``--factor`` times,
joint bilateral upsampling to full size) at ``--size`` squared, on a table whose physical disparity
is smooth (a Gaussian-filtered field, sigma 8 px: surfaces rather than per-pixel noise), against the per-pixel descent at
full resolution (:func:`~vergence.specular.optimise_offsets`, the reference), same table, same
process; and the mean cost each reaches at full resolution (the table interpolated at its offsets).
The issue's goal: well under a second at 512 x 512.

Run: ``.venv/bin/python benchmarks/specular_optimise.py [--size 128] [--layers 7] [--k 32] [--repeats 3]``
``.venv/bin/python benchmarks/specular_optimise.py --planner --size 512 [--factor 4] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import time  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import median_time  # noqa: E402

from vergence.specular import disparity_cost, optimise_offsets  # noqa: E402

ZONE = (-70.0, 60.0)


def _table(k: int, n: int, size: int, smooth: bool = False):
    rng = np.random.default_rng(0)
    ys = np.linspace(0, 1, k + 1, dtype=np.float32)
    physical = rng.normal(0, 90, (n, size, size, 2)).astype(np.float32)
    if smooth:  # surfaces, not noise: disparity varies over ~8 px (the planner solves per 4 x 4 block)
        from scipy.ndimage import gaussian_filter

        physical = gaussian_filter(physical, sigma=(0, 8, 8, 0))
        physical *= 90.0 / physical.std()
    physical[..., 1] *= 0.05
    disp = ys[:, None, None, None, None] * physical[None]
    riv = (1 - ys)[:, None, None, None] * rng.uniform(0, 5, (n, size, size)).astype(np.float32)[None]
    imp = np.broadcast_to(rng.uniform(0, 1, (n, size, size)).astype(np.float32), (k + 1, n, size, size))
    return disp, riv, imp, physical


def coordinate_search(disp, riv, imp, physical, sweeps: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The reference: per free layer in turn, the best tabulated offset with the others held."""
    kp1, n, h, w = riv.shape
    index = np.full((n, h, w), kp1 - 1)  # start at y = 1

    def at(table, idx):
        return np.take_along_axis(table, idx[None, ..., None] if table.ndim == 5 else idx[None], 0)[0]

    def cost(idx):
        return disparity_cost(at(disp, idx), at(riv, idx), at(imp, idx), physical, variant="comfort", zone=ZONE).total

    best = cost(index)
    for _ in range(sweeps):
        for i in range(1, n):
            for m in range(kp1):
                trial = index.copy()
                trial[i] = m
                c = cost(trial)
                better = c < best
                index[i][better] = m
                best = np.where(better, c, best)
    return index / (kp1 - 1), best


def _cost_at(disp, riv, imp, physical, y) -> float:
    """Mean cost of the table linearly interpolated at the offsets ``y (N, H, W)``."""
    k = disp.shape[0] - 1
    pos = np.clip(y, 0, 1) * k
    m = np.minimum(pos.astype(int), k - 1)
    t = (pos - m).astype(np.float32)

    def at(table):
        lo = np.take_along_axis(table, m[None, ..., None] if table.ndim == 5 else m[None], 0)[0]
        hi = np.take_along_axis(table, (m + 1)[None, ..., None] if table.ndim == 5 else (m + 1)[None], 0)[0]
        tt = t[..., None] if table.ndim == 5 else t
        return lo + tt * (hi - lo)

    return float(disparity_cost(at(disp), at(riv), at(imp), physical, variant="comfort", zone=ZONE).total.mean())


def planner_benchmark(disp, riv, imp, physical, args) -> None:  # noqa: ANN001
    from vergence.specular import OffsetAnalysis, OffsetPlanner
    from vergence.viewing import Display

    analysis = OffsetAnalysis(offsets=np.arange(args.k + 1) / args.k, disparity=disp, rivalry=riv, importance=imp,
                              exposure=1.0, display=Display.preset("samsung-2233rz"), seconds=0.0)  # fmt: skip
    small = OffsetAnalysis(offsets=analysis.offsets, disparity=disp[:, :, :16, :16], rivalry=riv[:, :, :16, :16],
                           importance=imp[:, :, :16, :16], exposure=1.0, display=analysis.display, seconds=0.0)  # fmt: skip
    OffsetPlanner(small, factor=args.factor).solve(variant="comfort", zone=ZONE)  # compile
    t0 = time.perf_counter()
    planner = OffsetPlanner(analysis, factor=args.factor)
    t_reduce = time.perf_counter() - t0
    fast, plan = median_time(lambda: planner.solve(variant="comfort", zone=ZONE), args.repeats)
    slow, sol = median_time(lambda: optimise_offsets(disp, riv, imp, physical, variant="comfort", zone=ZONE), 1)
    print(f"{args.size} x {args.size}, N = {args.layers}, K = {args.k}, factor {args.factor}:")
    print(f"  reduce the table once     {t_reduce:7.2f} s")
    print(f"  OffsetPlanner.solve       median {fast:7.3f} s, mean cost {_cost_at(disp, riv, imp, physical, plan.y):.1f}")
    print(f"  per-pixel descent, full   once   {slow:7.3f} s, mean cost {_cost_at(disp, riv, imp, physical, sol.y):.1f}")
    print(f"  ratio {slow / fast:.1f}x (mean cost at y = 1: {_cost_at(disp, riv, imp, physical, np.ones_like(sol.y)):.1f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--layers", type=int, default=7)
    parser.add_argument("--k", type=int, default=32)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--planner", action="store_true")
    parser.add_argument("--factor", type=int, default=4)
    args = parser.parse_args()
    disp, riv, imp, physical = _table(args.k, args.layers, args.size, smooth=args.planner)
    if args.planner:
        planner_benchmark(disp, riv, imp, physical, args)
        return
    optimise_offsets(disp[:, :, :4, :4], riv[:, :, :4, :4], imp[:, :, :4, :4], physical[:, :4, :4],
                     variant="comfort", zone=ZONE)  # compile  # fmt: skip
    pixels = args.size * args.size
    fast, sol = median_time(lambda: optimise_offsets(disp, riv, imp, physical, variant="comfort", zone=ZONE),
                            args.repeats)  # fmt: skip
    slow, (_, ref_cost) = median_time(lambda: coordinate_search(disp, riv, imp, physical), args.repeats)
    print(f"{args.size} x {args.size}, N = {args.layers}, K = {args.k}:")
    print(f"  descent (Numba)           median {fast:7.2f} s  ({pixels / fast / 1e3:7.1f} kpixel/s), mean cost {sol.cost.mean():.1f}")
    print(f"  coordinate search (numpy) median {slow:7.2f} s  ({pixels / slow / 1e3:7.1f} kpixel/s), mean cost {ref_cost.mean():.1f}")
    print(f"  ratio {slow / fast:.1f}x; descent cost <= search cost on {np.mean(sol.cost <= ref_cost + 1e-6) * 100:.0f} % of pixels")


if __name__ == "__main__":
    main()
