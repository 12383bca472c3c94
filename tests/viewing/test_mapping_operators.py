"""Disparity mapping operators of Lang et al. 2010 and their combinations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.viewing.mapping import (
    BlendedMapping,
    DisparityMapping,
    LinearMapping,
    LogMapping,
    PiecewiseMapping,
    RationalHermiteMapping,
    SaliencyMapping,
    bisect_inverse,
    temporal_mapping,
    temporal_weights,
)

# Closed-form values and round trips on disparities of order 10: a few roundings.
EXACT = 1e-12
# Central differences with step 1e-6 on disparities of order 10: error ~1e-9.
FD_STEP = 1e-6
FD_TOL = 1e-7


def _fd(op: DisparityMapping, d: np.ndarray) -> np.ndarray:
    return (op(d + FD_STEP) - op(d - FD_STEP)) / (2 * FD_STEP)


# --- linear and logarithmic (values worked by hand) ----------------------
def test_linear_maps_range_to_range():
    op = LinearMapping(-20.0, 40.0, -10.0, 10.0)
    assert_allclose(op(np.array([-20.0, 10.0, 40.0])), [-10.0, 0.0, 10.0], atol=EXACT)
    assert op.derivative(3.0) == pytest.approx(1.0 / 3.0, abs=EXACT)
    assert_allclose(op.inverse(op(np.linspace(-50, 70, 13))), np.linspace(-50, 70, 13), atol=EXACT)


def test_log_endpoints_increasing_and_compressive():
    op = LogMapping(-20.0, 40.0, -10.0, 10.0, strength=0.2)
    d = np.linspace(-20.0, 40.0, 61)
    v = op(d)
    assert_allclose(v[[0, -1]], [-10.0, 10.0], atol=EXACT)
    assert np.all(np.diff(v) > 0) and np.diff(v)[-1] < np.diff(v)[0]
    # a = r'/log(1 + s r) = 20/log(13); psi(10) = a log(7) - 10 (hand-worked from Lang et al. 2010's operator).
    assert op(10.0) == pytest.approx(20.0 / np.log(13.0) * np.log(7.0) - 10.0, abs=EXACT)
    assert_allclose(op.derivative(d), _fd(op, d), atol=FD_TOL)
    assert_allclose(op.inverse(v), d, atol=EXACT)


def test_log_outside_its_domain_is_an_error():
    op = LogMapping(0.0, 10.0, 0.0, 1.0, strength=0.5)  # defined for d > -2
    with pytest.raises(ValueError, match=r"d must lie in the domain \(-2, inf\) of LogMapping; got -3"):
        op(np.array([0.0, -3.0]))


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((1.0, 1.0, 0.0, 1.0), {}, "source_max must be > source_min 1; got 1"),
        ((0.0, 1.0, 2.0, 1.0), {}, "target_max must be > target_min 2; got 1"),
        ((0.0, float("nan"), 0.0, 1.0), {}, "source_max must be finite"),
        ((0.0, 1.0, 0.0, 1.0), {"strength": 0.0}, "strength must be > 0"),
    ],
)
def test_linear_and_log_bad_input(args, kwargs, match):
    cls = LogMapping if kwargs else LinearMapping
    with pytest.raises(ValueError, match=match):
        cls(*args, **kwargs)


def test_nan_passes_through():
    op = LinearMapping(0.0, 1.0, 0.0, 2.0)
    out = op(np.array([np.nan, 0.5]))
    assert np.isnan(out[0]) and out[1] == 1.0
    assert np.isnan(op.derivative(np.array([np.nan]))[0])
    assert np.isnan(op.inverse(np.array([np.nan]))[0])


# --- saliency histogram -----------------------------------------------------------------------
def test_saliency_allocates_output_range_by_weight():
    # Two bins of [0, 2]; all saliency in the first: h = (1 - 0.2)(1, 0) + 0.2/2 = (0.9, 0.1),
    # so psi(1) = 0 + 10 * 0.9 = 9 (hand-worked).
    d = np.array([0.0, 0.5, 0.9, 1.5, 2.0])
    w = np.array([1.0, 1.0, 1.0, 0.0, 0.0])
    op = SaliencyMapping.from_disparity(d, target_min=0.0, target_max=10.0, saliency=w, bins=2, floor=0.2)
    assert_allclose(op(np.array([0.0, 1.0, 2.0])), [0.0, 9.0, 10.0], atol=EXACT)
    x = np.linspace(-0.5, 2.5, 31) + 0.0123  # off the bin edges, where psi'' jumps
    assert np.all(op.derivative(x) > 0)
    assert_allclose(op.derivative(x), _fd(op, x), atol=FD_TOL)
    assert_allclose(op.inverse(op(x)), x, atol=EXACT)


def test_saliency_uniform_histogram_is_linear():
    # Equal counts in every bin: cumulative values on a line, PCHIP slopes = the secant -> linear psi.
    d = np.linspace(-5.0, 5.0, 1000)
    op = SaliencyMapping.from_disparity(d, target_min=-1.0, target_max=1.0, bins=10, floor=0.1)
    x = np.linspace(-5.0, 5.0, 41)
    assert_allclose(op(x), x / 5.0, atol=1e-12)


def test_saliency_ignores_nan_pixels():
    d = np.array([[0.0, np.nan], [4.0, 2.0]])
    op = SaliencyMapping.from_disparity(d, target_min=0.0, target_max=1.0, bins=4)
    assert op.edges[0] == 0.0 and op.edges[-1] == 4.0


@pytest.mark.parametrize(
    ("disparity", "kwargs", "match"),
    [
        (np.full(3, np.nan), {}, "at least one finite value"),
        (np.ones(3), {}, "must span a range"),
        (np.arange(3.0), {"saliency": np.ones(2)}, r"saliency must have shape \(3,\)"),
        (np.arange(3.0), {"saliency": -np.ones(3)}, "saliency must be >= 0"),
        (np.arange(3.0), {"saliency": np.zeros(3)}, "saliency must be > 0 somewhere"),
        (np.arange(3.0), {"floor": 0.0}, "floor must be > 0"),
        (np.arange(3.0), {"floor": 1.5}, r"floor must lie in \[0, 1\]"),
        (np.arange(3.0), {"bins": 0}, "bins must be >= 1"),
    ],
)
def test_saliency_bad_input(disparity, kwargs, match):
    with pytest.raises(ValueError, match=match):
        SaliencyMapping.from_disparity(disparity, target_min=0.0, target_max=1.0, **kwargs)


# --- rational Hermite operator --------------------------------------------------------------
def test_rational_hermite_extensions():
    # Below: linear with the first slope; above: saturating towards the ceiling, C1 at the knot.
    psi = RationalHermiteMapping([0.0, 0.1], [0.0, 0.02], [1.0, 0.1], ceiling=0.05)
    assert psi(-0.3) == pytest.approx(-0.3, abs=EXACT)
    # C - (C - y_n) exp(-s_n (d - x_n)/(C - y_n)) at d = 0.4: 0.05 - 0.03 exp(-1) (hand-worked).
    assert psi(0.4) == pytest.approx(0.05 - 0.03 * np.exp(-1.0), abs=EXACT)
    x = np.linspace(-0.2, 1.0, 121) + 0.0037  # off the knots, where psi'' jumps
    assert np.all(psi(x) < 0.05)
    assert_allclose(psi.derivative(x), _fd(psi, x), atol=FD_TOL)
    assert psi.derivative(0.1) == pytest.approx(0.1, abs=EXACT)
    assert_allclose(psi.inverse(psi(x)), x, atol=1e-12)
    with pytest.raises(ValueError, match=r"value must lie in the range \(-inf, 0.05\)"):
        psi.inverse(0.05)


def test_rational_hermite_without_ceiling_extends_linearly():
    psi = RationalHermiteMapping([0.0, 1.0], [0.0, 2.0], [1.0, 3.0])
    assert psi(2.0) == pytest.approx(5.0, abs=EXACT)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([0.0, 0.0], [0.0, 1.0], [1.0, 1.0]), "knots must be strictly increasing"),
        (([0.0, 1.0], [1.0, 1.0], [1.0, 1.0]), "values must be strictly increasing"),
        (([0.0, 1.0], [0.0, 1.0], [1.0, -1.0]), "slopes must be >= 0"),
        (([0.0, 1.0], [0.0, 1.0], [0.0, 1.0]), r"slopes\[0\] must be > 0"),
        (([0.0, 1.0], [0.0, 1.0], [1.0, 1.0], 0.5), "values must not exceed ceiling 0.5"),
        (([0.0, 1.0], [0.0, 1.0], [1.0, 1.0], 1.0), r"slopes\[-1\] must be 0 where the last value reaches"),
    ],
)
def test_rational_hermite_bad_input(args, match):
    with pytest.raises(ValueError, match=match):
        RationalHermiteMapping(*args)


# --- piecewise, blended, temporal -----------------------------------------------------------
def test_piecewise_is_continuous_by_construction():
    # Linear slope 1 up to 0, then log, then linear slope 0.1: values continue at each breakpoint.
    ops = (LinearMapping(-1.0, 0.0, -1.0, 0.0), LogMapping(0.0, 10.0, 5.0, 6.0, strength=1.0),
           LinearMapping(0.0, 10.0, 100.0, 101.0))
    op = PiecewiseMapping([0.0, 10.0], ops)
    assert op(0.0) == pytest.approx(0.0, abs=EXACT)
    assert op(10.0) == pytest.approx(1.0, abs=EXACT)  # the log piece adds its range, 1
    assert op(20.0) == pytest.approx(2.0, abs=EXACT)  # the last adds 0.1 per unit
    x = np.linspace(-5.0, 30.0, 351)
    assert np.all(np.diff(op(x)) > 0)
    assert_allclose(op.inverse(op(x)), x, atol=1e-10)
    assert_allclose(op.kinks, [float(ops[1].derivative(0.0)) - 1.0, 0.1 - float(ops[1].derivative(10.0))], atol=EXACT)


def test_piecewise_bad_input():
    lin = LinearMapping(0.0, 1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"breakpoints must have shape"):
        PiecewiseMapping([0.0, 1.0], (lin, lin))
    with pytest.raises(ValueError, match="breakpoints must be strictly increasing"):
        PiecewiseMapping([1.0, 0.0], (lin, lin, lin))
    with pytest.raises(ValueError, match=r"breakpoints\[0\] = -5 must lie in the domain"):
        PiecewiseMapping([-5.0], (lin, LogMapping(0.0, 1.0, 0.0, 1.0)))
    with pytest.raises(TypeError, match=r"operators\[1\] must be a DisparityMapping"):
        PiecewiseMapping([0.0], (lin, np.sin))


def test_temporal_weights_ramp_and_sum_to_one():
    cuts = [10.0, 20.0]
    assert_allclose(temporal_weights(0.0, cuts, transition=2.0), [1.0, 0.0, 0.0])
    assert_allclose(temporal_weights(9.5, cuts, transition=2.0), [0.75, 0.25, 0.0])
    assert_allclose(temporal_weights(15.0, cuts, transition=2.0), [0.0, 1.0, 0.0])
    assert_allclose(temporal_weights(20.0, cuts, transition=2.0), [0.0, 0.5, 0.5])
    assert_allclose(temporal_weights(10.0, [10.0], transition=0.0), [0.0, 1.0])  # hard cut
    for t in np.linspace(0.0, 30.0, 61):
        w = temporal_weights(t, cuts, transition=2.0)
        assert w.sum() == pytest.approx(1.0, abs=1e-15) and np.all(w >= 0)


def test_temporal_mapping_blends_per_shot_operators():
    ops = (LinearMapping(-20.0, 40.0, -10.0, 10.0), LogMapping(-20.0, 40.0, -10.0, 10.0, strength=0.2))
    d = np.linspace(-20.0, 40.0, 61)
    assert_allclose(temporal_mapping(ops, 0.0, cuts=[5.0], transition=2.0)(d), ops[0](d), atol=EXACT)
    assert_allclose(temporal_mapping(ops, 9.0, cuts=[5.0], transition=2.0)(d), ops[1](d), atol=EXACT)
    mid = temporal_mapping(ops, 5.0, cuts=[5.0], transition=2.0)
    assert_allclose(mid(d), 0.5 * (ops[0](d) + ops[1](d)), atol=EXACT)
    assert_allclose(mid.derivative(d), 0.5 * (ops[0].derivative(d) + ops[1].derivative(d)), atol=EXACT)
    assert_allclose(mid.inverse(mid(d)), d, atol=1e-12)  # bisection


def test_temporal_and_blend_bad_input():
    lin = LinearMapping(0.0, 1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"cuts must increase by at least transition 2"):
        temporal_weights(0.0, [1.0, 2.0], transition=2.0)
    with pytest.raises(ValueError, match="transition must be >= 0"):
        temporal_weights(0.0, [1.0], transition=-1.0)
    with pytest.raises(ValueError, match=r"operators must hold len\(cuts\) \+ 1 = 2 operators; got 1"):
        temporal_mapping((lin,), 0.0, cuts=[1.0], transition=0.5)
    with pytest.raises(ValueError, match="weights must sum to 1"):
        BlendedMapping((lin, lin), (0.5, 0.6))
    with pytest.raises(ValueError, match="weights must be >= 0"):
        BlendedMapping((lin, lin), (1.5, -0.5))


# --- generic inverse ------------------------------------------------------------------------
def test_bisect_inverse_matches_closed_form_and_flags_out_of_range():
    op = LogMapping(-20.0, 40.0, -10.0, 10.0, strength=0.2)
    y = np.array([-30.0, -10.0, 0.0, 10.0, 50.0, np.nan])
    got = bisect_inverse(op._value, y, *op.domain())
    assert_allclose(got[:5], op.inverse(y[:5]), rtol=1e-14, atol=1e-13)
    assert np.isnan(got[5])
    bounded = RationalHermiteMapping([0.0, 1.0], [0.0, 0.5], [1.0, 0.1], ceiling=1.0)
    assert bisect_inverse(bounded._value, np.array([2.0]), -np.inf, np.inf)[0] == np.inf


@settings(max_examples=30, deadline=None)
@given(
    st.floats(-50.0, 50.0), st.floats(0.1, 100.0), st.floats(-50.0, 50.0), st.floats(0.1, 100.0),
    st.floats(0.01, 5.0), st.floats(0.0, 1.0),
)
def test_operators_monotone_and_invertible(d_min, r, t_min, r_t, strength, w):
    lin = LinearMapping(d_min, d_min + r, t_min, t_min + r_t)
    log = LogMapping(d_min, d_min + r, t_min, t_min + r_t, strength=strength)
    blend = BlendedMapping((lin, log), (1.0 - w, w))
    d = np.linspace(d_min, d_min + r, 101)
    for op in (lin, log, blend):
        v = op(d)
        assert np.all(np.diff(v) > 0)
        assert_allclose(op.inverse(v), d, rtol=1e-9, atol=1e-9 * r)
