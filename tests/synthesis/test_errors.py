"""User-input errors of the synthesis functions that no other test reaches: each names the argument,
the expectation and what came."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.display import side_by_side, top_bottom
from vergence.synthesis import (
    ParallaxPlan,
    StereoResult,
    WarpedView,
    baseline_weights,
    epipole,
    error_image,
    fill_disparity,
    fill_holes,
    forward_warp,
    interpolate_view,
    median_refine,
    plan_parallax,
    refine_camera_warp,
    synthesize_stereo,
    synthesize_view,
    synthesize_views,
    warp_to_camera,
)
from vergence.viewing.geometry import Display
from vergence.viewing.mapping import LinearMapping

IMG = np.zeros((2, 3), np.float32)
MAP = np.ones((2, 3), np.float32)
HOLES = np.zeros((2, 3), bool)
DEPTH = np.array([[1.0, 2.0, 4.0], [1.0, 2.0, 4.0]])
CAM = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=2)
CAM_RIGHT = look_at([0.1, 0, 0], [0.1, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=2)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"image": np.zeros(3)}, ValueError, r"WarpedView.image must have shape \(H, W\) or \(H, W, C\)"),
        ({"nearness_unit": "m"}, ValueError, r"WarpedView.nearness_unit must be one of px, 1/m; got 'm'"),
        ({"holes": np.zeros((2, 2), bool)}, ValueError, r"WarpedView.holes must have shape \(2, 3\) matching image; got \(2, 2\)"),
        ({"depth": np.ones((3, 3))}, ValueError, r"WarpedView.depth must have shape \(2, 3\)"),
        ({"payload": {"g": np.ones(3)}}, ValueError, r"WarpedView.payload\['g'\] must have shape \(2, 3\)"),
        ({"holes": np.zeros((2, 3))}, TypeError, "WarpedView.holes must be a bool array; got float64"),
        ({"reliability": np.ones((2, 3), np.uint8)}, TypeError, "WarpedView.reliability must be a bool array; got uint8"),
    ],
)
def test_warped_view_checks_its_fields(kwargs, error, match):
    fields = {"image": IMG, "holes": HOLES, "nearness": MAP, **kwargs}
    with pytest.raises(error, match=match):
        WarpedView(**fields)


def test_warped_view_payload_is_read_only_and_to_dict():
    v = WarpedView(IMG, HOLES, MAP, payload={"g": MAP})
    with pytest.raises(TypeError):
        v.payload["h"] = MAP
    assert v.to_dict() == {"size": [3, 2], "holes_percent": 0.0, "nearness_unit": "px", "payload": ["g"]}


def test_median_refine_needs_a_rectified_warp():
    metric = WarpedView(IMG, HOLES, MAP, "1/m", MAP)
    with pytest.raises(ValueError, match="warped must come from a rectified warp .*got nearness in 1/m"):
        median_refine(metric, IMG, MAP, scale=1.0)


def test_refine_camera_warp_needs_a_metric_warp_of_the_target_size():
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=2)
    b = look_at([0.1, 0, 0], [0.1, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=2)
    with pytest.raises(ValueError, match="warped must carry metric depth"):
        refine_camera_warp(forward_warp(IMG, MAP), IMG, MAP, a, b)
    small = WarpedView(np.zeros((2, 2), np.float32), np.zeros((2, 2), bool), np.ones((2, 2), np.float32), "1/m", np.ones((2, 2), np.float32))
    with pytest.raises(ValueError, match=r"warped.image must have shape \(2, 3\) .*got \(2, 2\)"):
        refine_camera_warp(small, IMG, MAP, a, b)
    assert refine_camera_warp(warp_to_camera(IMG, MAP, a, b), IMG, MAP, a, b).depth.shape == (2, 3)


def test_baseline_weights_bad_positions():
    with pytest.raises(ValueError, match=r"positions must have shape \(N,\) with N >= 1; got \(0,\)"):
        baseline_weights([], 0.0)
    with pytest.raises(ValueError, match=r"positions must be distinct; got \[0.0, 0.0\]"):
        baseline_weights([0.0, 0.0], 0.5)


def test_fill_disparity_and_fill_holes_shapes():
    with pytest.raises(ValueError, match=r"disparity must have shape \(H, W\); got \(3,\)"):
        fill_disparity(np.ones(3))
    with pytest.raises(ValueError, match=r"holes must have shape \(H, W\); got \(2, 3, 1\)"):
        fill_holes(IMG, MAP, np.zeros((2, 3, 1), bool))
    with pytest.raises(TypeError, match="disparity must be numeric; got str"):
        forward_warp(IMG, "near")


def test_synthesize_stereo_and_views_bad_arguments():
    with pytest.raises(ValueError, match=r"depth must have shape \(H, W\) matching image \(2, 3\); got \(2, 2\)"):
        synthesize_stereo(IMG, np.ones((2, 2)), budget_px=1.0)
    with pytest.raises(ValueError, match="offsets must hold at least one view position; got none"):
        synthesize_views(IMG, MAP, offsets=())
    with pytest.raises(ValueError, match=r"offsets\[1\] must be finite"):
        synthesize_views(IMG, MAP, offsets=(0.0, np.nan))
    with pytest.raises(ValueError, match=r"smooth_sigma must lie in \(0, 1024\] pixels \(MAX_SMOOTH_SIGMA\); got 0"):
        synthesize_stereo(IMG, np.array([[1.0, 2, 3], [1, 2, 3]]), budget_px=1.0, smooth_sigma=0.0)
    with pytest.raises(ValueError, match="fill must be one of background, inpaint, mirror; got 'blur'"):
        synthesize_views(IMG, MAP, fill="blur")


def test_plan_parallax_and_results_refuse_inconsistent_parts():
    depth = np.array([[1.0, 2.0]])
    with pytest.raises(TypeError, match="mapping must be a DisparityMapping; got str"):
        plan_parallax(depth, mapping="log")
    with pytest.raises(ValueError, match="display resolution is unknown"):
        plan_parallax(depth, budget_arcmin=10.0, display=Display(0.065, 0.6, 0.5))
    with pytest.raises(ValueError, match="depth must not be flat at the convergence depth"):
        plan_parallax(np.full((1, 8), 2.0), budget_px=4.0, convergence=2.0)
    with pytest.raises(ValueError, match=r"parallax_px must have shape \(H, W\); got \(2,\)"):
        ParallaxPlan(np.zeros(2), LinearMapping(0, 1, 0, 1), (0.0, 1.0), None)
    with pytest.raises(ValueError, match=r"range_px must be \(min, max\) with min <= max; got \(1.0, 0.0\)"):
        ParallaxPlan(np.zeros((1, 2)), LinearMapping(0, 1, 0, 1), (1.0, 0.0), None)
    plan = plan_parallax(depth, budget_px=1.0)
    with pytest.raises(ValueError, match="views, holes and offsets must have one length; got 2, 1, 2"):
        StereoResult(views=(IMG, IMG), holes=(HOLES,), offsets=(0.0, 1.0), plan=plan)


# Issue 9: API calls that returned values (or raised an internal error) instead of a one-line error.
@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: fill_disparity(np.full((2, 3), np.nan)), ValueError, r"disparity must have at least one known value"),
        (lambda: forward_warp(np.zeros((2, 3, 4), np.float32), MAP), ValueError, r"image must be grey .*got shape \(2, 3, 4\) \(an alpha channel"),
        (lambda: forward_warp(np.zeros((2, 3, 4), np.uint8), MAP), ValueError, r"image must be grey .*an alpha channel"),
        (lambda: epipole(CAM, CAM), ValueError, r"target must not share the source's centre \[0.0, 0.0, 0.0\]"),
        (lambda: synthesize_stereo(IMG, DEPTH, budget_px=1.0, smooth_sigma=1e308), ValueError, r"smooth_sigma must lie in \(0, 1024\] pixels"),
        (lambda: synthesize_stereo(IMG, DEPTH, budget_px=1.0, edge_dilation=10**20), ValueError, r"edge_dilation must lie in \[0, 64\] pixels \(MAX_FILTER_RADIUS\)"),
        (lambda: interpolate_view(IMG, MAP, IMG, MAP, 0.5, contour_width=10**9), ValueError, r"contour_width must lie in \[0, 64\]"),
        (lambda: synthesize_stereo(IMG, DEPTH, budget_px=1.0, views=10**9), ValueError, r"views must lie in \[2, 128\] \(MAX_VIEWS\)"),
        (lambda: ParallaxPlan(np.zeros((1, 2)), LinearMapping(0, 1, 0, 1), (0.0,), None), ValueError, r"range_px must be a pair \(min, max\); got \(0.0,\)"),
        (lambda: ParallaxPlan(np.zeros((1, 2)), LinearMapping(0, 1, 0, 1), None, None), ValueError, r"range_px must be a pair"),
        (lambda: ParallaxPlan(np.zeros((1, 2)), LinearMapping(0, 1, 0, 1), (0.0, np.nan), None), ValueError, r"range_px\[1\] must be finite"),
        (lambda: ParallaxPlan(np.zeros((1, 2)), "linear", (0.0, 1.0), None), TypeError, r"mapping must be a DisparityMapping; got str"),
        (lambda: ParallaxPlan(np.zeros((1, 2)), LinearMapping(0, 1, 0, 1), (0.0, 1.0), (1.0,)), ValueError, r"range_arcmin must be a pair"),
        # Our own sweep (1106 bad arguments to every synthesis and display function): float32
        # overflow warnings on huge tolerances, ComplexWarning on complex arrays.
        (lambda: synthesize_stereo(IMG, DEPTH, budget_px=1.0, gradient_limit=1e308), ValueError, r"gradient_limit must be at most 3.403e\+38 in magnitude \(a float32\); got 1e\+308"),
        (lambda: interpolate_view(IMG, MAP, IMG, MAP, 0.5, depth_tolerance=1e308), ValueError, r"depth_tolerance must be at most 3.403e\+38"),
        (lambda: error_image(IMG, IMG, gain=1e308), ValueError, r"gain must be at most 3.403e\+38"),
        (lambda: forward_warp(IMG, MAP.astype(np.complex64)), TypeError, r"disparity must be real; got a complex array"),
        (lambda: forward_warp(IMG.astype(np.complex64), MAP), TypeError, r"image must be a numeric image .*got complex64"),
        (lambda: fill_holes(IMG, MAP.astype(np.complex64), HOLES), TypeError, r"disparity must be real"),
        (lambda: baseline_weights(np.array([0, 1], np.complex64), 0.5), TypeError, r"positions must be real"),
        (lambda: synthesize_view(IMG, np.full((2, 3), 1e-40), CAM, CAM_RIGHT), ValueError, r"depth must be >= .* m for these cameras \(its disparity f b / Z must be a float32\)"),
    ],
)
def test_issue9_bad_api_calls_raise_one_line_errors(call, error, match):
    with pytest.raises(error, match=match):
        call()


# Issue 9, sweep round 2 (api/interpolate_view/median=string): a bool option given a string returned
# a view ("no" is truthy); every bool option of synthesis and display refuses a non-bool.
@pytest.mark.parametrize(
    "call",
    [
        lambda value: interpolate_view(IMG, MAP, IMG, MAP, 0.5, median=value),
        lambda value: side_by_side(IMG, IMG, half=value),
        lambda value: top_bottom(IMG, IMG, half=value),
    ],
    ids=["interpolate_view.median", "side_by_side.half", "top_bottom.half"],
)
@pytest.mark.parametrize("value", ["no", 1, None])
def test_bool_options_refuse_a_non_bool(call, value):
    with pytest.raises(TypeError, match=rf"(median|half) must be a bool; got {type(value).__name__}"):
        call(value)


def test_median_refine_refuses_a_scale_that_moves_pixels_past_the_width():
    # Issue 9 full sweep (api/median_refine/scale=huge): numpy's overflow warning in the inverse warp's cast.
    warped = forward_warp(IMG, MAP, scale=1.0)
    with pytest.raises(ValueError, match=r"^scale 1e\+308 times the largest source disparity moves pixels"):
        median_refine(warped, IMG, MAP, scale=1e308)
