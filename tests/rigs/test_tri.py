"""The Tri-Rig planner of S0 §6: subject and background cameras, the reference rig, psi and phi."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.camera import look_at
from vergence.rigs import TriRig, plan_tri_rig
from vergence.rigs import tri as tri_module
from vergence.viewing import (
    DISPLAY_PRESETS,
    DirectorConstraint,
    Shooting,
    divergence_baseline,
    perceived_depth,
    perceived_depth_from_depth,
    roundness,
)

# Closed forms (S0 Eq. (2), (4), the single-rig solution) through a dozen roundings: ~1e-14 relative.
EXACT = 1e-12
PIX_ATOL = 1e-8
TV = DISPLAY_PRESETS["tv-55"]
SUBJECT = "z=30,perceived=3,roundness=1"


def _director(width: int = 480, height: int = 270):
    return look_at([0.0, 2.2, 0.0], [0.0, 1.1, -30.0], [0.0, 1.0, 0.0], fov_deg=8.0, width=width, height=height)


def _plan(constraints=(SUBJECT, "z=65,perceived=6"), **kw) -> TriRig:
    return plan_tri_rig(_director(), TV, list(constraints), **kw)


def _rig_of(rig: TriRig, name: str) -> Shooting:
    return Shooting(rig.baselines[name], rig.reference.convergence, rig.reference.window)


def test_round_subject_on_the_screen_gives_b_round():
    # z_e = H, z'_e = H', rho = 1: b = b' H / H' (S0 Eq. (5)) = 0.065 * 30 / 3 = 0.65 m, H = 30 m.
    rig = _plan()
    cam = rig.director
    assert rig.baselines["subject"] == pytest.approx(0.65, rel=EXACT)
    assert rig.reference.convergence == pytest.approx(30.0, rel=EXACT)
    assert rig.reference.window == pytest.approx(30.0 * cam.width / cam.focal_px, rel=EXACT)
    assert rig.reference.baseline == rig.baselines["subject"]  # reference "round" = the subject rig


@pytest.mark.parametrize("subject", ["z=25,perceived=14,roundness=0.7", "z=40,perceived=2.5,roundness=1.5",
                                     "z=30,perceived=3,roundness=1"])
def test_subject_rig_meets_depth_and_roundness(subject):
    rig = _plan((subject, "z=90,perceived=30"))
    c = DirectorConstraint.from_string(subject)
    s = _rig_of(rig, "subject")
    assert perceived_depth_from_depth(c.depth, s, TV) == pytest.approx(c.perceived_depth, rel=EXACT)  # S0 Eq. (2)
    assert roundness(c.depth, s, TV) == pytest.approx(c.roundness, rel=EXACT)  # S0 Eq. (4)
    # W = H / f with f = fx / width, the director's normalised focal length.
    assert s.window == pytest.approx(s.convergence * rig.director.width / rig.director.focal_px, rel=EXACT)


@pytest.mark.parametrize("background", ["z=65,perceived=6", "z=65,perceived=4", "z=200,perceived=40", "z=inf,perceived=9"])
def test_background_camera_meets_its_depth(background):
    rig = _plan((SUBJECT, background))
    c = DirectorConstraint.from_string(background)
    b = _rig_of(rig, "background")
    if math.isinf(c.depth):  # S0 Eq. (2) at z -> inf: z' = b'H'W / (b'W - bW')
        got = TV.eye_separation * TV.distance * b.window / (TV.eye_separation * b.window - b.baseline * TV.width)
    else:
        got = perceived_depth_from_depth(c.depth, b, TV)  # S0 Eq. (2), (H, W) kept
    assert got == pytest.approx(c.perceived_depth, rel=EXACT)


def test_background_at_infinity_perceived_at_infinity_is_b_div():
    rig = _plan((SUBJECT, "z=inf,perceived=inf"))
    assert rig.baselines["background"] == pytest.approx(divergence_baseline(rig.reference.window, TV), rel=EXACT)


def test_div_reference():
    rig = _plan(reference="div")
    W = rig.reference.window
    assert rig.reference.baseline == pytest.approx(TV.eye_separation * W / TV.width, rel=EXACT)  # S0 Eq. (3)
    assert rig.reference.convergence == pytest.approx(30.0, rel=EXACT)
    # psi'(d_subject) = rho z b' / (b_div z') = b_round / b_div = f / f' (S0 Eq. (6)).
    f = rig.director.focal_px / rig.director.width
    assert rig.mapping.control_points[0].slope == pytest.approx(f / TV.focal, rel=EXACT)


def test_right_cameras_are_shifted_sensor_partners_of_the_director():
    rig = _plan()
    cam, H = rig.director, rig.reference.convergence
    for name in ("subject", "background"):
        right = getattr(rig, name)
        b = rig.baselines[name]
        assert_allclose(right.center - cam.center, b * cam.R[0], atol=1e-14)
        assert_allclose(right.R, cam.R)
        assert right.principal_point[0] == pytest.approx(cam.principal_point[0] + cam.focal_px * b / H, rel=EXACT)
        # Zero parallax on the convergence plane, fx b (1/z - 1/H) elsewhere (S0 Eq. (1a)).
        pix = np.array([[10.0, 20.0], [240.0, 135.0]])
        for z in (H, 65.0):
            p = cam.backproject(pix, np.full(2, z))
            x_r, _ = right.project(p)
            assert_allclose(pix[:, 0] - x_r[:, 0], cam.focal_px * b * (1 / z - 1 / H), atol=PIX_ATOL)
    assert rig.reference_right == rig.distortion.reference_right


def test_cameras_names_and_eyes():
    rig = _plan()
    assert [(c.name, c.element, c.eye) for c in rig.cameras] == [
        ("director", "director", "left"), ("subject", "subject", "right"), ("background", "background", "right")]
    assert rig.cameras[0].camera is rig.director
    assert rig.cameras[1].camera == rig.subject and rig.cameras[2].camera == rig.background


def test_constraints_are_sorted_and_psi_honours_them():
    rig = _plan(("z=65,perceived=6", DirectorConstraint(30.0, 3.0, 1.0)))  # any order, strings or objects
    assert rig.baselines["subject"] == pytest.approx(0.65, rel=EXACT)
    m = rig.mapping
    assert m.perceived_depth(30.0) == pytest.approx(3.0, rel=1e-9)
    assert m.roundness(30.0) == pytest.approx(1.0, rel=1e-9)
    assert m.perceived_depth(65.0) == pytest.approx(6.0, rel=1e-9)
    assert m.near == 15.0 and math.isinf(m.far)  # default near: half the nearest constraint's depth
    assert m.monotone and not m.diverges


def test_the_right_image_shows_the_wanted_depths():
    # End to end: a point at scene depth z, distorted by phi and seen by the reference right camera, has
    # the disparity whose perceived depth on the display (S0 Eq. (1b)) is the constrained one.
    rig = _plan()
    cam = rig.director
    for z, wanted in ((30.0, 3.0), (65.0, 6.0)):
        p = cam.backproject(np.array([[200.0, 100.0]]), np.array([z]))
        q = rig.distortion.forward(p)
        x_l, _ = cam.project(q)
        x_r, _ = rig.reference_right.project(q)
        d = (x_r[0, 0] - x_l[0, 0]) / cam.width  # S0's d = x_r - x_l, fraction of the width
        assert perceived_depth(d, TV) == pytest.approx(wanted, rel=1e-9)


def test_three_constraints_background_from_the_farthest():
    rig = _plan((SUBJECT, "z=200,perceived=20", "z=65,perceived=6"))
    assert len(rig.cameras) == 3 and len(rig.mapping.control_points) == 3
    assert perceived_depth_from_depth(200.0, _rig_of(rig, "background"), TV) == pytest.approx(20.0, rel=EXACT)
    assert rig.mapping.perceived_depth(65.0) == pytest.approx(6.0, rel=1e-9)  # the middle one shapes psi


def test_explicit_near_and_far():
    rig = _plan(near=20.0, far=500.0)
    assert (rig.mapping.near, rig.mapping.far) == (20.0, 500.0)
    with pytest.raises(ValueError, match="lies outside the scene"):
        _plan(near=40.0)


def test_to_dict():
    rig = _plan()
    d = rig.to_dict()
    json.dumps(d, allow_nan=False)  # what `vergence rig plan --json` prints
    assert d["rig"] == "tri" and d["far"] is None and d["near"] == 15.0
    assert d["reference"] == {"baseline": rig.reference.baseline, "convergence": rig.reference.convergence,
                              "window": rig.reference.window}
    assert [c["name"] for c in d["cameras"]] == ["director", "subject", "background"]
    assert d["control_points"][1]["value"] == rig.mapping.control_points[1].value
    assert d["reference_right"] == rig.reference_right.to_dict()


@pytest.mark.parametrize(
    ("constraints", "kw", "error", "message"),
    [
        ([SUBJECT], {}, ValueError, "constraints must hold at least 2"),
        ("z=30,perceived=3", {}, TypeError, "constraints must be a sequence"),
        ([SUBJECT, 65.0], {}, TypeError, r"constraints\[1\] must be a string"),
        ([SUBJECT, "z=65,seen=6"], {}, ValueError, "constraint 'z=65,seen=6' is malformed"),
        (["z=30,perceived=3", "z=65,perceived=6"], {}, ValueError,
         "constraint z=30,perceived=3: the nearest constraint .* needs a roundness"),
        # Nearer than the screen with little roundness: z' + rho W' f < H' leaves no convergence H > 0.
        (["z=30,perceived=1,roundness=0.1", "z=65,perceived=6"], {}, ValueError,
         "constraint z=30,perceived=1,roundness=0.1: no subject rig satisfies it"),
        # Behind the subject's convergence plane yet in front of the screen: b_3 < 0.
        ([SUBJECT, "z=65,perceived=2.5"], {}, ValueError,
         "constraint z=65,perceived=2.5: no background camera .* satisfies it"),
        ([SUBJECT, "z=65,perceived=6"], {"reference": "flat"}, ValueError, "reference must be one of round, div"),
        ([SUBJECT, "z=30,perceived=6"], {}, ValueError,
         "constraints z=30,perceived=3,roundness=1 and z=30,perceived=6 are at the same depth"),
    ],
)
def test_bad_input(constraints, kw, error, message):
    with pytest.raises(error, match=message):
        plan_tri_rig(_director(), TV, constraints, **kw)


def test_bad_types():
    with pytest.raises(TypeError, match="director must be"):
        plan_tri_rig("cam", TV, [SUBJECT, "z=65,perceived=6"])
    with pytest.raises(TypeError, match="display must be"):
        plan_tri_rig(_director(), "tv-55", [SUBJECT, "z=65,perceived=6"])


@pytest.mark.parametrize(("flag", "value", "message"), [("monotone", False, "psi is not monotone"),
                                                        ("diverges", True, "psi passes the divergence limit")])
def test_mapping_report_is_enforced(monkeypatch, flag, value, message):
    # psi_from_constraints's Gregory–Delbourgo psi is monotone and bounded by construction; a mapping
    # reporting otherwise must still be refused, naming the constraints.
    real = tri_module.psi_from_constraints

    def reporting(*args, **kw):
        m = real(*args, **kw)
        object.__setattr__(m, flag, value)
        return m

    monkeypatch.setattr(tri_module, "psi_from_constraints", reporting)
    with pytest.raises(ValueError, match=f"constraints 'z=30,perceived=3,roundness=1', 'z=65,perceived=6': {message}"):
        _plan()
