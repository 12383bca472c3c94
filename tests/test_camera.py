"""Tests of vergence.camera: hand-worked projections, round trips, look_at, interpolation, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from vergence.camera import MIN_FOV_DEG, Camera, interpolate, look_at

# Round trips go through a 3x3 inverse and a few products: a few hundred ulps of the coordinates.
ROUND_TRIP_RTOL = 1e-10
ROUND_TRIP_ATOL = 1e-9


def _cam(position=(0.0, 0.0, 0.0), target=(0.0, 0.0, 1.0), up=(0.0, -1.0, 0.0), **kw) -> Camera:
    kw.setdefault("fov_deg", 60.0)
    kw.setdefault("width", 64)
    kw.setdefault("height", 48)
    return look_at(position, target, up, **kw)


def test_look_at_identity_pose_hand_values():
    # Looking down +z with world up = -y: the camera frame is the world frame.
    cam = _cam(fov_deg=90.0, width=101, height=51)
    assert_allclose(cam.R, np.eye(3), atol=1e-15)
    assert_allclose(cam.t, 0.0, atol=1e-15)
    # fov 90 deg across 101 px: f = 101 / (2 tan 45 deg) = 50.5; centre at ((101-1)/2, (51-1)/2).
    assert cam.focal_px == pytest.approx(50.5)
    assert cam.principal_point == (50.0, 25.0)
    pix, depth = cam.project([[1.0, 0.5, 2.0]])
    assert_allclose(pix, [[50.0 + 50.5 * 0.5, 25.0 + 50.5 * 0.25]])
    assert_allclose(depth, [2.0])


def test_look_at_world_y_up_gives_image_rows_downward():
    cam = _cam(position=(0, 0, 0), target=(0, 0, -5), up=(0, 1, 0), fov_deg=90.0, width=11, height=11)
    # A point above the optical axis (world +y) lands in a row above the centre (smaller y).
    pix, _ = cam.project([[0.0, 1.0, -5.0]])
    assert pix[0, 1] < 5.0
    # Looking down -z with y up, the camera's right axis is forward x up = world +x.
    right = np.cross([0, 0, -1.0], [0, 1.0, 0])
    pix, _ = cam.project([right + [0, 0, -5.0]])
    assert pix[0, 0] > 5.0
    assert cam.center.tolist() == pytest.approx([0, 0, 0])


def test_center_and_depth_of_a_translated_camera():
    cam = _cam(position=(1.0, 2.0, -3.0), target=(1.0, 2.0, 10.0))
    assert_allclose(cam.center, [1.0, 2.0, -3.0], atol=1e-12)
    _, depth = cam.project([[1.0, 2.0, 7.0]])
    assert depth[0] == pytest.approx(10.0)


def test_points_behind_the_camera_project_to_nan():
    cam = _cam()
    pix, depth = cam.project([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    assert np.isnan(pix).all()
    assert_allclose(depth, [-1.0, 0.0])


def test_off_axis_principal_point_is_kept():
    cam = _cam(principal_point=(-10.5, 200.0))
    assert cam.principal_point == (-10.5, 200.0)
    pix, _ = cam.project([[0.0, 0.0, 3.0]])
    assert_allclose(pix, [[-10.5, 200.0]])


@settings(max_examples=40, deadline=None)
@given(
    pos=st.tuples(*[st.floats(-5, 5)] * 3),
    yaw=st.floats(-math.pi, math.pi),
    pitch=st.floats(-1.2, 1.2),
    x=st.floats(-20, 80),
    y=st.floats(-20, 60),
    z=st.floats(0.1, 100),
)
def test_project_backproject_round_trip(pos, yaw, pitch, x, y, z):
    forward = np.array([math.cos(pitch) * math.sin(yaw), math.sin(pitch), math.cos(pitch) * math.cos(yaw)])
    cam = _cam(position=pos, target=np.add(pos, forward), up=(0, -1, 0), principal_point=(30.0, 20.0))
    world = cam.backproject([[x, y]], [z])
    pix, depth = cam.project(world)
    assert_allclose(pix, [[x, y]], rtol=ROUND_TRIP_RTOL, atol=ROUND_TRIP_ATOL)
    assert_allclose(depth, [z], rtol=ROUND_TRIP_RTOL)


def test_backproject_depth_map_shape_and_nan():
    cam = _cam(width=8, height=6)
    depth = np.full((6, 8), 2.0)
    depth[1, 2] = np.nan
    pts = cam.backproject_depth(depth)
    assert pts.shape == (6, 8, 3)
    assert np.isnan(pts[1, 2]).all()
    pix, z = cam.project(pts[0, 3])
    assert_allclose(pix, [3.0, 0.0], atol=1e-12)
    assert z == pytest.approx(2.0)


def test_ray_directions_are_unit_and_pass_through_pixels():
    cam = _cam(width=5, height=4, position=(0.3, 0.1, -1.0), target=(1.0, 0.0, 3.0))
    rays = cam.ray_directions()
    assert rays.shape == (4, 5, 3)
    assert_allclose(np.linalg.norm(rays, axis=-1), 1.0, rtol=1e-12)
    pix, _ = cam.project(cam.center + 3.0 * rays[2, 4])
    assert_allclose(pix, [4.0, 2.0], atol=1e-9)


def test_dict_round_trip_and_equality():
    cam = _cam(principal_point=(12.0, 7.0))
    again = Camera.from_dict(cam.to_dict())
    assert again == cam
    assert again != _cam()


def test_arrays_are_read_only_copies():
    K = np.array([[100.0, 0, 10], [0, 100.0, 10], [0, 0, 1]])
    cam = Camera(K=K, R=np.eye(3), t=np.zeros(3), width=20, height=20)
    K[0, 0] = 5.0
    assert cam.focal_px == 100.0
    with pytest.raises(ValueError):
        cam.K[0, 0] = 1.0


def test_interpolate_endpoints_and_midpoint():
    a = _cam(position=(0, 0, 0), target=(0, 0, 1))
    b = _cam(position=(2, 0, 0), target=(2 + math.sin(0.4), 0, math.cos(0.4)), fov_deg=40.0)
    assert interpolate(a, b, 0.0) == a and interpolate(b, a, 1.0) == a  # exact endpoints
    assert interpolate(a, b, 1.0) == b and interpolate(b, a, 0.0) == b
    near_a = interpolate(a, b, 1e-12)
    assert_allclose(near_a.R, a.R, atol=1e-11)
    assert_allclose(near_a.t, a.t, atol=1e-11)
    mid = interpolate(a, b, 0.5)
    assert_allclose(mid.center, [1.0, 0.0, 0.0], atol=1e-12)
    # Slerp: half the relative rotation angle about y.
    rel = Rotation.from_matrix(mid.R @ a.R.T).magnitude()
    assert rel == pytest.approx(0.2, abs=1e-12)
    assert_allclose(mid.K, (a.K + b.K) / 2)


@settings(max_examples=30, deadline=None)
@given(s=st.floats(0, 1), angle=st.floats(-2.5, 2.5), dx=st.floats(-3, 3))
def test_interpolate_is_symmetric(s, angle, dx):
    a = _cam(position=(0, 0, 0), target=(0, 0, 1))
    b = _cam(position=(dx, 0.5, 0), target=(dx + math.sin(angle), 0.5, math.cos(angle)), fov_deg=45.0)
    ab = interpolate(a, b, s)
    ba = interpolate(b, a, 1.0 - s)
    assert_allclose(ab.R, ba.R, atol=1e-9)
    assert_allclose(ab.center, ba.center, atol=1e-9)
    assert_allclose(ab.K, ba.K, rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"K": np.zeros((3, 3))}, "positive focal"),
        ({"K": np.diag([5e-324, 5e-324, 1.0])}, "MIN_FOCAL_PX"),  # ray_directions overflowed to inf
        ({"K": np.diag([100.0, 1e-300, 1.0])}, "MIN_FOCAL_PX"),
        ({"K": np.eye(2)}, r"K must have shape \(3, 3\)"),
        ({"R": 2 * np.eye(3)}, "R must be a rotation"),
        ({"R": np.diag([1.0, 1.0, -1.0])}, "R must be a rotation"),
        ({"t": [0.0, np.nan, 0.0]}, "t must be finite"),
        ({"width": 0}, "width must be >= 1"),
        ({"height": 2.5}, "height must be an integer"),
    ],
)
def test_bad_camera_parameters(kwargs, match):
    base = {"K": np.diag([100.0, 100.0, 1.0]), "R": np.eye(3), "t": np.zeros(3), "width": 10, "height": 10}
    base.update(kwargs)
    with pytest.raises((ValueError, TypeError), match=match):
        Camera(**base)


def test_bad_look_at_and_interpolate():
    with pytest.raises(ValueError, match="up must not be parallel"):
        look_at([0, 0, 0], [0, 0, 1], [0, 0, 2], fov_deg=60, width=4, height=4)
    with pytest.raises(ValueError, match=r"^up must be a non-zero vector; got \(0, 0, 0\)$"):
        look_at([0, 0, 0], [0, 0, 1], [0, 0, 0], fov_deg=60, width=4, height=4)
    with pytest.raises(ValueError, match="target must differ"):
        look_at([1, 1, 1], [1, 1, 1], [0, 1, 0], fov_deg=60, width=4, height=4)
    with pytest.raises(ValueError, match="fov_deg"):
        look_at([0, 0, 0], [0, 0, 1], [0, 1, 0], fov_deg=180, width=4, height=4)
    with pytest.raises(ValueError, match=r"s must lie in \[0, 1\]"):
        interpolate(_cam(), _cam(), 1.5)
    with pytest.raises(ValueError, match="share an image size"):
        interpolate(_cam(), _cam(width=10), 0.5)
    with pytest.raises(ValueError, match=r"points_world must have shape \(\.\.\., 3\)"):
        _cam().project([[1.0, 2.0]])
    with pytest.raises(ValueError, match="depth must be > 0"):
        _cam().backproject([[1.0, 2.0]], [-1.0])
    with pytest.raises(ValueError, match="missing field"):
        Camera.from_dict({"K": np.eye(3).tolist()})
    with pytest.raises(ValueError, match=r"^pixels must have shape \(\.\.\., 2\); got \(2, 3\)$"):
        _cam().backproject(np.zeros((2, 3)), [1.0, 1.0])
    with pytest.raises(ValueError, match=r"^depth must have shape \(2,\) matching pixels; got \(3,\)$"):
        _cam().backproject(np.zeros((2, 2)), [1.0, 1.0, 1.0])
    with pytest.raises(TypeError, match="^camera must be a JSON object; got list$"):
        Camera.from_dict([1, 2])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^camera has unknown field\\(s\\) focal, skew$"):
        Camera.from_dict({**_cam().to_dict(), "focal": 1.0, "skew": 0.0})
    with pytest.raises(TypeError, match="^a and b must be Camera instances$"):
        interpolate(_cam(), "camera", 0.5)  # type: ignore[arg-type]


def test_fov_bounds_and_exact_intrinsics_row():
    for fov in (0.0, -10.0, 180.0):
        with pytest.raises(ValueError, match="strictly between 0 and 180"):
            look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=fov, width=4, height=4)
    K = np.diag([100.0, 100.0, 1.0 + 1e-9])  # a K whose last row is not (0, 0, 1) breaks project/backproject
    with pytest.raises(ValueError, match=r"last row \(0, 0, 1\)"):
        Camera(K=K, R=np.eye(3), t=np.zeros(3), width=4, height=4)


@pytest.mark.parametrize(("options", "message"), [
    # sweep case api/look_at/fov_deg=subnormal: ZeroDivisionError (tan of a zero angle)
    ({"fov_deg": 5e-324}, r"^fov_deg must be at least 0.001 \(MIN_FOV_DEG\); got 4.94066e-324$"),
    ({"fov_deg": MIN_FOV_DEG / 2}, r"^fov_deg must be at least 0.001 \(MIN_FOV_DEG\); got 0.0005$"),
    # sweep case api/look_at/principal_point=empty: IndexError
    ({"principal_point": ()}, r"^principal_point must have shape \(2,\); got \(0,\)$"),
    ({"principal_point": (1.0, 2.0, 3.0)}, r"^principal_point must have shape \(2,\); got \(3,\)$"),
    ({"principal_point": (np.nan, 2.0)}, r"^principal_point must be finite \(no NaN or inf\)$"),
])
def test_look_at_refuses_degenerate_intrinsics(options, message):
    with pytest.raises(ValueError, match=message):
        look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], **{"fov_deg": 60.0, "width": 4, "height": 4, **options})


def test_look_at_narrowest_field_of_view_is_finite():
    cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=MIN_FOV_DEG, width=4, height=4)
    # f = 4 / (2 tan(0.0005 deg)) = 229183.1 px
    np.testing.assert_allclose(cam.focal_px, 4 / (2 * math.tan(math.radians(MIN_FOV_DEG / 2))), rtol=1e-12)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), s=st.floats(0, 1), near=st.sampled_from([None, 1e-9, 1e-4, math.pi - 1e-6]))
def test_interpolate_rotation_is_scipys_slerp(seed, s, near):
    """The quaternion slerp of interpolate against scipy's Slerp (the reference), for random rotations, nearly
    equal ones and ones almost half a turn apart (the arc's end the quaternions' sign decides)."""
    from scipy.spatial.transform import Slerp

    rng = np.random.default_rng(seed)
    ra = Rotation.random(random_state=rng)
    if near is None:
        rb = Rotation.random(random_state=rng)
    else:
        axis = rng.normal(size=3)
        rb = ra * Rotation.from_rotvec(near * axis / np.linalg.norm(axis))
    K = np.array([[100.0, 0, 10], [0, 100.0, 10], [0, 0, 1]])
    a = Camera(K=K, R=ra.as_matrix(), t=np.zeros(3), width=20, height=20)
    b = Camera(K=K, R=rb.as_matrix(), t=np.ones(3), width=20, height=20)
    want = Slerp([0.0, 1.0], Rotation.concatenate([ra, rb]))([s]).as_matrix()[0]
    got = interpolate(a, b, s).R
    assert_allclose(got, want, atol=1e-9)
    assert_allclose(got @ got.T, np.eye(3), atol=1e-12)
