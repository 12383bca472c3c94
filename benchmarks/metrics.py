"""Registration error (S1 Eq. 11): Numba kernel against the slow pure-Python reference of the tests.

Run: ``.venv/bin/python benchmarks/metrics.py``. Prints the median times of the kernel and of the
reference on a small image, their ratio, and the kernel's median time on a 695 x 555 colour pair
(Middlebury Dolls views 1 and 3 from ../shared/data when present, else random noise) with the
default r = 10, 5 x 5 ZNCC. The first (compiling) call is not timed.
"""

from __future__ import annotations

import importlib.util
import os
import statistics
import time
from pathlib import Path

# Before Numba's threading layer starts: spinning OpenMP threads steal shared cores (the library
# leaves the environment alone; see docs/conventions.md). A policy set by the caller wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np  # noqa: E402

from vergence.metrics import registration_error  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DOLLS = REPO.parent / "shared" / "data" / "multiview" / "dolls"


def _reference():
    """The slow reference loop, loaded from the test module (one source of truth)."""
    spec = importlib.util.spec_from_file_location("_test_metrics", REPO / "tests" / "test_metrics.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module.reference_registration_distance


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    reference = _reference()
    rng = np.random.default_rng(0)
    ref = rng.random((20, 20, 3)).astype(np.float32)
    image = np.clip(np.roll(ref, (1, 2), axis=(0, 1)) + 0.05 * rng.standard_normal(ref.shape), 0, 1)
    image = image.astype(np.float32)
    kwargs = {"radius": 4, "patch_size": 5}
    fast = registration_error(image, ref, **kwargs)  # compile (or load the cache)
    assert np.array_equal(fast.distance, reference(image, ref, **kwargs)), "kernel and reference disagree"
    t_fast = _median_time(lambda: registration_error(image, ref, **kwargs), 15)
    t_slow = _median_time(lambda: reference(image, ref, **kwargs), 3)
    print(f"small 20x20x3, r=4, 5x5 ZNCC: kernel {t_fast * 1e3:.2f} ms, reference {t_slow * 1e3:.0f} ms, "
          f"ratio {t_slow / t_fast:.0f}x")

    if (DOLLS / "view1.png").is_file():
        from vergence.io import read_image

        a, b = read_image(DOLLS / "view3.png"), read_image(DOLLS / "view1.png")
        source = "Dolls view3 vs view1"
    else:
        a = rng.random((555, 695, 3)).astype(np.float32)
        b = np.roll(a, (1, 2), axis=(0, 1))
        source = "random noise"
    t_big = _median_time(lambda: registration_error(a, b, radius=10, patch_size=5), 3)
    print(f"{a.shape[1]}x{a.shape[0]}x{a.shape[2]} ({source}), r=10, 5x5 ZNCC: kernel {t_big:.2f} s (median of 3)")


if __name__ == "__main__":
    main()
