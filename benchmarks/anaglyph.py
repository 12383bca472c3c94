"""Dubois's anaglyph (:func:`vergence.display.anaglyph`) on the views a StereoSpace pair packs, against the
float64 numpy formula in the same process.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/anaglyph.py [--repeat 15] [--data DIR]``
(kermit and dino under ``../shared/data/collections``, see ``shared/data/SOURCES.md``; random views always).
Per input: the share of the views' values that decode on sRGB's linear segment (<= 0.04045, black included:
no table value is used there), the median process CPU time of the Numba kernel and of the numpy formula
(both threads), their ratio, and the kernel's largest difference from the formula. Before the kernel was
vectorised, a mostly black view (dino's background) packed much faster than a photo-filled one (kermit,
random), because black skipped the tables; the vectorised rows depend less on the content (issue 27's
runs: dino 5.9-8.4, kermit 6.8-11.1, random 7.9-10.6 CPU-ms).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import timed  # noqa: E402

from vergence.display import DUBOIS_RED_CYAN_LEFT, DUBOIS_RED_CYAN_RIGHT, anaglyph  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "collections"
COLLECTIONS = {"kermit": "bundle.out", "dino": "dino_par.txt"}


def reference(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Dubois's red-cyan anaglyph in float64 numpy (linear light, clipped, sRGB encoded)."""
    def decode(v: np.ndarray) -> np.ndarray:
        v = v.astype(np.float64)
        return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)

    lin = np.clip(decode(left) @ DUBOIS_RED_CYAN_LEFT.T + decode(right) @ DUBOIS_RED_CYAN_RIGHT.T, 0.0, 1.0)
    return np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)


def _views(data: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    from vergence.stereospace import PreparedCollection, StereoState, load_collection, stereo_pair

    rng = np.random.default_rng(0)
    out = {"random": tuple(rng.random((480, 640, 3), dtype=np.float32) for _ in range(2))}
    for name, cameras in COLLECTIONS.items():
        if not (data / name / cameras).is_file():
            print(f"{name}: not found under {data}, skipped")
            continue
        prepared = PreparedCollection(load_collection(data / name / cameras, images=data / name))
        pair = stereo_pair(prepared, StereoState((0, 1), 0.5, 0.5), width=640)
        out[name] = (np.ascontiguousarray(pair.left, np.float32), np.ascontiguousarray(pair.right, np.float32))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15, help="timed calls of each, interleaved")
    parser.add_argument("--data", type=Path, default=DATA, help="the folder holding kermit/ and dino/")
    args = parser.parse_args()
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    for name, (left, right) in _views(args.data).items():
        anaglyph(left, right)  # compiled or loaded from the cache, untimed
        ours, ref = [], []
        for _ in range(args.repeat):
            ours.append(timed(lambda: anaglyph(left, right))[1])
            ref.append(timed(lambda: reference(left, right))[1])
        linear = np.mean(np.concatenate([left.ravel(), right.ravel()]) <= 0.04045)
        error = np.abs(anaglyph(left, right) - reference(left, right)).max()
        a, r = 1e3 * np.median(ours), 1e3 * np.median(ref)
        print(f"{name:7s} {left.shape[1]}x{left.shape[0]}: {100 * linear:5.1f} % of values on the linear segment; "
              f"kernel {a:6.1f} CPU-ms, numpy {r:6.1f} CPU-ms (ratio {r / a:4.1f}); largest difference {error:.1e}")
    print(f"load average {' '.join(open('/proc/loadavg').read().split()[:3])}")


if __name__ == "__main__":
    main()
