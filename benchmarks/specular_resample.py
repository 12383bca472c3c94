"""Low-resolution offset solve (S3 §3.4) speed: the Numba block mean and joint bilateral up-sampling
against simple numpy versions, same process, at S3's sizes.

- :func:`~vergence.specular.weighted_block_mean` on the offset table ``(K + 1, N, H, W, 2)`` float32
  (K = 32, N = 7, 512 x 512 by default: 484 MB of values, 242 MB of weights) with factor 4; the
  reference reshapes to ``(..., H/f, f, W/f, f, C)`` and ``nansum``s (it needs H, W divisible by f).
- :func:`~vergence.specular.joint_bilateral_upsample` of ``(N, 128, 128)`` to ``(N, 512, 512)``
  (radius 2); the reference loops over the ``(2r + 1)^2`` window offsets, vectorised over the image.

Inputs: uniform random values with 10 % NaN, uniform weights with 10 % zeros, smooth guides plus
noise. Prints median wall (and CPU) times, the ratio, and the largest difference between the two.

Run: ``.venv/bin/python benchmarks/specular_resample.py [--size 512] [--layers 7] [--k 32] [--repeats 5]``
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import report, timed  # noqa: E402

from vergence.specular import joint_bilateral_upsample, weighted_block_mean  # noqa: E402


def block_mean_numpy(values: np.ndarray, weights: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray]:
    """Reshape and nansum (H, W divisible by f)."""
    *lead, h, w, c = values.shape
    wz = np.where(np.isnan(values).any(-1), np.float32(0), weights)
    num = np.nansum((values * wz[..., None]).reshape(*lead, h // f, f, w // f, f, c), axis=(-4, -2))
    den = wz.reshape(*lead, h // f, f, w // f, f).sum(axis=(-3, -1))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = num / den[..., None]
    return mean.astype(np.float32), (den / (f * f)).astype(np.float32)


def jbu_numpy(values, weights, guide_low, guide_high, sigma_space, sigma_range, radius, fill) -> np.ndarray:
    """Kopf et al. 2007 with importance weights, one window offset at a time over the whole image."""
    n, h, w = values.shape
    big_h, big_w = guide_high.shape[1:]
    yl = (np.arange(big_h) + 0.5) * h / big_h - 0.5
    xl = (np.arange(big_w) + 0.5) * w / big_w - 0.5
    ny = ((2 * np.arange(big_h) + 1) * h) // (2 * big_h)
    nx = ((2 * np.arange(big_w) + 1) * w) // (2 * big_w)
    usable = ~np.isnan(values) & (weights > 0)
    wq_all = np.where(usable, weights, 0.0)
    vw_all = np.where(usable, values, 0.0) * wq_all
    num = np.zeros(guide_high.shape)
    den = np.zeros(guide_high.shape)
    for dy in range(-radius, radius + 1):
        qy = ny + dy
        oky = (qy >= 0) & (qy < h)
        qy = np.clip(qy, 0, h - 1)
        for dx in range(-radius, radius + 1):
            qx = nx + dx
            okx = (qx >= 0) & (qx < w)
            qx = np.clip(qx, 0, w - 1)
            space = np.exp(-(((yl - qy) ** 2)[:, None] + ((xl - qx) ** 2)[None, :]) / (2 * sigma_space**2))
            space = space * (oky[:, None] & okx[None, :])
            gq = guide_low[:, qy[:, None], qx[None, :]]
            rng = np.exp(-((guide_high - gq) ** 2) / (2 * sigma_range**2))
            rng = np.where(np.isnan(rng), 1.0, rng)
            k = space[None] * rng
            num += vw_all[:, qy[:, None], qx[None, :]] * k
            den += wq_all[:, qy[:, None], qx[None, :]] * k
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, fill).astype(np.float32)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--layers", type=int, default=7)
    parser.add_argument("--k", type=int, default=32)
    parser.add_argument("--factor", type=int, default=4)
    parser.add_argument("--radius", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    f, n, size = args.factor, args.layers, args.size

    shape = (args.k + 1, n, size, size)
    values = rng.random((*shape, 2), dtype=np.float32)
    values[rng.random(shape) < 0.1] = np.nan  # both channels: no match
    weights = rng.random(shape, dtype=np.float32)
    weights[weights < 0.1] = 0
    weighted_block_mean(values[:1, :1, :8, :8], weights[:1, :1, :8, :8], f)  # compile
    print(f"weighted_block_mean {values.shape} float32 ({values.nbytes / 2**20:.0f} MiB), factor {f}:")
    fast = report("  Numba", [timed(lambda: weighted_block_mean(values, weights, f)) for _ in range(args.repeats)])
    slow = report("  numpy reshape + nansum", [timed(lambda: block_mean_numpy(values, weights, f))
                                               for _ in range(args.repeats)])  # fmt: skip
    (a, wa), (b, wb) = weighted_block_mean(values, weights, f), block_mean_numpy(values, weights, f)
    diff = max(float(np.nanmax(np.abs(a - b))), float(np.abs(wa - wb).max()))
    same_nan = bool((np.isnan(a) == np.isnan(b)).all())
    print(f"  ratio {slow / fast:.1f}x; max |difference| {diff:.1e}, same NaNs: {same_nan}")
    del values, weights, a, b

    low = size // f
    smooth = np.linspace(0, 60, size)[None, :, None] + np.linspace(0, 30, size)[None, None, :]
    guide_high = np.repeat(smooth, n, axis=0) + rng.normal(0, 2, (n, size, size))
    guide_low = guide_high.reshape(n, low, f, low, f).mean(axis=(2, 4))
    y = rng.random((n, low, low))
    y[rng.random(y.shape) < 0.1] = np.nan
    imp = rng.random((n, low, low))
    imp[imp < 0.1] = 0
    kw = dict(sigma_space=1.0, sigma_range=6.0, radius=args.radius, fill=1.0)
    joint_bilateral_upsample(y[:, :4, :4], imp[:, :4, :4], guide_low[:, :4, :4], guide_high[:, :16, :16], **kw)  # compile
    print(f"joint_bilateral_upsample ({n}, {low}, {low}) -> ({n}, {size}, {size}), radius {args.radius}:")
    fast = report("  Numba", [timed(lambda: joint_bilateral_upsample(y, imp, guide_low, guide_high, **kw))
                              for _ in range(args.repeats)])  # fmt: skip
    slow = report("  numpy over window offsets", [timed(lambda: jbu_numpy(y, imp, guide_low, guide_high, **kw))
                                                  for _ in range(args.repeats)])  # fmt: skip
    up = joint_bilateral_upsample(y, imp, guide_low, guide_high, **kw)
    diff = float(np.abs(up - jbu_numpy(y, imp, guide_low, guide_high, **kw)).max())
    print(f"  ratio {slow / fast:.1f}x; max |difference| {diff:.1e}")


if __name__ == "__main__":
    main()
