"""Bad user input to the viewing and mapping API: each refusal is the documented one-line error."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vergence.viewing.geometry import Display, Shooting
from vergence.viewing.mapping import (
    BlendedMapping,
    DirectorConstraint,
    DisparityMapping,
    LinearMapping,
    PiecewiseMapping,
    RationalHermiteMapping,
    SaliencyMapping,
    mapped_perceived_depth,
    mapped_roundness,
    psi_from_constraints,
)

TV = Display(eye_separation=0.065, distance=3.0, width=1.2)
RIG = Shooting(baseline=0.65, convergence=30.0, window=3.0)
ID = LinearMapping(-1.0, 1.0, -1.0, 1.0)


class _Bounded(DisparityMapping):
    """A user operator defined on (lo, hi) only (every built-in one reaches +inf)."""

    def __init__(self, lo: float, hi: float) -> None:
        self.lo, self.hi = lo, hi

    def domain(self) -> tuple[float, float]:
        return (self.lo, self.hi)

    def _value(self, d: np.ndarray) -> np.ndarray:
        return d

    def _derivative(self, d: np.ndarray) -> np.ndarray:
        return np.ones_like(d)


def test_blend_of_operators_without_a_common_domain_is_refused():
    with pytest.raises(ValueError, match=r"^operators must share a domain; their domains meet in \(2, 1\)$"):
        BlendedMapping([_Bounded(0.0, 1.0), _Bounded(2.0, 3.0)], [0.5, 0.5])


def _mapping():
    return psi_from_constraints(RIG, TV, ["z=30,perceived=3,roundness=1", "z=inf,perceived=inf"], near=12.0,
                                far=math.inf)


@pytest.mark.parametrize(
    ("make", "error", "message"),
    [
        (lambda: PiecewiseMapping([], []), ValueError, "^operators must hold at least one operator; got none$"),
        (lambda: RationalHermiteMapping([], [], []), ValueError, "^knots must hold at least 1 point; got 0$"),
        (lambda: SaliencyMapping([0.0], [], 0.0, 1.0), ValueError,
         r"^edges must be at least 2 strictly increasing values; got \[0.0\]$"),
        (lambda: SaliencyMapping([0.0, 2.0, 1.0], [1.0, 1.0], 0.0, 1.0), ValueError,
         "^edges must be at least 2 strictly increasing values"),
        (lambda: SaliencyMapping([0.0, 1.0, 2.0], [1.0, 0.0], 0.0, 1.0), ValueError,
         r"^density must be > 0 in every bin \(add a floor\); got min 0$"),
        (lambda: SaliencyMapping([0.0, 1.0], [1.0], 1.0, 1.0), ValueError, "^target_max must be > target_min 1; got 1$"),
        (lambda: DirectorConstraint.from_string(3.0), TypeError, "^constraint must be a string; got float$"),
        (lambda: DirectorConstraint.from_string("z=3,z=4,perceived=2"), ValueError,
         "^constraint 'z=3,z=4,perceived=2' is malformed: z given twice$"),
        (lambda: DirectorConstraint(depth="far", perceived_depth=3.0), TypeError,
         "^depth must be a real number; got str$"),
        (lambda: mapped_perceived_depth(30.0, "identity", RIG, TV), TypeError,
         "^psi must be a DisparityMapping; got str$"),
        (lambda: mapped_roundness(30.0, ID, TV, TV), TypeError, "^reference must be a Shooting; got Display$"),
        (lambda: mapped_perceived_depth(object(), ID, RIG, TV), TypeError, "^z must be numeric; got object$"),
    ],
)
def test_bad_input_is_refused_with_its_message(make, error, message):
    with pytest.raises(error, match=message):
        make()


def test_constrained_mapping_checks_its_parts():
    m = _mapping()
    with pytest.raises(TypeError, match="^psi must be a DisparityMapping; got str$"):
        dataclasses.replace(m, psi="psi")
    with pytest.raises(ValueError, match=r"^control_points must match constraints \(2\); got 1$"):
        dataclasses.replace(m, control_points=m.control_points[:1])
    with pytest.raises(ValueError, match="^far must be > near 12 > 0; got 5$"):
        dataclasses.replace(m, far=5.0)
    for n in (1, 2.0, True):
        with pytest.raises(ValueError, match="^n must be an integer >= 2; got"):
            m.sample(n)
    samples = m.sample(5)
    with pytest.raises(ValueError, match=r"^mapped must have shape \(5,\) matching disparity; got \(4,\)$"):
        dataclasses.replace(samples, mapped=samples.mapped[:4])


def test_a_single_constraint_need_not_be_a_list():
    one = psi_from_constraints(RIG, TV, "z=30,perceived=3", near=12.0, far=80.0)
    assert len(one.constraints) == 1
    assert one.psi(np.array([0.0]))[0] == 0.0  # z' = H' at z = H: psi(0) = 0 (S0 Eq. (7))


def test_blend_weights_must_sum_to_one_to_a_few_ulps():
    # _WEIGHT_SUM_ULPS = 8 per weight: 2 weights allow 16 eps = 3.6e-15; 1e-14 is a user's mistake.
    other = LinearMapping(-1.0, 1.0, -2.0, 2.0)
    BlendedMapping([ID, other], [0.25, 0.75])
    BlendedMapping([ID, other], [0.5, 0.5 + 8 * np.finfo(float).eps])
    with pytest.raises(ValueError, match="^weights must sum to 1; got 1.00000000000001"):
        BlendedMapping([ID, other], [0.5, 0.5 + 1e-14])


def test_cuts_may_be_exactly_one_transition_apart():
    from vergence.viewing.mapping_composite import temporal_weights

    # ramps over [-0.5, 0.5] and [0.5, 1.5] touch at t = 0.5: allowed, and the weights telescope
    assert temporal_weights(0.5, [0.0, 1.0], transition=1.0).tolist() == [0.0, 1.0, 0.0]
    with pytest.raises(ValueError, match=r"^cuts must increase by at least transition 1; got \[0.0, 0.5\]$"):
        temporal_weights(0.5, [0.0, 0.5], transition=1.0)


# Issue 9, "Python: values instead of errors": NaN, text and wrong objects given to the public viewing
# functions, and inputs near 1e308 (numpy overflow warnings before; warnings are errors in the suite).
from vergence.viewing import (  # noqa: E402
    ComfortZone,
    arcmin_from_pixels,
    check_disparity_range,
    depth_budget,
    disparity,
    divergence_baseline,
    divergence_depth,
    focal_ratio,
    perceived_depth,
    perceived_depth_from_depth,
    pixels_from_arcmin,
    roundness,
    roundness_baseline,
    scene_depth_from_disparity,
    shift_sensor_parallax,
)

TV_PX = Display(eye_separation=0.065, distance=3.0, width=1.2, resolution=1920)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: arcmin_from_pixels(math.nan, TV_PX), ValueError,
         r"^parallax_px must hold at least one value that is not NaN .*; got 1 value\(s\), none valid$"),
        (lambda: pixels_from_arcmin(math.nan, TV_PX), ValueError,
         "^disparity_arcmin must hold at least one value that is not NaN"),
        (lambda: pixels_from_arcmin([math.nan, math.nan], TV_PX, exact=False), ValueError,
         "^disparity_arcmin must hold at least one value that is not NaN"),
        (lambda: roundness("30", RIG, TV), TypeError, "^z must be numeric; got str$"),
        (lambda: disparity(["30"], RIG), TypeError, "^z must be numeric; got list$"),
        (lambda: arcmin_from_pixels("1", TV_PX), TypeError, "^parallax_px must be numeric; got str$"),
        (lambda: arcmin_from_pixels(1.0, TV_PX, exact="no"), TypeError, "^exact must be True or False; got str$"),
        (lambda: mapped_roundness("30", ID, RIG, TV), TypeError, "^z must be numeric; got str$"),
        # wrong objects: TypeError naming the argument, never AttributeError
        (lambda: roundness(30.0, TV, RIG), TypeError, "^shooting must be a Shooting; got Display$"),
        (lambda: disparity(30.0, "rig"), TypeError, "^shooting must be a Shooting; got str$"),
        (lambda: perceived_depth(0.0, "tv"), TypeError, "^display must be a vergence.viewing.Display; got str$"),
        (lambda: perceived_depth_from_depth(30.0, RIG, None), TypeError, "^display must be a vergence.viewing.Display; got NoneType$"),
        (lambda: scene_depth_from_disparity(0.1, "rig"), TypeError, "^shooting must be a Shooting; got str$"),
        (lambda: divergence_baseline(1.0, "tv"), TypeError, "^display must be a vergence.viewing.Display; got str$"),
        (lambda: roundness_baseline(1.0, None), TypeError, "^display must be a vergence.viewing.Display; got NoneType$"),
        (lambda: focal_ratio(1, 2), TypeError, "^shooting must be a Shooting; got int$"),
        (lambda: divergence_depth(RIG, 1), TypeError, "^display must be a vergence.viewing.Display; got int$"),
        (lambda: arcmin_from_pixels(1.0, "tv"), TypeError, "^display must be a vergence.viewing.Display; got str$"),
        (lambda: ComfortZone().pixels("tv"), TypeError, "^display must be a vergence.viewing.Display; got str$"),
        (lambda: check_disparity_range([0.0, 1.0], "tv"), TypeError, "^display must be a vergence.viewing.Display; got str$"),
        (lambda: depth_budget(RIG, TV, "far"), TypeError, "^depths must be numeric; got str$"),
        # 1e308: a clean error, not an overflow warning
        (lambda: scene_depth_from_disparity(1e308, RIG), ValueError,
         r"^d must lie in \[-1e\+30, 1e\+30\] image widths; got 1e\+308$"),
        (lambda: perceived_depth(-1e308, TV), ValueError, r"^d must lie in \[-1e\+30, 1e\+30\] image widths"),
        (lambda: pixels_from_arcmin(1e308, TV_PX, exact=False), ValueError,
         r"^disparity_arcmin must lie in \[-10800, 10800\] arcmin"),
        (lambda: arcmin_from_pixels(1e308, Display(0.065, 3.0, 1e6, resolution=1)), ValueError,
         r"^parallax_px must lie in \[-1e\+30, 1e\+30\]"),
        (lambda: roundness_baseline(1e308, TV), ValueError, r"^convergence must lie in \[1e-06, 1e\+06\] m; got 1e\+308$"),
        (lambda: roundness_baseline(1.0, TV, roundness=1e9), ValueError,
         r"^roundness must lie in \[0.001, 1000\]; got 1e\+09$"),
        (lambda: divergence_baseline(1e308, TV), ValueError, r"^window must lie in \[1e-06, 1e\+06\] m"),
        (lambda: shift_sensor_parallax(1.0, focal_px=1e300, interaxial=1e3, convergence=1.0), ValueError,
         "^focal_px must be <= .* with interaxial 1000 m"),
    ],
)
def test_issue9_api_refuses_nan_text_wrong_objects_and_overflow(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_nan_pixels_of_a_map_still_pass_through_beside_valid_ones():
    out = arcmin_from_pixels(np.array([math.nan, 2.0]), TV_PX)
    assert math.isnan(out[0]) and out[1] > 0


# Kin found by the issue-9 sweep (1,965 wrong-type and extreme calls over every public viewing function).
from vergence.viewing import default_depths  # noqa: E402
from vergence.viewing.mapping import temporal_weights  # noqa: E402
from vergence.viewing.mapping_hermite import pchip_slopes  # noqa: E402


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: default_depths("rig"), TypeError, "^shooting must be a Shooting; got str$"),
        (lambda: ComfortZone().pixels(TV_PX, exact="yes"), TypeError, "^exact must be True or False; got str$"),
        (lambda: ComfortZone().disparities(TV_PX, exact=None), TypeError, "^exact must be True or False; got NoneType$"),
        (lambda: ID("30"), TypeError, "^d must be numeric; got str$"),
        (lambda: ID.inverse(["0.5"]), TypeError, "^value must be numeric; got list$"),
        (lambda: mapped_perceived_depth(5e-324, ID, RIG, TV), ValueError,
         r"^z must be >= 1e-06 m \(LENGTH_RANGE; inf allowed\); got 4.94066e-324$"),
        (lambda: pchip_slopes([0.0, 5e-324, 1.0], [-1e308, 1e308, 1e308]), ValueError, "^values must not rise faster"),
    ],
)
def test_issue9_sweep_kin(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_subnormal_ranges_and_ramps_give_exact_results_without_overflow_warnings():
    # Warnings are errors in the suite: these overflowed (1/5e-324) before.
    assert temporal_weights(10.5, [10.0], transition=5e-324).tolist() == [0.0, 1.0]
    slopes = pchip_slopes([0.0, 1.0, 2.0], [0.0, 5e-324, 1e-323])
    assert np.all(slopes >= 0) and np.all(np.isfinite(slopes))
    with pytest.raises(ValueError, match=r"^target_max - target_min = 4.94066e-324 is too narrow to give each of the 2 bins"):
        SaliencyMapping([0.0, 1.0, 2.0], [1.0, 1.0], 0.0, 5e-324)


def test_check_display_is_the_one_display_check():
    import doctest

    from vergence.viewing import check_display, geometry

    assert check_display(TV) is TV
    assert check_display(TV_PX, name="target_display", resolution=True) is TV_PX
    with pytest.raises(TypeError, match=r"^target_display must be a vergence\.viewing\.Display; got str$"):
        check_display("tv-55", name="target_display")
    with pytest.raises(TypeError, match=r"^display must be a vergence\.viewing\.Display; got NoneType$"):
        check_display(None, resolution=True)
    with pytest.raises(ValueError, match="^target_display resolution is unknown: give the screen width in pixels$"):
        check_display(TV, name="target_display", resolution=True)
    with pytest.raises(ValueError, match="^display resolution is unknown: give the screen width in pixels$"):
        TV.pixel_pitch  # noqa: B018 - the property speaks as check_display
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner()
    for test in finder.find(check_display, "check_display", globs=vars(geometry)):
        runner.run(test)
    assert runner.tries >= 3 and runner.failures == 0
