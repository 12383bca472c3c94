"""Per-layer disparity speed (S3 §3.2): the branch-and-bound search vs the exhaustive one, same process.

The stereo ray tree of the built-in ``glasses`` scene (two glass spheres, a goblet, a mirror), rendered
once at 512 x 512 with D = 2 (7 layers) on its own rig (b = 0.065 m, H = 3.6 m), 1 AO sample (the
radiance does not matter here, only the positions). Then, interleaved, ``--repeats`` calls of
:func:`vergence.specular.layer_disparity` with ``method="bounded"`` (the default) and
``method="exhaustive"`` (every candidate of the 81 x 9 window, also a Numba kernel, parallel over rows):
whole public calls, validation, scene diameter and bounding boxes included; the first (compiling)
calls are not timed. Prints the median wall and CPU times, the throughput in layer-pixels per second
counted two ways (all ``N x H x W`` layer-pixels, and only those whose left pixel has a surface, the
ones searched), the ratio, and checks that both results are identical.

S3 matches 0.6 Mpixel/s on a GPU; issue 12's goal is 10 times that, 6 M layer-pixels/s, on 2 CPU cores.

Run: ``.venv/bin/python benchmarks/specular_matching.py [--size 512] [--repeats 7]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()

    import numba

    from vergence.render import open_scene, render_stereo
    from vergence.specular import layer_disparity

    scene = open_scene("glasses", width=args.size, height=args.size)
    t0 = time.perf_counter()
    left, right = render_stereo(scene, baseline=scene.stereo.baseline, convergence=scene.stereo.convergence,
                                max_depth=2, samples=1)  # fmt: skip
    t_render = time.perf_counter() - t0
    lp, rp = left.position, right.position
    n, h, w, _ = lp.shape
    valid = np.isfinite(lp).all(axis=-1)
    print(f"glasses {w}x{h}, D = 2: {n} layers, {n * h * w:,} layer-pixels, {int(valid.sum()):,} with a surface in the "
          f"left eye (per layer: {', '.join(f'{v:.1%}' for v in valid.reshape(n, -1).mean(axis=1))}); rendered once in "
          f"{t_render:.1f} s; lighting: {left.settings.environment}")  # fmt: skip
    print(f"Numba {numba.__version__}, {numba.get_num_threads()} threads, {os.cpu_count()} CPUs visible")

    calls = {m: (lambda m=m: layer_disparity(lp, rp, method=m)) for m in ("bounded", "exhaustive")}
    results = {m: fn() for m, fn in calls.items()}  # compiles (or loads the cache)
    runs: dict[str, list[tuple[float, float]]] = {m: [] for m in calls}
    for _ in range(args.repeats):
        for m, fn in calls.items():
            runs[m].append(timed(fn))
    walls = {}
    for m in calls:
        walls[m] = report(f"layer_disparity(method={m!r})", runs[m], width=36)
        print(f"    {n * h * w / walls[m] / 1e6:6.2f} M layer-pixels/s (all);  "
              f"{valid.sum() / walls[m] / 1e6:6.2f} M layer-pixels/s (with a surface)")
    a, b = results["bounded"], results["exhaustive"]
    same = np.array_equal(a.disparity_px, b.disparity_px, equal_nan=True) and np.array_equal(
        a.distance, b.distance, equal_nan=True
    )
    print(f"ratio exhaustive / bounded: {walls['exhaustive'] / walls['bounded']:.1f}x (wall medians); "
          f"identical results: {same}")  # fmt: skip
    print(f"matched per layer: {', '.join(f'{v:.1%}' for v in a.matched.reshape(n, -1).mean(axis=1))}; "
          f"epsilon {a.epsilon * 100:.2f} cm")  # fmt: skip
    goal = 6e6
    print(f"goal 6 M layer-pixels/s: {'met' if n * h * w / walls['bounded'] >= goal else 'NOT met'} counting all "
          f"layer-pixels, {'met' if valid.sum() / walls['bounded'] >= goal else 'NOT met'} counting those with a surface")
    if not same:
        raise SystemExit("the two methods disagree")


if __name__ == "__main__":
    main()
