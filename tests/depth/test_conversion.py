"""Depth <-> disparity (S1 Eq. 7): hand values, round trips, invalid values, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vergence.camera import look_at
from vergence.depth import depth_from_disparity, disparity_from_depth, rectify_cameras

# Round trip f b / (f b / Z) in float64: a few ulps.
RTOL = 1e-12


def test_hand_values_and_doffs():
    np.testing.assert_allclose(depth_from_disparity([20.0, 40.0], focal_px=800.0, baseline=0.05), [2.0, 1.0], rtol=RTOL)
    np.testing.assert_allclose(depth_from_disparity(15.0, focal_px=800.0, baseline=0.05, doffs_px=5.0), 2.0, rtol=RTOL)
    np.testing.assert_allclose(disparity_from_depth(2.0, focal_px=800.0, baseline=0.05, doffs_px=5.0), 15.0, rtol=RTOL)


def test_invalid_disparities_give_nan():
    z = depth_from_disparity([np.nan, 0.0, -3.0, 2.0], focal_px=100.0, baseline=1.0, doffs_px=1.0)
    # d + doffs = NaN, 1, -2 (behind: invalid), 3; assert_allclose compares NaN positions too.
    np.testing.assert_allclose(z, [np.nan, 100.0, np.nan, 100.0 / 3.0], rtol=RTOL)
    np.testing.assert_allclose(disparity_from_depth([np.nan, 10.0], focal_px=100.0, baseline=1.0), [np.nan, 10.0],
                               rtol=RTOL)


# Unit roundoff of float64 (round to nearest): every +, -, *, / has relative error <= U.
U = np.finfo(np.float64).eps / 2


def round_trip_rtol(q: float, d: float) -> float:
    """Bound on |z'/z - 1| for z' = f b / ((f b / z - doffs) + doffs), with q = f b / z and d = q - doffs.

    Write p = fl(f b), q = fl(p / z) = (p / z)(1 + e2), d = fl(q - doffs) = (q - doffs)(1 + e3),
    s = fl(d + doffs) = (q + e3 d)(1 + e4), z' = fl(p / s) = (p / s)(1 + e5), |e_i| <= U. The error
    of fl(f b) cancels (p is in both), so z'/z = (1 + e5) / ((1 + e2 + e3 d / q)(1 + e4)) and, to first
    order, |z'/z - 1| <= U (3 + |d| / q). The term |d| / q is the cancellation: the absolute error
    U |d| of the subtraction is relative to q once doffs is added back (z = 6111, f = 10, b = 0.001,
    doffs = 33: q = 1.6e-6, |d| / q = 2e7, bound 2.2e-9). One more U covers the second-order terms,
    which are below (U (3 + |d| / q))^2 << U.
    """
    return U * (4.0 + abs(d) / q)


@settings(max_examples=30, deadline=None)
@given(z=st.floats(0.1, 1e4), f=st.floats(10.0, 1e4), b=st.floats(1e-3, 10.0), off=st.floats(-50.0, 50.0))
def test_round_trip(z, f, b, off):
    d = disparity_from_depth(z, focal_px=f, baseline=b, doffs_px=off)
    rtol = round_trip_rtol(f * b / z, float(d))
    np.testing.assert_allclose(depth_from_disparity(d, focal_px=f, baseline=b, doffs_px=off), z, rtol=rtol, atol=0)


def test_round_trip_of_the_reported_cancellation():
    """The case that broke the old fixed rtol = 1e-9: the error is 2e-9, inside the derived bound."""
    z, f, b, off = 6111.0, 10.0, 0.001, 33.0
    d = disparity_from_depth(z, focal_px=f, baseline=b, doffs_px=off)
    err = abs(depth_from_disparity(d, focal_px=f, baseline=b, doffs_px=off) / z - 1.0)
    assert 1e-9 < err <= round_trip_rtol(f * b / z, float(d))


def test_matches_the_rectified_cameras():
    """Depth from a rectified pair's disparity equals the left camera's z (doffs from the cameras)."""
    a = look_at([0, 0, 0], [0.3, 0, 5], [0, -1, 0], fov_deg=50, width=320, height=240)
    b = look_at([0.2, 0.01, 0], [0.0, 0, 5], [0, -1, 0], fov_deg=55, width=320, height=240)
    rect = rectify_cameras(a, b)
    pts = np.array([[0.1, 0.2, 3.0], [-0.4, 0.1, 6.0], [0.3, -0.2, 9.0]])
    pl, zl = rect.left_camera.project(pts)
    pr, _ = rect.right_camera.project(pts)
    z = depth_from_disparity(pl[:, 0] - pr[:, 0], focal_px=rect.focal_px, baseline=rect.baseline,
                             doffs_px=rect.doffs_px)
    np.testing.assert_allclose(z, zl, rtol=1e-9)


def test_bad_input():
    with pytest.raises(ValueError, match="focal_px must be > 0; got 0"):
        depth_from_disparity([1.0], focal_px=0.0, baseline=1.0)
    with pytest.raises(ValueError, match="baseline must be > 0; got -1"):
        depth_from_disparity([1.0], focal_px=1.0, baseline=-1.0)
    with pytest.raises(ValueError, match="disparity must not contain inf"):
        depth_from_disparity([np.inf], focal_px=1.0, baseline=1.0)
    with pytest.raises(ValueError, match="depth must be > 0 where known"):
        disparity_from_depth([1.0, 0.0], focal_px=1.0, baseline=1.0)
    with pytest.raises(TypeError, match="doffs_px must be a real number"):
        disparity_from_depth([1.0], focal_px=1.0, baseline=1.0, doffs_px="1")
