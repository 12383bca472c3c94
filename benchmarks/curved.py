"""Curved-ray render speed: :meth:`Tracer.render_curved` against :meth:`Tracer.render` on the built-in stadium.

Run: ``.venv/bin/python benchmarks/curved.py [--width 320] [--height 180] [--samples 16] [--repeat 3]``.
The map is smoothly curved, of the Tri-Rig's kind (S0 §6): a scaling about a centre c 0.3 m to the
left of the camera (a left camera's centre), by Z(z) / z with Z(z) = z up to 30 m and
z + (z - 30)^2 / 60 beyond (the distortion compresses depths beyond 30 m; ``to_world`` stretches them
back). Prints the median wall times (one tracer, the first JIT-compiling calls not timed), their ratio,
the points ``to_world`` maps per ray (each render maps each sample, midpoint, one-pixel step and
quarter point once: issue 31), the segments per ray (sampled over [near, CURVE_CUT_DEPTH], and cast until the hit), and the pixel
error of the hits: phi(position) projected by the camera against the pixel centres (phi = to_world^-1
in closed form), to compare with ``tolerance_px``.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as the vergence command: idle OpenMP threads must not spin

import numpy as np  # noqa: E402
from _timing import median_time  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--near", type=float, default=0.5)
    parser.add_argument("--tolerance", type=float, default=0.25, help="tolerance_px")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    from vergence.render import Tracer, builtin_scene, trace_curved
    from vergence.render.curved import sample_curves

    scene = builtin_scene("stadium", width=args.width, height=args.height)
    cam = scene.camera.build()
    axis, c = cam.R[2], cam.center - 0.3 * cam.R[0]

    def to_world(q):  # noqa: ANN001, ANN202
        z = (q - c) @ axis
        with np.errstate(divide="ignore", invalid="ignore"):
            return c + ((z + np.where(z > 30.0, (z - 30.0) ** 2 / 60.0, 0.0)) / z)[..., None] * (q - c)

    def phi(p):  # noqa: ANN001, ANN202
        zr = (p - c) @ axis
        z = np.where(zr > 30.0, 30.0 + 30.0 * (np.sqrt(1.0 + np.maximum(zr - 30.0, 0.0) / 15.0) - 1.0), zr)
        return c + (z / zr)[..., None] * (p - c)

    mapped = [0]

    def counted(q):  # noqa: ANN001, ANN202
        mapped[0] += np.asarray(q).size // 3
        return to_world(q)

    tracer = Tracer(scene)
    options = {"near": args.near, "far": np.inf, "tolerance_px": args.tolerance, "samples": args.samples}
    tracer.render(cam, samples=args.samples)
    trace_curved(tracer, cam, to_world, **options)
    t_straight, straight = median_time(lambda: tracer.render(cam, samples=args.samples), args.repeat)
    t_curved, bent = median_time(lambda: trace_curved(tracer, cam, counted, **options), args.repeat)
    per_ray = mapped[0] / args.repeat / (args.width * args.height)
    t_identity, _ = median_time(lambda: trace_curved(tracer, cam, lambda q: q, **options), args.repeat)
    sampled = sample_curves(cam, to_world, near=args.near, far=np.inf, tolerance_px=args.tolerance).segments
    n = args.width * args.height
    cast = (bent.settings.tree_rays - straight.settings.tree_rays) / n
    px, _ = cam.project(phi(bent.position[0].reshape(-1, 3).astype(np.float64)))
    ys, xs = np.mgrid[0 : args.height, 0 : args.width]
    err = np.hypot(px[:, 0] - xs.ravel(), px[:, 1] - ys.ravel())
    print(f"stadium {args.width}x{args.height}, samples {args.samples}, tolerance {args.tolerance:g} px, "
          f"near {args.near:g} m, far inf")  # fmt: skip
    print(f"render        {t_straight:.3f} s")
    print(f"render_curved {t_curved:.3f} s ({t_curved / t_straight:.2f}x); identity map {t_identity:.3f} s "
          f"({t_identity / t_straight:.2f}x)")  # fmt: skip
    print(f"to_world maps {per_ray:.1f} points per ray")
    print(f"segments per ray: {sampled.mean():.2f} sampled over [near, CURVE_CUT_DEPTH] (max {sampled.max()}), "
          f"{cast:.2f} cast until the hit")  # fmt: skip
    print(f"hit pixel error: max {np.nanmax(err):.3f} px, mean {np.nanmean(err):.3f} px; "
          f"depth {np.nanmin(bent.depth):.1f}-{np.nanmax(bent.depth):.1f} m "
          f"(straight: {np.nanmin(straight.depth):.1f}-{np.nanmax(straight.depth):.1f} m)")  # fmt: skip


if __name__ == "__main__":
    main()
