"""Tests of vergence.viewing.geometry: S0 Eq. (1)-(6) against hand values and ray geometry, S1 Table I.

Ground truth for the equations is built independently of them: a point is projected through two
shifted-sensor cameras (``vergence.camera.Camera`` with off-axis principal points), and the perceived
point is the intersection of the two eye rays through the screen points.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.camera import Camera
from vergence.viewing.geometry import (
    CARDBOARD_ROUNDNESS,
    CONTROL_EFFECTS,
    DISPLAY_PRESETS,
    Display,
    Shooting,
    disparity,
    divergence_baseline,
    divergence_depth,
    focal_ratio,
    perceived_depth,
    perceived_depth_from_depth,
    roundness,
    roundness_baseline,
    scene_depth_from_disparity,
    shift_sensor_parallax,
    shift_sensor_positions,
)

# Closed forms vs closed forms: a handful of roundings of O(1) quantities.
RTOL = 1e-12
# Closed forms vs ray geometry (a 3x3 camera projection and a ray intersection): the eye-ray
# intersection divides by a small disparity difference, which costs a few digits.
RAY_RTOL = 1e-9
# Roundness by central finite differences with a step of 1e-4 of the distance to the nearest
# singularity (z = 0 or the divergence depth): truncation O(1e-8), rounding O(eps 1e4); 1e-6 leaves
# a wide margin.
FD_RTOL = 1e-6
FD_STEP = 1e-4
EPS = np.finfo(float).eps

TV = Display(eye_separation=0.065, distance=3.0, width=1.2)  # f' = 2.5, S0's living room
LONG_LENS = Shooting(baseline=0.26, convergence=30.0, window=3.0)  # f = 10, b > b_div = 0.1625


# ---------------------------------------------------------------------------------------------
# Independent ray geometry


def _shifted_sensor_pair(shooting: Shooting, n_px: int = 1000) -> tuple[Camera, Camera]:
    """Cameras at x = 0 and x = b looking down +z whose frusta cut the plane z = H in the same window.

    The window spans x in [b/2 - W/2, b/2 + W/2] at depth H and maps onto pixel columns
    [-0.5, n_px - 0.5] of both cameras (S0 Fig. 1): fx = n_px H / W, principal point shifted.
    """
    b, H, W = shooting.baseline, shooting.convergence, shooting.window
    fx = n_px * H / W
    cams = []
    for c in (0.0, b):
        cx = -0.5 - fx * (b / 2.0 - W / 2.0 - c) / H
        K = np.array([[fx, 0.0, cx], [0.0, fx, 50.0], [0.0, 0.0, 1.0]])
        cams.append(Camera(K=K, R=np.eye(3), t=np.array([-c, 0.0, 0.0]), width=n_px, height=100))
    return cams[0], cams[1]


def _image_fractions(shooting: Shooting, X: float, z: float, n_px: int = 1000) -> tuple[float, float]:
    """Abscissae of scene point (X, 0, z) in both images, as fractions of the window (0 = left edge)."""
    left, right = _shifted_sensor_pair(shooting, n_px)
    ul = (left.project([[X, 0.0, z]])[0][0, 0] + 0.5) / n_px
    ur = (right.project([[X, 0.0, z]])[0][0, 0] + 0.5) / n_px
    return float(ul), float(ur)


def _perceive(ul: float, ur: float, display: Display) -> tuple[float, float]:
    """Intersect the eye rays (eyes at -b'/2 and +b'/2) through the screen points of ul and ur."""
    bp, Hp, Wp = display.eye_separation, display.distance, display.width
    sl, sr = (ul - 0.5) * Wp, (ur - 0.5) * Wp
    el, er = -bp / 2.0, bp / 2.0
    t = (er - el) / ((sl - el) - (sr - er))  # x = e + (s - e) t, z = H' t on both rays
    return el + (sl - el) * t, Hp * t


def _perceived_point(shooting: Shooting, display: Display, X: float, z: float) -> tuple[float, float]:
    return _perceive(*_image_fractions(shooting, X, z), display)


def _numeric_roundness(shooting: Shooting, display: Display, X: float, z: float) -> float:
    """Depth magnification dz'/dz over width magnification dx'/dX, by central differences."""
    # z'(z) has poles at z = 0 and at the divergence depth: keep the step well inside both.
    hz, hx = FD_STEP * min(z, divergence_depth(shooting, display) - z), FD_STEP * max(abs(X), 1.0)
    zp_hi = _perceived_point(shooting, display, X, z + hz)[1]
    zp_lo = _perceived_point(shooting, display, X, z - hz)[1]
    xp_hi = _perceived_point(shooting, display, X + hx, z)[0]
    xp_lo = _perceived_point(shooting, display, X - hx, z)[0]
    return ((zp_hi - zp_lo) / (2 * hz)) / ((xp_hi - xp_lo) / (2 * hx))


positive = st.floats(min_value=0.01, max_value=100.0, allow_nan=False, allow_infinity=False)


def _rig(b: float, H: float, W: float) -> Shooting:
    """A rig from a computed baseline; examples whose baseline leaves LENGTH_RANGE are not rigs."""
    from vergence.viewing.geometry import LENGTH_RANGE

    assume(LENGTH_RANGE[0] <= b <= LENGTH_RANGE[1])
    return Shooting(b, H, W)


# ---------------------------------------------------------------------------------------------
# Hand-worked values


def test_disparity_hand_values():
    rig = Shooting(baseline=0.2, convergence=30.0, window=2.0)  # b/W = 0.1
    assert disparity(60.0, rig) == pytest.approx(0.05, rel=RTOL)  # 0.1 * 30/60
    assert disparity(30.0, rig) == 0.0  # on the convergence plane
    assert disparity(15.0, rig) == pytest.approx(-0.1, rel=RTOL)  # 0.1 * (-15)/15
    assert disparity(1e12, rig) == pytest.approx(0.1, rel=1e-10)  # b/W at infinity
    assert_allclose(disparity([15.0, 30.0, 60.0], rig), [-0.1, 0.0, 0.05], rtol=RTOL)


def test_scene_depth_from_disparity_hand_values_and_limits():
    rig = Shooting(baseline=0.2, convergence=30.0, window=2.0)
    assert scene_depth_from_disparity(0.05, rig) == pytest.approx(60.0, rel=RTOL)  # 0.2*30/(0.2-0.1)
    assert scene_depth_from_disparity(-0.1, rig) == pytest.approx(15.0, rel=RTOL)
    assert scene_depth_from_disparity(0.1, rig) == math.inf  # d = b/W: infinitely far
    assert math.isnan(scene_depth_from_disparity(0.2, rig))  # past b/W: no depth in front


def test_perceived_depth_hand_values():
    # b'/W' = 0.065/1.2; half of it doubles the screen distance, minus it halves it.
    half = 0.065 / 2.4
    assert perceived_depth(0.0, TV) == pytest.approx(3.0, rel=RTOL)
    assert perceived_depth(half, TV) == pytest.approx(6.0, rel=RTOL)
    assert perceived_depth(-2 * half, TV) == pytest.approx(1.5, rel=RTOL)
    assert perceived_depth(TV.divergence_disparity, TV) == math.inf  # parallel eyes
    assert math.isnan(perceived_depth(TV.divergence_disparity * 1.01, TV))  # eyes diverge


def test_perceived_depth_and_roundness_from_depth_hand_values():
    # b'W - bW' = 0.195 - 0.312 = -0.117, bHW' = 9.36, b'H'W = 0.585, bH'W = 2.34.
    assert perceived_depth_from_depth(60.0, LONG_LENS, TV) == pytest.approx(60 * 0.585 / 2.34, rel=RTOL)  # 15 m
    assert perceived_depth_from_depth(30.0, LONG_LENS, TV) == pytest.approx(3.0, rel=RTOL)  # on the screen
    assert roundness(60.0, LONG_LENS, TV) == pytest.approx(1.0, rel=RTOL)  # 2.34 / 2.34
    assert roundness(30.0, LONG_LENS, TV) == pytest.approx(0.4, rel=RTOL)  # 2.34 / 5.85
    # Past the divergence depth 9.36/0.117 = 80 m: no perceived depth, Eq. (4) negative as is.
    z_div = divergence_depth(LONG_LENS, TV)  # 80 m up to rounding
    assert perceived_depth_from_depth(z_div, LONG_LENS, TV) == math.inf  # parallel eyes exactly there
    assert math.isnan(perceived_depth_from_depth(90.0, LONG_LENS, TV))
    assert roundness(90.0, LONG_LENS, TV) == pytest.approx(-2.0, rel=RTOL)  # 2.34 / -1.17


def test_baselines_focal_ratio_and_divergence_depth_hand_values():
    assert divergence_baseline(3.0, TV) == pytest.approx(0.1625, rel=RTOL)  # 0.065 * 3 / 1.2
    assert roundness_baseline(30.0, TV) == pytest.approx(0.65, rel=RTOL)  # 0.065 * 30 / 3
    assert roundness_baseline(30.0, TV, roundness=0.3) == pytest.approx(0.195, rel=RTOL)
    assert focal_ratio(LONG_LENS, TV) == pytest.approx(4.0, rel=RTOL)  # f = 10, f' = 2.5
    assert divergence_depth(LONG_LENS, TV) == pytest.approx(80.0, rel=RTOL)
    assert divergence_depth(Shooting(0.1625, 30.0, 3.0), TV) == math.inf  # b = b_div
    assert divergence_depth(Shooting(0.1, 30.0, 3.0), TV) == math.inf


def test_shooting_from_focal_and_display_properties():
    rig = Shooting.from_focal(baseline=0.1, convergence=30.0, focal_mm=350.0, sensor_mm=35.0)
    assert rig.window == pytest.approx(3.0, rel=RTOL)
    assert rig.focal == pytest.approx(10.0, rel=RTOL)
    assert TV.focal == pytest.approx(2.5, rel=RTOL)
    assert TV.divergence_disparity == pytest.approx(0.065 / 1.2, rel=RTOL)
    assert Display(0.065, 0.6, 0.47376, resolution=1680).pixel_pitch == pytest.approx(0.282e-3, rel=RTOL)


def test_display_presets_published_and_hand_values():
    # S3's study display: Samsung 2233RZ, 1680 px at 0.282 mm pitch, viewed from 60 cm (S3 §4).
    samsung = Display.preset("samsung-2233rz")
    assert samsung.pixel_pitch == pytest.approx(0.282e-3, rel=1e-9)
    assert samsung.distance == 0.6 and samsung.resolution == 1680
    # 16:9 screens: width = diagonal * 16 / sqrt(16^2 + 9^2), to the 0.1 mm the presets store.
    width_16_9 = lambda inches: inches * 0.0254 * 16 / math.hypot(16, 9)  # noqa: E731
    assert Display.preset("tv-55").width == pytest.approx(width_16_9(55), abs=1e-4)
    assert Display.preset("desktop-24").width == pytest.approx(width_16_9(24), abs=1e-4)
    assert Display.preset("laptop-15").width == pytest.approx(width_16_9(15.6), abs=1e-4)  # 0.3454 m
    # The phone: 6.1" 20:9 in landscape, 2400 x 1080 px.
    assert Display.preset("phone").width == pytest.approx(6.1 * 0.0254 * 20 / math.hypot(20, 9), abs=1e-4)
    for name in ("desktop-24", "laptop-15", "tv-55"):
        assert Display.preset(name).resolution == 1920  # 1920 x 1080, 16:9
    assert Display.preset("phone").resolution == 2400
    # S0 §2: usual projection focal lengths f' lie in [1.4, 2.5].
    assert 1.4 <= Display.preset("tv-55").focal <= 2.5
    assert Display.preset("cinema").focal == 1.5
    for name, preset in DISPLAY_PRESETS.items():
        assert Display.preset(name) is preset
        assert preset.eye_separation == 0.065 and preset.resolution is not None



def test_display_presets_cannot_be_changed():
    tv = DISPLAY_PRESETS["tv-55"]
    with pytest.raises(TypeError):
        DISPLAY_PRESETS["tv-55"] = Display(eye_separation=0.065, distance=1.0, width=1.0)  # type: ignore[index]
    with pytest.raises(TypeError):
        del DISPLAY_PRESETS["tv-55"]  # type: ignore[attr-defined]
    with pytest.raises(dataclasses.FrozenInstanceError):
        tv.distance = 1.0  # type: ignore[misc]
    assert not hasattr(DISPLAY_PRESETS, "update") and Display.preset("tv-55").distance == 3.0

def test_scalar_in_float_out_and_array_shapes_kept():
    assert type(disparity(40.0, LONG_LENS)) is float
    assert type(roundness(np.float32(40.0), LONG_LENS, TV)) is float
    z = np.linspace(10.0, 70.0, 12).reshape(3, 4)
    for fn in (perceived_depth_from_depth, roundness):
        out = fn(z, LONG_LENS, TV)
        assert out.shape == (3, 4) and out.dtype == np.float64
    assert disparity(z, LONG_LENS).shape == (3, 4)
    z_copy = z.copy()
    perceived_depth_from_depth(z, LONG_LENS, TV)
    assert_allclose(z, z_copy, rtol=0)  # inputs are never modified


def test_dataclasses_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        LONG_LENS.baseline = 1.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        TV.width = 2.0  # type: ignore[misc]


# ---------------------------------------------------------------------------------------------
# Ray geometry: the closed forms against shifted-sensor cameras and eye-ray intersection


RIGS = [
    Shooting(0.065, 3.0, 1.2),
    Shooting(0.26, 30.0, 3.0),
    Shooting(0.02, 2.0, 5.0),
    Shooting(1.5, 80.0, 40.0),
]


@pytest.mark.parametrize("rig", RIGS)
@pytest.mark.parametrize("X, z_over_H", [(0.0, 1.0), (-0.7, 0.4), (0.3, 1.7), (2.0, 6.0)])
def test_eq1a_disparity_matches_shifted_sensor_projection(rig, X, z_over_H):
    z = z_over_H * rig.convergence
    ul, ur = _image_fractions(rig, X, z)
    assert (ur - ul) == pytest.approx(disparity(z, rig), rel=RAY_RTOL, abs=RAY_RTOL)


def test_shifted_sensor_pair_sees_the_same_window():
    # Sanity of the ground truth itself: both window edges at z = H land on the image edges.
    rig = RIGS[1]
    left_edge = rig.baseline / 2 - rig.window / 2
    for X, frac in ((left_edge, 0.0), (left_edge + rig.window, 1.0)):
        ul, ur = _image_fractions(rig, X, rig.convergence)
        assert ul == pytest.approx(frac, abs=1e-12) and ur == pytest.approx(frac, abs=1e-12)


@pytest.mark.parametrize("d", np.linspace(-0.08, 0.9 * 0.065 / 1.2, 7).tolist())
def test_eq1b_perceived_depth_matches_eye_ray_intersection(d):
    _, zp = _perceive(0.4, 0.4 + d, TV)
    assert perceived_depth(d, TV) == pytest.approx(zp, rel=RAY_RTOL)


@settings(max_examples=40, deadline=None)
@given(b=positive, H=positive, W=positive, z_over_H=st.floats(0.2, 20.0), X=st.floats(-5.0, 5.0))
def test_eq2_and_eq4_match_ray_geometry(b, H, W, z_over_H, X):
    rig = Shooting(b, H, W)
    z = z_over_H * H
    zp = perceived_depth_from_depth(z, rig, TV)
    # Diverging or near-parallel eyes: the eye rays are not a stable reference there.
    assume(np.isfinite(zp) and disparity(z, rig) < 0.95 * TV.divergence_disparity)
    _, zp_ray = _perceived_point(rig, TV, X, z)
    assert zp == pytest.approx(zp_ray, rel=RAY_RTOL)
    # The finite-difference step is 1e-4 of the distance to the divergence depth: when that distance
    # is a tiny share of z (b/W in the thousands), the ray geometry's rounding (RAY_RTOL) swamps the
    # difference quotient, so Eq. (4) is compared only where the step stays >= 1e-6 z.
    assume(divergence_depth(rig, TV) - z >= 0.01 * z)
    assert roundness(z, rig, TV) == pytest.approx(_numeric_roundness(rig, TV, X, z), rel=FD_RTOL)


@pytest.mark.parametrize("rig", RIGS)
def test_eq4_roundness_matches_finite_differences_of_ray_geometry(rig):
    z = 1.3 * rig.convergence  # no rig of RIGS diverges there on TV
    assert np.isfinite(perceived_depth_from_depth(z, rig, TV))
    assert roundness(z, rig, TV) == pytest.approx(_numeric_roundness(rig, TV, 0.25, z), rel=FD_RTOL)


def test_perceived_depth_from_depth_is_eq1b_of_eq1a():
    z = np.linspace(5.0, 79.0, 50)  # in front of the divergence depth of LONG_LENS on TV
    via_disparity = perceived_depth(disparity(z, LONG_LENS), TV)
    assert_allclose(perceived_depth_from_depth(z, LONG_LENS, TV), via_disparity, rtol=1e-11)
    # S0 Eq. (2) and (4) identity: rho(z) / z'(z) = b / (z b').
    ratio = roundness(z, LONG_LENS, TV) / perceived_depth_from_depth(z, LONG_LENS, TV)
    assert_allclose(ratio, LONG_LENS.baseline / (z * TV.eye_separation), rtol=1e-12)


# ---------------------------------------------------------------------------------------------
# Properties


@settings(max_examples=60, deadline=None)
@given(b=positive, H=positive, W=positive, z=st.floats(0.01, 1e4))
def test_orthostereoscopic_setup_has_roundness_one_and_true_depth(b, H, W, z):
    # b = b', H = H', W = W': the viewer sees the scene as it is (S0 §2, Eq. (4)).
    rig, display = Shooting(b, H, W), Display(eye_separation=b, distance=H, width=W)
    assert roundness(z, rig, display) == pytest.approx(1.0, rel=8 * np.finfo(float).eps)
    assert perceived_depth_from_depth(z, rig, display) == pytest.approx(z, rel=8 * np.finfo(float).eps)
    assert focal_ratio(rig, display) == pytest.approx(1.0, rel=4 * np.finfo(float).eps)
    assert divergence_baseline(W, display) == pytest.approx(b, rel=4 * np.finfo(float).eps)
    assert roundness_baseline(H, display) == pytest.approx(b, rel=4 * np.finfo(float).eps)


@settings(max_examples=30, deadline=None)
@given(b=positive, H=positive, W=positive, z_over_H=st.floats(0.2, 20.0), X=st.floats(-3.0, 3.0))
def test_orthostereoscopic_ray_geometry_reproduces_the_point(b, H, W, z_over_H, X):
    # Eyes sit where the cameras were (shifted by -b/2): the perceived point is the scene point.
    rig, display = Shooting(b, H, W), Display(eye_separation=b, distance=H, width=W)
    xp, zp = _perceived_point(rig, display, X, z_over_H * H)
    assert zp == pytest.approx(z_over_H * H, rel=RAY_RTOL)
    assert xp == pytest.approx(X - b / 2, rel=RAY_RTOL, abs=RAY_RTOL * max(1.0, W))


@settings(max_examples=60, deadline=None)
@given(b=positive, H=positive, W=positive, bp=positive, Hp=positive, Wp=positive, rho=st.floats(0.05, 5.0))
def test_eq6_focal_ratio_is_roundness_over_divergence_baseline(b, H, W, bp, Hp, Wp, rho):
    rig, display = Shooting(b, H, W), Display(bp, Hp, Wp)
    b_div = divergence_baseline(W, display)
    assert focal_ratio(rig, display) == pytest.approx(roundness_baseline(H, display) / b_div, rel=RTOL)  # Eq. (6)
    # Eq. (5)-(6) for any target roundness: b_rho / b_div = rho f / f', and b_rho gives rho at H.
    b_rho = roundness_baseline(H, display, roundness=rho)
    assert b_rho / b_div == pytest.approx(rho * rig.focal / display.focal, rel=RTOL)
    # At z = H the Eq. (4) denominator H(b'W - b_rho W') + b_rho H W' cancels down to H b'W: the
    # rounding grows with b_rho W' / (b'W) = rho f/f', so the tolerance is counted in those ulps.
    cancellation = max(1.0, b_rho * Wp / (bp * W))
    assert roundness(H, _rig(b_rho, H, W), display) == pytest.approx(rho, rel=16 * EPS * cancellation)


@settings(max_examples=60, deadline=None)
@given(H=positive, W=positive, bp=positive, Hp=positive, Wp=positive, excess=st.floats(1.01, 50.0))
def test_divergence_depth_is_where_disparity_reaches_the_eye_limit(H, W, bp, Hp, Wp, excess):
    display = Display(bp, Hp, Wp)
    rig = _rig(excess * divergence_baseline(W, display), H, W)  # b > b_div
    z_div = divergence_depth(rig, display)
    assert math.isfinite(z_div) and z_div > H
    assert disparity(z_div, rig) == pytest.approx(display.divergence_disparity, rel=1e-10)  # Eq. (8) limit
    assert np.isfinite(perceived_depth_from_depth(z_div * (1 - 1e-6), rig, display))
    assert math.isnan(perceived_depth_from_depth(z_div * (1 + 1e-6), rig, display))
    assert roundness(z_div * (1 + 1e-6), rig, display) < 0


@settings(max_examples=60, deadline=None)
@given(b=positive, H=positive, W=positive, bp=positive, Hp=positive, Wp=positive)
def test_limits_are_exact_in_floating_point(b, H, W, bp, Hp, Wp):
    # b' - W'(b'/W') and b'W - (b'W/W')W' need not round to 0: the limits must still be exact.
    rig, display = Shooting(b, H, W), Display(bp, Hp, Wp)
    assert perceived_depth(display.divergence_disparity, display) == math.inf  # parallel eyes, Eq. (1b)
    assert math.isnan(perceived_depth(math.nextafter(display.divergence_disparity, math.inf), display))
    assert scene_depth_from_disparity(b / W, rig) == math.inf  # d(inf) = b/W, Eq. (1c)
    b_div = divergence_baseline(W, display)
    assert divergence_depth(_rig(b_div, H, W), display) == math.inf  # b = b_div never diverges (Eq. 3)
    assert np.all(np.isfinite(perceived_depth_from_depth(np.array([H, 1e6 * H]), _rig(b_div, H, W), display)))
    z_div = divergence_depth(rig, display)
    if math.isfinite(z_div):  # parallel exactly at z_div, finite before, diverging after (consistently)
        assert perceived_depth_from_depth(z_div, rig, display) == math.inf
        assert math.isfinite(perceived_depth_from_depth(math.nextafter(z_div, 0.0), rig, display))
        assert math.isnan(perceived_depth_from_depth(math.nextafter(z_div, math.inf), rig, display))
        assert roundness(math.nextafter(z_div, math.inf), rig, display) < 0


@settings(max_examples=60, deadline=None)
@given(H=positive, W=positive, bp=positive, Hp=positive, Wp=positive, share=st.floats(0.01, 0.999))
def test_no_divergence_under_the_divergence_baseline(H, W, bp, Hp, Wp, share):
    # (b = b_div exactly is a hand-worked case above: in floating point b'W/W' * W' may round past b'W.)
    display = Display(bp, Hp, Wp)
    b = share * divergence_baseline(W, display)
    rig = _rig(b, H, W)
    assert divergence_depth(rig, display) == math.inf
    z = np.geomspace(0.01 * H, 1e6 * H, 40)
    zp = perceived_depth_from_depth(z, rig, display)
    assert np.all(np.isfinite(zp) & (zp > 0))
    if share < 0.99:  # z' tends to b'H'W / (b'W - bW') (S0 Eq. (2) as z -> inf; Eq. (3))
        far = bp * Hp * W / (bp * W - b * Wp)
        assert perceived_depth_from_depth(1e12 * H, rig, display) == pytest.approx(far, rel=1e-9)


@settings(max_examples=60, deadline=None)
@given(b=positive, H=positive, W=positive, z_over_H=st.floats(0.05, 1e3))
def test_scene_depth_from_disparity_inverts_eq1a(b, H, W, z_over_H):
    rig = Shooting(b, H, W)
    z = z_over_H * H
    assert scene_depth_from_disparity(disparity(z, rig), rig) == pytest.approx(z, rel=1e-9)


# ---------------------------------------------------------------------------------------------
# Shift-sensor parallax (S1 §IV.C) and the directions of S1 Table I


def test_shift_sensor_parallax_hand_values():
    kw = dict(focal_px=1000.0, interaxial=0.06, convergence=2.0)
    assert shift_sensor_parallax(4.0, **kw) == pytest.approx(15.0, rel=RTOL)  # 60 (1/2 - 1/4)
    assert shift_sensor_parallax(2.0, **kw) == 0.0  # zero parallax at Z_c
    assert shift_sensor_parallax(1.0, **kw) == pytest.approx(-30.0, rel=RTOL)  # 60 (1/2 - 1)
    xl, xr = shift_sensor_positions([100.0, 200.0], [4.0, 1.0], **kw)
    assert_allclose(xl, [92.5, 215.0], rtol=RTOL)  # x_c + 30 (1/Z - 1/2)
    assert_allclose(xr, [107.5, 185.0], rtol=RTOL)
    assert_allclose(xr - xl, shift_sensor_parallax(np.array([4.0, 1.0]), **kw), rtol=RTOL)


def test_s1_table_i_published_values():
    # S1 Table I, "control parameters for depth perception", the '+' rows.
    assert CONTROL_EFFECTS == {
        "interaxial": {"parallax": "increase", "perceived_depth": "increase", "object_size": "constant"},
        "focal_length": {"parallax": "increase", "perceived_depth": "increase", "object_size": "increase"},
        "convergence": {"parallax": "decrease", "perceived_depth": "shift toward viewer", "object_size": "constant"},
    }


def _viewing(focal_px: float, interaxial: float, convergence: float, depths: np.ndarray) -> dict[str, np.ndarray]:
    """Parallax, perceived depth (S0 Eq. 1b on a 1920-px TV) and the left-view width of a 0.5 m object."""
    n_px, obj = 1920, 0.5
    p = shift_sensor_parallax(depths, focal_px=focal_px, interaxial=interaxial, convergence=convergence)
    zp = perceived_depth(p / n_px, TV)
    # Centre-view columns of the object's two edges (pinhole: alpha_u X / Z from the image centre).
    x_c = np.stack([np.full_like(depths, n_px / 2), n_px / 2 + focal_px * obj / depths])
    xl, _ = shift_sensor_positions(x_c, np.stack([depths, depths]), focal_px=focal_px, interaxial=interaxial,
                                   convergence=convergence)
    return {"parallax": p, "perceived_depth": zp, "object_size": xl[1] - xl[0]}


@pytest.mark.parametrize("control", ["interaxial", "focal_length", "convergence"])
def test_s1_table_i_directions_numerically(control):
    depths = np.array([1.5, 2.5, 4.0, 8.0])  # in front of and behind Z_c = 3 m
    base = dict(focal_px=1000.0, interaxial=0.05, convergence=3.0)
    more = dict(base)
    key = {"interaxial": "interaxial", "focal_length": "focal_px", "convergence": "convergence"}[control]
    more[key] = base[key] * 1.2
    v0, v1 = _viewing(depths=depths, **base), _viewing(depths=depths, **more)
    assert np.all(np.isfinite(v0["perceived_depth"])) and np.all(np.isfinite(v1["perceived_depth"]))
    expected = CONTROL_EFFECTS[control]

    # Parallax: t_c and f scale its magnitude; Z_c lowers its signed value at every depth.
    if expected["parallax"] == "increase":
        assert np.all(np.abs(v1["parallax"]) > np.abs(v0["parallax"]))
    else:
        assert np.all(v1["parallax"] < v0["parallax"])
    # Perceived depth: "increase" = farther from the screen plane; "shift toward viewer" = nearer.
    if expected["perceived_depth"] == "increase":
        assert np.all(np.abs(v1["perceived_depth"] - TV.distance) > np.abs(v0["perceived_depth"] - TV.distance))
    else:
        assert np.all(v1["perceived_depth"] < v0["perceived_depth"])
    # Object size (image width of the object): constant, or growing with the focal length.
    if expected["object_size"] == "constant":
        assert_allclose(v1["object_size"], v0["object_size"], rtol=RTOL)
    else:
        assert np.all(v1["object_size"] > v0["object_size"])


# ---------------------------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize("name", ["baseline", "convergence", "window"])
@pytest.mark.parametrize("value, match", [(0.0, "must be > 0; got 0"), (-1.0, "must be > 0; got -1"),
                                          (math.nan, "must be finite; got nan"), (math.inf, "must be finite")])
def test_shooting_rejects_bad_lengths(name, value, match):
    kw = dict(baseline=0.1, convergence=30.0, window=3.0)
    kw[name] = value
    with pytest.raises(ValueError, match=f"^{name} {match}"):
        Shooting(**kw)


@pytest.mark.parametrize("name", ["eye_separation", "distance", "width"])
@pytest.mark.parametrize("value, match", [(0.0, "must be > 0; got 0"), (-0.5, "must be > 0; got -0.5"),
                                          (math.nan, "must be finite; got nan")])
def test_display_rejects_bad_lengths(name, value, match):
    kw = dict(eye_separation=0.065, distance=3.0, width=1.2)
    kw[name] = value
    with pytest.raises(ValueError, match=f"^{name} {match}"):
        Display(**kw)


def test_bad_types_and_resolution():
    with pytest.raises(TypeError, match="^baseline must be a real number; got str"):
        Shooting("0.1", 30.0, 3.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^resolution must be >= 1; got 0"):
        Display(0.065, 3.0, 1.2, resolution=0)
    with pytest.raises(TypeError, match="^resolution must be an integer; got float"):
        Display(0.065, 3.0, 1.2, resolution=1920.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="display resolution is unknown"):
        _ = TV.pixel_pitch


@pytest.mark.parametrize("name, value", [("focal_mm", 0.0), ("sensor_mm", -35.0), ("focal_mm", math.nan)])
def test_from_focal_rejects_bad_lengths(name, value):
    kw = dict(baseline=0.1, convergence=30.0, focal_mm=350.0, sensor_mm=35.0)
    kw[name] = value
    with pytest.raises(ValueError, match=f"^{name} must be"):
        Shooting.from_focal(**kw)


@pytest.mark.parametrize("z, match", [(-1.0, r"z must be > 0 \(in front of the cameras\); got min -1"),
                                      (0.0, r"z must be > 0 \(in front of the cameras\); got min 0"),
                                      ([10.0, -5.0], "got min -5"),
                                      (math.nan, r"z must be finite \(no NaN or inf\)")])
def test_depths_behind_the_camera_or_nan_are_refused(z, match):
    for fn in (lambda v: disparity(v, LONG_LENS), lambda v: perceived_depth_from_depth(v, LONG_LENS, TV),
               lambda v: roundness(v, LONG_LENS, TV)):
        with pytest.raises(ValueError, match=match):
            fn(z)


def test_nan_disparity_and_bad_baseline_arguments_are_refused():
    with pytest.raises(ValueError, match=r"^d must be finite"):
        perceived_depth(math.nan, TV)
    with pytest.raises(ValueError, match=r"^d must be finite"):
        scene_depth_from_disparity([0.0, math.inf], LONG_LENS)
    with pytest.raises(ValueError, match="^window must be > 0; got -3"):
        divergence_baseline(-3.0, TV)
    with pytest.raises(ValueError, match="^convergence must be > 0; got 0"):
        roundness_baseline(0.0, TV)
    with pytest.raises(ValueError, match="^roundness must be > 0; got -1"):
        roundness_baseline(30.0, TV, roundness=-1.0)


@pytest.mark.parametrize("name", ["imax", "", "TV-55", 3])
def test_unknown_display_preset_lists_the_valid_ones(name):
    valid = ", ".join(sorted(DISPLAY_PRESETS))
    with pytest.raises(ValueError, match=f"^unknown display preset {name!r}; valid presets: {valid}$"):
        Display.preset(name)  # type: ignore[arg-type]


@pytest.mark.parametrize("kw, match", [
    (dict(interaxial=0.0), "^interaxial must be > 0; got 0"),
    (dict(interaxial=-0.06), "^interaxial must be > 0; got -0.06"),
    (dict(focal_px=0.0), "^focal_px must be > 0; got 0"),
    (dict(convergence=math.nan), "^convergence must be finite; got nan"),
])
def test_shift_sensor_parallax_rejects_bad_parameters(kw, match):
    args = dict(focal_px=1000.0, interaxial=0.06, convergence=2.0)
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        shift_sensor_parallax(4.0, **args)


def test_shift_sensor_rejects_depth_behind_camera_and_mismatched_shapes():
    kw = dict(focal_px=1000.0, interaxial=0.06, convergence=2.0)
    with pytest.raises(ValueError, match=r"^depth must be > 0 \(in front of the cameras\); got min -4"):
        shift_sensor_parallax(-4.0, **kw)
    with pytest.raises(ValueError, match=r"^depth must have shape \(3,\) matching x_center; got \(2,\)"):
        shift_sensor_positions([1.0, 2.0, 3.0], [4.0, 5.0], **kw)


def test_cardboard_threshold_is_the_papers():
    assert CARDBOARD_ROUNDNESS == 0.3  # S0 §2: roundness below 0.3 looks like a cardboard cut-out


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: Shooting(1e308, 2.0, 1.0), r"baseline must lie in \[1e-06, 1e\+06\] m; got 1e\+308"),
        (lambda: Shooting(0.1, 2.0, 5e-324), r"window must lie in \[1e-06, 1e\+06\] m; got 4.94066e-324"),
        (lambda: Shooting.from_focal(baseline=0.1, convergence=2.0, focal_mm=5e-324, sensor_mm=36.0),
         r"focal_mm must lie in \[0.001, 1e\+09\] mm; got 4.94066e-324"),
        (lambda: Display(0.065, 1e9, 1.0), r"distance must lie in \[1e-06, 1e\+06\] m; got 1e\+09"),
    ],
)
def test_lengths_outside_the_representable_range_are_refused(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def test_depths_outside_the_range_are_refused_and_extremes_stay_consistent():
    import warnings

    from vergence.viewing.geometry import LENGTH_RANGE, MAX_SCENE_DEPTH

    with pytest.raises(ValueError, match=r"z must lie in \[1e-06, 1e\+20\] m"):
        disparity(1e-300, Shooting(0.1, 2.0, 1.0))
    # the extreme rig and display the limits allow: every figure finite, no numpy warning
    lo, hi = LENGTH_RANGE
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for b, H, W in ((hi, lo, lo), (lo, hi, hi), (hi, hi, lo), (lo, lo, hi)):
            shooting, display = Shooting(b, H, W), Display(lo, hi, lo, resolution=10**6)
            for z in (lo, H, MAX_SCENE_DEPTH):
                d = disparity(z, shooting)
                zp = perceived_depth_from_depth(z, shooting, display)
                assert math.isfinite(d) and math.isfinite(d * display.resolution)
                assert math.isnan(zp) or zp > 0
