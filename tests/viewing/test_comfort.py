"""Tests of vergence.viewing.comfort: pixel <-> arcmin (S3 §3–4), the comfort zone, range checks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.viewing.comfort import (
    ARCMIN_PER_RADIAN,
    ComfortReport,
    ComfortZone,
    arcmin_from_pixels,
    check_disparity_range,
    pixels_from_arcmin,
)
from vergence.viewing.geometry import Display, perceived_depth

# Closed form against the same closed form written out by hand: a few roundings.
RTOL = 1e-12
# Round trips go through atan/tan: a few ulps of the angle, amplified by at most ~1/cos^2.
ROUND_TRIP_RTOL = 1e-9

SAMSUNG = Display.preset("samsung-2233rz")  # 0.47376 m, 1680 px, 60 cm (S3's study display)
TV = Display(eye_separation=0.065, distance=3.0, width=1.2, resolution=1920)
CINEMA = Display.preset("cinema")  # 15 m from a 10 m screen: the screen vergence is only 14.9 arcmin


def _exact_arcmin(px: float, display: Display) -> float:
    """The vergence geometry written out: 2 atan(e/2D) - 2 atan((e - s)/2D), s = px * W'/N."""
    e, D = display.eye_separation, display.distance
    s = px * display.width / display.resolution
    return (2 * math.atan(e / (2 * D)) - 2 * math.atan((e - s) / (2 * D))) * 180 * 60 / math.pi


# ---------------------------------------------------------------------------------------------
# Published and hand-worked values


def test_samsung_2233rz_one_pixel_is_about_1_62_arcmin():
    # S3 §4's display: pitch 0.282 mm at 60 cm, 1 px ≈ 1.62′ (small angle: 0.282/600 rad = 1.6157′).
    small = arcmin_from_pixels(1.0, SAMSUNG, exact=False)
    assert round(small, 2) == 1.62
    assert small == pytest.approx(0.282e-3 / 0.6 * 180 * 60 / math.pi, rel=1e-9)
    exact = arcmin_from_pixels(1.0, SAMSUNG)
    assert exact == pytest.approx(_exact_arcmin(1.0, SAMSUNG), rel=RTOL)
    assert abs(exact - small) / small < 0.003  # the two forms agree within 0.3 % at 60 cm


@pytest.mark.parametrize("px, arcmin", [(9.0, 14.5), (81.0, 131.0)])
def test_samsung_2233rz_published_pixel_figures(px, arcmin):
    # S3 §3's 81 x 9 px search: 9 px ≈ 14.5′ (its 15′ vertical range) and 81 px ≈ 131′ (S3 prints 24′,
    # inconsistent with its own display), to the figures' precision.
    assert arcmin_from_pixels(px, SAMSUNG, exact=False) == pytest.approx(arcmin, abs=0.5)


def test_samsung_2233rz_three_degrees_is_about_111_pixels():
    assert pixels_from_arcmin(180.0, SAMSUNG, exact=False) == pytest.approx(111.0, abs=0.5)  # 180′ / 1.616′


def test_exact_form_hand_values():
    for px in (-40.0, -3.0, 0.0, 2.5, 100.0):
        assert arcmin_from_pixels(px, TV) == pytest.approx(_exact_arcmin(px, TV), rel=RTOL, abs=1e-12)
    # At the divergence limit (parallax = eye separation) the eyes are parallel: the vergence change
    # equals the whole screen vergence 2 atan(e / 2D).
    limit_px = TV.eye_separation / TV.pixel_pitch
    screen_vergence = 2 * math.atan(0.065 / 6.0) * ARCMIN_PER_RADIAN
    assert arcmin_from_pixels(limit_px, TV) == pytest.approx(screen_vergence, rel=RTOL)
    assert arcmin_from_pixels(0.0, TV) == 0.0


def test_sign_convention_uncrossed_is_positive():
    assert arcmin_from_pixels(5.0, TV) > 0 > arcmin_from_pixels(-5.0, TV)
    # The exact form is not odd: d theta / ds = 1 / (D (1 + u^2)) with u = (e - s) / 2D grows with s,
    # so an uncrossed parallax turns the eyes a little more than the same crossed one.
    assert arcmin_from_pixels(50.0, TV) > -arcmin_from_pixels(-50.0, TV)
    assert arcmin_from_pixels(50.0, TV, exact=False) == -arcmin_from_pixels(-50.0, TV, exact=False)


def test_arrays_keep_shape_nan_passes_through_and_scalars_give_floats():
    px = np.array([[0.0, 1.0], [np.nan, -2.0]])
    out = arcmin_from_pixels(px, SAMSUNG)
    assert out.shape == (2, 2) and np.isnan(out[1, 0]) and np.isfinite(out[0]).all()
    back = pixels_from_arcmin(out, SAMSUNG)
    assert np.isnan(back[1, 0])
    assert_allclose(back[0], px[0], rtol=ROUND_TRIP_RTOL, atol=1e-9)
    assert type(arcmin_from_pixels(np.float32(1.0), SAMSUNG)) is float


@settings(max_examples=60, deadline=None)
@given(px=st.floats(-500.0, 500.0), exact=st.booleans())
def test_pixels_arcmin_round_trip(px, exact):
    back = pixels_from_arcmin(arcmin_from_pixels(px, TV, exact=exact), TV, exact=exact)
    assert back == pytest.approx(px, rel=ROUND_TRIP_RTOL, abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(px=st.floats(-300.0, 300.0))
def test_small_angle_form_is_linear(px):
    assert arcmin_from_pixels(px, SAMSUNG, exact=False) == pytest.approx(
        px * arcmin_from_pixels(1.0, SAMSUNG, exact=False), rel=RTOL, abs=1e-12
    )


# ---------------------------------------------------------------------------------------------
# Comfort zone


def test_default_zone_is_plus_minus_one_degree():
    zone = ComfortZone()
    assert (zone.crossed_arcmin, zone.uncrossed_arcmin) == (60.0, 60.0)
    assert (zone.min_arcmin, zone.max_arcmin) == (-60.0, 60.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        zone.crossed_arcmin = 30.0  # type: ignore[misc]


def test_zone_in_pixels_hand_values():
    # Small angle: 60′ = pi/180 rad; times 0.6 m over 0.282 mm = 37.133 px on the Samsung.
    lo, hi = ComfortZone().pixels(SAMSUNG, exact=False)
    assert hi == pytest.approx(math.radians(1.0) * 0.6 / 0.282e-3, rel=1e-9)
    assert lo == pytest.approx(-hi, rel=RTOL)
    # Exact: the parallax whose vergence is the screen's -/+ 1 degree, s = e - 2D tan(g0/2 -/+ 0.5 deg).
    g0 = 2 * math.atan(0.065 / 1.2)
    lo, hi = ComfortZone().pixels(SAMSUNG)
    pitch = 0.282e-3
    assert hi == pytest.approx((0.065 - 1.2 * math.tan(g0 / 2 - math.radians(0.5))) / pitch, rel=1e-9)
    assert lo == pytest.approx((0.065 - 1.2 * math.tan(g0 / 2 + math.radians(0.5))) / pitch, rel=1e-9)
    assert arcmin_from_pixels(hi, SAMSUNG) == pytest.approx(60.0, rel=1e-9)
    assert arcmin_from_pixels(lo, SAMSUNG) == pytest.approx(-60.0, rel=1e-9)


def test_asymmetric_zone_and_normalised_disparities():
    zone = ComfortZone(crossed_arcmin=70.0, uncrossed_arcmin=20.0)
    lo_px, hi_px = zone.pixels(TV)
    lo_d, hi_d = zone.disparities(TV)
    assert lo_d == pytest.approx(lo_px / 1920, rel=RTOL) and hi_d == pytest.approx(hi_px / 1920, rel=RTOL)
    assert arcmin_from_pixels(lo_px, TV) == pytest.approx(-70.0, rel=1e-9)
    assert arcmin_from_pixels(hi_px, TV) == pytest.approx(20.0, rel=1e-9)


def test_zone_perceived_depths_are_fixation_distances():
    # TV: screen vergence g0 = 2 atan(0.065/6) = 74.49′. Exact zone limits fixate where the
    # vergence is g0 +/- 60′: distance e / (2 tan(g / 2)).
    zone = ComfortZone()
    near, far = zone.perceived_depths(TV)
    g0 = 2 * math.atan(0.065 / 6.0)
    one_deg = math.radians(1.0)
    assert near == pytest.approx(0.065 / (2 * math.tan((g0 + one_deg) / 2)), rel=1e-9)
    assert far == pytest.approx(0.065 / (2 * math.tan((g0 - one_deg) / 2)), rel=1e-9)
    assert (round(near, 2), round(far, 2)) == (1.66, 15.43)
    # The same through S0 Eq. (1b) of the zone's normalised disparities.
    d_lo, d_hi = zone.disparities(TV)
    assert near == pytest.approx(perceived_depth(d_lo, TV), rel=1e-12)
    assert far == pytest.approx(perceived_depth(d_hi, TV), rel=1e-12)
    # No resolution needed for depths or normalised disparities.
    bare = Display(0.065, 3.0, 1.2)
    assert zone.perceived_depths(bare) == pytest.approx((near, far), rel=RTOL)


def test_zone_past_the_divergence_limit_has_infinite_far_depth():
    # Cinema: the screen vergence (14.9′) is smaller than 60′, so the uncrossed limit diverges.
    assert 2 * math.atan(0.0325 / 15.0) * ARCMIN_PER_RADIAN < 60.0
    near, far = ComfortZone().perceived_depths(CINEMA)
    assert far == math.inf and 0 < near < CINEMA.distance
    lo, hi = ComfortZone().pixels(CINEMA)
    assert hi > CINEMA.eye_separation / CINEMA.pixel_pitch  # past the divergence limit b'/W' N
    # A zone inside the screen vergence keeps a finite far depth.
    assert math.isfinite(ComfortZone(uncrossed_arcmin=10.0).perceived_depths(CINEMA)[1])


@pytest.mark.parametrize("kw, match", [
    (dict(crossed_arcmin=0.0), "^crossed_arcmin must be > 0; got 0"),
    (dict(uncrossed_arcmin=-5.0), r"^uncrossed_arcmin must lie in \[0, 5400\]; got -5"),
    (dict(crossed_arcmin=6000.0), r"^crossed_arcmin must lie in \[0, 5400\]; got 6000"),
    (dict(uncrossed_arcmin=math.nan), "^uncrossed_arcmin must be finite; got nan"),
])
def test_zone_rejects_bad_limits(kw, match):
    with pytest.raises(ValueError, match=match):
        ComfortZone(**kw)


# ---------------------------------------------------------------------------------------------
# Range checks


def test_range_inside_the_zone_hand_margins():
    lo_z, hi_z = ComfortZone().pixels(SAMSUNG)
    r = check_disparity_range([-10.0, 30.0], SAMSUNG)
    assert isinstance(r, ComfortReport) and r.inside and not r.diverges
    assert (r.min_px, r.max_px) == (-10.0, 30.0)
    assert r.near_margin_px == pytest.approx(-10.0 - lo_z, rel=RTOL)
    assert r.far_margin_px == pytest.approx(hi_z - 30.0, rel=RTOL)
    assert r.excess_px == 0.0 and r.excess_arcmin == 0.0
    assert r.divergence_px == pytest.approx(0.065 / 0.282e-3, rel=1e-9)  # b'/W' * N = 230.5 px
    assert r.min_arcmin == pytest.approx(_exact_arcmin(-10.0, SAMSUNG), rel=RTOL)
    assert r.max_arcmin == pytest.approx(_exact_arcmin(30.0, SAMSUNG), rel=RTOL)


def test_range_out_in_front_and_behind():
    lo_z, hi_z = ComfortZone().pixels(SAMSUNG)
    front = check_disparity_range([-60.0, 5.0], SAMSUNG)
    assert not front.inside and front.near_margin_px < 0 < front.far_margin_px
    assert front.excess_px == pytest.approx(lo_z + 60.0, rel=RTOL)
    assert front.excess_arcmin == pytest.approx(-60.0 - _exact_arcmin(-60.0, SAMSUNG), rel=1e-9)
    behind = check_disparity_range([0.0, 50.0], SAMSUNG)
    assert not behind.inside and not behind.diverges
    assert behind.excess_px == pytest.approx(50.0 - hi_z, rel=RTOL)
    both = check_disparity_range([-100.0, 45.0], SAMSUNG)
    assert both.excess_px == pytest.approx(max(lo_z + 100.0, 45.0 - hi_z), rel=RTOL)


def test_range_past_divergence_is_reported_even_inside_the_zone():
    # Cinema: 2048 px over 10 m, eyes 65 mm apart: divergence at 13.3 px, zone edge far beyond.
    r = check_disparity_range([0.0, 20.0], CINEMA)
    assert r.divergence_px == pytest.approx(0.065 / 10.0 * 2048, rel=RTOL)
    assert r.far_margin_px > 0 and r.diverges and not r.inside
    assert not check_disparity_range([0.0, 13.0], CINEMA).diverges


def test_range_of_a_disparity_map_ignores_nan_and_to_dict_is_json_ready():
    disparity_map = np.array([[np.nan, -4.0], [12.0, np.nan], [3.0, 0.0]], dtype=np.float32)
    r = check_disparity_range(disparity_map, SAMSUNG, zone=ComfortZone(crossed_arcmin=5.0, uncrossed_arcmin=30.0))
    assert (r.min_px, r.max_px) == (-4.0, 12.0)
    assert not r.inside and r.near_margin_px < 0  # -4 px ≈ -6.4′ is past the 5′ crossed limit
    d = r.to_dict()
    assert set(d) == {f.name for f in dataclasses.fields(ComfortReport)}
    assert d["inside"] is False and isinstance(d["excess_px"], float)


def test_small_angle_option_changes_the_conversion():
    exact = check_disparity_range([-10.0, 30.0], SAMSUNG)
    small = check_disparity_range([-10.0, 30.0], SAMSUNG, exact=False)
    assert small.max_arcmin == pytest.approx(30.0 * arcmin_from_pixels(1.0, SAMSUNG, exact=False), rel=RTOL)
    assert small.zone_max_px != exact.zone_max_px


def test_range_check_bad_input():
    with pytest.raises(ValueError, match="^parallax_px must hold at least one finite value; got 2 values, none"):
        check_disparity_range([np.nan, np.nan], SAMSUNG)
    with pytest.raises(ValueError, match="^parallax_px must hold at least one finite value; got 0 values"):
        check_disparity_range([], SAMSUNG)
    with pytest.raises(ValueError, match=r"^parallax_px must not contain inf"):
        check_disparity_range([0.0, np.inf], SAMSUNG)
    with pytest.raises(TypeError, match="^zone must be a ComfortZone; got tuple"):
        check_disparity_range([0.0, 1.0], SAMSUNG, zone=(60, 60))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="display resolution is unknown"):
        check_disparity_range([0.0, 1.0], Display(0.065, 3.0, 1.2))


def test_conversion_bad_input():
    with pytest.raises(ValueError, match="display resolution is unknown"):
        arcmin_from_pixels(1.0, Display(0.065, 3.0, 1.2))
    with pytest.raises(ValueError, match="^parallax_px must not contain inf"):
        arcmin_from_pixels(np.inf, TV)
    with pytest.raises(TypeError, match="^disparity_arcmin must be numeric; got str"):
        pixels_from_arcmin("one", TV)
    # The exact inverse exists only for vergence angles inside (-180, 180) degrees: the screen
    # vergence on TV is 74.49′, so angles in (74.49 - 10800, 74.49 + 10800) arcmin.
    with pytest.raises(ValueError, match=r"^disparity_arcmin must lie in \(-10725.5, 10874.5\) arcmin .*; got 11000$"):
        pixels_from_arcmin(11000.0, TV)


def test_report_validates_its_fields():
    r = check_disparity_range([-10.0, 30.0], SAMSUNG)
    with pytest.raises(ValueError, match="^min_px must be <= max_px; got 30 > -10"):
        dataclasses.replace(r, min_px=30.0, max_px=-10.0)
    with pytest.raises(ValueError, match="^excess_px and excess_arcmin must be >= 0; got -1, 0$"):
        dataclasses.replace(r, excess_px=-1.0)
    with pytest.raises(ValueError, match="^excess_px must be finite"):
        dataclasses.replace(r, excess_px=math.nan)


def test_the_limits_themselves_are_inside():
    # Eyes exactly parallel at the divergence limit do not diverge, one float past they do; a range
    # that touches the zone edge (margin exactly 0) is inside, and so is one a float past it (issue 30:
    # the test below).
    r = check_disparity_range([0.0, 1.0], CINEMA)
    at_limit = check_disparity_range([0.0, r.divergence_px], CINEMA)
    assert not at_limit.diverges
    assert check_disparity_range([0.0, np.nextafter(r.divergence_px, math.inf)], CINEMA).diverges
    zone_lo, zone_hi = ComfortZone().pixels(SAMSUNG)
    edge = check_disparity_range([zone_lo, zone_hi], SAMSUNG)
    assert edge.near_margin_px == 0.0 and edge.far_margin_px == 0.0 and edge.inside
    assert check_disparity_range([np.nextafter(zone_lo, -math.inf), 0.0], SAMSUNG).inside
    assert not check_disparity_range([zone_lo - 1e-3, 0.0], SAMSUNG).inside


def test_a_range_that_ends_on_a_limit_to_round_off_is_inside():
    """Issue 30: a maximum of 59.99999999999999' (60' through pixel <-> arcmin round-off) was reported
    outside, 'leaving the comfort zone by 0 arcmin'. Within COMFORT_TOLERANCE_PX of a limit is on it."""
    from vergence.viewing.comfort import COMFORT_TOLERANCE_PX

    display = Display.preset("samsung-2233rz")
    zone_lo, zone_hi = ComfortZone().pixels(display)
    on_edge = np.nextafter(zone_hi, np.inf)  # one float past the edge: round-off, not content
    report = check_disparity_range([0.0, on_edge], display)
    assert report.inside and report.excess_px == 0.0 and report.excess_arcmin == 0.0
    report = check_disparity_range([np.nextafter(zone_lo, -np.inf), 0.0], display)
    assert report.inside and report.excess_px == 0.0
    # past the tolerance, outside, by what it is
    past = zone_hi + 10 * COMFORT_TOLERANCE_PX
    report = check_disparity_range([0.0, past], display)
    assert not report.inside and report.excess_px == pytest.approx(10 * COMFORT_TOLERANCE_PX, rel=1e-3)
