"""Monotone C1 interpolation through values and slopes: Gregory–Delbourgo and PCHIP
(Gregory & Delbourgo 1982, Fritsch & Carlson 1980; for psi of S0 §6).

S0 §6 builds the disparity mapping psi from control points (value and, for a roundness constraint,
slope) and asks for "any technique exactly interpolating the control points and its derivatives".
A plain cubic Hermite spline overshoots as soon as a prescribed slope exceeds three times the
secant (the Fritsch–Carlson bound), which long lenses always cause; the Gregory–Delbourgo
rational-quadratic Hermite interpolant honours any non-negative slopes and never overshoots.
Where no slope is prescribed, the Fritsch–Carlson (PCHIP) estimate supplies one.

All functions are vectorised; knots, values and slopes are validated by the public callers
(:class:`vergence.viewing.mapping_operators.RationalHermiteMapping` and
:func:`pchip_slopes`).
"""

from __future__ import annotations

import numpy as np

from vergence._validate import as_float_array

__all__ = [
    "gregory_delbourgo",
    "gregory_delbourgo_derivative",
    "gregory_delbourgo_inverse",
    "pchip_slopes",
]


def _segments(x: np.ndarray, knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interval index ``i`` (knots[i] <= x <= knots[i+1], clipped) and local ``t`` of each x."""
    i = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, len(knots) - 2)
    h = knots[i + 1] - knots[i]
    return i, (x - knots[i]) / h


def gregory_delbourgo(x: np.ndarray, knots: np.ndarray, values: np.ndarray, slopes: np.ndarray) -> np.ndarray:
    """Gregory–Delbourgo rational-quadratic Hermite interpolant (Gregory & Delbourgo 1982).

    On ``[x_i, x_{i+1}]`` with ``h = x_{i+1} - x_i``, ``t = (x - x_i)/h``,
    ``Delta = (y_{i+1} - y_i)/h``::

        S(x) = y_i + (y_{i+1} - y_i) [Delta t^2 + s_i t(1-t)] / [Delta + (s_{i+1} + s_i - 2 Delta) t(1-t)]

    Parameters
    ----------
    x : ndarray
        Abscissae; values outside ``[knots[0], knots[-1]]`` use the end intervals' formula (callers
        extrapolate themselves).
    knots : ndarray, shape (n,)
        Strictly increasing abscissae, n >= 2.
    values : ndarray, shape (n,)
        Strictly increasing values ``y_i``.
    slopes : ndarray, shape (n,)
        Slopes ``s_i >= 0``.

    Returns
    -------
    ndarray
        ``S(x)``, same shape as ``x``. ``S(x_i) = y_i`` and ``S'(x_i) = s_i`` exactly, and S is
        increasing on each interval for any non-negative slopes (the denominator is at least
        ``Delta/2 > 0``).

    Notes
    -----
    For ``t >= 1/2`` the value is computed from the right knot,
    ``S = y_{i+1} - (y_{i+1} - y_i)(1-t)[Delta(1-t) + s_{i+1} t] / den``, an algebraically equal form
    whose subtracted term is non-negative: in floating point S never exceeds ``y_{i+1}``, so a psi
    that reaches the divergence limit ``b'/W'`` at a knot never crosses it (S0 Eq. 8).

    Examples
    --------
    >>> k, y, s = np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([3.0, 0.0])
    >>> float(gregory_delbourgo(np.array(0.5), k, y, s))
    0.8
    """
    i, t = _segments(x, knots)
    dy = values[i + 1] - values[i]
    delta = dy / (knots[i + 1] - knots[i])
    s0, s1 = slopes[i], slopes[i + 1]
    u = t * (1.0 - t)
    den = delta + (s1 + s0 - 2.0 * delta) * u
    left = values[i] + dy * (delta * t * t + s0 * u) / den
    right = values[i + 1] - dy * (1.0 - t) * (delta * (1.0 - t) + s1 * t) / den
    return np.where(t < 0.5, left, right)


def gregory_delbourgo_derivative(
    x: np.ndarray, knots: np.ndarray, values: np.ndarray, slopes: np.ndarray
) -> np.ndarray:
    """Derivative of :func:`gregory_delbourgo`.

    ``S'(x) = Delta^2 [s_{i+1} t^2 + 2 Delta t(1-t) + s_i (1-t)^2] / [Delta + (s_{i+1} + s_i - 2 Delta) t(1-t)]^2``,
    a ratio of non-negative terms: the interpolant is monotone for any slopes ``s_i >= 0``.

    Examples
    --------
    >>> k, y, s = np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([3.0, 0.0])
    >>> gregory_delbourgo_derivative(np.array([0.0, 1.0]), k, y, s).tolist()
    [3.0, 0.0]
    """
    i, t = _segments(x, knots)
    delta = (values[i + 1] - values[i]) / (knots[i + 1] - knots[i])
    s0, s1 = slopes[i], slopes[i + 1]
    u = t * (1.0 - t)
    den = delta + (s1 + s0 - 2.0 * delta) * u
    num = s1 * t * t + 2.0 * delta * u + s0 * (1.0 - t) ** 2
    return delta * delta * num / (den * den)


def _root(r: np.ndarray, delta: np.ndarray, s_near: np.ndarray, s_far: np.ndarray) -> np.ndarray:
    """t in [0, 1] with ``[Delta t^2 + s_near t(1-t)] / [Delta + (s_near + s_far - 2 Delta) t(1-t)] = r``.

    The equation is ``(Delta - B) t^2 + B t - r Delta = 0`` with ``B = s_near - r (s_near + s_far - 2 Delta)``;
    its root in [0, 1] is taken in the form free of cancellation for the sign of B.
    """
    b = s_near - r * (s_near + s_far - 2.0 * delta)
    root = np.sqrt(np.maximum(b * b + 4.0 * r * delta * (delta - b), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(b >= 0.0, 2.0 * r * delta / (b + root), (root - b) / (2.0 * (delta - b)))
    return np.where(r > 0.0, t, 0.0)


def gregory_delbourgo_inverse(
    y: np.ndarray, knots: np.ndarray, values: np.ndarray, slopes: np.ndarray
) -> np.ndarray:
    """Closed-form inverse of :func:`gregory_delbourgo` for ``values[0] <= y <= values[-1]``.

    With ``r = (y - y_i)/(y_{i+1} - y_i)``, ``S(x) = y`` is a quadratic in ``t`` whose root in [0, 1]
    is unique (S is increasing). For ``r > 1/2`` the mirrored problem is solved from the right knot
    (the interpolant is symmetric under ``t -> 1 - t`` with the slopes swapped), so that ``x`` keeps
    full precision near both knots, as the forward evaluation does.

    Examples
    --------
    >>> k, y, s = np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([3.0, 0.0])
    >>> round(float(gregory_delbourgo_inverse(np.array(0.8), k, y, s)), 12)
    0.5
    """
    i = np.clip(np.searchsorted(values, y, side="right") - 1, 0, len(values) - 2)
    h = knots[i + 1] - knots[i]
    dy = values[i + 1] - values[i]
    delta = dy / h
    r_left = (y - values[i]) / dy
    r_right = (values[i + 1] - y) / dy
    left = knots[i] + h * _root(r_left, delta, slopes[i], slopes[i + 1])
    right = knots[i + 1] - h * _root(r_right, delta, slopes[i + 1], slopes[i])
    return np.where(r_left <= 0.5, left, right)


def pchip_slopes(knots: object, values: object) -> np.ndarray:
    """Fritsch–Carlson (PCHIP) slope estimates at the knots of monotone data.

    Interior knots take the weighted harmonic mean of the neighbouring secants (Fritsch & Butland
    1984), ``(w1 + w2)/s_k = w1/delta_{k-1} + w2/delta_k`` with ``w1 = 2h_k + h_{k-1}``,
    ``w2 = h_k + 2h_{k-1}``, or 0 where the secants differ in sign or one is 0; end knots take the
    shape-preserving three-point formula. These are the slopes of ``scipy.interpolate.PchipInterpolator``.

    Parameters
    ----------
    knots : array_like, shape (n,)
        Strictly increasing abscissae, n >= 2.
    values : array_like, shape (n,)
        Ordinates.

    Returns
    -------
    ndarray, shape (n,)
        Slopes; with n = 2 both equal the secant.

    Raises
    ------
    ValueError
        If the shapes differ, n < 2, a value is not finite, or the knots are not strictly increasing.

    Examples
    --------
    >>> pchip_slopes([0.0, 1.0, 2.0], [0.0, 1.0, 3.0]).tolist()
    [0.5, 1.3333333333333333, 2.5]
    """
    x = as_float_array("knots", knots, shape=(None,))
    y = as_float_array("values", values, shape=(x.size,))
    if x.size < 2:
        raise ValueError(f"knots must hold at least 2 points; got {x.size}")
    h = np.diff(x)
    if (h <= 0).any():
        raise ValueError("knots must be strictly increasing")
    with np.errstate(over="ignore"):
        delta = np.diff(y) / h
    if not np.isfinite(delta).all():
        raise ValueError("values must not rise faster than float64 allows between knots (a secant overflows)")
    if x.size == 2:
        return np.array([delta[0], delta[0]])
    s = np.zeros_like(x)
    # The harmonic mean in units of the largest secant, as d0 d1 (w1 + w2)/(w1 d1 + w2 d0): nothing is
    # divided by a secant, so subnormal secants (a range of 1e-323) cannot overflow it.
    unit = float(np.abs(delta).max()) or 1.0
    d0, d1 = delta[:-1] / unit, delta[1:] / unit
    w1 = 2.0 * h[1:] + h[:-1]
    w2 = h[1:] + 2.0 * h[:-1]
    same = (np.sign(d0) * np.sign(d1)) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        harmonic = unit * (d0 * d1 * (w1 + w2) / (w1 * d1 + w2 * d0))
    s[1:-1] = np.where(same, harmonic, 0.0)
    s[0] = _edge_slope(h[0], h[1], delta[0], delta[1])
    s[-1] = _edge_slope(h[-1], h[-2], delta[-1], delta[-2])
    return s


def _edge_slope(h0: float, h1: float, m0: float, m1: float) -> float:
    """One-sided three-point PCHIP end slope, limited to keep the data's shape."""
    d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    if np.sign(d) != np.sign(m0):
        return 0.0
    if np.sign(m0) != np.sign(m1) and abs(d) > abs(3.0 * m0):
        return 3.0 * m0
    return float(d)
