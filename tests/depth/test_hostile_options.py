"""Issue 9, the sweep's depth/metrics cases (tools/sweep, /work/notes/sweep_quick1.md): one hostile
option at a time on an otherwise valid call, each refused with the documented error."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.depth import (
    compute_disparity,
    confidence_map,
    depth_from_disparity,
    disparity_from_depth,
    disparity_preview,
    evaluate_disparity,
    left_right_check,
    middlebury_regions,
    rectify_cameras,
    rectify_pair,
    refine_disparity,
    remove_speckles,
    unreliable_pixels,
    weighted_median_filter,
)

H, W = 24, 48


def _pair() -> tuple[np.ndarray, np.ndarray]:
    right = np.random.default_rng(0).random((H, W)).astype(np.float32)
    return np.roll(right, 3, axis=1), right


def _cameras():
    a = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=W, height=H)
    b = look_at([0.1, 0, 0], [0.1, 0, 5], [0, -1, 0], fov_deg=60, width=W, height=H)
    return a, b


def _ramp() -> np.ndarray:
    return np.broadcast_to(np.linspace(2.0, 4.0, W, dtype=np.float32), (H, W)).copy()


# name -> call with the bool option given; a string ("no", "False") is truthy and used to pass unseen
BOOL_OPTIONS = {
    "keep_invalid (compute_disparity)": lambda v: compute_disparity(*_pair(), max_disparity=16, keep_invalid=v),
    "keep_invalid (refine_disparity)": lambda v: refine_disparity(_ramp(), _pair()[0], keep_invalid=v),
    "colour_bar": lambda v: disparity_preview(_ramp(), lo=0.0, hi=8.0, colour_bar=v),
    "disc_includes_occlusions": lambda v: middlebury_regions(_ramp(), disc_includes_occlusions=v),
    "common_principal_point (rectify_cameras)": lambda v: rectify_cameras(*_cameras(), common_principal_point=v),
    "common_principal_point (rectify_pair)": lambda v: rectify_pair(*_pair(), *_cameras(), common_principal_point=v),
}


@pytest.mark.parametrize("option", list(BOOL_OPTIONS))
@pytest.mark.parametrize("value", ["False", None, 1])
def test_bool_option_refuses_non_bool(option, value):
    """Sweep cases api/{compute_disparity,refine_disparity}/keep_invalid=string, disparity_preview/colour_bar,
    middlebury_regions/disc_includes_occlusions, rectify_{cameras,pair}/common_principal_point."""
    name = option.split(" ")[0]
    with pytest.raises(TypeError, match=rf"^{name} must be a bool; got {type(value).__name__}$"):
        BOOL_OPTIONS[option](value)


@pytest.mark.parametrize("option", list(BOOL_OPTIONS))
def test_bool_option_takes_numpy_bool(option):
    BOOL_OPTIONS[option](np.bool_(False))


ALL_NAN = np.full((H, W), np.nan, np.float32)

# name -> call that gets an all-NaN map: nothing to convert, show or filter (sweep cases */=all_nan)
NO_FINITE_VALUE = {
    "disparity (depth_from_disparity)": lambda: depth_from_disparity(ALL_NAN, focal_px=500.0, baseline=0.1),
    "disparity (depth_from_disparity, None)": lambda: depth_from_disparity(None, focal_px=500.0, baseline=0.1),
    "depth (disparity_from_depth)": lambda: disparity_from_depth(ALL_NAN, focal_px=500.0, baseline=0.1),
    "depth (disparity_from_depth, None)": lambda: disparity_from_depth(None, focal_px=500.0, baseline=0.1),
    "raw (confidence_map)": lambda: confidence_map(ALL_NAN, _ramp()),
    "refined (confidence_map)": lambda: confidence_map(_ramp(), ALL_NAN),
    "raw (confidence_map, both)": lambda: confidence_map(ALL_NAN, ALL_NAN),
    "disparity (disparity_preview)": lambda: disparity_preview(ALL_NAN, lo=0.0, hi=8.0),
    "disparity (remove_speckles)": lambda: remove_speckles(ALL_NAN, max_size=4),
    "disparity (weighted_median_filter)": lambda: weighted_median_filter(ALL_NAN, _pair()[0], radius=2),
}


@pytest.mark.parametrize("case", list(NO_FINITE_VALUE))
def test_all_nan_input_is_refused(case):
    name = case.split(" ")[0]
    with pytest.raises(ValueError, match=rf"^{name} has no finite value$"):
        NO_FINITE_VALUE[case]()


# name -> call with a value at the edge of the float range; each must give a finite, sensible answer with no
# RuntimeWarning (the suite turns warnings into errors): sweep cases unreliable_pixels/jump=huge,
# weighted_median_filter/sigma_color=subnormal, refine_disparity/sigma_color=subnormal, and their kin.
HUGE = np.full((H, W), 1e38, np.float32)
EXTREME_VALUES = {
    "unreliable_pixels jump=1e308": lambda: unreliable_pixels(_ramp(), jump=1e308),
    "unreliable_pixels disparity=+-3e38": lambda: unreliable_pixels(np.where(np.arange(W) % 2, 3e38, -3e38)
                                                                    .astype(np.float32)[None].repeat(H, 0)),
    "weighted_median_filter sigma_color=5e-324": lambda: weighted_median_filter(_ramp(), _pair()[0], radius=2,
                                                                               sigma_color=5e-324),
    "refine_disparity sigma_color=5e-324": lambda: refine_disparity(_ramp(), _pair()[0], sigma_color=5e-324),
    "confidence_map raw=1e38": lambda: confidence_map(HUGE, _ramp()),
    "confidence_map refined=-1e38": lambda: confidence_map(_ramp(), -HUGE),
    "disparity_preview hi=5e-324": lambda: disparity_preview(_ramp(), lo=0.0, hi=5e-324),
    "left_right_check disparity_left=1e38": lambda: left_right_check(HUGE, _ramp()),
    "left_right_check tolerance=1e308": lambda: left_right_check(_ramp(), _ramp(), tolerance=1e308),
    "middlebury_regions truth=1e38": lambda: middlebury_regions(HUGE),
    "evaluate_disparity truth=1e38": lambda: evaluate_disparity(_ramp(), HUGE.astype(np.float64), threshold=1.0),
    "depth_from_disparity disparity=5e-324": lambda: depth_from_disparity(np.array([5e-324, 1.0]), focal_px=500.0,
                                                                          baseline=0.1),
}


@pytest.mark.parametrize("case", list(EXTREME_VALUES))
def test_extreme_values_compute_without_warnings(case):
    out = EXTREME_VALUES[case]()
    values = out.values() if isinstance(out, dict) else [out]
    for v in values:
        v = getattr(v, "bad", getattr(v, "disparity", v))  # a RegionScore's figure, a RefinedDisparity's map
        assert np.isfinite(v).any()


def test_extreme_values_give_the_limit_answers():
    # no jump of 1e308 px anywhere; the ramp has no outlier either
    assert not unreliable_pixels(_ramp(), jump=1e308).any()
    # a subnormal sigma_color: only votes of the centre's exact colour count, as in the sigma -> 0 limit
    guide = np.zeros((H, W), np.float32)
    guide[:, W // 2:] = 1.0
    d = np.where(np.arange(W) < W // 2, 2.0, 6.0).astype(np.float32)[None].repeat(H, 0)
    np.testing.assert_array_equal(weighted_median_filter(d, guide, radius=3, sigma_color=5e-324), d)
    # 1e308 px of tolerance accepts every match that stays in the image
    np.testing.assert_array_equal(left_right_check(_ramp(), np.zeros((H, W)), tolerance=1e308)[:, 4:], True)
    # 5e-324 px of disparity: as far as infinity (NaN), like 0
    np.testing.assert_allclose(depth_from_disparity(np.array([5e-324, 1.0]), focal_px=500.0, baseline=0.1),
                               [np.nan, 50.0])
    # hi - lo = 5e-324: every positive disparity is past hi, the top of turbo
    top = disparity_preview(np.array([[1.0]]), lo=0.0, hi=1.0)
    np.testing.assert_array_equal(disparity_preview(_ramp(), lo=0.0, hi=5e-324)[0, 0], top[0, 0])


# name -> (call, message): options past what the computation can represent (sweep cases with huge values)
OUT_OF_RANGE = {
    "remove_speckles max_size=2**63": (lambda: remove_speckles(_ramp(), max_size=2**63),
                                       r"^max_size must be at most 2147483647 px \(OpenCV's int\); got 9223372036854775808$"),
    "refine_disparity speckle_size=2**63": (lambda: refine_disparity(_ramp(), _pair()[0], speckle_size=2**63),
                                            r"^max_size must be at most"),
    "remove_speckles max_difference=1e308": (lambda: remove_speckles(_ramp(), max_size=4, max_difference=1e308),
                                             r"^max_difference must be at most 4094 px"),
    "weighted_median_filter step=2**63": (lambda: weighted_median_filter(_ramp(), _pair()[0], radius=2, step=2**63),
                                          r"^step must not exceed radius \(2 px\)"),
    "disparity_from_depth baseline=1e308": (lambda: disparity_from_depth(_ramp(), focal_px=500.0, baseline=1e308),
                                            r"^baseline times focal_px must be a finite number; got 1e\+308 m x 500 px$"),
    "depth_from_disparity baseline=1e308": (lambda: depth_from_disparity(_ramp(), focal_px=500.0, baseline=1e308),
                                            r"^baseline times focal_px must be a finite number"),
    "disparity_from_depth depth=1e-320": (lambda: disparity_from_depth(np.array([1e-320, 1.0]), focal_px=500.0,
                                                                       baseline=0.1),
                                          r"^depth must be large enough for a finite disparity"),
}


@pytest.mark.parametrize("case", list(OUT_OF_RANGE))
def test_values_past_the_representable_range_are_refused(case):
    call, message = OUT_OF_RANGE[case]
    with pytest.raises(ValueError, match=message):
        call()


def test_evaluate_disparity_rms_of_errors_past_the_square_root_of_the_float_range():
    """Kin of the sweep's huge values: errors of 1e200 px (a float64 .npy) squared to inf with a warning."""
    truth = np.zeros((30, 30))
    estimate = np.full((30, 30), 1e200)
    estimate[:15] = 0.0  # half the pixels exact: RMS = 1e200 / sqrt(2)
    np.testing.assert_allclose(evaluate_disparity(estimate, truth)["all"].rms, 1e200 / np.sqrt(2), rtol=1e-12)
    with pytest.raises(ValueError, match=r"^estimate - truth must be a finite number of pixels"):
        evaluate_disparity(np.full((30, 30), 1e308), np.full((30, 30), -1e308))
