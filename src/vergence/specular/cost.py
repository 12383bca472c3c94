"""The cost of a pixel's layered disparities (S3 §3.3, Eq. 2) and its gradient.

Per pixel, with ``N`` layers, ``d_i = (dx_i, dy_i)`` the disparity of layer ``i`` in arcminutes
(:func:`~vergence.specular.disparity_arcmin`), ``r_i`` its rivalry
(:func:`~vergence.specular.rivalry`), ``w_i`` its importance (:func:`~vergence.specular.importance`)
and ``o_i`` its original (physical) disparity:

- absolute ``f_a = sum_i m_a,i w_i^2 (a(dx_i)^2 + dy_i^2)``: S3's ``||W d||^2`` pulls every
  disparity to the screen (``a(x) = x``, variant ``"screen"``), which flattens the scene; variant
  ``"comfort"`` costs only what lies outside the display's comfort zone
  (``a(x) = x - max`` above it, ``x - min`` below it, 0 inside). Vertical disparity is never
  comfortable: it is costed whole in both.
- relative ``f_p = sum_{i<j} m_p,ij (w_i w_j)^2 sum_c (sigma_ij,c (d_j,c - d_i,c) - lambda_c)^2``:
  S3 writes ``||diag(Q w)(P d - d_p)||^2`` over ordered pairs, where ``(D - lambda)^2 + (-D - lambda)^2``
  is smallest at ``D = 0`` whatever ``lambda``. Over unordered pairs it pulls two layers to
  ``lambda`` apart, S3's "small relative disparity" (``lambda = (3', 0')``, S3 §3.3: above the 2'
  at which transparent layers pool into one, S3 §2); ``sigma_ij`` is the sign of the physical
  difference ``o_j - o_i``, so the pair keeps its physical order: a reflection comes to 3' *behind*
  its mirror, never in front of it or onto it (S3 §1's complaint about on-surface methods).
  ``m_p,ij = (m_p,i + m_p,j) / 2``.
- rivalry ``f_r = sum_i m_r,i w_i^2 r_i^2`` (S3's ``||W r||^2``).
- data ``f_d = sum_i m_d,i w_i^2 |d_i - o_i|^2`` (S3's ``||W (d - d_d)||^2``).
- ``f = alpha_a f_a + alpha_p f_p + alpha_r f_r + alpha_d f_d``, ``alpha = (1, 1, 10, 0.1)`` by
  default (S3 §4).

The maps ``m`` are per-layer, per-pixel weights a user paints (default 1). A layer without a match
at a pixel (NaN disparity) has no importance there (S3's proximity is 0) and adds nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = [
    "ABSOLUTE_VARIANTS",
    "COST_TERMS",
    "COST_WEIGHTS",
    "RELATIVE_LAMBDA_ARCMIN",
    "CostTerms",
    "disparity_cost",
    "disparity_cost_gradient",
]

#: The four terms, in the order of :data:`COST_WEIGHTS`.
COST_TERMS = ("absolute", "relative", "rivalry", "data")
#: ``alpha`` of S3 §4: absolute, relative, rivalry, data.
COST_WEIGHTS = (1.0, 1.0, 10.0, 0.1)
#: ``(lambda_x, lambda_y)`` of the relative term, arcminutes (S3 §3.3).
RELATIVE_LAMBDA_ARCMIN = (3.0, 0.0)
#: ``"screen"``: S3's absolute term; ``"comfort"``: only what lies outside the comfort zone.
ABSOLUTE_VARIANTS = ("screen", "comfort")


@dataclass(frozen=True, slots=True)
class CostTerms:
    """The cost of every pixel (S3 Eq. 2): each term and the weighted total, ``(H, W)`` float64.

    ``absolute``, ``relative``, ``rivalry`` and ``data`` are unweighted by ``alpha`` (the painted
    maps are in them); ``total = sum alpha_t * term_t``.
    """

    absolute: np.ndarray
    relative: np.ndarray
    rivalry: np.ndarray
    data: np.ndarray
    total: np.ndarray
    alpha: tuple[float, float, float, float]
    variant: str

    def means(self) -> dict[str, float]:
        """The mean of each term and of the total over the image (for reports)."""
        return {name: float(np.mean(getattr(self, name))) for name in (*COST_TERMS, "total")}


def _inputs(disparity, rivalry, importance, original, maps, alpha, variant, zone, lam):
    d = np.asarray(disparity, dtype=np.float64)
    if d.ndim != 4 or d.shape[-1] != 2 or 0 in d.shape:
        raise ValueError(f"disparity must have shape (N, H, W, 2) in arcmin, not empty; got {d.shape}")
    shape = d.shape[:3]
    r = np.asarray(rivalry, dtype=np.float64)
    w = np.asarray(importance, dtype=np.float64)
    o = np.asarray(original, dtype=np.float64)
    for name, arr, want in (("rivalry", r, shape), ("importance", w, shape), ("original", o, d.shape)):
        if arr.shape != want:
            raise ValueError(f"{name} must have shape {want}; got {arr.shape}")
    if np.isinf(d).any() or np.isinf(o).any() or np.isinf(r).any():
        raise ValueError("disparity, original and rivalry must not hold inf (NaN marks no match)")
    if not np.isfinite(w).all() or (w < 0).any() or (w > 1).any():
        raise ValueError("importance must be finite and in [0, 1]")
    matched = np.isfinite(d).all(axis=-1) & np.isfinite(o).all(axis=-1) & np.isfinite(r)
    w = np.where(matched, w, 0.0)
    d, o, r = np.where(matched[..., None], d, 0.0), np.where(matched[..., None], o, 0.0), np.where(matched, r, 0.0)
    try:
        a = tuple(float(v) for v in alpha)
    except (TypeError, ValueError):
        raise ValueError(f"alpha must be four numbers; got {alpha!r}") from None
    if len(a) != 4 or not all(np.isfinite(v) and v >= 0 for v in a):
        raise ValueError(f"alpha must be four finite numbers >= 0 (absolute, relative, rivalry, data); got {alpha!r}")
    if variant not in ABSOLUTE_VARIANTS:
        raise ValueError(f"variant must be one of {', '.join(ABSOLUTE_VARIANTS)}; got {variant!r}")
    if variant == "comfort":
        if zone is None or len(zone) != 2 or not zone[0] <= 0.0 <= zone[1]:
            raise ValueError(f"the comfort variant needs zone = (min, max) arcmin with min <= 0 <= max; got {zone!r}")
    if len(lam) != 2 or not all(np.isfinite(v) and v >= 0 for v in lam):
        raise ValueError(f"lam must be (lambda_x, lambda_y) arcmin >= 0; got {lam!r}")
    unknown = set(maps) - set(COST_TERMS)
    if unknown:
        raise ValueError(f"maps has unknown terms {sorted(unknown)}; the terms are {', '.join(COST_TERMS)}")
    m = {}
    for name in COST_TERMS:
        arr = np.ones(shape) if maps.get(name) is None else np.asarray(maps[name], dtype=np.float64)
        if arr.shape != shape:
            raise ValueError(f"the {name} weight map must have shape {shape}; got {arr.shape}")
        if not np.isfinite(arr).all() or (arr < 0).any():
            raise ValueError(f"the {name} weight map must be finite and >= 0")
        m[name] = arr
    return d, r, w, o, m, a


def _order(o: np.ndarray, d: np.ndarray, i: int, j: int, c: int) -> np.ndarray:
    """``sigma_ij``: the sign of the physical difference ``o_j - o_i`` (component ``c``), else of
    the current one, else +1."""
    sigma = np.sign(o[j, ..., c] - o[i, ..., c])
    sigma = np.where(sigma == 0, np.sign(d[j, ..., c] - d[i, ..., c]), sigma)
    return np.where(sigma == 0, 1.0, sigma)


def _outside(x: np.ndarray, variant: str, zone) -> np.ndarray:
    if variant == "screen":
        return x
    lo, hi = zone
    return np.where(x > hi, x - hi, np.where(x < lo, x - lo, 0.0))


def disparity_cost(
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
) -> CostTerms:
    """The cost of every pixel's layer disparities (see the module's text).

    Parameters
    ----------
    disparity, original : (N, H, W, 2) array
        The disparities now and the physical ones, arcmin (NaN: no match).
    rivalry, importance : (N, H, W) array
        Rivalry (NaN: no match) and importance in [0, 1].
    alpha : four numbers >= 0
        Absolute, relative, rivalry, data.
    variant : {"screen", "comfort"}
        The absolute term; ``"comfort"`` needs ``zone = (min, max)`` arcmin (``min <= 0 <= max``,
        e.g. :class:`vergence.viewing.ComfortZone`'s bounds).
    maps : dict, optional
        Painted per-layer, per-pixel weights ``(N, H, W) >= 0`` by term name (:data:`COST_TERMS`).
    lam : (float, float)
        ``(lambda_x, lambda_y)`` of the relative term, arcmin.
    """
    d, r, w, o, m, a = _inputs(disparity, rivalry, importance, original, {} if maps is None else maps,
                               alpha, variant, zone, lam)  # fmt: skip
    w2 = w * w
    dx = _outside(d[..., 0], variant, zone)
    absolute = (m["absolute"] * w2 * (dx * dx + d[..., 1] ** 2)).sum(axis=0)
    relative = np.zeros(d.shape[1:3])
    n = d.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            pair = 0.5 * (m["relative"][i] + m["relative"][j]) * (w[i] * w[j]) ** 2
            for c in range(2):
                gap = _order(o, d, i, j, c) * (d[j, ..., c] - d[i, ..., c]) - lam[c]
                relative += pair * gap * gap
    riv = (m["rivalry"] * w2 * r * r).sum(axis=0)
    data = (m["data"] * w2 * ((d - o) ** 2).sum(axis=-1)).sum(axis=0)
    total = a[0] * absolute + a[1] * relative + a[2] * riv + a[3] * data
    return CostTerms(absolute, relative, riv, data, total, a, variant)


def disparity_cost_gradient(
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
) -> tuple[np.ndarray, np.ndarray]:
    """``(df/dd (N, H, W, 2), df/dr (N, H, W))`` of :func:`disparity_cost`'s total at every pixel,
    importance held fixed (S3 §3.4 chains it with the numerical derivative of the tabulated ``g``).
    0 for a layer without a match (``sigma_ij`` is held fixed: it is piecewise constant)."""
    d, r, w, o, m, a = _inputs(disparity, rivalry, importance, original, {} if maps is None else maps,
                               alpha, variant, zone, lam)  # fmt: skip
    w2 = w * w
    grad_d = np.zeros_like(d)
    grad_d[..., 0] = a[0] * 2.0 * m["absolute"] * w2 * _outside(d[..., 0], variant, zone)
    grad_d[..., 1] = a[0] * 2.0 * m["absolute"] * w2 * d[..., 1]
    n = d.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            pair = 0.5 * (m["relative"][i] + m["relative"][j]) * (w[i] * w[j]) ** 2
            for c in range(2):
                sigma = _order(o, d, i, j, c)
                g = a[1] * 2.0 * pair * (sigma * (d[j, ..., c] - d[i, ..., c]) - lam[c]) * sigma
                grad_d[j, ..., c] += g
                grad_d[i, ..., c] -= g
    grad_d += a[3] * 2.0 * (m["data"] * w2)[..., None] * (d - o)
    grad_r = a[2] * 2.0 * m["rivalry"] * w2 * r
    return grad_d, grad_r
