"""Monotone Hermite interpolants: Gregory & Delbourgo 1982 and PCHIP slopes (Fritsch & Carlson 1980)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

from vergence.viewing.mapping_hermite import (
    gregory_delbourgo,
    gregory_delbourgo_derivative,
    gregory_delbourgo_inverse,
    pchip_slopes,
)

# Values and slopes at the knots are reproduced to a few roundings of numbers of order 1.
EXACT = 1e-13
# Central differences with step 1e-6 on functions of order 1: truncation ~1e-12, rounding ~1e-10.
FD_STEP = 1e-6
FD_TOL = 1e-7


def _tri_rig_knots():
    """S0 §6, Fig. 8 right: f = 10, f' = 2.5, reference b_round; subject and background."""
    bp, Hp, Wp = 0.065, 2.5, 1.0  # f' = 2.5
    H, W = 20.0, 2.0  # f = 10
    b_r = bp * H / Hp  # b_round
    d1, psi1 = b_r / W, bp / Wp  # background at infinity -> divergence limit
    secant = psi1 / d1
    return np.array([0.0, d1]), np.array([0.0, psi1]), np.array([1.0, 0.05 * secant]), psi1


def test_gd_honours_values_and_slopes_hand_worked():
    # One interval [0, 1], y 0 -> 1, slopes 3 and 0: Delta = 1, den(1/2) = 1 + (3 - 2)/4 = 1.25,
    # S(1/2) = (1/4 + 3/4)/1.25 = 0.8 (hand-worked).
    k, y, s = np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([3.0, 0.0])
    assert_allclose(gregory_delbourgo(np.array([0.0, 0.5, 1.0]), k, y, s), [0.0, 0.8, 1.0], atol=EXACT)
    assert_allclose(gregory_delbourgo_derivative(np.array([0.0, 1.0]), k, y, s), [3.0, 0.0], atol=EXACT)


def test_gd_equal_slopes_give_the_straight_line():
    # s_i = s_{i+1} = Delta: the rational reduces to y_i + Delta (x - x_i).
    k, y = np.array([1.0, 3.0]), np.array([2.0, 6.0])
    x = np.linspace(1.0, 3.0, 9)
    assert_allclose(gregory_delbourgo(x, k, y, np.array([2.0, 2.0])), 2.0 + 2.0 * (x - 1.0), atol=EXACT)


def test_cubic_hermite_overshoots_where_gd_does_not():
    # Fritsch & Carlson 1980: slope/secant > 3 makes the cubic exceed psi <= b'/W' (Eq. 8); GD stays below.
    k, y, s, limit = _tri_rig_knots()
    x = np.linspace(k[0], k[1], 2001)
    assert s[0] / ((y[1] - y[0]) / (k[1] - k[0])) > 3.0  # the Fritsch–Carlson bound is exceeded
    cubic = CubicHermiteSpline(k, y, s)(x)
    gd = gregory_delbourgo(x, k, y, s)
    assert cubic.max() > limit
    assert gd.max() <= limit
    assert np.all(np.diff(gd) > 0)
    assert_allclose(gregory_delbourgo_derivative(k, k, y, s), s, atol=EXACT)


def test_gd_derivative_matches_finite_differences():
    k = np.array([-1.0, 0.0, 0.5, 2.0])
    y = np.array([-2.0, 0.0, 0.1, 3.0])
    s = np.array([0.5, 4.0, 0.0, 1.0])
    x = np.array([-0.7, -0.2, 0.1, 0.3, 0.9, 1.7])
    fd = (gregory_delbourgo(x + FD_STEP, k, y, s) - gregory_delbourgo(x - FD_STEP, k, y, s)) / (2 * FD_STEP)
    assert_allclose(gregory_delbourgo_derivative(x, k, y, s), fd, atol=FD_TOL)


def test_gd_inverse_round_trip_and_knots():
    k = np.array([-1.0, 0.0, 0.5, 2.0])
    y = np.array([-2.0, 0.0, 0.1, 3.0])
    s = np.array([0.5, 4.0, 0.0, 1.0])
    x = np.linspace(-1.0, 2.0, 301)
    assert_allclose(gregory_delbourgo_inverse(gregory_delbourgo(x, k, y, s), k, y, s), x, atol=1e-12)
    assert_allclose(gregory_delbourgo_inverse(y, k, y, s), k, atol=EXACT)


def test_pchip_slopes_match_scipy():
    # Independent reference: scipy's PchipInterpolator derivative at the knots.
    x = np.array([0.0, 0.3, 1.0, 1.2, 2.5, 4.0])
    y = np.array([0.0, 0.1, 0.15, 0.9, 1.0, 3.0])
    assert_allclose(pchip_slopes(x, y), PchipInterpolator(x, y).derivative()(x), rtol=1e-12)
    assert_allclose(pchip_slopes([0.0, 2.0], [1.0, 2.0]), [0.5, 0.5])


@pytest.mark.parametrize(
    ("knots", "values", "match"),
    [
        ([0.0], [0.0], "at least 2"),
        ([0.0, 0.0, 1.0], [0.0, 1.0, 2.0], "strictly increasing"),
        ([0.0, 1.0], [0.0, np.nan], "finite"),
        ([0.0, 1.0], [0.0, 1.0, 2.0], "values must have shape"),
    ],
)
def test_pchip_slopes_bad_input(knots, values, match):
    with pytest.raises(ValueError, match=match):
        pchip_slopes(knots, values)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(0.01, 10.0), min_size=1, max_size=5),
    st.lists(st.floats(0.01, 10.0), min_size=1, max_size=5),
    st.lists(st.floats(0.0, 50.0), min_size=6, max_size=6),
)
def test_gd_monotone_for_any_nonnegative_slopes(dx, dy, slopes):
    n = min(len(dx), len(dy)) + 1
    k = np.concatenate([[0.0], np.cumsum(dx[: n - 1])])
    y = np.concatenate([[0.0], np.cumsum(dy[: n - 1])])
    s = np.array(slopes[:n])
    x = np.linspace(k[0], k[-1], 1001)
    v = gregory_delbourgo(x, k, y, s)
    assert np.all(np.diff(v) >= 0)
    assert v.min() >= y[0] and v.max() <= y[-1]  # never overshoots the data range
    assert_allclose(gregory_delbourgo(k, k, y, s), y, atol=1e-12 * y[-1])
    assert_allclose(gregory_delbourgo_derivative(k, k, y, s), s, rtol=1e-9, atol=1e-9)
