"""The world distortion phi of S0 §6 (Fig. 9): round trips, the left image, the mapped disparity, D phi."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.camera import look_at
from vergence.rigs import WorldDistortion
from vergence.viewing import Display, LinearMapping, Shooting, psi_from_constraints

# phi and phi^-1 go through D_r, psi (closed-form Gregory–Delbourgo inverse) and D_r^-1: a few
# hundred ulps where phi is well conditioned. Where psi saturates, z' hardly moves with z and phi^-1
# amplifies the rounding of q by (z'/z) / (dz'/dz): the bound scales with that condition number.
ROUNDTRIP_ULPS = 1000
# Pixel coordinates of order 1e3 px through two projections: agree to ~1e-10 px.
PIX_ATOL = 1e-8
# S0 disparities (fractions of the width, ~1e-2) compared after projection: ~1e-13 absolute.
DISPARITY_ATOL = 1e-11
# Central differences with a relative step of 1e-6 of the depth: truncation ~1e-12, rounding ~1e-10.
FD_STEP = 1e-6
FD_RTOL = 1e-6

H = 30.0
TV = Display(eye_separation=0.065, distance=3.0, width=1.2176)


def _camera(width: int = 480, height: int = 270):
    # The stadium's long lens, looking down the field from (0, 2.2, 0).
    return look_at([0.0, 2.2, 0.0], [0.0, 1.1, -30.0], [0.0, 1.0, 0.0], fov_deg=8.0, width=width, height=height)


def _distortion(cam=None, constraints=("z=30,perceived=3,roundness=1", "z=65,perceived=8")) -> WorldDistortion:
    cam = _camera() if cam is None else cam
    W = H * cam.width / cam.focal_px
    ref = Shooting(baseline=TV.eye_separation * H / TV.distance, convergence=H, window=W)  # b_round, S0 Eq. (5)
    mapping = psi_from_constraints(ref, TV, list(constraints), near=15.0, far=math.inf)
    assert mapping.monotone and not mapping.diverges
    return WorldDistortion(cam, ref, mapping.psi)


def _points(cam, n: int, seed: int, z_range=(15.0, 1e4)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pix = rng.uniform([-20.0, -20.0], [cam.width + 20.0, cam.height + 20.0], (n, 2))
    z = np.exp(rng.uniform(math.log(z_range[0]), math.log(z_range[1]), n))
    return cam.backproject(pix, z)


def _roundtrip_bound(phi: WorldDistortion, p: np.ndarray) -> np.ndarray:
    """ROUNDTRIP_ULPS ulps of |p - c_l|, times the condition number of phi^-1 along the ray (>= 1)."""
    e_z = phi.left.R[2]
    dzp = np.einsum("i,...ij,j->...", e_z, phi.jacobian(p), e_z)  # e_z . D phi e_z = dz'/dz
    z = (p - phi.left.center) @ e_z
    cond = np.maximum(1.0, (phi.depth(z) / z) / dzp)
    return ROUNDTRIP_ULPS * np.finfo(float).eps * np.linalg.norm(p - phi.left.center, axis=-1) * cond


def test_hand_worked_linear_psi():
    # psi(d) = d/2 on a rig converged at H: D_r(60) = (b/W)/2 -> psi = (b/W)/4 -> z' = H/(1 - 1/4) = 40.
    cam = look_at([0, 0, 0], [0, 0, -1], [0, 1, 0], fov_deg=10.0, width=100, height=50)
    ref = Shooting(0.5, H, H * cam.width / cam.focal_px)
    phi = WorldDistortion(cam, ref, LinearMapping(-1.0, 1.0, -0.5, 0.5))
    assert phi.depth(60.0) == pytest.approx(40.0, rel=1e-14)
    assert phi.depth(H) == H  # D_r(H) = 0 exactly, psi(0) = 0, D_r^-1(0) = H
    # z = inf: D_r = b/W, psi = b/(2W), z' = 2H.
    assert phi.depth(math.inf) == pytest.approx(2 * H, rel=1e-14)
    assert_allclose(phi.forward([[0.0, 3.0, -60.0]]), [[0.0, 2.0, -40.0]], rtol=1e-14)
    assert_allclose(phi.inverse([[0.0, 2.0, -40.0]]), [[0.0, 3.0, -60.0]], rtol=1e-14)


def test_inverse_undoes_forward():
    phi = _distortion()
    p = _points(phi.left, 20000, seed=1)
    q = phi.forward(p)
    assert np.isfinite(q).all()
    back = phi.inverse(q)
    assert np.all(np.linalg.norm(back - p, axis=-1) <= _roundtrip_bound(phi, p))


def test_left_image_is_unchanged():
    phi = _distortion()
    p = _points(phi.left, 2000, seed=2)
    before, _ = phi.left.project(p)
    after, _ = phi.left.project(phi.forward(p))
    assert_allclose(after, before, atol=PIX_ATOL)


def test_reference_right_camera_sees_psi_of_d():
    phi = _distortion()
    ref, cam = phi.reference, phi.left
    right = phi.reference_right
    assert_allclose(right.center - cam.center, ref.baseline * cam.R[0], atol=1e-14)
    assert right.principal_point[0] == pytest.approx(cam.principal_point[0] + cam.focal_px * ref.baseline / H)
    p = _points(cam, 2000, seed=3)
    q = phi.forward(p)
    x_l, z = cam.project(q)
    x_r, _ = right.project(q)
    assert_allclose(x_r[:, 1], x_l[:, 1], atol=PIX_ATOL)  # same rows
    d_seen = (x_r[:, 0] - x_l[:, 0]) / cam.width  # S0's d = x_r - x_l in window widths
    z_real = (p - cam.center) @ cam.R[2]
    d_wanted = phi.psi((ref.baseline / ref.window) * (z_real - H) / z_real)
    assert_allclose(d_seen, d_wanted, atol=DISPARITY_ATOL)


def test_convergence_plane_is_fixed_when_psi_of_zero_is_zero():
    phi = _distortion()
    assert phi.psi(0.0) == 0.0
    cam = phi.left
    pix = np.array([[0.0, 0.0], [240.0, 135.0], [479.0, 269.0]])
    p = cam.backproject(pix, np.full(3, H))
    assert_allclose(phi.forward(p), p, rtol=0, atol=1e-12 * H)
    assert phi.depth(H) == H


def test_jacobian_matches_central_differences():
    phi = _distortion()
    p = _points(phi.left, 50, seed=4, z_range=(16.0, 500.0))
    J = phi.jacobian(p)
    assert J.shape == (50, 3, 3)
    h = FD_STEP * np.linalg.norm(p - phi.left.center, axis=-1)
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1.0
        step = h[:, None] * e
        fd = (phi.forward(p + step) - phi.forward(p - step)) / (2 * h[:, None])
        assert_allclose(J[:, :, j], fd, rtol=FD_RTOL, atol=FD_RTOL * np.abs(J).max())


def test_jacobian_of_identity_psi_is_identity():
    cam = _camera()
    ref = Shooting(0.5, H, H * cam.width / cam.focal_px)
    phi = WorldDistortion(cam, ref, LinearMapping(-1.0, 1.0, -1.0, 1.0))
    p = _points(cam, 10, seed=5)
    assert_allclose(phi.jacobian(p), np.broadcast_to(np.eye(3), (10, 3, 3)), atol=1e-12)
    assert_allclose(phi.forward(p), p, rtol=1e-12)


def test_shapes_are_kept():
    phi = _distortion()
    p = _points(phi.left, 24, seed=6).reshape(2, 3, 4, 3)
    assert phi.forward(p).shape == (2, 3, 4, 3)
    assert phi.inverse(p).shape == (2, 3, 4, 3)
    assert phi.jacobian(p).shape == (2, 3, 4, 3, 3)
    assert phi.depth(np.ones((2, 5)) * 40).shape == (2, 5)
    assert isinstance(phi.depth(40.0), float)
    assert phi.forward(p[0, 0, 0]).shape == (3,)


def test_undefined_points_are_nan_not_errors():
    phi = _distortion()
    cam = phi.left
    good = cam.backproject(np.array([[100.0, 100.0]]), np.array([40.0]))[0]
    behind = cam.center - 5.0 * cam.R[2]
    on_plane = cam.center + 3.0 * cam.R[0]
    pts = np.array([good, behind, on_plane, [np.nan, 0.0, -10.0], [np.inf, 0.0, -10.0]])
    for out in (phi.forward(pts), phi.inverse(pts)):
        assert np.isfinite(out[0]).all()
        assert np.isnan(out[1:]).all()
    J = phi.jacobian(pts)
    assert np.isfinite(J[0]).all() and np.isnan(J[1:]).all()
    assert np.isnan(phi.depth(np.array([0.0, -1.0, np.nan]))).all()


def test_inverse_is_nan_beyond_the_image_of_infinity():
    # psi saturates: every real depth maps nearer than depth(inf); a distorted point farther has no preimage.
    phi = _distortion()
    far = phi.depth(math.inf)
    assert math.isfinite(far)
    cam = phi.left
    pts = cam.backproject(np.array([[240.0, 135.0]] * 3), np.array([0.5 * far, 1.5 * far, 100 * far]))
    out = phi.inverse(pts)
    assert np.isfinite(out[0]).all() and np.isnan(out[1:]).all()


def test_inverse_is_one_vectorised_call_even_past_the_image_of_infinity():
    # Depths past depth(inf) are masked before psi.inverse, which would refuse them (psi saturates below
    # b'/W'): one call for the whole array, no element-by-element fallback.
    phi = _distortion()
    calls = []

    class Counting:
        def __init__(self, psi):
            self.psi = psi

        def __call__(self, d):
            return self.psi(d)

        def derivative(self, d):
            return self.psi.derivative(d)

        def inverse(self, v):
            calls.append(np.size(v))
            return self.psi.inverse(v)

    counted = WorldDistortion(phi.left, phi.reference, Counting(phi.psi))
    far = phi.depth(math.inf)
    z = np.array([20.0, 0.5 * far, 2.0 * far, 1e6])
    pts = phi.left.backproject(np.tile([[240.0, 135.0]], (4, 1)), z)
    out = counted.inverse(pts)
    assert calls == [2]
    assert np.isfinite(out[:2]).all() and np.isnan(out[2:]).all()


def test_inverse_with_a_range_bounded_below_is_nan_below_it():
    # A mapping whose inverse refuses values under its range: those points come back NaN, the others exact.
    class Floor:
        """psi(d) = d for d >= -0.05; refuses to invert values below -0.05."""

        def __call__(self, d):
            return np.asarray(d, dtype=np.float64)

        def derivative(self, d):
            return np.ones_like(np.asarray(d, dtype=np.float64))

        def inverse(self, v):
            v = np.asarray(v, dtype=np.float64)
            if (v < -0.05).any():
                raise ValueError("value must lie in the range")
            return v

    cam = _camera()
    ref = Shooting(0.5, H, H * cam.width / cam.focal_px)
    phi = WorldDistortion(cam, ref, Floor())
    # D_r(z) = (b/W)(z - H)/z < -0.05 for z small enough: b/W = 0.5 / 6.86 ~ 0.073 -> z < ~17.8 m.
    pts = cam.backproject(np.array([[240.0, 135.0]] * 3), np.array([10.0, 25.0, 80.0]))
    out = phi.inverse(pts)
    assert np.isnan(out[0]).all()
    assert_allclose(out[1:], pts[1:], rtol=1e-13)


@settings(max_examples=40, deadline=None)
@given(
    z=st.floats(min_value=16.0, max_value=1e5),
    x=st.floats(min_value=-50.0, max_value=530.0),
    y=st.floats(min_value=-50.0, max_value=320.0),
    far_perceived=st.floats(min_value=3.5, max_value=50.0),
)
def test_round_trip_property(z, x, y, far_perceived):
    phi = _distortion(constraints=("z=30,perceived=3,roundness=1", f"z=65,perceived={far_perceived!r}"))
    p = phi.left.backproject(np.array([[x, y]]), np.array([z]))
    back = phi.inverse(phi.forward(p))
    assert np.all(np.linalg.norm(back - p, axis=-1) <= _roundtrip_bound(phi, p))


def test_bad_arguments():
    cam = _camera()
    ref = Shooting(0.5, H, H * cam.width / cam.focal_px)
    psi = LinearMapping(-1.0, 1.0, -1.0, 1.0)
    with pytest.raises(TypeError, match="left must be"):
        WorldDistortion("cam", ref, psi)
    with pytest.raises(TypeError, match="reference must be"):
        WorldDistortion(cam, (0.5, H, 1.0), psi)
    with pytest.raises(TypeError, match="psi must be callable"):
        WorldDistortion(cam, ref, lambda d: d)
    with pytest.raises(ValueError, match="reference window must be"):
        WorldDistortion(cam, Shooting(0.5, H, ref.window * (1 + 1e-8)), psi)
    WorldDistortion(cam, Shooting(0.5, H, ref.window * (1 + 1e-10)), psi)  # 10-digit rounding passes
    phi = WorldDistortion(cam, ref, psi)
    with pytest.raises(ValueError, match=r"points must have shape \(\.\.\., 3\)"):
        phi.forward(np.zeros((4, 2)))
    with pytest.raises(TypeError, match="points must be numeric"):
        phi.inverse("0,0,1")
    with pytest.raises(TypeError, match="z must be numeric"):
        phi.depth(["a"])
