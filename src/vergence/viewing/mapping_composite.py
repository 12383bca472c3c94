"""Combinations of disparity mapping operators: piecewise and temporal blends (Lang et al. 2010).

``PiecewiseMapping`` applies operator k on the k-th interval of a partition of the disparity axis
and stays continuous by construction; ``BlendedMapping`` is a convex combination
``sum_k w_k psi_k`` (Lang et al. 2010, temporal operator), and :func:`temporal_weights` gives the weights of
per-shot operators at time ``t`` with a linear ramp over a transition window around each cut.
Both keep psi increasing, since each part is.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from vergence._validate import as_float_array, check_finite
from vergence.viewing.mapping_operators import DisparityMapping

__all__ = [
    "BlendedMapping",
    "PiecewiseMapping",
    "temporal_mapping",
    "temporal_weights",
]

# Blend weights must sum to 1 within this many float epsilons per weight: the telescoping ramps of
# temporal_weights sum to 1 up to a few roundings each, user weights are expected to be exact.
_WEIGHT_SUM_ULPS = 8


def _operators(name: str, operators: Sequence[DisparityMapping]) -> tuple[DisparityMapping, ...]:
    ops = tuple(operators)
    if not ops:
        raise ValueError(f"{name} must hold at least one operator; got none")
    for k, op in enumerate(ops):
        if not isinstance(op, DisparityMapping):
            raise TypeError(f"{name}[{k}] must be a DisparityMapping; got {type(op).__name__}")
    return ops


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class PiecewiseMapping(DisparityMapping):
    """Operator k on the k-th interval of a partition, kept continuous (Lang et al. 2010).

    With breakpoints ``b_1 < ... < b_{n-1}`` and operators ``psi_0 ... psi_{n-1}``, piece k covers
    ``(b_k, b_{k+1}]`` and adds its own increments to the value reached at ``b_k``:
    ``psi(d) = psi(b_k) + psi_k(d) - psi_k(b_k)``, with ``psi = psi_0`` on the first piece. psi is
    continuous and increasing; it is C1 only where the slopes of neighbouring pieces agree at the
    breakpoint (see :attr:`kinks`).

    Parameters
    ----------
    breakpoints : array_like, shape (n - 1,)
        Strictly increasing disparities, each inside the domains of the two pieces it joins.
    operators : sequence of DisparityMapping, length n
        One operator per piece.

    Examples
    --------
    >>> from vergence.viewing.mapping_operators import LinearMapping
    >>> op = PiecewiseMapping([0.0], (LinearMapping(-1.0, 0.0, -1.0, 0.0), LinearMapping(0.0, 1.0, 0.0, 0.5)))
    >>> op(np.array([-1.0, 0.0, 2.0])).tolist()
    [-1.0, 0.0, 1.0]
    """

    breakpoints: np.ndarray
    operators: tuple[DisparityMapping, ...]
    offsets: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        ops = _operators("operators", self.operators)
        b = as_float_array("breakpoints", self.breakpoints, shape=(len(ops) - 1,))
        if (np.diff(b) <= 0).any():
            raise ValueError(f"breakpoints must be strictly increasing; got {b.tolist()}")
        offsets = np.zeros(len(ops))
        for k, bk in enumerate(b):
            for j in (k, k + 1):
                lo, hi = ops[j].domain()
                if not lo < bk < hi:
                    raise ValueError(
                        f"breakpoints[{k}] = {bk:g} must lie in the domain ({lo:g}, {hi:g}) of operators[{j}]"
                    )
            left = offsets[k] + float(ops[k](bk))
            offsets[k + 1] = left - float(ops[k + 1](bk))
        b.setflags(write=False)
        offsets.setflags(write=False)
        object.__setattr__(self, "breakpoints", b)
        object.__setattr__(self, "operators", ops)
        object.__setattr__(self, "offsets", offsets)

    def domain(self) -> tuple[float, float]:
        return (self.operators[0].domain()[0], self.operators[-1].domain()[1])

    def _piece(self, d: np.ndarray) -> np.ndarray:
        return np.searchsorted(self.breakpoints, d, side="left")

    def _apply(self, d: np.ndarray, method: str) -> np.ndarray:
        k = self._piece(d)
        out = np.full(d.shape, np.nan)
        for j, op in enumerate(self.operators):
            mask = (k == j) & ~np.isnan(d)
            if mask.any():
                vals = getattr(op, method)(d[mask])
                out[mask] = vals + (self.offsets[j] if method == "_value" else 0.0)
        return out

    def _value(self, d: np.ndarray) -> np.ndarray:
        return self._apply(d, "_value")

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        return self._apply(d, "_derivative")

    def _inverse(self, value: np.ndarray) -> np.ndarray:
        ends = np.array([off + float(op(bk)) for off, op, bk in zip(self.offsets, self.operators, self.breakpoints)])
        k = np.searchsorted(ends, value, side="left")
        out = np.full(value.shape, np.nan)
        for j, op in enumerate(self.operators):
            mask = (k == j) & ~np.isnan(value)
            if mask.any():
                out[mask] = op._inverse(value[mask] - self.offsets[j])
        return out

    @property
    def kinks(self) -> np.ndarray:
        """Slope jump ``psi_{k+1}'(b_k) - psi_k'(b_k)`` at each breakpoint (all 0 where psi is C1)."""
        return np.array(
            [float(self.operators[k + 1].derivative(bk)) - float(self.operators[k].derivative(bk))
             for k, bk in enumerate(self.breakpoints)]
        )


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class BlendedMapping(DisparityMapping):
    """Convex combination ``psi(d) = sum_k w_k psi_k(d)``, ``sum_k w_k = 1`` (Lang et al. 2010, temporal operator).

    Increasing because every ``psi_k`` is and the weights are >= 0; defined on the intersection of
    the operators' domains. The inverse has no closed form: vectorised bisection.

    Examples
    --------
    >>> from vergence.viewing.mapping_operators import LinearMapping
    >>> a, b = LinearMapping(0.0, 1.0, 0.0, 1.0), LinearMapping(0.0, 1.0, 0.0, 3.0)
    >>> BlendedMapping((a, b), (0.5, 0.5))(1.0)
    2.0
    """

    operators: tuple[DisparityMapping, ...]
    weights: np.ndarray

    def __post_init__(self) -> None:
        ops = _operators("operators", self.operators)
        w = as_float_array("weights", self.weights, shape=(len(ops),))
        if (w < 0).any():
            raise ValueError(f"weights must be >= 0; got {w.tolist()}")
        total = float(w.sum())
        if abs(total - 1.0) > _WEIGHT_SUM_ULPS * len(ops) * np.finfo(np.float64).eps:
            raise ValueError(f"weights must sum to 1; got {total!r}")
        object.__setattr__(self, "operators", ops)
        lo, hi = self.domain()
        if not lo < hi:
            raise ValueError(f"operators must share a domain; their domains meet in ({lo:g}, {hi:g})")
        w.setflags(write=False)
        object.__setattr__(self, "weights", w)

    def domain(self) -> tuple[float, float]:
        return (max(op.domain()[0] for op in self.operators), min(op.domain()[1] for op in self.operators))

    def _value(self, d: np.ndarray) -> np.ndarray:
        return sum((wk * op._value(d) for wk, op in zip(self.weights, self.operators) if wk > 0), np.zeros(d.shape))

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        out = sum((wk * op._derivative(d) for wk, op in zip(self.weights, self.operators) if wk > 0), np.zeros(d.shape))
        return np.where(np.isnan(d), np.nan, out)


def temporal_weights(t: float, cuts: object, *, transition: float) -> np.ndarray:
    """Weights of the per-shot operators at time ``t``: linear ramps across each cut (Lang et al. 2010).

    Shot k runs from cut k-1 to cut k. Across cut ``c_k`` the weight moves linearly from shot k to
    shot k+1 over ``[c_k - T/2, c_k + T/2]`` (``T = transition``; ``T = 0`` is a hard cut, taking the
    later shot from ``c_k`` on). With ``r_k(t) = clip((t - c_k + T/2)/T, 0, 1)``:
    ``w_0 = 1 - r_0``, ``w_k = r_{k-1} - r_k``, ``w_last = r_last``; they sum to 1 and are >= 0.

    Parameters
    ----------
    t : float
        Time (any unit: seconds, frames).
    cuts : array_like, shape (n_shots - 1,)
        Cut times, increasing, at least ``transition`` apart so that ramps do not overlap.
    transition : float
        Length of each ramp, >= 0.

    Returns
    -------
    ndarray, shape (n_shots,)

    Examples
    --------
    >>> temporal_weights(10.5, [10.0], transition=2.0).tolist()
    [0.25, 0.75]
    """
    time = check_finite("t", t)
    c = as_float_array("cuts", cuts, shape=(None,))
    width = check_finite("transition", transition)
    if width < 0:
        raise ValueError(f"transition must be >= 0; got {width:g}")
    gaps = np.diff(c)
    if (gaps <= 0).any() or (gaps < width).any():
        raise ValueError(f"cuts must increase by at least transition {width:g}; got {c.tolist()}")
    if width == 0:
        r = (time >= c).astype(np.float64)
    else:
        with np.errstate(over="ignore"):  # a ramp shorter than a float step: +-inf, clipped to 0 or 1 (exact)
            r = np.clip((time - c + 0.5 * width) / width, 0.0, 1.0)
    return np.concatenate([[1.0 - r[0]] if r.size else [1.0], r[:-1] - r[1:], r[-1:]])


def temporal_mapping(
    operators: Sequence[DisparityMapping], t: float, *, cuts: object, transition: float
) -> BlendedMapping:
    """The mapping in force at time ``t``: per-shot operators blended by :func:`temporal_weights`.

    ``psi_t(d) = sum_k w_k(t) psi_k(d)`` (Lang et al. 2010): one operator per shot,
    ``len(cuts) + 1`` operators.

    Examples
    --------
    >>> from vergence.viewing.mapping_operators import LinearMapping
    >>> shots = (LinearMapping(0.0, 1.0, 0.0, 1.0), LinearMapping(0.0, 1.0, 0.0, 3.0))
    >>> temporal_mapping(shots, 10.0, cuts=[10.0], transition=2.0)(1.0)
    2.0
    """
    ops = _operators("operators", operators)
    w = temporal_weights(t, cuts, transition=transition)
    if w.size != len(ops):
        raise ValueError(f"operators must hold len(cuts) + 1 = {w.size} operators; got {len(ops)}")
    return BlendedMapping(ops, w)
