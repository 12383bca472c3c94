"""Ray-tree render speed: the built-in ``glasses`` scene at 512 x 512, D = 2 (7 layers).

Run: ``.venv/bin/python benchmarks/render.py [--size 512] [--samples 4] [--repeat 5]``.
Prints the median wall time of :func:`vergence.render.render` (deterministic AO with the test
sample count, 4; it prepares the scene anew on every call), the same for
:meth:`vergence.render.Tracer.render` on a tracer built once (the path for many cameras: S3's
re-renders, the Tri-Rig truth), the rays cast per second (tree rays + AO rays), the process CPU
time per render, and for scale the median time
of Mitsuba's bare primary-ray cast of the same scene in the same process (a
``ray_intersect_preliminary`` of all camera rays, already on the Dr.Jit side, evaluated) with the
ratio of the two. The first (JIT-compiling) calls are not timed. The goal of issue 3 is the whole
7-layer tree in under 2 s on 2 CPU cores. Uses the shared HDR sky when present (see
``vergence.render.builtin``); the lighting line says which.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np


def _median_time(fn, repeats: int) -> tuple[float, list[float]]:  # noqa: ANN001
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=4, help="AO samples (the tests' glasses fixture uses 4)")
    parser.add_argument("--depth", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

    import drjit as dr
    import mitsuba as mi

    import vergence.render as vr
    from vergence.render._mitsuba import Caster
    from vergence.render.surfaces import pack_scene

    scene = vr.builtin_scene("glasses", width=args.size, height=args.size)
    run = lambda: vr.render(scene, max_depth=args.depth, samples=args.samples)  # noqa: E731
    result = run()  # compiles Mitsuba's kernels
    t_render, all_render = _median_time(run, args.repeat)
    tracer = vr.Tracer(scene)
    reuse = lambda: tracer.render(max_depth=args.depth, samples=args.samples)  # noqa: E731
    reuse()
    cpu0 = time.process_time()
    t_reuse, all_reuse = _median_time(reuse, args.repeat)
    cpu_reuse = (time.process_time() - cpu0) / args.repeat
    s = result.settings
    rays = s.tree_rays + s.ao_rays

    caster = Caster(pack_scene(scene).shapes)
    cam = scene.camera.build()
    d = cam.ray_directions().reshape(-1, 3).T.astype(np.float32)
    o = np.repeat(cam.center[:, None], d.shape[1], axis=1).astype(np.float32)
    ray = mi.Ray3f(mi.Point3f(o), mi.Vector3f(d))
    dr.eval(ray)

    def bare() -> None:
        pi = caster._scene.ray_intersect_preliminary(ray, True)
        dr.eval(pi.t, pi.prim_index, pi.shape)
        dr.sync_thread()

    bare()
    t_bare, _ = _median_time(bare, args.repeat)

    print(f"glasses {args.size}x{args.size}, D = {args.depth} ({result.n_layers} layers), {args.samples} AO samples, "
          f"deterministic AO; {s.variant}; {os.cpu_count()} CPUs visible")  # fmt: skip
    print(f"lighting: {s.environment}")
    print(f"render (whole ray tree + shading): median {t_render:.3f} s over {args.repeat} runs "
          f"(all: {', '.join(f'{t:.3f}' for t in all_render)})")  # fmt: skip
    print(f"Tracer built once, render per camera: median {t_reuse:.3f} s (all: {', '.join(f'{t:.3f}' for t in all_reuse)}); "
          f"CPU time {cpu_reuse:.3f} s per render")  # fmt: skip
    print(f"rays cast: {s.tree_rays:,} tree + {s.ao_rays:,} AO = {rays:,}; {rays / t_render / 1e6:.2f} Mrays/s overall "
          f"(render), {rays / t_reuse / 1e6:.2f} Mrays/s (Tracer reused)")  # fmt: skip
    print(f"Mitsuba bare primary cast ({args.size * args.size:,} rays): median {t_bare * 1e3:.1f} ms "
          f"({args.size * args.size / t_bare / 1e6:.1f} Mrays/s)")  # fmt: skip
    print(f"ratio render / bare primary cast: {t_render / t_bare:.1f}x (Tracer reused: {t_reuse / t_bare:.1f}x);  goal < 2 s: {'met' if t_render < 2.0 else 'NOT met'}")


if __name__ == "__main__":
    main()
