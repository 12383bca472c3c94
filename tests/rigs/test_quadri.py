"""The Quadri-Rig planner of S0 §5 (Eq. (10)): positions, focal lengths, pixel-identical element planes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.camera import look_at
from vergence.rigs import QuadriRig, RigCamera, plan_quadri_rig, stereo_pair

# Pixels of order 1e3 through a product of two 3x3 matrices and a projection: ~1e-12 px; positions
# of order 1e2 m: ~1e-13 m.
PIX_ATOL = 1e-8
POS_ATOL = 1e-10


def _virtual(width: int = 480, height: int = 270):
    # The stadium's subject seen from 10 m, a little off axis and from above.
    return look_at([0.4, 1.6, -20.0], [0.0, 1.0, -30.0], [0.0, 1.0, 0.0], fov_deg=40.0, width=width, height=height)


ELEMENTS = [("subject", [0.0, 1.0, -30.0]), ("background", [2.0, 3.0, -64.0])]


def _plan(**kw) -> QuadriRig:
    kw.setdefault("baseline", 0.3)
    kw.setdefault("convergence", 10.0)
    kw.setdefault("setback", 20.0)
    kw.setdefault("elements", ELEMENTS)
    return plan_quadri_rig(_virtual(), **kw)


def test_hand_worked_rig_of_s0_fig6():
    # R = identity; virtual left eye at (3, 0, 45), real plane z = 0 (setback 45), subject at z = 60:
    # k = 60/15 = 4, c = p + 4 (v - p) = (10.5, 0, 0); background at z = 150: k = 150/105, c = (5.143, 0, 0).
    cam = look_at([3.5, 0, 45], [3.5, 0, 60], [0, -1, 0], fov_deg=40, width=640, height=480)
    assert_allclose(cam.R, np.eye(3), atol=1e-15)
    rig = plan_quadri_rig(cam, baseline=1.0, convergence=15.0, setback=45.0,
                          elements=[("subject", [0.5, 0.0, 60.0]), ("background", [-2.0, 0.0, 150.0])])
    sub_l, sub_r, bg_l, bg_r = (c.camera for c in rig.cameras)
    assert_allclose(sub_l.center, [10.5, 0.0, 0.0], atol=POS_ATOL)
    assert_allclose(bg_l.center, [-2.0 + (150 / 105) * 5.0, 0.0, 0.0], atol=POS_ATOL)
    assert sub_l.focal_px == pytest.approx(4 * cam.focal_px, rel=1e-14)
    assert bg_l.focal_px == pytest.approx(150 / 105 * cam.focal_px, rel=1e-14)
    # pp_c = pp_v + f_v (c_x - v_x) / z_e with pp_v the virtual left eye's (sensor-shifted) one.
    v_left = rig.left
    assert sub_l.principal_point[0] == pytest.approx(v_left.principal_point[0] + cam.focal_px * 7.5 / 15.0)
    assert rig.baselines == pytest.approx({"subject": 4.0, "background": 150 / 105})
    assert_allclose(sub_r.center - sub_l.center, [4.0, 0.0, 0.0], atol=POS_ATOL)
    assert_allclose(bg_r.center - bg_l.center, [150 / 105, 0.0, 0.0], atol=POS_ATOL)


def test_names_order_and_eyes():
    rig = _plan()
    assert [c.name for c in rig.cameras] == ["subject_left", "subject_right", "background_left", "background_right"]
    assert [(c.element, c.eye) for c in rig.cameras] == [
        ("subject", "left"), ("subject", "right"), ("background", "left"), ("background", "right")]
    assert [c.name for c in rig.sources("right")] == ["subject_right", "background_right"]
    left, right = stereo_pair(_virtual(), baseline=0.3, convergence=10.0)
    assert rig.left == left and rig.right == right and rig.virtual("right") == right
    assert [n for n, _ in rig.elements] == ["subject", "background"]
    with pytest.raises(ValueError, match="eye must be one of left, right"):
        rig.sources("centre")


def test_real_cameras_on_the_element_line_and_the_real_plane():
    rig = _plan()
    fwd, c0 = rig.center.R[2], rig.center.center
    for rc in rig.cameras:
        point = dict(rig.elements)[rc.element]
        v = rig.virtual(rc.eye).center
        c = rc.camera.center
        assert (c - c0) @ fwd == pytest.approx(-rig.setback, abs=POS_ATOL)  # on the real plane
        assert np.linalg.norm(np.cross(c - point, v - point)) < POS_ATOL * 100  # on the line (p_e, v)
        assert_allclose(rc.camera.R, rig.center.R)
        # S0 Eq. (10): f_e / f_v = distance real camera -> element plane / virtual eye -> element plane.
        z_e = (point - v) @ fwd
        assert rc.camera.focal_px / rig.center.focal_px == pytest.approx((z_e + rig.setback) / z_e, rel=1e-13)
        assert rc.camera.K[1, 1] / rig.center.K[1, 1] == pytest.approx((z_e + rig.setback) / z_e, rel=1e-13)


def test_element_plane_imaged_pixel_for_pixel():
    rig = _plan()
    for rc in rig.cameras:
        point = dict(rig.elements)[rc.element]
        virtual = rig.virtual(rc.eye)
        z_e = (point - virtual.center) @ virtual.R[2]
        xs, ys = np.meshgrid(np.linspace(-50, virtual.width + 50, 9), np.linspace(-30, virtual.height + 30, 7))
        pix = np.stack([xs.ravel(), ys.ravel()], axis=-1)
        plane = virtual.backproject(pix, np.full(len(pix), z_e))  # the plane through the element, facing the rig
        seen, _ = rc.camera.project(plane)
        assert_allclose(seen, pix, atol=PIX_ATOL)
        # ... and not off that plane: a point 5 m behind it lands elsewhere (parallax between c and v).
        behind, _ = rc.camera.project(virtual.backproject(pix, np.full(len(pix), z_e + 5.0)))
        assert np.abs(behind - pix).max() > 1.0


@settings(max_examples=30, deadline=None)
@given(
    x=st.floats(-20, 20), y=st.floats(-5, 10), depth=st.floats(0.5, 200.0),
    setback=st.floats(0.1, 100.0), baseline=st.floats(0.01, 2.0),
)
def test_element_plane_identity_property(x, y, depth, setback, baseline):
    cam = _virtual()
    point = cam.center + depth * cam.R[2] + x * cam.R[0] + y * cam.R[1]
    rig = plan_quadri_rig(cam, baseline=baseline, convergence=10.0, setback=setback, elements=[("e", point)])
    pix = np.array([[0.0, 0.0], [240.0, 135.0], [479.0, 269.0]])
    for rc in rig.cameras:
        virtual = rig.virtual(rc.eye)
        plane = virtual.backproject(pix, np.full(3, depth))
        seen, _ = rc.camera.project(plane)
        assert_allclose(seen, pix, atol=PIX_ATOL * (1 + setback / depth))
    assert rig.baselines["e"] == pytest.approx(baseline * (depth + setback) / depth, rel=1e-12)


def test_collinear_elements_share_cameras():
    # S0 Fig. 6 right: when the subject, the background and the virtual eye are aligned, c_s = c_b.
    cam = _virtual()
    left, _ = stereo_pair(cam, baseline=0.3, convergence=10.0)
    subject = np.array([0.0, 1.0, -30.0])
    background = left.center + 3.0 * (subject - left.center)
    rig = plan_quadri_rig(cam, baseline=0.3, convergence=10.0, setback=20.0,
                          elements={"subject": subject, "background": background})
    assert_allclose(rig.cameras[0].camera.center, rig.cameras[2].camera.center, atol=POS_ATOL)


def test_to_dict():
    rig = _plan()
    d = rig.to_dict()
    json.dumps(d, allow_nan=False)  # what `vergence rig plan --json` prints
    assert d["rig"] == "quadri" and d["setback"] == 20.0
    assert d["virtual"]["left"] == rig.left.to_dict()
    assert [c["name"] for c in d["cameras"]] == [c.name for c in rig.cameras]
    assert d["cameras"][0]["camera"] == rig.cameras[0].camera.to_dict()
    assert d["elements"][1] == {"name": "background", "point": [2.0, 3.0, -64.0], "baseline": rig.baselines["background"]}


@pytest.mark.parametrize(
    ("kw", "error", "message"),
    [
        ({"elements": []}, ValueError, "elements must hold at least one"),
        ({"elements": [("a", [0, 1, -30]), ("a", [0, 1, -40])]}, ValueError, "name 'a' is used twice"),
        ({"elements": [("a", [0, 1, np.nan])]}, ValueError, "element 'a' point must be finite"),
        ({"elements": [("a", [0, 1])]}, ValueError, r"element 'a' point must have shape \(3,\)"),
        ({"elements": [("my subject", [0, 1, -30])]}, ValueError, "elements\\[0\\] name must be letters"),
        ({"elements": [(3, [0, 1, -30])]}, TypeError, "elements\\[0\\] name must be a str"),
        ({"elements": [("a", [0, 1, -30], 2)]}, TypeError, "elements\\[0\\] must be a \\(name, point\\) pair"),
        ({"elements": "subject"}, TypeError, "elements must be a sequence"),
        # Virtual centre at z = -20 looking down -z; real plane 20 m behind it (z = 0).
        ({"elements": [("s", [0, 1, -30]), ("behind", [0.4, 1.6, -15])]}, ValueError,
         "element 'behind' .* is behind or on the virtual cameras"),
        ({"elements": [("on", [5.0, 1.6, -20.0])]}, ValueError, "element 'on' .* behind or on the virtual cameras"),
        ({"elements": [("past", [0, 1, 10])]}, ValueError, "element 'past' .* is behind the real camera plane"),
        ({"setback": 0.0}, ValueError, "setback must be > 0"),
        ({"setback": -5.0}, ValueError, "setback must be > 0"),
        ({"setback": float("inf")}, ValueError, "setback must be finite"),
        ({"baseline": 0.0}, ValueError, "baseline must be > 0"),
    ],
)
def test_bad_input(kw, error, message):
    with pytest.raises(error, match=message):
        _plan(**kw)


def test_bad_camera():
    with pytest.raises(TypeError, match="camera must be a vergence.camera.Camera"):
        plan_quadri_rig("cam", baseline=0.3, convergence=10.0, setback=20.0, elements=ELEMENTS)


def test_rig_camera_validates():
    cam = _virtual()
    with pytest.raises(ValueError, match="eye must be one of left, right"):
        RigCamera(name="a_left", element="a", eye="middle", camera=cam)
    with pytest.raises(TypeError, match="camera must be"):
        RigCamera(name="a_left", element="a", eye="left", camera=None)
    with pytest.raises(ValueError, match="name must be letters"):
        RigCamera(name="a/left", element="a", eye="left", camera=cam)
