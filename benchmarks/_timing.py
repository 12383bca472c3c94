"""Timing helpers shared by the scripts in ``benchmarks/`` (run as ``python benchmarks/NAME.py``).

Wall-clock and process CPU time of one call, medians over repeats, and the one-line report the
scripts print. Medians, because the development machine's cores are shared.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np


def timed(fn: Callable[[], object]) -> tuple[float, float]:
    """Wall-clock and process CPU time of one call ``fn()``, seconds."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def median_time(fn: Callable[[], object], repeats: int) -> tuple[float, object]:
    """Median wall-clock seconds of ``repeats`` calls of ``fn()``, and the last call's result."""
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def report(name: str, runs: list[tuple[float, float]], note: str = "", *, width: int = 44) -> float:
    """Print the median wall and CPU time of ``runs`` (from :func:`timed`) in ms; return the wall median, s."""
    arr = np.array(runs)
    wall, cpu = np.median(arr, axis=0)
    print(f"{name:{width}s} median {1e3 * wall:8.1f} ms  (CPU {1e3 * cpu:8.1f} ms; min {1e3 * arr[:, 0].min():.1f}, "
          f"max {1e3 * arr[:, 0].max():.1f} ms){note}")
    return float(wall)
