"""Tests of vergence.rigs.stereo_pair: S0 Eq. (1a) disparity, zero parallax at H, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.camera import Camera, look_at
from vergence.rigs import stereo_pair
from vergence.viewing.geometry import Shooting, disparity

# Projections go through a few float64 products: pixel coordinates agree to ~1e-12 px; a few
# hundred ulps of values up to ~1e3 px.
PIX_ATOL = 1e-9


def _cam(**kw) -> Camera:
    kw.setdefault("fov_deg", 40.0)
    kw.setdefault("width", 640)
    kw.setdefault("height", 360)
    return look_at([1.0, 1.5, 4.0], [0.2, 1.0, -6.0], [0.0, 1.0, 0.0], **kw)


def _points_at_depth(cam: Camera, z: float) -> np.ndarray:
    """World points seen by ``cam`` at camera-frame depth ``z`` on a 5 x 3 grid of pixels."""
    xs, ys = np.meshgrid(np.linspace(0, cam.width - 1, 5), np.linspace(0, cam.height - 1, 3))
    pix = np.stack([xs.ravel(), ys.ravel()], axis=-1)
    return cam.backproject(pix, np.full(len(pix), z))


def test_hand_worked_pair():
    cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90.0, width=101, height=51)
    left, right = stereo_pair(cam, baseline=0.1, convergence=2.0)
    # fx = 101 / (2 tan 45 deg) = 50.5; shift = fx b / (2H) = 50.5 * 0.1 / 4 = 1.2625 px.
    assert_allclose(left.center, [-0.05, 0.0, 0.0], atol=1e-15)
    assert_allclose(right.center, [0.05, 0.0, 0.0], atol=1e-15)
    assert left.principal_point == pytest.approx((50.0 - 1.2625, 25.0))
    assert right.principal_point == pytest.approx((50.0 + 1.2625, 25.0))
    assert_allclose(left.R, cam.R)
    assert (left.width, left.height) == (101, 51)
    # A point at z = 4 on the axis: x_l - x_r = fx b (1/z - 1/H) = 50.5 * 0.1 * (0.25 - 0.5).
    pl, _ = left.project([[0.0, 0.0, 4.0]])
    pr, _ = right.project([[0.0, 0.0, 4.0]])
    assert pl[0, 0] - pr[0, 0] == pytest.approx(-1.2625, abs=PIX_ATOL)


def test_zero_disparity_on_convergence_plane_and_same_window():
    cam = _cam()
    left, right = stereo_pair(cam, baseline=0.065, convergence=3.0)
    pts = _points_at_depth(cam, 3.0)
    pl, _ = left.project(pts)
    pr, _ = right.project(pts)
    pc, _ = cam.project(pts)
    # Both frusta meet the plane z = H in the central camera's window (S0 §2).
    assert_allclose(pl, pc, atol=PIX_ATOL)
    assert_allclose(pr, pc, atol=PIX_ATOL)


@settings(max_examples=25, deadline=None)
@given(
    z=st.floats(0.3, 500.0),
    b=st.floats(0.01, 2.0),
    H=st.floats(0.5, 100.0),
)
def test_disparity_is_s0_eq_1a(z, b, H):
    cam = _cam()
    left, right = stereo_pair(cam, baseline=b, convergence=H)
    pts = _points_at_depth(cam, z)
    pl, zl = left.project(pts)
    pr, zr = right.project(pts)
    # Parallel cameras: same depth, same rows (no vertical disparity).
    assert_allclose(zl, z, rtol=1e-12)
    assert_allclose(zr, z, rtol=1e-12)
    assert_allclose(pl[:, 1], pr[:, 1], atol=PIX_ATOL)
    # S0 Eq. (1a): d = x_r - x_l as a fraction of the window W = H * width / fx.
    window = H * cam.width / cam.focal_px
    expected = disparity(z, Shooting(baseline=b, convergence=H, window=window))
    assert_allclose((pr[:, 0] - pl[:, 0]) / cam.width, expected, atol=PIX_ATOL / cam.width)


def test_bad_input():
    cam = _cam()
    with pytest.raises(TypeError, match="camera must be a vergence.camera.Camera; got str"):
        stereo_pair("cam", baseline=0.1, convergence=2.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="baseline must be > 0; got 0"):
        stereo_pair(cam, baseline=0.0, convergence=2.0)
    with pytest.raises(ValueError, match="convergence must be > 0; got -1"):
        stereo_pair(cam, baseline=0.1, convergence=-1.0)
    with pytest.raises(ValueError, match="convergence must be finite; got nan"):
        stereo_pair(cam, baseline=0.1, convergence=float("nan"))


# Issue 9 sweep (api/render_stereo/convergence=subnormal, api/stereo_preview/baseline=huge): the sensor
# shift fx b / (2H) overflowed with a numpy warning and Camera said "K must be finite", naming no argument.
@pytest.mark.parametrize(
    ("baseline", "convergence", "message"),
    [
        (1e308, 2.0, r"^baseline must be in \[1e-06, 1e\+06\] m \(LENGTH_RANGE\); got 1e\+308$"),
        (0.065, 5e-324, r"^convergence must be in \[1e-06, 1e\+06\] m \(LENGTH_RANGE\); got 4.94066e-324$"),
        (0.065, 1e7, r"^convergence must be in \[1e-06, 1e\+06\] m \(LENGTH_RANGE\); got 1e\+07$"),
    ],
)
def test_rig_lengths_outside_their_range_are_refused(baseline, convergence, message):
    with pytest.raises(ValueError, match=message):
        stereo_pair(_cam(), baseline=baseline, convergence=convergence)
    # the range's ends are admitted and give finite cameras (no warning: the suite turns them into errors)
    for b, h in ((1e-6, 1e6), (1e6, 1e-6)):
        left, right = stereo_pair(_cam(), baseline=b, convergence=h)
        assert np.isfinite(left.K).all() and np.isfinite(right.K).all()


def test_a_sensor_shift_past_float64_is_refused_naming_the_rig():
    huge_focal = Camera(K=np.diag([1e300, 1e300, 1.0]) + np.array([[0, 0, 50.0], [0, 0, 25.0], [0, 0, 0]]),
                        R=np.eye(3), t=np.zeros(3), width=101, height=51)  # fmt: skip
    with pytest.raises(ValueError, match=r"^convergence must keep the sensor shift fx b / \(2 H\) finite; got inf px"):
        stereo_pair(huge_focal, baseline=1e6, convergence=1e-6)
