"""Depth controls (S1 §IV.C, Table I): depth to screen parallax by budget, shift-sensor or psi."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.synthesis import MAX_PARALLAX_WIDTHS, MAX_VIEWS, nearness_from_depth, plan_parallax, views_offsets
from vergence.viewing.comfort import arcmin_from_pixels
from vergence.viewing.geometry import Display, shift_sensor_parallax
from vergence.viewing.mapping import LogMapping

# float32 parallax maps: a few ulps of values up to ~100 px.
PARALLAX_ATOL = 1e-4

# Tiled to 24 px: a parallax must stay below one image width (MAX_PARALLAX_WIDTHS).
DEPTH = np.tile(np.array([[1.0, 2.0, 4.0], [np.nan, 2.0, 8.0]]), (1, 8))
# Four depths for the shift-sensor set-up, tiled to 64 px for the same reason.
SHIFT_DEPTH = np.tile(np.array([[1.5, 2.0, 3.0, 7.0]]), (1, 16))


def test_nearness_kinds():
    assert_allclose(nearness_from_depth([[2.0, 4.0]]), [[0.5, 0.25]])
    assert_allclose(nearness_from_depth([[2.0, -4.0]], kind="disparity"), [[2.0, -4.0]])
    assert_allclose(nearness_from_depth([[0.0, 1.0]], kind="inverse"), [[0.0, 1.0]])
    q = nearness_from_depth(DEPTH)
    assert q.dtype == np.float32 and np.isnan(q[1, 0])


def test_budget_maps_the_nearness_range_onto_plus_minus_budget():
    plan = plan_parallax(DEPTH, budget_px=12.0)
    # 1/Z spans [1/8, 1]; nearest (1 m) -> -12 (crossed, in front), farthest (8 m) -> +12.
    assert plan.range_px == (-12.0, 12.0)
    assert plan.parallax_px[0, 0] == pytest.approx(-12.0)
    assert plan.parallax_px[1, 2] == pytest.approx(12.0)
    assert np.isnan(plan.parallax_px[1, 0])
    assert plan.range_arcmin is None


def test_budget_with_convergence_keeps_zero_parallax_there():
    plan = plan_parallax(DEPTH, budget_px=10.0, convergence=2.0)
    assert_allclose(plan.parallax_px[0, 1], 0.0, atol=PARALLAX_ATOL)
    # 1/Z: nearest 1 is 0.5 from 1/2, farthest 1/8 is 0.375 away: the near side reaches the budget.
    assert plan.range_px[0] == pytest.approx(-10.0)
    assert plan.range_px[1] == pytest.approx(10.0 * 0.375 / 0.5)


def test_budget_in_arcmin_for_a_display():
    display = Display.preset("desktop-24")
    plan = plan_parallax(DEPTH, budget_arcmin=30.0, display=display)
    lo, hi = plan.range_arcmin
    assert max(abs(lo), abs(hi)) == pytest.approx(30.0, rel=1e-9)
    assert abs(lo) <= 30.0 + 1e-9 and hi <= 30.0 + 1e-9
    # The image (24 px wide) fills the 1920-px screen: 80 display pixels per image pixel.
    assert hi == pytest.approx(arcmin_from_pixels(plan.range_px[1] * 80.0, display))


def test_shift_sensor_matches_the_geometry_formula():
    depth = SHIFT_DEPTH
    plan = plan_parallax(depth, focal_px=1200.0, interaxial=0.065, convergence=2.0)
    expected = shift_sensor_parallax(depth, focal_px=1200.0, interaxial=0.065, convergence=2.0)
    assert_allclose(plan.parallax_px, expected, atol=PARALLAX_ATOL)
    assert plan.parallax_px[0, 1] == pytest.approx(0.0, abs=PARALLAX_ATOL)


def test_table_one_trends():
    depth = SHIFT_DEPTH
    base = plan_parallax(depth, focal_px=1000.0, interaxial=0.06, convergence=2.0).parallax_px
    wider = plan_parallax(depth, focal_px=1000.0, interaxial=0.09, convergence=2.0).parallax_px
    longer = plan_parallax(depth, focal_px=1500.0, interaxial=0.06, convergence=2.0).parallax_px
    farther = plan_parallax(depth, focal_px=1000.0, interaxial=0.06, convergence=3.0).parallax_px
    # S1 Table I: interaxial + and focal length + increase |parallax|; convergence + decreases
    # parallax everywhere (the scene moves toward the viewer).
    off = np.abs(base) > PARALLAX_ATOL
    assert (np.abs(wider)[off] > np.abs(base)[off]).all()
    assert (np.abs(longer)[off] > np.abs(base)[off]).all()
    assert (farther < base).all()


def test_any_mapping_is_applied_to_the_input_parallax():
    psi = LogMapping(-1.0, -0.125, -5.0, 5.0, strength=2.0)
    plan = plan_parallax(DEPTH, mapping=psi)
    assert_allclose(plan.parallax_px[0], psi(-1.0 / DEPTH[0]), atol=PARALLAX_ATOL)
    assert plan.range_px == pytest.approx((-5.0, 5.0))


def test_views_offsets():
    assert views_offsets(2) == (-0.5, 0.5)
    assert views_offsets(3) == (-1.0, 0.0, 1.0)
    assert views_offsets(3, origin="left") == (0.0, 1.0, 2.0)


@pytest.mark.parametrize(
    ("depth", "kwargs", "error", "match"),
    [
        (DEPTH, {}, ValueError, "give exactly one control: .*; got none"),
        (DEPTH, {"budget_px": 5.0, "mapping": LogMapping(0, 1, 0, 1)}, ValueError, "got budget, mapping"),
        (DEPTH, {"budget_arcmin": 30.0}, ValueError, "budget_arcmin needs a display"),
        (DEPTH, {"budget_px": 1.0, "budget_arcmin": 1.0, "display": Display.preset("phone")}, ValueError, "not both"),
        (DEPTH, {"budget_px": -1.0}, ValueError, "budget_px must be > 0; got -1"),
        (DEPTH, {"focal_px": 1000.0, "interaxial": 0.06}, ValueError, "needs focal_px, interaxial and convergence"),
        (DEPTH, {"focal_px": 1000.0, "interaxial": -0.06, "convergence": 2.0}, ValueError, "interaxial must be > 0"),
        (DEPTH, {"kind": "disparity", "focal_px": 1.0, "interaxial": 1.0, "convergence": 1.0}, ValueError, "need metric depth"),
        (np.full((2, 8), 3.0), {"budget_px": 5.0}, ValueError, "depth must vary for a disparity budget"),
        (np.array([[1.0, -2.0]]), {"budget_px": 5.0}, ValueError, "depth must be > 0 metres where known .*got min -2"),
        (np.array([[1.0, np.inf]]), {"budget_px": 5.0}, ValueError, "depth must not contain inf"),
        (np.full((2, 2), np.nan), {"budget_px": 5.0}, ValueError, "at least one known value"),
        (np.ones(3), {"budget_px": 5.0}, ValueError, r"depth must have shape \(H, W\); got \(3,\)"),
        (DEPTH, {"kind": "sonar", "budget_px": 5.0}, ValueError, "kind must be one of disparity, inverse, metric; got 'sonar'"),
        (DEPTH, {"budget_px": 5.0, "display": "tv"}, TypeError, "display must be a vergence.viewing.Display; got str"),
        # Issue 9: inverse depth outside [0, 1] (MPEG's normalised 1/Z) is not a depth.
        (np.array([[0.5, 2.0]]), {"kind": "inverse", "budget_px": 5.0}, ValueError, r"depth must lie in \[0, 1\] for inverse depth .*got \[0.5, 2\]"),
        (np.array([[-0.5, 1.0]]), {"kind": "inverse", "budget_px": 5.0}, ValueError, r"depth must lie in \[0, 1\] for inverse depth .*got \[-0.5, 1\]"),
        # Issue 9 kin: 1/depth would overflow float32 (RuntimeWarning before).
        (np.array([[1e-40, 1.0]], np.float32), {"budget_px": 5.0}, ValueError, r"depth must be >= 1.18e-38 \(MIN_METRIC_DEPTH"),
    ],
)
def test_plan_parallax_bad_input(depth, kwargs, error, match):
    with pytest.raises(error, match=match):
        plan_parallax(depth, **kwargs)


def test_views_offsets_bad_input():
    with pytest.raises(ValueError, match=r"views must lie in \[2, 128\] \(MAX_VIEWS\); got 1"):
        views_offsets(1)
    # Issue 9 kin: a huge view count is refused before any view is allocated.
    with pytest.raises(ValueError, match=r"views must lie in \[2, 128\] \(MAX_VIEWS\); got 129"):
        views_offsets(MAX_VIEWS + 1)
    assert len(views_offsets(MAX_VIEWS)) == MAX_VIEWS
    with pytest.raises(ValueError, match="origin must be one of center, left; got 'right'"):
        views_offsets(2, origin="right")


# Issue 9: --budget-px 1e6 (both views black), --budget-px 200 on 64 px (84 % holes), --focal-px 5000
# --interaxial 1 --convergence 3 (94 % holes) were rendered while --budget-arcmin 1e6 was refused:
# every control now meets one rule, |P| < MAX_PARALLAX_WIDTHS image widths.
def test_every_control_refuses_a_parallax_of_a_whole_image_width():
    width = DEPTH.shape[1]
    assert MAX_PARALLAX_WIDTHS == 1.0
    assert plan_parallax(DEPTH, budget_px=0.99 * width).range_px == pytest.approx((-0.99 * width, 0.99 * width))
    for budget in (float(width), 200.0, 1e6, 1e308):
        with pytest.raises(ValueError, match=r"budget_px must be < 24 px, 1 image width \(MAX_PARALLAX_WIDTHS\)"):
            plan_parallax(DEPTH, budget_px=budget)
    # The arcminute budget meets the same limit, converted: a whole image width (1920 display px of
    # desktop-24, 80 per image pixel), the larger of the two sides (the budget keeps the smaller).
    display = Display.preset("desktop-24")
    a_max = max(arcmin_from_pixels(1920.0, display), -arcmin_from_pixels(-1920.0, display))
    assert max(np.abs(plan_parallax(DEPTH, budget_arcmin=0.999 * a_max, display=display).range_px)) < width
    for budget in (a_max, 1e6):
        with pytest.raises(ValueError, match=rf"budget_arcmin must be < {a_max:.4g} arcmin on this display, 24 px"):
            plan_parallax(DEPTH, budget_arcmin=budget, display=display)
    # By hand: 5000 x 1 x (1/3 - 1/1.5) = -1667 px, 5000 x (1/3 - 1/7) = 952.4 px.
    with pytest.raises(ValueError, match=r"focal_px 5000 with interaxial 1 and convergence 3 gives parallaxes of -1667 .. 952.4 px, which must stay within \+-64 px"):
        plan_parallax(SHIFT_DEPTH, focal_px=5000.0, interaxial=1.0, convergence=3.0)
    with pytest.raises(ValueError, match=r"focal_px 1e\+308 with interaxial 1e\+308 .* -inf .. inf px"):
        plan_parallax(SHIFT_DEPTH, focal_px=1e308, interaxial=1e308, convergence=3.0)
    with pytest.raises(ValueError, match=r"mapping gives parallaxes of -30 .. 30 px, which must stay within \+-24 px"):
        plan_parallax(DEPTH, mapping=LogMapping(-1.0, -0.125, -30.0, 30.0, strength=2.0))


def test_a_steep_budget_on_a_narrow_depth_range_stays_finite():
    # Issue 9 kin: 1/Z of 1e38 m spans 5e-39 (float32 subnormals): the gain 4e38 overflowed float32
    # with RuntimeWarnings (errors under pytest). Computed in float64, the plan is the budget.
    plan = plan_parallax(np.tile(np.array([[1e38, 2e38]], np.float32), (1, 4)), budget_px=1.0)
    assert plan.range_px == (-1.0, 1.0)
    assert_allclose(plan.parallax_px[0, :2], [-1.0, 1.0], atol=PARALLAX_ATOL)
