"""``vergence.camera.interpolate`` (the eyes' cameras of every StereoSpace state) against scipy's ``Slerp``.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/camera_interpolate.py [--calls 2000]``.
Times, interleaved in one process, ``interpolate(a, b, s)`` (a quaternion slerp of our own) and the former
code, scipy's ``Rotation`` and ``Slerp`` making the same camera, over random rotation pairs; prints the median
process CPU time a call of each, their ratio and the largest difference of the rotations.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from vergence.camera import Camera, interpolate

K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])


def scipy_interpolate(a: Camera, b: Camera, s: float) -> Camera:
    """The former ``interpolate``: centres and intrinsics linear, rotations by scipy's Slerp."""
    center = (1.0 - s) * a.center + s * b.center
    R = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([a.R, b.R])))([s]).as_matrix()[0]
    return Camera(K=(1.0 - s) * a.K + s * b.K, R=R, t=-R @ center, width=a.width, height=a.height)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2000, help="calls of each per round (7 rounds)")
    args = parser.parse_args()
    if args.calls < 1:
        parser.error("--calls must be at least 1")
    rng = np.random.default_rng(0)
    pairs = [(Camera(K=K, R=Rotation.random(random_state=rng).as_matrix(), t=rng.normal(size=3), width=640, height=480),
              Camera(K=K, R=Rotation.random(random_state=rng).as_matrix(), t=rng.normal(size=3), width=640, height=480),
              float(rng.uniform(0.01, 0.99))) for _ in range(args.calls)]  # fmt: skip
    times = {"ours": [], "scipy": []}
    for _ in range(7):
        for name, fn in (("ours", interpolate), ("scipy", scipy_interpolate)):
            start = time.process_time()
            for a, b, s in pairs:
                fn(a, b, s)
            times[name].append((time.process_time() - start) / len(pairs))
    error = max(np.abs(interpolate(a, b, s).R - scipy_interpolate(a, b, s).R).max() for a, b, s in pairs)
    ours, ref = 1e3 * np.median(times["ours"]), 1e3 * np.median(times["scipy"])
    print(f"interpolate {ours:.3f} CPU-ms a call, scipy's Slerp {ref:.3f} (ratio {ref / ours:.1f}); "
          f"largest rotation difference {error:.1e} over {len(pairs)} random pairs; "
          f"load average {' '.join(open('/proc/loadavg').read().split()[:3])}")


if __name__ == "__main__":
    main()
