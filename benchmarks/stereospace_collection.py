"""Loading the dino and kermit collections: points, reprojection error, camera graph and timings.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereospace_collection.py [--neighbours 4] [--repeat 3]``
(reads ``../shared/data/collections``; see ``shared/data/SOURCES.md``). For each collection it prints
the cameras kept and left out, the point count and where the points come from (dino: SIFT matches
with each image's k nearest cameras, triangulated; kermit: Bundler's), the median reprojection
error, the graph's edge count and capture paths, and the median wall times of
:func:`load_collection` and of graph + paths.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _timing import median_time

from vergence.stereospace import camera_graph, capture_paths, load_collection

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "collections"



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--neighbours", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args()
    for cameras, images in (("dino/dino_par.txt", "dino"), ("kermit/bundle.out", "kermit")):
        t_load, col = median_time(lambda: load_collection(args.data / cameras, images=args.data / images,
                                                           neighbours=args.neighbours), args.repeat)  # fmt: skip
        t_graph, (graph, paths) = median_time(lambda: (g := camera_graph(col), capture_paths(g)), args.repeat)
        print(f"{images}: {len(col)} cameras kept, {col.left_out} without an image, {col.unregistered} unregistered; "
              f"{col.point_count} points ({col.points_source}), median reprojection error "
              f"{col.median_reprojection_error_px:.3f} px (90th percentile "
              f"{np.nanpercentile(col.reprojection_errors_px, 90):.3f}); graph {len(graph.edges)} edges "
              f"(axis angle {graph.axis_angle_deg.min():.1f}-{graph.axis_angle_deg.max():.1f} deg, shared points "
              f"{graph.shared_points.min()}-{graph.shared_points.max()}); "
              f"{len(paths)} polyline(s), lengths {[len(p) for p in paths]}, closed {[p[0] == p[-1] for p in paths]}; "
              f"load {t_load:.2f} s, graph + paths {1000 * t_graph:.1f} ms (median of {args.repeat})")


if __name__ == "__main__":
    main()
