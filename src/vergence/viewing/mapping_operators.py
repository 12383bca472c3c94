"""Disparity mapping operators psi(d) (Lang et al. 2010; S0 Eq. (7)–(9)).

Every operator is a frozen object, increasing in ``d``, callable on arrays, with
``derivative(d)`` (psi', needed by the mapped roundness, S0 Eq. 9) and ``inverse(value)``
(closed form where one exists, vectorised bisection otherwise). Disparities are in any consistent
unit (fractions of the image width for S0's geometry, pixels for images); NaN (invalid) passes
through. See ``docs/conventions.md`` for the disparity sign.
"""

from __future__ import annotations

import dataclasses
import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array, check_finite, check_in_range, check_positive, check_positive_int
from vergence.viewing._shared import float_or_array, real_array
from vergence.viewing.mapping_hermite import (
    gregory_delbourgo,
    gregory_delbourgo_derivative,
    gregory_delbourgo_inverse,
    pchip_slopes,
)

__all__ = [
    "DisparityMapping",
    "LinearMapping",
    "LogMapping",
    "RationalHermiteMapping",
    "SaliencyMapping",
    "bisect_inverse",
]

# Bisection halves a bracket at most this often; 2200 halvings take any pair of finite doubles
# (range < 2^1024, spacing >= 2^-1074) down to adjacent floats.
_BISECTION_STEPS = 2200
# Bisection stops when the bracket is 2 float epsilons of its end points (or of the first
# bracket's width near 0): the root is then known to the precision psi itself is computed to.
_BISECTION_EPS = 2.0 * np.finfo(np.float64).eps
# Doublings allowed when searching a bracket on an unbounded side (2^1100 exceeds every double).
_BRACKET_DOUBLINGS = 1100


class DisparityMapping(ABC):
    """An increasing disparity mapping ``psi``: call it, differentiate it, invert it.

    Subclasses implement ``_value`` and ``_derivative`` on validated float64 arrays and, where a
    closed form exists, ``_inverse``; the default inverse is a vectorised bisection over
    :meth:`domain`.
    """

    __slots__ = ()

    def domain(self) -> tuple[float, float]:
        """Open interval of disparities where psi is defined; ``(-inf, inf)`` unless overridden."""
        return (-math.inf, math.inf)

    @abstractmethod
    def _value(self, d: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def _derivative(self, d: np.ndarray) -> np.ndarray: ...

    def _inverse(self, value: np.ndarray) -> np.ndarray:
        return bisect_inverse(self._value, value, *self.domain())

    def _checked(self, name: str, d: object) -> np.ndarray:
        arr = real_array(name, d, allow_nan=True)
        lo, hi = self.domain()
        bad = ~np.isnan(arr) & ((arr <= lo) | (arr >= hi))
        if bad.any():
            raise ValueError(
                f"{name} must lie in the domain ({lo:g}, {hi:g}) of {type(self).__name__}; "
                f"got {arr[bad].flat[0]:g}"
            )
        return arr

    def __call__(self, d: object) -> float | np.ndarray:
        """psi(d), same shape as ``d``; NaN stays NaN."""
        arr = self._checked("d", d)
        with np.errstate(invalid="ignore"):
            return float_or_array(self._value(arr))

    def derivative(self, d: object) -> float | np.ndarray:
        """psi'(d), same shape as ``d``; NaN stays NaN."""
        arr = self._checked("d", d)
        with np.errstate(invalid="ignore"):
            return float_or_array(self._derivative(arr))

    def inverse(self, value: object) -> float | np.ndarray:
        """The disparity ``d`` with ``psi(d) = value`` (the smallest one where psi is flat).

        The range of psi is open where psi only tends to a bound (a saturating tail, a logarithm):
        such a bound has no inverse, even where ``psi(d)`` rounds to it in floating point.

        Raises
        ------
        ValueError
            If a value lies outside the range of psi.
        """
        y = real_array("value", value, allow_nan=True)
        with np.errstate(all="ignore"):
            d = np.asarray(self._inverse(y), dtype=np.float64)
            lo, hi = self.domain()
            bad = ~np.isnan(y) & ~((d > lo) & (d < hi))
        if bad.any():
            with np.errstate(all="ignore"):
                ends = self._value(np.array([lo, hi]))
            raise ValueError(
                f"value must lie in the range ({ends[0]:g}, {ends[1]:g}) of {type(self).__name__}; "
                f"got {y[bad].flat[0]:g}"
            )
        return float_or_array(d)


def bisect_inverse(
    fn: Callable[[np.ndarray], np.ndarray], value: np.ndarray, lo: float, hi: float
) -> np.ndarray:
    """Solve ``fn(d) = value`` element-wise for an increasing ``fn`` on ``(lo, hi)`` by bisection.

    Unbounded sides are bracketed by doubling. Returns the smallest root to float precision, NaN
    for NaN values, and +-inf for values outside the range of ``fn`` (callers report those).
    """
    y = np.asarray(value, dtype=np.float64)
    open_lo, open_hi = not math.isfinite(lo), not math.isfinite(hi)
    a = np.full(y.shape, -1.0 if open_lo else lo)
    b = np.full(y.shape, 1.0 if open_hi else hi)
    if open_hi and not open_lo:
        b = b + lo + 1.0
    if open_lo and not open_hi:
        a = a + hi - 1.0
    with np.errstate(all="ignore"):
        for _ in range(_BRACKET_DOUBLINGS):  # widen the unbounded sides until fn(a) <= y <= fn(b)
            low = (fn(a) > y) if open_lo else np.zeros(y.shape, dtype=bool)
            high = (fn(b) < y) if open_hi else np.zeros(y.shape, dtype=bool)
            if not (low.any() or high.any()):
                break
            width = b - a
            a = np.where(low, a - width, a)
            b = np.where(high, b + width, b)
        outside = (fn(a) > y) | (fn(b) < y)
        floor = _BISECTION_EPS * (b - a)  # absolute resolution: a float eps of the first bracket
        for _ in range(_BISECTION_STEPS):
            mid = 0.5 * (a + b)
            tol = np.maximum(_BISECTION_EPS * np.maximum(np.abs(a), np.abs(b)), floor)
            active = (b - a > tol) & (mid > a) & (mid < b)
            if not active.any():
                break
            below = fn(mid) < y
            a = np.where(active & below, mid, a)
            b = np.where(active & ~below, mid, b)
        d = np.where(outside, np.where(fn(a) > y, -np.inf, np.inf), b)
    return np.where(np.isnan(y), np.nan, d)


@dataclass(frozen=True, slots=True)
class LinearMapping(DisparityMapping):
    """Linear range-to-range operator (Lang et al. 2010).

    ``psi(d) = (r'/r)(d - d_min) + d'_min`` with ``r = d_max - d_min``, ``r' = d'_max - d'_min``;
    defined (extrapolated) on all of R.

    Examples
    --------
    >>> LinearMapping(-20.0, 40.0, -10.0, 10.0)(40.0)
    10.0
    """

    source_min: float
    source_max: float
    target_min: float
    target_max: float

    def __post_init__(self) -> None:
        for name in ("source_min", "source_max", "target_min", "target_max"):
            object.__setattr__(self, name, check_finite(name, getattr(self, name)))
        if not self.source_min < self.source_max:
            raise ValueError(f"source_max must be > source_min {self.source_min:g}; got {self.source_max:g}")
        if not self.target_min < self.target_max:
            raise ValueError(f"target_max must be > target_min {self.target_min:g}; got {self.target_max:g}")

    @property
    def gain(self) -> float:
        """``r'/r``, the constant slope."""
        return (self.target_max - self.target_min) / (self.source_max - self.source_min)

    def _value(self, d: np.ndarray) -> np.ndarray:
        return self.gain * (d - self.source_min) + self.target_min

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        return np.where(np.isnan(d), np.nan, self.gain)

    def _inverse(self, value: np.ndarray) -> np.ndarray:
        return (value - self.target_min) / self.gain + self.source_min


@dataclass(frozen=True, slots=True)
class LogMapping(DisparityMapping):
    """Logarithmic range-mapped operator (Lang et al. 2010): compresses large disparities.

    ``psi(d) = a log(1 + s (d - d_min)) + d'_min`` with ``a = r' / log(1 + s r)`` so that
    ``[d_min, d_max]`` maps onto ``[d'_min, d'_max]``. ``strength`` is ``s`` (1/disparity unit);
    psi is defined for ``d > d_min - 1/s``.

    Examples
    --------
    >>> op = LogMapping(-20.0, 40.0, -10.0, 10.0, strength=0.2)
    >>> round(op(-20.0), 12), round(op(40.0), 12)
    (-10.0, 10.0)
    """

    source_min: float
    source_max: float
    target_min: float
    target_max: float
    strength: float = 1.0

    def __post_init__(self) -> None:
        LinearMapping(self.source_min, self.source_max, self.target_min, self.target_max)  # same checks
        for name in ("source_min", "source_max", "target_min", "target_max"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "strength", check_positive("strength", self.strength))

    @property
    def scale(self) -> float:
        """``a = r' / log(1 + s r)``."""
        r = self.source_max - self.source_min
        return (self.target_max - self.target_min) / math.log1p(self.strength * r)

    def domain(self) -> tuple[float, float]:
        return (self.source_min - 1.0 / self.strength, math.inf)

    def _value(self, d: np.ndarray) -> np.ndarray:
        return self.scale * np.log1p(self.strength * (d - self.source_min)) + self.target_min

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        return self.scale * self.strength / (1.0 + self.strength * (d - self.source_min))

    def _inverse(self, value: np.ndarray) -> np.ndarray:
        return self.source_min + np.expm1((value - self.target_min) / self.scale) / self.strength


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class RationalHermiteMapping(DisparityMapping):
    """Monotone C1 psi through control points: Gregory–Delbourgo between knots (S0 §6).

    Between the knots psi is the rational-quadratic Hermite interpolant
    (:func:`~vergence.viewing.mapping_hermite.gregory_delbourgo`), honouring values and slopes
    exactly. Below the first knot psi continues linearly with the first slope. Above the last knot:

    - with ``ceiling=None``, linearly with the last slope;
    - with a ``ceiling`` C (the divergence limit ``b'/W'``, S0 Eq. 8), by the saturating
      exponential ``C - (C - y_n) exp(-s_n (d - x_n)/(C - y_n))``: value and slope continue (C1),
      psi increases and never reaches C. When ``y_n = C`` (slope 0 there) psi stays at C.

    Parameters
    ----------
    knots : array_like, shape (n,)
        Strictly increasing disparities, n >= 1.
    values : array_like, shape (n,)
        Strictly increasing psi values at the knots.
    slopes : array_like, shape (n,)
        psi' at the knots, >= 0; the first must be > 0 (psi below it would be constant).
    ceiling : float or None
        Upper bound of psi above the last knot; the last value must not exceed it, and a last value
        equal to it needs slope 0 (psi cannot cross its bound while C1).

    Examples
    --------
    >>> psi = RationalHermiteMapping([0.0, 0.1], [0.0, 0.05], [1.0, 0.0], ceiling=0.05)
    >>> psi(np.array([-0.1, 0.0, 0.1, 1.0])).tolist()
    [-0.1, 0.0, 0.05, 0.05]
    """

    knots: np.ndarray
    values: np.ndarray
    slopes: np.ndarray
    ceiling: float | None = None

    def __post_init__(self) -> None:
        x = as_float_array("knots", self.knots, shape=(None,))
        y = as_float_array("values", self.values, shape=(x.size,))
        s = as_float_array("slopes", self.slopes, shape=(x.size,))
        if x.size == 0:
            raise ValueError("knots must hold at least 1 point; got 0")
        if (np.diff(x) <= 0).any():
            raise ValueError(f"knots must be strictly increasing; got {x.tolist()}")
        if (np.diff(y) <= 0).any():
            raise ValueError(f"values must be strictly increasing; got {y.tolist()}")
        if (s < 0).any():
            raise ValueError(f"slopes must be >= 0; got {s.tolist()}")
        if s[0] <= 0:
            raise ValueError(f"slopes[0] must be > 0 (psi below the first knot continues with it); got {s[0]:g}")
        if self.ceiling is not None:
            c = check_finite("ceiling", self.ceiling)
            object.__setattr__(self, "ceiling", c)
            if y[-1] > c:
                raise ValueError(f"values must not exceed ceiling {c:g}; got {y[-1]:g}")
            if y[-1] == c and s[-1] != 0:
                raise ValueError(f"slopes[-1] must be 0 where the last value reaches ceiling {c:g}; got {s[-1]:g}")
        for name, arr in (("knots", x), ("values", y), ("slopes", s)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    # --- extension above the last knot -------------------------------------------------------
    def _rate(self) -> float:
        """``k = s_n / (C - y_n)``: decay rate of the saturating extension (0 when flat)."""
        gap = self.ceiling - self.values[-1]
        return 0.0 if gap == 0 else self.slopes[-1] / gap

    def _above(self, d: np.ndarray) -> np.ndarray:
        xn, yn, sn = self.knots[-1], self.values[-1], self.slopes[-1]
        if self.ceiling is None:
            return yn + sn * (d - xn)
        gap = self.ceiling - yn
        kx = self._rate() * np.maximum(d - xn, 0.0)  # used above x_n only: no overflow below
        near = yn - gap * np.expm1(-kx)  # >= y_n exactly
        far = self.ceiling - gap * np.exp(-kx)  # <= C exactly
        return np.where(kx < 1.0, near, far)

    def _value(self, d: np.ndarray) -> np.ndarray:
        x, y, s = self.knots, self.values, self.slopes
        out = np.where(d < x[0], y[0] + s[0] * (d - x[0]), self._above(d))
        if x.size > 1:
            inside = (d >= x[0]) & (d <= x[-1])
            out = np.where(inside, gregory_delbourgo(np.clip(d, x[0], x[-1]), x, y, s), out)
        else:
            out = np.where(d == x[0], y[0], out)
        return out

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        x, s = self.knots, self.slopes
        if self.ceiling is None:
            above = np.full(d.shape, s[-1])
        else:
            above = s[-1] * np.exp(-self._rate() * np.maximum(d - x[-1], 0.0))
        out = np.where(d < x[0], s[0], above)
        if x.size > 1:
            inside = (d >= x[0]) & (d <= x[-1])
            out = np.where(inside, gregory_delbourgo_derivative(np.clip(d, x[0], x[-1]), x, self.values, s), out)
        return np.where(np.isnan(d), np.nan, out)

    def _inverse(self, value: np.ndarray) -> np.ndarray:
        x, y, s = self.knots, self.values, self.slopes
        below = x[0] + (value - y[0]) / s[0]
        if self.ceiling is None:
            above = x[-1] + (value - y[-1]) / s[-1] if s[-1] > 0 else np.where(value == y[-1], x[-1], np.inf)
        elif self._rate() == 0.0:
            above = np.where(value == y[-1], x[-1], np.inf)
        else:
            gap = self.ceiling - y[-1]
            ratio = (self.ceiling - value) / gap  # exp(-k (d - x_n)); C - value is exact near C
            with np.errstate(divide="ignore", invalid="ignore"):
                near = x[-1] - np.log1p((y[-1] - value) / gap) / self._rate()  # accurate near y_n
                far = x[-1] - np.log(ratio) / self._rate()  # accurate near C
            above = np.where(value >= self.ceiling, np.inf, np.where(ratio > math.exp(-1.0), near, far))
        out = np.where(value < y[0], below, above)
        if x.size > 1:
            inside = (value >= y[0]) & (value <= y[-1])
            out = np.where(inside, gregory_delbourgo_inverse(np.clip(value, y[0], y[-1]), x, y, s), out)
        else:
            out = np.where(value == y[0], x[0], out)
        return np.where(np.isnan(value), np.nan, out)


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class SaliencyMapping(DisparityMapping):
    """Saliency-driven operator (Lang et al. 2010): output range follows importance.

    ``psi(d) = d'_min + r' * integral_{d_min}^{d} h / integral_Omega h``, with ``h`` the
    saliency-weighted disparity histogram on ``bins`` equal bins of ``[d_min, d_max]``, mixed with
    a uniform density so the slope stays positive: ``h = (1 - floor) p + floor / bins`` where ``p``
    holds the bin probabilities. The cumulative values at the bin edges are honoured exactly and
    joined by the Gregory–Delbourgo interpolant (PCHIP slopes inside, the end bins' densities at
    the two ends), so psi is C1, as S0 Eq. (9) needs; outside ``[d_min, d_max]`` it continues
    linearly with the end slopes.

    Build it from a disparity map with :meth:`from_disparity`.

    Parameters
    ----------
    edges : array_like, shape (bins + 1,)
        Strictly increasing bin edges (the first is d_min, the last d_max).
    density : array_like, shape (bins,)
        Bin weights ``h``, all > 0 (normalised here).
    target_min, target_max : float
        Output range ``[d'_min, d'_max]``.

    Examples
    --------
    >>> op = SaliencyMapping([0.0, 1.0, 2.0], [3.0, 1.0], 0.0, 1.0)
    >>> op(np.array([0.0, 1.0, 2.0])).tolist()
    [0.0, 0.75, 1.0]
    """

    edges: np.ndarray
    density: np.ndarray
    target_min: float
    target_max: float
    hermite: RationalHermiteMapping = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        x = as_float_array("edges", self.edges, shape=(None,))
        if x.size < 2 or (np.diff(x) <= 0).any():
            raise ValueError(f"edges must be at least 2 strictly increasing values; got {x.tolist()}")
        h = as_float_array("density", self.density, shape=(x.size - 1,))
        if (h <= 0).any():
            raise ValueError(f"density must be > 0 in every bin (add a floor); got min {h.min():g}")
        lo = check_finite("target_min", self.target_min)
        hi = check_finite("target_max", self.target_max)
        if not lo < hi:
            raise ValueError(f"target_max must be > target_min {lo:g}; got {hi:g}")
        mass = h / h.sum()
        values = lo + (hi - lo) * np.concatenate([[0.0], np.cumsum(mass)])
        values[-1] = hi  # the cumulative sum ends at 1 up to rounding; the range end is exact
        if (np.diff(values) <= 0).any():
            raise ValueError(f"target_max - target_min = {hi - lo:g} is too narrow to give each of the "
                             f"{h.size} bins a rising share of it in float64")
        secants = np.diff(values) / np.diff(x)
        slopes = pchip_slopes(x, values)
        slopes[0], slopes[-1] = secants[0], secants[-1]
        for name, arr in (("edges", x), ("density", h)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "target_min", lo)
        object.__setattr__(self, "target_max", hi)
        object.__setattr__(self, "hermite", RationalHermiteMapping(x, values, slopes))

    @classmethod
    def from_disparity(
        cls,
        disparity: object,
        *,
        target_min: float,
        target_max: float,
        saliency: object | None = None,
        bins: int = 32,
        floor: float = 0.05,
    ) -> SaliencyMapping:
        """Build the operator from a disparity map and optional per-pixel saliency weights.

        Parameters
        ----------
        disparity : array_like
            Disparity map, any shape; NaN = invalid (ignored). Its finite range is ``[d_min, d_max]``.
        target_min, target_max : float
            Output range.
        saliency : array_like or None
            Non-negative weights, same shape as ``disparity``; None weighs every pixel 1.
        bins : int
            Number of histogram bins.
        floor : float
            Share of the output range spread uniformly, in (0, 1]: keeps psi' > 0 in empty bins.

        Raises
        ------
        ValueError
            If no disparity is finite, the map is constant, the saliency has another shape or is
            negative or sums to 0 over the valid pixels, or ``floor``/``bins`` are out of range.
        """
        d = as_float_array("disparity", disparity, allow_nan=True)
        valid = ~np.isnan(d)
        if not valid.any():
            raise ValueError("disparity must hold at least one finite value; got all NaN")
        n_bins = check_positive_int("bins", bins)
        mix = check_in_range("floor", floor, 0.0, 1.0)
        if mix == 0.0:
            raise ValueError("floor must be > 0 (the slope of psi must stay positive); got 0")
        if saliency is None:
            w = np.ones(d.shape)
        else:
            w = as_float_array("saliency", saliency)
            if w.shape != d.shape:
                raise ValueError(f"saliency must have shape {d.shape} matching disparity; got {w.shape}")
            if (w < 0).any():
                raise ValueError(f"saliency must be >= 0; got min {w.min():g}")
        lo, hi = float(d[valid].min()), float(d[valid].max())
        if not lo < hi:
            raise ValueError(f"disparity must span a range (min < max); got constant {lo:g}")
        counts, edges = np.histogram(d[valid], bins=n_bins, range=(lo, hi), weights=w[valid])
        total = counts.sum()
        if total <= 0:
            raise ValueError("saliency must be > 0 somewhere on the valid disparities; got all 0")
        density = (1.0 - mix) * counts / total + mix / n_bins
        return cls(edges, density, target_min, target_max)

    def _value(self, d: np.ndarray) -> np.ndarray:
        return self.hermite._value(d)

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        return self.hermite._derivative(d)

    def _inverse(self, value: np.ndarray) -> np.ndarray:
        return self.hermite._inverse(value)
