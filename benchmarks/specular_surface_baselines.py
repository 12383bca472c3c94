"""Speed and reach of S3 §4.1's baselines (:func:`vergence.specular.on_surface`, :func:`~vergence.specular.near_surface`).

The stereo ray tree of the built-in ``glasses`` scene rendered once with D = 2 (7 layers) on its own rig,
1 AO sample. Then ``--repeats`` calls of each baseline (whole public calls, validation included;
``near_surface`` includes its :func:`~vergence.specular.layer_disparity`, compiled before timing).
Prints the median wall and CPU times and, per specular layer, the share of the left pixels with a first
hit that took the right eye's shading (the rest keep their physical layer: off the right image, or
another surface seen there).

Run: ``.venv/bin/python benchmarks/specular_surface_baselines.py [--size 512] [--repeats 5]``
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
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    from vergence.render import open_scene, render_stereo
    from vergence.specular import near_surface, on_surface
    from vergence.viewing import Display

    scene = open_scene("glasses", width=args.size, height=args.size)
    t0 = time.perf_counter()
    left, right = render_stereo(scene, baseline=scene.stereo.baseline, convergence=scene.stereo.convergence,
                                max_depth=2, samples=1)  # fmt: skip
    n, h, w = left.radiance.shape[:3]
    print(f"glasses {w}x{h}, D = 2 ({n} layers), rendered once in {time.perf_counter() - t0:.1f} s")
    display = Display.preset("samsung-2233rz")
    calls = {"on_surface": lambda: on_surface(left, right), "near_surface": lambda: near_surface(left, right, display)}
    results = {name: fn() for name, fn in calls.items()}  # compiles the matcher (or loads its cache)
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in calls}
    for _ in range(args.repeats):
        for name, fn in calls.items():
            runs[name].append(timed(fn))
    hit = np.isfinite(left.position[0]).all(axis=-1)
    for name in calls:
        report(name, runs[name], width=16)
        moved = (results[name].radiance[1:] != left.radiance[1:]).any(axis=-1) & hit
        print(f"    pixels whose layer changed, per specular layer (of {int(hit.sum()):,} with a first hit): "
              f"{', '.join(f'{v:.1%}' for v in moved.reshape(n - 1, -1).sum(axis=1) / hit.sum())}")  # fmt: skip


if __name__ == "__main__":
    main()
