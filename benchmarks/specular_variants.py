"""S3's absolute term against ours, on ``glasses`` and ``far_mirror``: what each does to the layers.

For each scene (its own rig, ``--width`` px wide at the scene's aspect, D = 2, k = ``--k``, shown on
``--display``) and each absolute variant (S3's ``screen``: every disparity pulled to the screen;
ours, ``comfort``: only what lies outside the display's comfort zone), one
:func:`vergence.specular.specular_stereo` run, then per layer with important matched pixels:

- the comfort share before -> after (importance-weighted share of matched pixels inside +-60');
- the separation share before -> after: of the specular layer's important pixels, the share still
  at least 2' from the first surface on its physical side (a reflection behind its mirror stays
  behind it; below 2' the two pool into one surface, S3 §2);
- the mean offset ``y`` (1: physical, 0: mono);
- the matched share before -> after (of the layer's pixels with a surface);

and the mean cost terms before and after, the matching rate and the stage times. Each run renders
its own table: about a minute per run at 512 px on 2 cores. The two variants are now S3 Eq. 2 as
written and our objective (issue 26); ``benchmarks/specular_ablation.py`` compares them on scenes of
large excess, term by term, with plain and weighted shares (docs/specular.md).

Run: ``.venv/bin/python benchmarks/specular_variants.py [--width 512] [--k 32] [--display samsung-2233rz]
[--scenes glasses examples/scenes/far_mirror.json]``
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

ROOT = Path(__file__).resolve().parents[1]


def _fmt(v: float | None) -> str:
    return "  -  " if v is None else f"{v:5.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=512)
    parser.add_argument("--k", type=int, default=32)
    parser.add_argument("--display", default="samsung-2233rz")
    parser.add_argument("--scenes", nargs="+", default=["glasses", str(ROOT / "examples/scenes/far_mirror.json")])
    args = parser.parse_args()

    from vergence.render import Tracer, open_scene
    from vergence.rigs import stereo_pair
    from vergence.specular import ABSOLUTE_VARIANTS, specular_stereo
    from vergence.viewing import Display

    display = Display.preset(args.display)
    for name in args.scenes:
        scene = open_scene(name, width=args.width)
        tracer = Tracer(scene)
        left, right = stereo_pair(scene.camera.build(), baseline=scene.stereo.baseline,
                                  convergence=scene.stereo.convergence)  # fmt: skip
        for variant in ABSOLUTE_VARIANTS:
            t0 = time.perf_counter()
            report = specular_stereo(tracer, left, right, display, k=args.k, variant=variant).report()
            wall = time.perf_counter() - t0
            print(f"\n{scene.name} {scene.camera.width}x{scene.camera.height}, k = {args.k}, {args.display}, "
                  f"absolute variant {variant!r}: {wall:.1f} s")  # fmt: skip
            secs = report["seconds"]
            print("  stages: " + ", ".join(f"{k} {v:.2f} s" for k, v in secs.items()))
            before, after = report["cost_before"], report["cost_after"]
            print("  cost     " + "  ".join(f"{t} {before[t]:9.1f} -> {after[t]:9.1f}" for t in before))
            print("  layer  name  pixels  matched before -> after  comfort before -> after  separated before -> after  mean y")
            for layer in report["layers"]:
                if layer["comfort_share_before"] is None and layer["comfort_share_after"] is None:
                    continue  # no important matched pixel: nothing to judge
                print(f"  {layer['layer']:5d}  {layer['name']:4s}  {layer['pixels']:6d}  {_fmt(layer['matched_before'])} -> "
                      f"{_fmt(layer['matched_after'])}          "
                      f"{_fmt(layer['comfort_share_before'])} -> {_fmt(layer['comfort_share_after'])}           "
                      f"{_fmt(layer['separated_share_before'])} -> {_fmt(layer['separated_share_after'])}       "
                      f"{layer['offset_mean']:.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
