"""S3 §3.4 tabulation and final-render time: ``tabulate_offsets``, ``analyse_table`` and ``render_offsets`` on ``glasses``, once each.

The built-in ``glasses`` scene on its own rig (b = 0.065 m, H = 3.6 m), ``--size`` x ``--size``,
D = ``--depth``, ``--samples`` AO rays per diffuse hit. First a tiny run compiles the kernels (not
timed); then one timed :func:`vergence.specular.tabulate_offsets` with ``--k`` steps (k renders of
the left eye besides the right one, and k + 1 per-layer matches) and one
:func:`vergence.specular.analyse_table` (disparity in arcmin, L*, importance and rivalry of every
row on ``--display``: the rest of S3's ``g``), then one :func:`vergence.specular.render_offsets` with a different offset map per layer (y = 1 for the first
hit, per-pixel ramps for the others: N passes, the worst case). A single run each, not a median:
these take minutes and the machine's cores are shared. Prints wall times, the table's size and the
process's peak resident memory.

S3 reports "up to one minute" on a GPU; issue 12's goal is under 60 s on 2 CPU cores at 512 x 512, D = 2.

Run: ``.venv/bin/python benchmarks/specular_offsets.py [--size 512] [--depth 2] [--k 32] [--samples 16]
[--display samsung-2233rz]``
"""

from __future__ import annotations

import argparse
import os
import resource
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import numpy as np  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--depth", type=int, default=2)
    parser.add_argument("--k", type=int, default=32)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--display", default="samsung-2233rz")
    args = parser.parse_args()

    from vergence.render import Tracer, builtin_scene
    from vergence.rigs import stereo_pair
    from vergence.specular import analyse_table, render_offsets, tabulate_offsets
    from vergence.viewing import Display

    display = Display.preset(args.display)

    def rig(size: int):  # noqa: ANN202
        scene = builtin_scene("glasses", width=size, height=size)
        cam = scene.camera.build()
        return Tracer(scene), *stereo_pair(cam, baseline=scene.stereo.baseline, convergence=scene.stereo.convergence)

    tracer, left, right = rig(16)
    analyse_table(tabulate_offsets(tracer, left, right, k=2, max_depth=args.depth, samples=2), display)  # compile
    n = 2 ** (args.depth + 1) - 1
    render_offsets(tracer, left, right, np.linspace(0, 1, n)[:, None, None] * np.ones((n, 16, 16)), samples=2)

    t0 = time.perf_counter()
    tracer, left, right = rig(args.size)
    t_prepare = time.perf_counter() - t0
    t0 = time.perf_counter()
    table = tabulate_offsets(tracer, left, right, k=args.k, max_depth=args.depth, samples=args.samples)
    t_table = time.perf_counter() - t0
    nbytes = table.radiance.nbytes + table.disparity_px.nbytes + table.distance.nbytes
    matched = [float(np.mean(table.distance[m] == table.distance[m])) for m in (0, args.k // 2, args.k)]
    print(f"glasses {args.size}x{args.size}, D = {args.depth} ({n} layers), k = {args.k}, samples {args.samples}, "
          f"{os.cpu_count()} CPUs")  # fmt: skip
    print(f"  tracer preparation          {t_prepare:7.2f} s")
    print(f"  tabulate_offsets            {t_table:7.2f} s  (render {table.seconds_render:.2f} s for {args.k + 1} "
          f"renders incl. the right eye, {table.seconds_render / (args.k + 1):.2f} s each; "
          f"matching {table.seconds_match:.2f} s for {args.k + 1}, {table.seconds_match / (args.k + 1):.2f} s each)")
    print(f"  table arrays                {nbytes / 2**30:7.2f} GiB (radiance, disparity, distance; float32)")
    print(f"  matched share (y = 0, 1/2, 1): {', '.join(f'{m:.3f}' for m in matched)}")
    analysis = analyse_table(table, display)
    print(f"  analyse_table               {analysis.seconds:7.2f} s  ({analysis.seconds / (args.k + 1):.2f} s per row; "
          f"display {args.display})")
    print(f"  g(y) in all                 {t_table + analysis.seconds:7.2f} s  (goal: under 60 s at 512 x 512, D = 2)")
    del table, analysis

    ys = np.ones((n, args.size, args.size))
    ramp = np.linspace(0.0, 1.0, args.size)
    for i in range(1, n):
        ys[i] = (ramp[None, :] * (i / n) + (1 - i / n) * ramp[:, None])  # distinct per layer: N passes
    t0 = time.perf_counter()
    render_offsets(tracer, left, right, ys, samples=args.samples)
    t_final = time.perf_counter() - t0
    print(f"  render_offsets ({n} distinct maps, {n} passes) {t_final:7.2f} s")
    print(f"  peak resident memory        {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20:7.2f} GiB")


if __name__ == "__main__":
    main()
