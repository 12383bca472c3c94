"""Ray-tree render speed: the built-in ``glasses`` scene at 512 x 512, D = 2 (7 layers).

Run: ``.venv/bin/python benchmarks/render.py [--size 512] [--samples 4] [--repeat 5]``; with ``--table``,
S3's table of 33 renders instead (``tabulate_offsets`` on ``glasses`` 320x240, k = 32, 16 AO samples),
fused and staged.
Prints the median wall time of :func:`vergence.render.render` (deterministic AO with the test
sample count, 4; it prepares the scene anew on every call), the same for
:meth:`vergence.render.Tracer.render` on a tracer built once (the path for many cameras: S3's
re-renders, the Tri-Rig truth), fused (the default) and staged (``Tracer(scene, staged=True)``, the
reference path and the renderer before issue 31), the rays cast per second (tree rays + AO rays),
the process CPU time per render, and for scale the median time of Mitsuba's bare cast in the same
process: of the primary rays alone, and of **as many rays as the render casts** (tree + AO; the
camera's rays repeated, already on the Dr.Jit side, ``ray_intersect_preliminary`` evaluated), with
the ratios (issue 31's goal: the 7-layer tree within 4x of the bare cast of as many rays). The first (JIT-compiling) calls are not timed. The goal of issue 3 is the whole
7-layer tree in under 2 s on 2 CPU cores. Uses the shared HDR sky when present (see
``vergence.render.builtin``); the lighting line says which.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as the vergence command: idle OpenMP threads must not spin

import numpy as np  # noqa: E402


def _time(fn) -> float:  # noqa: ANN001
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _table() -> None:
    """S3's table of 33 renders (``tabulate_offsets``, ``glasses`` 320x240, k = 32, D = 2, 16 AO samples),
    with the fused tracer (8 offsets side by side per wavefront) and the staged one, in this process."""
    from vergence.render import Tracer, builtin_scene
    from vergence.rigs import stereo_pair
    from vergence.specular import tabulate_offsets

    def rig(w: int, h: int, staged: bool):  # noqa: ANN202
        scene = builtin_scene("glasses", width=w, height=h)
        cam = scene.camera.build()
        return Tracer(scene, staged=staged), *stereo_pair(cam, baseline=scene.stereo.baseline,
                                                          convergence=scene.stereo.convergence)  # fmt: skip

    for staged in (False, True):
        tabulate_offsets(*rig(32, 24, staged), k=2, samples=2)  # compiles
    tables = {}
    for staged in (False, True):
        t0 = time.perf_counter()
        tables[staged] = tab = tabulate_offsets(*rig(320, 240, staged), k=32, samples=16, max_depth=2)
        print(f"tabulate_offsets glasses 320x240, k = 32, D = 2, 16 AO ({'staged, one render at a time' if staged else 'fused, 8 offsets side by side'}): "
              f"{time.perf_counter() - t0:.2f} s (renders {tab.seconds_render:.2f} s, matching {tab.seconds_match:.2f} s)")  # fmt: skip
    print(f"radiance max |fused - staged|: {np.abs(tables[False].radiance - tables[True].radiance).max():.2g}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=4, help="AO samples (the tests' glasses fixture uses 4)")
    parser.add_argument("--depth", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--table", action="store_true", help="instead: time S3's table (tabulate_offsets), fused and staged")
    args = parser.parse_args()
    if args.table:
        _table()
        return

    import drjit as dr
    import mitsuba as mi

    import vergence.render as vr
    from vergence.render._mitsuba import Caster
    from vergence.render.surfaces import pack_scene

    scene = vr.builtin_scene("glasses", width=args.size, height=args.size)
    opts = {"max_depth": args.depth, "samples": args.samples}
    tracer, staged = vr.Tracer(scene), vr.Tracer(scene, staged=True)
    result = vr.render(scene, **opts)  # compiles the kernels
    s = result.settings
    rays = s.tree_rays + s.ao_rays
    staged_result = staged.render(**opts)
    diff = float(np.abs(staged_result.beauty - tracer.render(**opts).beauty).max())

    caster = Caster(pack_scene(scene).shapes)
    cam = scene.camera.build()
    d = cam.ray_directions().reshape(-1, 3).T.astype(np.float32)
    o = np.repeat(cam.center[:, None], d.shape[1], axis=1).astype(np.float32)
    reps = -(-rays // d.shape[1])
    cast = {}
    for name, count in (("primary", d.shape[1]), ("as many", rays)):
        ray = mi.Ray3f(mi.Point3f(np.tile(o, reps)[:, :count].copy()), mi.Vector3f(np.tile(d, reps)[:, :count].copy()))
        dr.eval(ray)

        def bare(ray=ray) -> None:  # noqa: ANN001
            pi = caster._scene.ray_intersect_preliminary(ray, True)
            dr.eval(pi.t, pi.prim_index, pi.shape)
            dr.sync_thread()

        bare()
        cast[name] = bare

    runs = {"render": lambda: vr.render(scene, **opts), "fused": lambda: tracer.render(**opts),
            "staged": lambda: staged.render(**opts), "primary": cast["primary"], "as many": cast["as many"]}  # fmt: skip
    times: dict[str, list[float]] = {k: [] for k in runs}
    cpu_fused = []
    for _ in range(args.repeat):  # interleaved: every round sees the same load on the shared cores
        for name, fn in runs.items():
            c0 = time.process_time()
            times[name].append(_time(fn))
            if name == "fused":
                cpu_fused.append(time.process_time() - c0)
    med = {k: statistics.median(v) for k, v in times.items()}
    ratio = {k: statistics.median([a / b for a, b in zip(times[k], times["as many"])]) for k in ("render", "fused", "staged")}
    fmt = lambda v: ", ".join(f"{t:.3f}" for t in v)  # noqa: E731

    print(f"glasses {args.size}x{args.size}, D = {args.depth} ({result.n_layers} layers), {args.samples} AO samples, "
          f"deterministic AO; {s.variant}; {os.cpu_count()} CPUs visible; {args.repeat} interleaved rounds")  # fmt: skip
    print(f"lighting: {s.environment}")
    print(f"render (whole ray tree + shading, scene prepared per call): median {med['render']:.3f} s (all: {fmt(times['render'])})")
    print(f"Tracer built once, fused (default): median {med['fused']:.3f} s (all: {fmt(times['fused'])}); "
          f"CPU time {statistics.median(cpu_fused):.3f} s per render")  # fmt: skip
    print(f"Tracer built once, staged (the reference; the renderer before issue 31): median {med['staged']:.3f} s "
          f"(all: {fmt(times['staged'])}); fused / staged {med['fused'] / med['staged']:.2f}; beauty max |diff| {diff:.2g}")  # fmt: skip
    print(f"rays cast: {s.tree_rays:,} tree + {s.ao_rays:,} AO = {rays:,}; {rays / med['fused'] / 1e6:.2f} Mrays/s (fused)")
    print(f"Mitsuba bare cast: primary rays ({d.shape[1]:,}) median {med['primary'] * 1e3:.1f} ms; as many rays as the "
          f"render ({rays:,}) median {med['as many'] * 1e3:.1f} ms ({rays / med['as many'] / 1e6:.1f} Mrays/s)")  # fmt: skip
    print(f"ratio to the bare cast of as many rays (median of per-round ratios): render {ratio['render']:.1f}x, "
          f"fused {ratio['fused']:.1f}x, staged {ratio['staged']:.1f}x; goal <= 4x: {'met' if ratio['fused'] <= 4 else 'NOT met'}")  # fmt: skip


if __name__ == "__main__":
    main()
