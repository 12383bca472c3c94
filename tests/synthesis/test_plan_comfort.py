"""plan_comfort: the comfort report of a planned parallax and the share of pixels outside the zone."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.synthesis import plan_comfort, plan_parallax, stereo_warnings
from vergence.viewing import ComfortZone, Display
from vergence.viewing.comfort import arcmin_from_pixels, check_disparity_range


def _outside_reference(plan, display, zone):
    """Slow and plain: each known pixel to display pixels, then to arcmin of vergence, one at a time."""
    per_px = display.resolution / plan.parallax_px.shape[1]
    known = outside = 0
    for value in plan.parallax_px.ravel():
        if not np.isfinite(value):
            continue
        known += 1
        theta = float(arcmin_from_pixels(float(value) * per_px, display))
        outside += not (zone.min_arcmin <= theta <= zone.max_arcmin)
    return outside / known


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("budget", [10.0, 40.0, 90.0])
def test_the_share_outside_equals_a_per_pixel_reference_in_arcmin(seed, budget):
    rng = np.random.default_rng(seed)
    depth = rng.uniform(1.0, 10.0, (12, 40))
    depth[rng.random(depth.shape) < 0.1] = np.nan
    display = Display.preset("desktop-24")
    zone = ComfortZone(crossed_arcmin=45.0, uncrossed_arcmin=30.0)
    plan = plan_parallax(depth, budget_arcmin=budget, display=display)
    report, outside = plan_comfort(plan, display, zone=zone)
    assert outside == pytest.approx(_outside_reference(plan, display, zone), abs=1e-12)
    per_px = display.resolution / depth.shape[1]
    assert report == check_disparity_range(np.array(plan.range_px) * per_px, display, zone=zone)
    assert report.min_arcmin == pytest.approx(plan.range_arcmin[0], abs=1e-9)
    assert report.max_arcmin == pytest.approx(plan.range_arcmin[1], abs=1e-9)


def test_inside_and_outside_the_default_zone():
    display = Display.preset("desktop-24")
    inside = plan_parallax(np.tile([[1.0, 4.0]], (3, 20)), budget_arcmin=30.0, display=display)
    assert plan_comfort(inside, display)[1] == 0.0 and plan_comfort(inside, display)[0].inside
    # half the pixels near (crossed), half far: a +-90 arcmin budget puts every pixel outside +-60
    both = plan_parallax(np.tile([[1.0, 4.0]], (3, 20)), budget_arcmin=90.0, display=display)
    assert plan_comfort(both, display)[1] == 1.0
    # only the far side leaves a zone whose uncrossed limit is 45 arcmin: half the pixels
    zone = ComfortZone(crossed_arcmin=120.0, uncrossed_arcmin=45.0)
    assert plan_comfort(both, display, zone=zone)[1] == 0.5


def test_the_warnings_read_the_same_report():
    display = Display.preset("desktop-24")
    plan = plan_parallax(np.tile([[1.0, 4.0]], (1, 96)), budget_px=20.0)
    report, _ = plan_comfort(plan, display)
    lines = stereo_warnings(plan, display)
    assert any(f"{report.min_arcmin:+.4g} .. {report.max_arcmin:+.4g} arcmin" in line for line in lines)


@pytest.mark.parametrize(("args", "kwargs", "error", "message"), [
    ((None, Display.preset("desktop-24")), {}, TypeError, "plan must be a ParallaxPlan"),
    (("plan", "desktop-24"), {}, TypeError, "display must be a vergence.viewing.Display"),
    (("plan", Display(0.065, 0.6, 0.5)), {}, ValueError, "display resolution is unknown"),
    (("plan", Display.preset("desktop-24")), {"zone": 60.0}, TypeError, "zone must be a ComfortZone"),
])
def test_bad_arguments_are_refused_in_one_line(args, kwargs, error, message):
    plan = plan_parallax(np.tile([[1.0, 4.0]], (1, 8)), budget_px=2.0)
    args = tuple(plan if a == "plan" else a for a in args)
    with pytest.raises(error, match=message):
        plan_comfort(*args, **kwargs)
