"""Leave-one-out quality of the StereoSpace novel views (S2 §3.1) on dino and kermit.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereospace_loo.py [--data DIR] [--collections dino kermit
CAMERA_FILE ...] [--methods plane mls depth] [--limit N] [--grid-step N] [--out DIR]``.
A collection is a built-in name (``dino``, ``kermit``: under ``--data``, by default the shared data
beside the checkout, ``../shared/data/collections``, as the tests find it) or the path of any camera
file of :func:`vergence.io.read_cameras`, its images in the same folder.
Each camera's view is made from the others (it left out of the sources, of the depth maps' matching
and of their checks), by the one-plane baseline, S2's MLS method and ours (per-view depth + ULR), and
compared with its photo: PSNR (dB) over the pixels the plane baseline covers. Prints one row per view
and the means, with the split the depth checks were tuned on (kermit and the even-numbered dino views)
apart from the held-out views (the odd-numbered dino views), the time of each method and, per view,
the share of the scored pixels that no checked depth covers (filled by S2's view) with their share of
the depth view's squared error; ``--out``
writes each view and its error image (|view - photo| x 4).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from PIL import Image

from vergence.stereospace import leave_one_out, load_collection
from vergence.stereospace.mls_view import S2_GRID_STEP

CAMERAS = {"dino": "dino_par.txt", "kermit": "bundle.out"}
# The shared data beside the checkout, as tests/conftest.py finds it (see shared/data/SOURCES.md).
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "collections"


def _camera_file(spec: str, data: Path) -> tuple[str, Path]:
    """(label, camera file) of a built-in collection name or a camera file's path."""
    if spec in CAMERAS:
        path = data / spec / CAMERAS[spec]
        if not path.is_file():
            raise SystemExit(f"collection {spec!r}: {path} not found (give --data, the folder holding {spec}/)")
        return spec, path
    path = Path(spec)
    if not path.is_file():
        raise SystemExit(f"collection {spec!r} is neither {' nor '.join(CAMERAS)} nor a camera file")
    return path.parent.name or path.stem, path


def _save(path: Path, image: np.ndarray) -> None:
    Image.fromarray((np.clip(image, 0, 1) * 255 + 0.5).astype(np.uint8)).save(path)


def _split(collection: str, names: list[str]) -> list[tuple[str, list[str]]]:
    """The views the depth checks were tuned on and the held-out ones (odd-numbered dino views)."""
    if collection == "kermit":
        return [("tuned", names)]
    if collection != "dino":
        return [("all", names)]
    held = [n for n in names if int(Path(n).stem[-4:]) % 2 == 1]
    parts = [("tuned", [n for n in names if n not in held]), ("held-out", held)]
    return [(label, part) for label, part in parts if part]


def _hole_share(scores: dict, name: str, photo: np.ndarray) -> tuple[float, float]:
    """Of the scored pixels (those the plane baseline covers), the share no checked depth covers in
    the depth view (filled by S2's view), and their share of its squared error, in %."""
    scored = scores["plane"][name][1].coverage
    view = scores["depth"][name][1]
    hole = scored & ~view.coverage
    error = ((view.image - photo) ** 2).sum(axis=-1)
    total = error[scored].sum()
    return 100 * hole.sum() / scored.sum(), 100 * (error[hole].sum() / total if total > 0 else 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA, help="folder of the built-in collections")
    parser.add_argument("--collections", nargs="+", default=["dino", "kermit"],
                        help="built-in names (dino, kermit) or camera files (images beside them)")
    parser.add_argument("--methods", nargs="+", default=["plane", "mls", "depth"])
    parser.add_argument("--limit", type=int, default=None, help="only the first N views")
    parser.add_argument("--grid-step", type=int, default=None,
                        help="S2's MLS grid spacing, pixels (mls, and depth's hole fill; default: the library's)")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    step = {} if args.grid_step is None else {"grid_step": args.grid_step}
    for spec in args.collections:
        name, camera_file = _camera_file(spec, args.data)
        start = time.perf_counter()
        col = load_collection(camera_file, images=camera_file.parent)
        print(f"{name}: {len(col)} views, {col.point_count} points, loaded in {time.perf_counter() - start:.1f} s; "
              f"MLS grid step {args.grid_step or S2_GRID_STEP}")  # fmt: skip
        images: dict = {}
        names = list(col.names)[: args.limit]
        scores = {}
        for method in args.methods:
            start = time.perf_counter()
            scores[method] = leave_one_out(col, method=method, names=names, images=images, **step)
            print(f"  {method}: {time.perf_counter() - start:.1f} s")
        both = {"depth", "plane"} <= set(args.methods)
        print("  " + f"{'view':<16}" + "".join(f"{m:>9}" for m in args.methods)
              + ("   depth-plane   holes: pixels, error" if both else ""))  # fmt: skip
        for n in names:
            row = "".join(f"{scores[m][n][0]:9.2f}" for m in args.methods)
            if both:
                pixels, error = _hole_share(scores, n, images[col.names.index(n)])
                row += f"   {scores['depth'][n][0] - scores['plane'][n][0]:+11.2f}   {pixels:5.1f} %  {error:5.1f} %"
            print(f"  {n:<16}{row}")
        for label, part in _split(name, names):
            means = "".join(f"{np.mean([scores[m][n][0] for n in part]):9.3f}" for m in args.methods)
            print(f"  {'mean ' + label:<16}{means}   ({len(part)} views)")
            if {"depth", "plane"} <= set(args.methods):
                gain = [scores["depth"][n][0] - scores["plane"][n][0] for n in part]
                print(f"  {label}: depth - plane min {min(gain):+.2f} dB, views >= +2 dB: "
                      f"{sum(g >= 2 for g in gain)}/{len(gain)}")  # fmt: skip
        if args.out is not None:
            out = args.out / name
            out.mkdir(parents=True, exist_ok=True)
            for n in names:
                photo = images[col.names.index(n)]
                for m in args.methods:
                    view = scores[m][n][1].image
                    _save(out / f"{Path(n).stem}_{m}.png", view)
                    _save(out / f"{Path(n).stem}_{m}_error.png", 4 * np.abs(view - photo))


if __name__ == "__main__":
    main()
