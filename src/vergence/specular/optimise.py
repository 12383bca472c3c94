"""Per-pixel camera offsets that minimise the layered disparity cost (S3 §3.4).

The left eye's shading camera for layer ``i`` sits at offset ``y_i`` on the line to the right eye
(``y = 1``: the left eye, the physical stereo; ``y = 0``: the right eye's centre, the layer mono).
The disparity and rivalry of every layer are tabulated at the offsets ``m / K`` (``K + 1`` renders
of the left eye, S3: ``K = 32``); importance is the physical pair's (S3 §3.2 computes it on the
physical render), held fixed. Per pixel, :func:`optimise_offsets` runs
``steps`` steps of gradient descent on the linearly interpolated table (the chain rule of the
table's slope and the analytic gradient of S3 Eq. 2, :func:`~vergence.specular.disparity_cost_gradient`)
from S3's starts ``y = (1, s, ..., s)``, ``s = i / (restarts - 1)``, and keeps the best (among
equals the first, ``s = 1``). The diffuse (first) layer stays at ``y = 1`` unless told otherwise.

Decisions: a step is ``-step * grad / max |grad|`` (a normalised step: the cost's scale in
arcmin^2 varies by orders of magnitude between pixels), kept only when it lowers the cost, else
halved, from :data:`FIRST_STEP`. Importance is not read at the current offsets: a pixel whose
importance falls as its layer slides off a feature would lower its cost without coming into the
zone (issue 26: a mirror's important pixels had w = 0.8 at y = 1 and 0.01-0.06 at y = 0.25-0.88).
Rows of the table where a layer lost its match take the disparity of the nearest matched rows
(interpolated): losing the match is no escape either. A layer whose painted maps are all 0 at a
pixel stays at ``y = 1`` there (frozen). S3's edge-aware blur and the low-resolution solve with joint-bilateral
upsampling are :class:`vergence.specular.OffsetPlanner`'s (stages in :mod:`vergence.specular.resample`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from vergence.specular import _optimise_kernels
from vergence.specular.cost import (
    COMFORT_MARGIN_ARCMIN,
    COST_TERMS,
    COST_WEIGHTS,
    RELATIVE_LAMBDA_ARCMIN,
    RIVALRY_TOLERANCE,
    VERTICAL_TOLERANCE_ARCMIN,
    cost_inputs,
)

__all__ = ["DESCENT_STEPS", "FIRST_STEP", "RESTARTS", "OffsetSolution", "optimise_offsets"]

#: Gradient steps per start (S3 §3.4).
DESCENT_STEPS = 32
#: Starts per pixel (S3 §3.4: y = (1, i/3, ..., i/3), i = 0..3).
RESTARTS = 4
#: The first step's length in offset units (a quarter of the range).
FIRST_STEP = 0.25


@dataclass(frozen=True, slots=True)
class OffsetSolution:
    """The optimised offsets: ``y (N, H, W)`` in [0, 1] and the cost there, ``cost (H, W)``."""

    y: np.ndarray
    cost: np.ndarray


def optimise_offsets(
    disparity: object,
    rivalry: object,
    importance: object,
    original: object,
    *,
    alpha: object = COST_WEIGHTS,
    variant: str = "screen",
    zone: tuple[float, float] | None = None,
    maps: Mapping[str, object] | None = None,
    lam: tuple[float, float] = RELATIVE_LAMBDA_ARCMIN,
    margin: float = COMFORT_MARGIN_ARCMIN,
    vertical: float = VERTICAL_TOLERANCE_ARCMIN,
    rivalry_tolerance: float = RIVALRY_TOLERANCE,
    fixed: object = (0,),
    steps: int = DESCENT_STEPS,
    restarts: int = RESTARTS,
) -> OffsetSolution:
    """Per pixel, the layer offsets minimising S3 Eq. 2 on a tabulated ``g(y)``.

    Parameters
    ----------
    disparity : (K + 1, N, H, W, 2) array
        The disparity of each layer (arcmin, NaN: no match) with its left camera at offset ``m / K``.
    rivalry : (K + 1, N, H, W) array
        Likewise, (ΔL*)^2 >= 0.
    importance : (N, H, W) array
        The physical pair's importance in [0, 1], held fixed (S3 §3.2).
    original : (N, H, W, 2) array
        The physical disparity (the table at ``y = 1``, usually).
    alpha, variant, zone, maps, lam, margin, vertical, rivalry_tolerance
        As :func:`~vergence.specular.disparity_cost`.
    fixed : sequence of int
        Layers kept at ``y = 1`` (default the diffuse first layer); a layer whose four maps are 0
        at a pixel is kept at 1 there too.
    steps, restarts : int
        Descent steps per start (>= 1) and starts (>= 1; one start is ``y = 1``).
    """
    d = np.asarray(disparity, dtype=np.float32)  # the table is large: 33 x N x H x W x 2 at S3's K
    if d.ndim != 5 or d.shape[-1] != 2 or d.shape[0] < 3 or 0 in d.shape:
        raise ValueError(f"disparity must have shape (K + 1, N, H, W, 2) with K >= 2; got {d.shape}")
    kp1, n, h, w, _ = d.shape
    r = np.asarray(rivalry, dtype=np.float32)
    imp = np.asarray(importance, dtype=np.float64)
    if r.shape != d.shape[:4]:
        raise ValueError(f"rivalry must have shape {d.shape[:4]}; got {r.shape}")
    if imp.shape != d.shape[1:4]:
        raise ValueError(f"importance must have shape {d.shape[1:4]} (the physical pair's, held fixed); "
                         f"got {imp.shape}")  # fmt: skip
    if np.isinf(d).any() or np.isinf(r).any():
        raise ValueError("disparity and rivalry must not hold inf (NaN marks no match)")
    if (r < 0).any():
        raise ValueError("rivalry must be >= 0 (a mean of squared lightness differences)")
    if not np.isfinite(imp).all() or imp.min() < 0 or imp.max() > 1:
        raise ValueError("importance must be finite and in [0, 1]")
    orig = np.asarray(original, dtype=np.float64)
    if orig.shape != (n, h, w, 2):
        raise ValueError(f"original must have shape {(n, h, w, 2)}; got {orig.shape}")
    # alpha, variant, zone, lam and the maps checked as the cost checks them
    _, _, _, _, m, a, opts = cost_inputs(orig, np.zeros((n, h, w)), np.zeros((n, h, w)), orig,
                                     {} if maps is None else maps, alpha, variant, zone, lam, margin, vertical,
                                     rivalry_tolerance)  # fmt: skip
    lo, hi, lam_f, _, vert, rho0 = opts
    for name, v, low in (("steps", steps, 1), ("restarts", restarts, 1)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < low:
            raise ValueError(f"{name} must be an integer >= {low}; got {v!r}")
    free = np.ones(n, dtype=np.bool_)
    for i in fixed:
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < n:
            raise ValueError(f"fixed must list layer indices in [0, {n - 1}]; got {fixed!r}")
        free[i] = False
    # y = 1 first: the kernel keeps the first of equal costs, so a pixel whose free layers all lack
    # importance (cost independent of y) keeps the physical stereo
    levels = np.array([1.0]) if restarts == 1 else np.arange(restarts)[::-1] / (restarts - 1)
    starts = np.repeat(levels[:, None], n, axis=1)
    # pixel-major, so that the kernel reads one contiguous block per pixel (a transposed copy: the
    # whole-image table at S3's K = 32 is read once here rather than scattered 128 x 4 times per pixel)
    tab = np.empty((h, w, n, kp1, 3), np.float32)
    tab[..., :2] = d.transpose(2, 3, 1, 0, 4)
    tab[..., 2] = r.transpose(2, 3, 1, 0)
    maps4 = np.ascontiguousarray(np.stack([m[t] for t in COST_TERMS]).transpose(2, 3, 0, 1))
    y = np.empty((n, h, w))
    cost = np.empty((h, w))
    _optimise_kernels.descend(tab, np.ascontiguousarray(imp.transpose(1, 2, 0)),
                              np.ascontiguousarray(orig.transpose(1, 2, 0, 3)), maps4, free, starts, int(steps),
                              FIRST_STEP, np.array(a), variant == "comfort", lo, hi, vert, rho0, lam_f[0], lam_f[1],
                              y, cost)  # fmt: skip
    y.flags.writeable = False
    cost.flags.writeable = False
    return OffsetSolution(y, cost)
