"""Prefiltered (mip-mapped) source colours for :func:`vergence.synthesis.render_ibr`.

A source that sees a surface at a higher resolution than the target (a longer lens, a nearer camera:
the Quadri-Rig's subject cameras see the background 2-3 times denser than the virtual eye) must be
low-pass filtered before it is resampled, or its texture aliases in the target. A GPU renderer such
as SIBR's ULR gets this from the texture unit's mipmaps; here it is explicit, as Williams 1983
("Pyramidal parametrics") defines it: a pyramid of 2x2 box averages per source, and per target
pixel the level ``lambda = log2(rho)`` where ``rho`` is the target pixel's footprint in the source,
the longer of the two target axes mapped into source pixels (``|d beta / dx|``, ``|d beta / dy|``),
trilinear between the two nearest levels.

The footprint comes from differences of the source pixel positions of neighbouring target pixels
that lie on one surface (proxy depths within :data:`MIP_DEPTH_CONTINUITY`); where neither neighbour
does, the level is 0. Near an occlusion edge of the source (a level-0 neighbour of the sample that
fails the visibility test) the level-0 occlusion-aware sample is kept, so a coarse level cannot
blend an occluder into the surface behind it there.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["MIP_DEPTH_CONTINUITY", "MIP_MAX_LEVEL", "footprint_levels", "prefilter_colours", "pyramid"]

# Neighbouring proxy points are one surface for the footprint when their target depths differ by at most
# this fraction (a 5 % step is an occlusion edge at any scene scale; a surface slanted at 80 degrees
# changes by ~1 % per pixel at the long-lens field of view of the examples).
MIP_DEPTH_CONTINUITY = 0.05
# Coarsest pyramid level used: 2^4 = 16 source pixels per target pixel, far beyond any rig of S0.
MIP_MAX_LEVEL = 4


def pyramid(image: np.ndarray, levels: int) -> list[np.ndarray]:
    """``levels + 1`` float32 images: level 0 = ``image``; level l+1 = 2x2 box averages of level l
    (an odd last row or column is repeated). Level l's pixel j covers level-0 pixels
    ``[j 2^l, (j+1) 2^l)``, centred at ``(j + 1/2) 2^l - 1/2``."""
    out = [np.ascontiguousarray(image, dtype=np.float32)]
    for _ in range(levels):
        a = out[-1]
        if a.shape[0] % 2:
            a = np.concatenate([a, a[-1:]], axis=0)
        if a.shape[1] % 2:
            a = np.concatenate([a, a[:, -1:]], axis=1)
        out.append(np.ascontiguousarray(0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])))
    return out


def _axis_derivative(pix: np.ndarray, same_prev: np.ndarray, same_next: np.ndarray, axis: int) -> np.ndarray:
    """d pix / d (target axis): central where both neighbours are one surface, one-sided where one is, NaN else."""
    n = pix.shape[axis]
    d = np.full(pix.shape, np.nan)
    if n < 2:
        return d
    sl = lambda a, b: tuple(slice(a, b) if i == axis else slice(None) for i in range(pix.ndim))  # noqa: E731
    fwd = np.full(pix.shape, np.nan)
    bwd = np.full(pix.shape, np.nan)
    fwd[sl(0, n - 1)] = pix[sl(1, n)] - pix[sl(0, n - 1)]
    bwd[sl(1, n)] = pix[sl(1, n)] - pix[sl(0, n - 1)]
    fwd[~same_next] = np.nan
    bwd[~same_prev] = np.nan
    both = np.isfinite(fwd) & np.isfinite(bwd)
    d[both] = 0.5 * (fwd[both] + bwd[both])
    one = ~both & np.isfinite(fwd)
    d[one] = fwd[one]
    one = ~both & ~np.isfinite(fwd) & np.isfinite(bwd)
    d[one] = bwd[one]
    return d


def footprint_levels(pixels: np.ndarray, visible: np.ndarray, depth_t: np.ndarray) -> np.ndarray:
    """Mip level ``log2(rho)`` per target pixel for one source, clipped to [0, MIP_MAX_LEVEL] (float32).

    ``pixels`` (h, w, 2): the source position of each target pixel's proxy point; ``visible`` (h, w);
    ``depth_t`` (h, w): the target proxy depth. ``rho = max(|d beta/dx|, |d beta/dy|)``.
    """
    z = depth_t
    with np.errstate(invalid="ignore"):
        ok = visible & np.isfinite(z)
        tol = MIP_DEPTH_CONTINUITY * z
        same_x = np.zeros(z.shape, dtype=bool)
        same_x[:, :-1] = ok[:, :-1] & ok[:, 1:] & (np.abs(z[:, 1:] - z[:, :-1]) <= tol[:, :-1])
        same_y = np.zeros(z.shape, dtype=bool)
        same_y[:-1] = ok[:-1] & ok[1:] & (np.abs(z[1:] - z[:-1]) <= tol[:-1])
    prev_x = np.zeros_like(same_x)
    prev_x[:, 1:] = same_x[:, :-1]
    prev_y = np.zeros_like(same_y)
    prev_y[1:] = same_y[:-1]
    dx = np.stack([_axis_derivative(pixels[..., c], prev_x, same_x, 1) for c in range(2)], axis=-1)
    dy = np.stack([_axis_derivative(pixels[..., c], prev_y, same_y, 0) for c in range(2)], axis=-1)
    import os
    if os.environ.get("MIPMODE") == "det":
        rho = np.sqrt(np.abs(dx[..., 0] * dy[..., 1] - dx[..., 1] * dy[..., 0]))
    elif os.environ.get("MIPMODE") == "min":
        rho = np.fmin(np.hypot(dx[..., 0], dx[..., 1]), np.hypot(dy[..., 0], dy[..., 1]))
    else:
        rho = np.fmax(np.hypot(dx[..., 0], dx[..., 1]), np.hypot(dy[..., 0], dy[..., 1]))  # NaN only if both NaN
    rho = rho * float(os.environ.get("MIPSCALE", "1"))
    with np.errstate(divide="ignore", invalid="ignore"):
        lod = np.log2(rho)
    lod = np.where(np.isfinite(lod) & ok, np.clip(lod, 0.0, MIP_MAX_LEVEL), 0.0)
    return lod.astype(np.float32)


def prefilter_colours(points: np.ndarray, camera: object, depth: np.ndarray, image: np.ndarray, visible: np.ndarray,
                      lod: np.ndarray, tol: float, colours: np.ndarray) -> None:  # fmt: skip
    """Replace ``colours`` (h, w, 3) by trilinear mip samples where ``lod > 0`` and the sample is inside a
    source surface (its four level-0 neighbours pass the visibility test), in place."""
    if not (lod > 0).any():
        return
    top = min(MIP_MAX_LEVEL, max(1, int(math.ceil(float(lod.max())))))
    levels = pyramid(image, top)
    flat = np.concatenate([lv.reshape(-1, 3) for lv in levels])
    sizes = np.array([lv.shape[:2] for lv in levels], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes[:, 0] * sizes[:, 1])[:-1]]).astype(np.int64)
    _prefilter(np.ascontiguousarray(points), np.ascontiguousarray(camera.K), np.ascontiguousarray(camera.R),
               np.ascontiguousarray(camera.t), np.ascontiguousarray(depth), flat, offsets, sizes, visible, lod,
               float(tol), colours)  # fmt: skip


@nb.njit(cache=True)
def _bilinear(flat, offset, hl, wl, u, v, c):  # pragma: no cover - compiled
    uc = min(max(u, 0.0), wl - 1.0)
    vc = min(max(v, 0.0), hl - 1.0)
    x0 = min(int(math.floor(uc)), wl - 1)
    y0 = min(int(math.floor(vc)), hl - 1)
    x1 = min(x0 + 1, wl - 1)
    y1 = min(y0 + 1, hl - 1)
    fx = uc - x0
    fy = vc - y0
    a = flat[offset + y0 * wl + x0, c] * (1.0 - fx) + flat[offset + y0 * wl + x1, c] * fx
    b = flat[offset + y1 * wl + x0, c] * (1.0 - fx) + flat[offset + y1 * wl + x1, c] * fx
    return a * (1.0 - fy) + b * fy


@nb.njit(cache=True, parallel=True)
def _prefilter(points, K, R, t, depth, flat, offsets, sizes, visible, lod, tol, colours):  # pragma: no cover - compiled
    h, w = visible.shape
    hs, ws = depth.shape
    top = sizes.shape[0] - 1
    for y in nb.prange(h):
        for x in range(w):
            lam = lod[y, x]
            if not (visible[y, x] and lam > 0.0):
                continue
            px, py, pz = points[y, x, 0], points[y, x, 1], points[y, x, 2]
            qx = R[0, 0] * px + R[0, 1] * py + R[0, 2] * pz + t[0]
            qy = R[1, 0] * px + R[1, 1] * py + R[1, 2] * pz + t[1]
            qz = R[2, 0] * px + R[2, 1] * py + R[2, 2] * pz + t[2]
            u = (K[0, 0] * qx + K[0, 1] * qy + K[0, 2] * qz) / qz
            v = (K[1, 1] * qy + K[1, 2] * qz) / qz
            x0 = min(max(int(math.floor(u)), 0), ws - 1)
            y0 = min(max(int(math.floor(v)), 0), hs - 1)
            inside = True
            for j in range(4):
                xj = min(x0 + (j & 1), ws - 1)
                yj = min(y0 + (j >> 1), hs - 1)
                if not abs(depth[yj, xj] - qz) <= tol * qz:
                    inside = False
            if not inside:
                continue
            lo = min(int(math.floor(lam)), top)
            hi = min(lo + 1, top)
            frac = lam - lo if hi > lo else 0.0
            for c in range(3):
                acc = 0.0
                for level, wt in ((lo, 1.0 - frac), (hi, frac)):
                    if wt <= 0.0:
                        continue
                    s = 2.0 ** level
                    ul = (u + 0.5) / s - 0.5
                    vl = (v + 0.5) / s - 0.5
                    acc += wt * _bilinear(flat, offsets[level], sizes[level, 0], sizes[level, 1], ul, vl, c)
                colours[y, x, c] = acc
