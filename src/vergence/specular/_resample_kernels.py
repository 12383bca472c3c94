"""Numba kernels of the low-resolution offset solve (S3 §3.4); caller :mod:`.resample`.

:func:`block_mean` reduces an importance-weighted image to a coarser grid and reports inputs that
break its contract (so that the caller validates in the same single pass over the large offset
table); :func:`joint_bilateral` up-samples with the guide of the fine grid (Kopf et al. 2007).
The slow, obviously-correct twins are loops in ``tests/specular/test_resample.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["block_mean", "joint_bilateral"]


@nb.njit(cache=True, parallel=True)
def block_mean(values, weights, f, mean, weight_mean, bad_values, bad_weights):  # noqa: ANN001, ANN201  # pragma: no cover - compiled
    """Per ``f x f`` block of ``values (L, H, W, C)``: ``sum(w v) / sum(w)`` into ``mean (L, h, w, C)``
    (NaN where the sum of usable weights is 0) and ``sum(w) / pixels`` into ``weight_mean (L, h, w)``,
    a pixel whose value is NaN in any channel counting with weight 0. Blocks at the right and bottom
    edges hold the pixels they have. Work item ``i`` is output row ``i % h`` of image ``i // h``; it
    sets ``bad_values[i]`` when its pixels hold an inf value and ``bad_weights[i]`` when they hold a
    weight that is negative, NaN or inf.
    """
    n_img, big_h, big_w, nc = values.shape
    ho, wo = mean.shape[1], mean.shape[2]
    for item in nb.prange(n_img * ho):
        img = item // ho
        by = item % ho
        sw = np.zeros(wo)
        swv = np.zeros((wo, nc))
        r0 = by * f
        r1 = min(r0 + f, big_h)
        inf_v = False
        bad_w = False
        for r in range(r0, r1):
            for bx in range(wo):  # block by block: no division per pixel
                acc = 0.0
                for c in range(bx * f, min(bx * f + f, big_w)):
                    wt = float(weights[img, r, c])
                    if not (wt >= 0.0 and wt < math.inf):  # negative, NaN or inf
                        bad_w = True
                        continue
                    t = 0.0
                    for ch in range(nc):
                        t += values[img, r, c, ch]
                    if t - t != 0.0:  # a NaN or inf channel (or an overflowing sum): look closer
                        usable = True
                        for ch in range(nc):
                            v = values[img, r, c, ch]
                            if v != v:
                                usable = False
                            elif v == math.inf or v == -math.inf:
                                inf_v = True
                        if not usable:
                            continue
                    acc += wt  # weight 0 with finite values adds 0
                    for ch in range(nc):
                        swv[bx, ch] += wt * float(values[img, r, c, ch])
                sw[bx] += acc
        bad_values[item] = inf_v
        bad_weights[item] = bad_w
        rows = r1 - r0
        for bx in range(wo):
            cols = min(f, big_w - bx * f)
            weight_mean[img, by, bx] = sw[bx] / (rows * cols)
            for ch in range(nc):
                if sw[bx] > 0.0:
                    # factor 1: the value itself (w v / w may differ from v by an ulp when w is float64)
                    mean[img, by, bx, ch] = values[img, r0, bx, ch] if f == 1 else swv[bx, ch] / sw[bx]
                else:
                    mean[img, by, bx, ch] = np.nan


@nb.njit(cache=True)
def _window(i, n_low, n_high, radius):  # noqa: ANN001, ANN202  # pragma: no cover - compiled
    """Fine pixel ``i`` of ``n_high`` on a grid of ``n_low``: its coarse coordinate
    ``(i + 1/2) n_low / n_high - 1/2`` and the clipped window ``[lo, hi)`` of ``radius`` around the
    nearest coarse pixel ``floor((2 i + 1) n_low / (2 n_high))`` (integer arithmetic: no tie flips)."""
    pos = (i + 0.5) * n_low / n_high - 0.5
    near = ((2 * i + 1) * n_low) // (2 * n_high)
    return pos, max(0, near - radius), min(n_low, near + radius + 1)


@nb.njit(cache=True, parallel=True)
def joint_bilateral(vw, w, guide_low, guide_high, inv2ss, inv2sr, radius, fill, out):  # noqa: ANN001, ANN201  # pragma: no cover - compiled
    """Joint bilateral up-sampling of ``vw / w`` (``(N, h, w)``: value times weight and weight, both
    0 where the value is unusable) to ``out (N, H, W)`` with ``guide_high`` against ``guide_low``.

    Tap ``q`` of fine pixel ``p`` has the exponent ``e_q = |p_low - q|^2 inv2ss + (g_p - g_q)^2 inv2sr``
    (the range term dropped where either guide is NaN); the output is
    ``sum_q vw_q exp(-e_q) / sum_q w_q exp(-e_q)``, evaluated with every exponent shifted by the
    smallest one so that far-apart guides do not underflow both sums to 0 (the ratio is unchanged);
    ``fill`` where no tap has ``w_q > 0``.
    """
    n_img, h, wl = w.shape
    big_h, big_w = out.shape[1], out.shape[2]
    taps = (2 * radius + 1) * (2 * radius + 1)
    for item in nb.prange(n_img * big_h):
        img = item // big_h
        r = item % big_h
        e = np.empty(taps)
        qw = np.empty(taps)
        qv = np.empty(taps)
        ypos, y0, y1 = _window(r, h, big_h, radius)
        for c in range(big_w):
            xpos, x0, x1 = _window(c, wl, big_w, radius)
            gp = guide_high[img, r, c]
            k = 0
            emin = np.inf
            for qy in range(y0, y1):
                dy = ypos - qy
                for qx in range(x0, x1):
                    wq = w[img, qy, qx]
                    if wq == 0.0:
                        continue
                    dx = xpos - qx
                    ex = (dy * dy + dx * dx) * inv2ss
                    gq = guide_low[img, qy, qx]
                    if gp == gp and gq == gq:  # a NaN guide: range factor 1
                        dg = gp - gq
                        ex += dg * dg * inv2sr
                    e[k] = ex
                    qw[k] = wq
                    qv[k] = vw[img, qy, qx]
                    emin = min(emin, ex)
                    k += 1
            if k == 0:
                out[img, r, c] = fill
                continue
            num = 0.0
            den = 0.0
            for j in range(k):
                s = math.exp(emin - e[j])
                num += qv[j] * s
                den += qw[j] * s
            out[img, r, c] = num / den
