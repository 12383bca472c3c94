"""Re-optimising a specular run with new weights (S3 §3.4, the workbench's page 5) against the first run,
same process: :func:`vergence.specular.specular_stereo` (table, analysis, plan, final render) and
:meth:`SpecularResult.reoptimise <vergence.specular.SpecularResult.reoptimise>` with a painted map (the
absolute term of layer 2 switched off on the left half), which reuses the table: a solve, one render
and the measurement of the new pair. Scene glasses on its own rig, samsung-2233rz, samples 4.

Run: ``.venv/bin/python benchmarks/specular_reoptimise.py [--sizes 160x120:16,320x240:32] [--repeats 5]``
(each ``WxH:k``).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import median_time  # noqa: E402

from vergence.commands._scene import scene_rig  # noqa: E402
from vergence.render import Tracer, builtin_scene  # noqa: E402
from vergence.specular import specular_stereo  # noqa: E402
from vergence.viewing import Display  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="160x120:16,320x240:32")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    display = Display.preset("samsung-2233rz")
    for spec in args.sizes.split(","):
        size, k = spec.split(":")
        w, h = (int(v) for v in size.split("x"))
        scene = builtin_scene("glasses", width=w, height=h)
        left, right, _, _ = scene_rig(scene, None, None, needed_by="the benchmark")
        tracer = Tracer(scene)
        specular_stereo(tracer, left, right, display, k=int(k), samples=4)  # compiles and warms
        first, result = median_time(lambda: specular_stereo(tracer, left, right, display, k=int(k), samples=4),
                                    max(1, args.repeats // 2))
        maps = {"absolute": np.ones(result.y.shape)}
        maps["absolute"][1, :, : w // 2] = 0.0
        again, re = median_time(lambda: result.reoptimise(maps=maps), args.repeats)
        print(f"glasses {w}x{h} k={k}: first run {first:.2f} s, reoptimise {again:.2f} s "
              f"(x{first / again:.1f} faster; solve {re.seconds['plan_solve']:.3f} s, "
              f"render {re.seconds['final_render']:.3f} s, the rest measuring the new pair)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
