"""Importance and rivalry speed (S3 §3.2) on the ray tree of ``glasses``.

The stereo ray tree of the built-in ``glasses`` scene rendered once at ``--size`` squared with D = 2
(7 layers) on its own rig, 1 AO sample; the matches from :func:`vergence.specular.layer_disparity`
(not timed). Then ``--repeats`` calls of each stage, whole public calls with validation:
:func:`~vergence.specular.perceived_lightness` (tone map, CSF, L* of both eyes),
:func:`~vergence.specular.importance` and :func:`~vergence.specular.rivalry`; the first (compiling)
calls are not timed. Prints median wall and CPU times (``_timing.report``) and the share of matched
layer-pixels (the distinctiveness kernel works only on those).

Run: ``.venv/bin/python benchmarks/specular_importance.py [--size 512] [--repeats 3] [--display samsung-2233rz]``
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
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--display", default="samsung-2233rz")
    args = parser.parse_args()

    import numba

    from vergence.render import open_scene, render_stereo
    from vergence.specular import importance, layer_disparity, perceived_lightness, rivalry
    from vergence.viewing import Display

    display = Display.preset(args.display)
    scene = open_scene("glasses", width=args.size, height=args.size)
    t0 = time.perf_counter()
    left, right = render_stereo(scene, baseline=scene.stereo.baseline, convergence=scene.stereo.convergence,
                                max_depth=2, samples=1)  # fmt: skip
    t_render = time.perf_counter() - t0
    matches = layer_disparity(left.position, right.position)
    n, h, w = matches.distance.shape
    print(f"glasses {w}x{h}, D = 2: {n} layers, {n * h * w:,} layer-pixels, {int(matches.matched.sum()):,} matched; "
          f"rendered once in {t_render:.1f} s; display {args.display}")  # fmt: skip
    print(f"Numba {numba.__version__}, {numba.get_num_threads()} threads, {os.cpu_count()} CPUs visible")

    def lightness():  # noqa: ANN202
        return perceived_lightness(left.radiance, right.radiance, left.position, right.position, display)

    pair = lightness()
    calls = {"perceived_lightness": lightness, "importance": lambda: importance(pair, matches),
             "rivalry": lambda: rivalry(pair, matches)}  # fmt: skip
    for fn in calls.values():
        fn()  # compiles (or loads the cache)
    for name, fn in calls.items():
        report(name, [timed(fn) for _ in range(args.repeats)], width=22)
    imp = importance(pair, matches)
    riv = rivalry(pair, matches)
    m = matches.matched
    print("per layer, matched share / mean importance (matched) / median rivalry (matched, (dL*)^2):")
    for i in range(n):
        if m[i].any():
            print(f"  layer {i + 1}: {m[i].mean():6.1%}  {imp.weight[i][m[i]].mean():.3f}  "
                  f"{np.median(riv.rivalry[i][m[i]]):8.2f}")
        else:
            print(f"  layer {i + 1}: no match")


if __name__ == "__main__":
    main()
