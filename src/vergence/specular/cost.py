"""The cost of a pixel's layered disparities (S3 §3.3, Eq. 2) and its gradient.

Per pixel, with ``N`` layers, ``d_i = (dx_i, dy_i)`` the disparity of layer ``i`` in arcminutes
(:func:`~vergence.specular.disparity_arcmin`), ``r_i`` its rivalry in (ΔL*)^2
(:func:`~vergence.specular.rivalry`), ``w_i`` its importance (:func:`~vergence.specular.importance`)
and ``o_i`` its original (physical) disparity, S3 Eq. 2 is
``f = alpha_a f_a + alpha_p f_p + alpha_r f_r + alpha_d f_d`` with ``alpha = (1, 1, 10, 0.1)`` (S3 §3.3).
Two objectives share that form (``variant``):

``"screen"``: S3 Eq. 2 as written (S3 §3.3)
    ``f_a = sum_i w_i^2 |d_i|^2`` (``||W d||^2``, every disparity pulled to the screen);
    ``f_p = sum_{i<j} (w_i w_j)^2 sum_c (sigma_ij,c (d_j,c - d_i,c) - lambda_c)^2`` (``||diag(Q w)(P d - d_p)||^2``
    over unordered pairs: over ordered pairs ``(D - lambda)^2 + (-D - lambda)^2`` is smallest at
    ``D = 0`` whatever ``lambda``; ``sigma_ij`` the sign of the physical difference, so the pair
    keeps its order); ``f_r = sum_i w_i^2 r_i^2`` (``||W r||^2``); ``f_d = sum_i w_i^2 |d_i - o_i|^2``.

``"comfort"`` (ours, the default): what S3 Eq. 2 intends, on scenes of large excess
    S3 §3.3 states the intent of each term: the absolute one "prevents disparity from exceeding the
    comfort zone"; the relative one moves layers closer where their relative disparity "prevents
    fusion" while two layers under about 2' pool into one (S3 §2); rivalry "needs to be avoided", but
    moderate differences are fused and tolerated (S3 §2); the data term "ensures that the
    optimization prefers the original disparity if multiple choices are equally good". Written so
    that each term does only that:

    - absolute ``f_a = sum_i w_i^2 (e(dx_i)^2 + v(dy_i)^2)``: ``e`` the part of ``dx`` outside the
      target zone ``[min + mu, max - mu]`` (the display's comfort zone less a margin ``mu``,
      :data:`COMFORT_MARGIN_ARCMIN`, so that whole-pixel matches of a surface brought to the
      target do not straddle the zone's edge), ``v`` the part of ``|dy|`` above the vertical
      tolerance (:data:`VERTICAL_TOLERANCE_ARCMIN`, S3 §3.2's 15' vertical fusion range).
    - data ``f_d = sum_i w_i^2 |d_i - P(o_i)|^2``, ``P`` the nearest point of that target box: the
      original disparity where it is comfortable, the nearest comfortable one where it is not. With
      ``o_i`` itself (S3) the data and absolute terms disagree wherever the original is outside the
      zone and settle between: with the zone's hinge and ``alpha_d = 0.1`` a reflection at 339'
      stops at ``(60 + 0.1 x 339) / 1.1 = 85'``. With ``P(o_i)`` both are 0 at the same point, so the
      data term is the tie-breaker S3 asks for, and a comfortable layer has no reason to move.
    - relative ``f_p = sum_{i<j} (w_i w_j)^2 max(0, lambda_x - sigma_ij (dx_j - dx_i))^2``: what
      remains of S3's pull towards ``lambda`` once the absolute term keeps every layer in the zone:
      two layers must not come closer than ``lambda_x = 3'`` (they would pool, S3 §2) nor swap
      sides (a reflection in front of its mirror). No pull on a pair already apart: S3's two-sided
      form flattens comfortable reflections onto their surface.
    - rivalry ``f_r = sum_i w_i^2 max(0, sqrt(r_i) - rho_0)^2`` in (ΔL*)^2: ``sqrt(r_i)`` is the RMS
      lightness difference of the matched 7 x 7 patches, ``rho_0`` the rivalry viewers tolerate
      (:data:`RIVALRY_TOLERANCE`, S3 §2). ``||W r||^2`` with ``r`` in (ΔL*)^2 is in (ΔL*)^4: a
      mean of thousands against an absolute term of a few arcmin^2, so that S3's balance of the
      weights (``alpha_r = 10``: 1 ΔL* of excess rivalry against sqrt(10) = 3.2' of excess
      disparity) meant nothing.

Importance ``w`` is the physical pair's (S3 §3.2 computes it on the physical render) and held
fixed: read at the current offsets, a pixel lowers its cost by sliding off its feature (its
importance falls) rather than by coming into the zone.

The maps ``m`` are per-layer, per-pixel weights a user paints (default 1), multiplying each term of
their layer (``m_p,ij = (m_p,i + m_p,j) / 2``); a layer whose maps are all 0 at a pixel costs
nothing there, and :func:`~vergence.specular.optimise_offsets` keeps it at ``y = 1`` (frozen). A
layer without a match at a pixel (NaN disparity) has no importance there (S3's proximity is 0) and
adds nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = [
    "ABSOLUTE_VARIANTS",
    "COMFORT_MARGIN_ARCMIN",
    "COST_TERMS",
    "COST_WEIGHTS",
    "RELATIVE_LAMBDA_ARCMIN",
    "RIVALRY_TOLERANCE",
    "VERTICAL_TOLERANCE_ARCMIN",
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
#: ``"screen"``: S3 Eq. 2 as written; ``"comfort"``: ours (see the module text).
ABSOLUTE_VARIANTS = ("screen", "comfort")
#: ``mu``: the comfort objective's target is the comfort zone less this on each side, arcmin (ours:
#: a quarter of the default zone's half-width, about two image pixels of a 320-px image stretched
#: over S3's study display, 8.5' each).
COMFORT_MARGIN_ARCMIN = 15.0
#: Vertical disparity the comfort objective tolerates, arcmin (S3 §3.2: 15' of vertical fusion range).
VERTICAL_TOLERANCE_ARCMIN = 15.0
#: ``rho_0``: the RMS lightness difference (ΔL*) of matched patches below which rivalry is not
#: costed (ours; S3 §2: "when differences ... are moderate, the HVS can fuse the images and
#: tolerate the rivalry"). Set at the noise of the measure itself: on Lambertian first-hit layers,
#: which have no rivalry (a diffuse point has one colour from both eyes), whole-pixel matches at
#: texture edges read a median of 1.7-11 and a 75th percentile of 5.6-23 ΔL* on the development
#: scenes and ``glasses`` (important pixels, 320 x 240, docs/specular.md); a tolerance below that
#: moves comfortable layers for the measure's own noise.
RIVALRY_TOLERANCE = 10.0


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


def _check_shape(variant, zone, lam, margin, vertical, rivalry_tolerance) -> tuple:  # noqa: ANN001
    """The objective's options checked; returns ``(lo, hi, lam, margin, vertical, rho0)`` as floats
    (``lo, hi`` the target zone: the comfort zone less the margin; 0 for the screen variant)."""
    if variant not in ABSOLUTE_VARIANTS:
        raise ValueError(f"variant must be one of {', '.join(ABSOLUTE_VARIANTS)}; got {variant!r}")
    if len(lam) != 2 or not all(np.isfinite(v) and v >= 0 for v in lam):
        raise ValueError(f"lam must be (lambda_x, lambda_y) arcmin >= 0; got {lam!r}")
    for name, v in (("margin", margin), ("vertical", vertical), ("rivalry_tolerance", rivalry_tolerance)):
        real = not isinstance(v, bool) and isinstance(v, int | float | np.integer | np.floating)
        if not real or not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite number >= 0; got {v!r}")
    if variant == "screen":
        return 0.0, 0.0, (float(lam[0]), float(lam[1])), 0.0, 0.0, 0.0
    if zone is None or len(zone) != 2 or not zone[0] <= 0.0 <= zone[1]:
        raise ValueError(f"the comfort variant needs zone = (min, max) arcmin with min <= 0 <= max; got {zone!r}")
    lo, hi = float(zone[0]) + float(margin), float(zone[1]) - float(margin)
    if lo > 0.0 or hi < 0.0:
        raise ValueError(f"margin {margin}' leaves nothing of the zone {tuple(zone)} (its target must hold 0)")
    return lo, hi, (float(lam[0]), float(lam[1])), float(margin), float(vertical), float(rivalry_tolerance)


def cost_inputs(disparity, rivalry, importance, original, maps, alpha, variant, zone, lam,
            margin=COMFORT_MARGIN_ARCMIN, vertical=VERTICAL_TOLERANCE_ARCMIN,
            rivalry_tolerance=RIVALRY_TOLERANCE):  # fmt: skip
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
    if (r < 0).any():
        raise ValueError("rivalry must be >= 0 (a mean of squared lightness differences)")
    matched = np.isfinite(d).all(axis=-1) & np.isfinite(o).all(axis=-1) & np.isfinite(r)
    w = np.where(matched, w, 0.0)
    d, o, r = np.where(matched[..., None], d, 0.0), np.where(matched[..., None], o, 0.0), np.where(matched, r, 0.0)
    try:
        a = tuple(float(v) for v in alpha)
    except (TypeError, ValueError):
        raise ValueError(f"alpha must be four numbers; got {alpha!r}") from None
    if len(a) != 4 or not all(np.isfinite(v) and v >= 0 for v in a):
        raise ValueError(f"alpha must be four finite numbers >= 0 (absolute, relative, rivalry, data); got {alpha!r}")
    opts = _check_shape(variant, zone, lam, margin, vertical, rivalry_tolerance)
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
    return d, r, w, o, m, a, opts


def _order(o: np.ndarray, d: np.ndarray, i: int, j: int, c: int) -> np.ndarray:
    """``sigma_ij``: the sign of the physical difference ``o_j - o_i`` (component ``c``), else of
    the current one, else +1."""
    sigma = np.sign(o[j, ..., c] - o[i, ..., c])
    sigma = np.where(sigma == 0, np.sign(d[j, ..., c] - d[i, ..., c]), sigma)
    return np.where(sigma == 0, 1.0, sigma)


def _excess(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The part of ``x`` outside ``[lo, hi]`` (signed; 0 inside)."""
    return np.where(x > hi, x - hi, np.where(x < lo, x - lo, 0.0))


def _terms(d, r, w, o, m, opts, variant):  # noqa: ANN001, ANN202
    """The four terms and their gradients in ``d`` and ``r`` (unweighted by alpha)."""
    lo, hi, lam, _, vert, rho0 = opts
    w2 = w * w
    n = d.shape[0]
    g = {t: (np.zeros_like(d), np.zeros_like(r)) for t in COST_TERMS}
    if variant == "screen":
        ex, ey = d[..., 0], d[..., 1]
        tx, ty = o[..., 0], o[..., 1]
        riv = m["rivalry"] * w2 * r * r
        g["rivalry"][1][:] = 2.0 * m["rivalry"] * w2 * r
    else:
        ex, ey = _excess(d[..., 0], lo, hi), _excess(d[..., 1], -vert, vert)
        tx, ty = np.clip(o[..., 0], lo, hi), np.clip(o[..., 1], -vert, vert)
        rho = np.sqrt(r)
        over = np.maximum(rho - rho0, 0.0)
        riv = m["rivalry"] * w2 * over * over
        with np.errstate(invalid="ignore", divide="ignore"):
            g["rivalry"][1][:] = np.where(over > 0, m["rivalry"] * w2 * over / np.where(rho > 0, rho, 1.0), 0.0)
    absolute = (m["absolute"] * w2 * (ex * ex + ey * ey)).sum(axis=0)
    g["absolute"][0][..., 0] = 2.0 * m["absolute"] * w2 * ex
    g["absolute"][0][..., 1] = 2.0 * m["absolute"] * w2 * ey
    e = d - np.stack([tx, ty], axis=-1)
    data = (m["data"] * w2 * (e**2).sum(axis=-1)).sum(axis=0)
    g["data"][0][:] = 2.0 * (m["data"] * w2)[..., None] * e
    relative = np.zeros(d.shape[1:3])
    for i in range(n):
        for j in range(i + 1, n):
            pair = 0.5 * (m["relative"][i] + m["relative"][j]) * (w[i] * w[j]) ** 2
            for c in range(2 if variant == "screen" else 1):
                sigma = _order(o, d, i, j, c)
                gap = sigma * (d[j, ..., c] - d[i, ..., c]) - lam[c]
                if variant != "screen":
                    gap = np.minimum(gap, 0.0)  # only closer than lambda (or swapped) costs
                relative += pair * gap * gap
                gg = 2.0 * pair * gap * sigma
                g["relative"][0][j, ..., c] += gg
                g["relative"][0][i, ..., c] -= gg
    return {"absolute": absolute, "relative": relative, "rivalry": riv.sum(axis=0), "data": data}, g


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
    margin: float = COMFORT_MARGIN_ARCMIN,
    vertical: float = VERTICAL_TOLERANCE_ARCMIN,
    rivalry_tolerance: float = RIVALRY_TOLERANCE,
) -> CostTerms:
    """The cost of every pixel's layer disparities (see the module's text).

    Parameters
    ----------
    disparity, original : (N, H, W, 2) array
        The disparities now and the physical ones, arcmin (NaN: no match).
    rivalry, importance : (N, H, W) array
        Rivalry in (ΔL*)^2, >= 0 (NaN: no match) and importance in [0, 1] (the physical pair's).
    alpha : four numbers >= 0
        Absolute, relative, rivalry, data.
    variant : {"screen", "comfort"}
        S3 Eq. 2 as written, or ours; ``"comfort"`` needs ``zone = (min, max)`` arcmin
        (``min <= 0 <= max``, e.g. :class:`vergence.viewing.ComfortZone`'s bounds).
    maps : dict, optional
        Painted per-layer, per-pixel weights ``(N, H, W) >= 0`` by term name (:data:`COST_TERMS`).
    lam : (float, float)
        ``(lambda_x, lambda_y)`` of the relative term, arcmin (the comfort variant uses ``lambda_x``).
    margin, vertical, rivalry_tolerance : float
        The comfort variant's ``mu`` and vertical tolerance (arcmin) and ``rho_0`` (ΔL*).

    Examples
    --------
    A reflection at 339' on a mirror at 0', both fully important, no rivalry: S3's data term pulls
    it back to 339', ours to the target zone's edge, 45' (where the absolute term is 0 too).

    >>> d = np.array([[[[0.0, 0.0]]], [[[45.0, 0.0]]]]); o = np.array([[[[0.0, 0.0]]], [[[339.0, 0.0]]]])
    >>> c = disparity_cost(d, np.zeros((2, 1, 1)), np.ones((2, 1, 1)), o, variant="comfort", zone=(-60, 60))
    >>> [float(c.absolute[0, 0]), float(c.data[0, 0]), float(c.relative[0, 0])]
    [0.0, 0.0, 0.0]
    """
    d, r, w, o, m, a, opts = cost_inputs(disparity, rivalry, importance, original, {} if maps is None else maps,
                                     alpha, variant, zone, lam, margin, vertical, rivalry_tolerance)  # fmt: skip
    terms, _ = _terms(d, r, w, o, m, opts, variant)
    total = sum(a[t] * terms[name] for t, name in enumerate(COST_TERMS))
    return CostTerms(terms["absolute"], terms["relative"], terms["rivalry"], terms["data"], total, a, variant)


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
    margin: float = COMFORT_MARGIN_ARCMIN,
    vertical: float = VERTICAL_TOLERANCE_ARCMIN,
    rivalry_tolerance: float = RIVALRY_TOLERANCE,
) -> tuple[np.ndarray, np.ndarray]:
    """``(df/dd (N, H, W, 2), df/dr (N, H, W))`` of :func:`disparity_cost`'s total at every pixel,
    importance held fixed (S3 §3.4 chains it with the numerical derivative of the tabulated ``g``).
    0 for a layer without a match (``sigma_ij`` is held fixed: it is piecewise constant)."""
    d, r, w, o, m, a, opts = cost_inputs(disparity, rivalry, importance, original, {} if maps is None else maps,
                                     alpha, variant, zone, lam, margin, vertical, rivalry_tolerance)  # fmt: skip
    _, g = _terms(d, r, w, o, m, opts, variant)
    grad_d = sum(a[t] * g[name][0] for t, name in enumerate(COST_TERMS))
    grad_r = sum(a[t] * g[name][1] for t, name in enumerate(COST_TERMS))
    return grad_d, grad_r
