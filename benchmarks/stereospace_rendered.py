"""The built-in photo collections (:func:`vergence.stereospace.render_collection`): time to ray-trace
them and to triangulate their points (:func:`~vergence.stereospace.load_collection`), and how far the
points lie from the truth: each point's depth in every 3rd view against the ray-traced depth of the
pixel it projects to (relative error; points occluded in that view compare with their occluder,
which the 90th percentile shows).

Run: ``.venv/bin/python benchmarks/stereospace_rendered.py [--scenes tabletop,stadium] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import median_time  # noqa: E402

from vergence.render import Tracer, builtin_scene  # noqa: E402
from vergence.stereospace import load_collection, render_collection  # noqa: E402


def _depth_error(collection, scene) -> np.ndarray:
    tracer, errors = Tracer(scene), []
    for cam in collection.cameras[::3]:
        depth = np.asarray(tracer.render(cam, max_depth=0, samples=1).depth)
        px, z = cam.project(collection.points)
        ok = np.isfinite(px).all(axis=1)
        ok &= (px[:, 0] >= 0) & (px[:, 0] <= cam.width - 1) & (px[:, 1] >= 0) & (px[:, 1] <= cam.height - 1)
        truth = depth[np.round(px[ok, 1]).astype(int), np.round(px[ok, 0]).astype(int)]
        known = np.isfinite(truth)
        errors.append(np.abs(z[ok][known] - truth[known]) / truth[known])
    return np.concatenate(errors)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="tabletop,stadium")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    for name in args.scenes.split(","):
        scene = builtin_scene(name)
        folder = Path(tempfile.mkdtemp(prefix=f"collection-{name}-"))
        render_collection(scene, folder, samples=1)  # compiles and warms
        render_s, path = median_time(lambda: render_collection(scene, folder), args.repeats)
        load_s, collection = median_time(lambda: load_collection(path, images=folder), args.repeats)
        error = _depth_error(collection, scene)
        print(f"{name}: {len(collection)} views {scene.camera.width}x{scene.camera.height}: render {render_s:.2f} s, "
              f"triangulate {load_s:.2f} s, {collection.point_count} points; depth error median "
              f"{100 * np.median(error):.2f} %, 90th percentile {100 * np.percentile(error, 90):.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
