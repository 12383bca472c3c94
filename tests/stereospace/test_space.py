"""The stereospace of S2 §4: stereo points, regions, and the map back to parameters (S2 §4.2)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.stereospace import RELATIVE_TOLERANCE, StereoSpace, StereoState, stereo_point

# Round trips on well-conditioned random segments come back to ~1e-13; 1e-9 is the library's own
# tolerance for "in the region", so a solver off by more than round-off fails.
ROUND_TRIP_TOL = 1e-9

SQUARE = StereoSpace([[[0, 0, 0], [1, 0, 0]], [[0, 1, 0], [1, 1, 0]], [[2, 0, 0], [2, 1, 1]]])


def test_stereo_point_is_midpoint_and_distance():
    assert_allclose(stereo_point([1, 2, 3], [4, 6, 3]), [2.5, 4.0, 3.0, 5.0])
    assert_allclose(stereo_point([1, 2, 3], [1, 2, 3]), [1, 2, 3, 0])


def test_regions_are_the_ordered_pairs():
    assert SQUARE.regions == ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    assert len(StereoSpace(np.zeros((5, 2, 3))).regions) == 15


def test_point_by_hand():
    # first eye at (0.25, 0, 0) on segment 0, second at (2, 0.5, 0.5) on segment 2
    p = SQUARE.point(0, 0.25, 2, 0.5)
    d = np.array([2 - 0.25, 0.5, 0.5])
    assert_allclose(p, [(0.25 + 2) / 2, 0.25, 0.25, np.linalg.norm(d)])
    assert_allclose(SQUARE.eyes(StereoState((0, 2), 0.25, 0.5)), [[0.25, 0, 0], [2, 0.5, 0.5]])


def test_points_matches_point():
    rng = np.random.default_rng(0)
    lam = rng.random((20, 2))
    got = SQUARE.points(lam, region=(1, 2))
    want = [SQUARE.point(1, a, 2, b) for a, b in lam]
    assert_allclose(got, want, rtol=0, atol=1e-15)
    lam.sort(axis=1)
    assert_allclose(SQUARE.points(lam, region=(0, 0))[:, 3], lam[:, 1] - lam[:, 0], atol=1e-15)


coord = st.floats(-10.0, 10.0, allow_nan=False)
unit = st.floats(0.0, 1.0)


@settings(max_examples=80, deadline=None)
@given(seg=st.lists(coord, min_size=12, max_size=12), li=unit, lj=unit)
def test_round_trip_on_random_regions(seg, li, lj):
    space = StereoSpace(np.array(seg).reshape(2, 2, 3))
    tol = ROUND_TRIP_TOL * 10  # graph size up to 10
    u = space.segments[:, 1] - space.segments[:, 0]
    lengths = np.linalg.norm(u, axis=1)
    for i, j in ((0, 1), (0, 0), (1, 1)):
        a, b = (min(li, lj), max(li, lj)) if i == j else (li, lj)
        p = space.point(i, a, j, b)
        got = space.parameters(p, region=(i, j))
        assert_allclose(space.point(i, got[0], j, got[1]), p, rtol=0, atol=tol)
        sine = np.linalg.norm(np.cross(u[i], u[j])) / max(lengths[i] * lengths[j], 1e-300)
        if i != j and min(lengths) > 0.1 and sine > 0.1:  # injective and well conditioned: same pair
            assert_allclose(got, (a, b), rtol=0, atol=1e-9)
        if i == j and lengths[i] > 0.1:  # the triangle: the canonical half comes back
            assert_allclose(got, (a, b), rtol=0, atol=1e-9)


def test_parallel_segments_give_the_oriented_solution():
    # segments 0 and 1 are parallel (S2 §4.2): (0.2, 0.7) and (0.7, 0.2) share the mid-point and distance
    p = SQUARE.point(0, 0.2, 1, 0.7)
    assert_allclose(p, [0.45, 0.5, 0.0, np.hypot(0.5, 1.0)])
    assert_allclose(SQUARE.point(0, 0.7, 1, 0.2), p, atol=1e-15)
    # default: the baseline (second eye - first) points along segment 0
    assert_allclose(SQUARE.parameters(p, region=(0, 1)), (0.2, 0.7), atol=1e-12)
    # near a pair whose baseline points the other way, the mirrored solution keeps that orientation
    assert_allclose(SQUARE.parameters(p, region=(0, 1), near=(0.9, 0.1)), (0.7, 0.2), atol=1e-12)
    assert_allclose(SQUARE.parameters(p, region=(0, 1), near=(0.1, 0.9)), (0.2, 0.7), atol=1e-12)


def test_antiparallel_and_collinear_segments():
    space = StereoSpace([[[0, 0, 0], [1, 0, 0]], [[4, 1, 0], [2, 1, 0]], [[2, 0, 0], [3, 0, 0]]])
    for region, lam in (((0, 1), (0.3, 0.25)), ((0, 2), (0.6, 0.1)), ((1, 2), (0.9, 0.4))):
        p = space.point(region[0], lam[0], region[1], lam[1])
        got = space.parameters(p, region=region, near=lam)
        assert_allclose(got, lam, atol=1e-12)


def test_triangle_region_is_the_half_li_le_lj():
    p = SQUARE.point(0, 0.2, 0, 0.9)
    assert_allclose(p, [0.55, 0, 0, 0.7], atol=1e-15)
    assert_allclose(SQUARE.parameters(p, region=(0, 0)), (0.2, 0.9), atol=1e-12)
    # the diagonal: coincident eyes, interocular distance 0
    assert_allclose(SQUARE.point(2, 0.5, 2, 0.5), [2, 0.5, 0.5, 0], atol=1e-15)
    assert_allclose(SQUARE.parameters([2, 0.5, 0.5, 0], region=(2, 2)), (0.5, 0.5), atol=1e-9)
    with pytest.raises(ValueError, match="li must be <= lj on the triangle"):
        SQUARE.point(0, 0.9, 0, 0.2)


def test_zero_length_segment_is_a_fixed_camera():
    space = StereoSpace([[[0, 0, 0], [0, 0, 0]], [[1, 0, 0], [1, 2, 0]]])
    p = space.point(0, 0.3, 1, 0.5)  # the first parameter does not move the eye
    assert_allclose(p, [0.5, 0.5, 0, np.sqrt(2)])
    assert space.parameters(p, region=(0, 1)) == (0.0, pytest.approx(0.5, abs=1e-12))
    assert space.parameters([0, 0, 0, 0], region=(0, 0)) == (0.0, 0.0)
    with pytest.raises(ValueError, match="not in region"):
        space.parameters([0, 0, 0, 0.1], region=(0, 0))


@pytest.mark.parametrize(
    ("point", "region", "off"),
    [
        ([0.5, 0.5, 0.0, 0.5], (0, 1), 0.5),  # interocular distance below the segments' gap of 1
        ([0.5, 0.5, 0.3, 1.0], (0, 1), 0.3),  # mid-point off the plane of the two segments
        ([0.5, 0.0, 0.0, 1.5], (0, 0), 0.5),  # longer than the segment
    ],
)
def test_points_off_the_region_are_refused_with_the_distance(point, region, off):
    with pytest.raises(ValueError, match=rf"not in region \({region[0]}, {region[1]}\): its best fit in the region is {off:g} away"):
        SQUARE.parameters(point, region=region)


def test_point_beyond_a_rhomboid_is_refused():
    p = SQUARE.point(0, 1.0, 2, 1.0) + np.array([1.0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"not in region \(0, 2\)"):
        SQUARE.parameters(p, region=(0, 2))


def test_tolerance_scales_with_the_graph():
    assert SQUARE.tolerance == RELATIVE_TOLERANCE * 2.0
    p = SQUARE.point(0, 0.3, 2, 0.6)
    SQUARE.parameters(p + [0, 0, 0, 0.5 * SQUARE.tolerance], region=(0, 2))
    with pytest.raises(ValueError, match="not in region"):
        SQUARE.parameters(p + [0, 0, 0, 1e3 * SQUARE.tolerance], region=(0, 2))


@pytest.mark.parametrize(
    ("segments", "error", "match"),
    [
        (np.zeros((0, 2, 3)), ValueError, "at least one segment"),
        (np.zeros((2, 3)), ValueError, r"shape \(m, 2, 3\)"),
        (np.zeros((2, 2, 2)), ValueError, r"shape \(m, 2, 3\)"),
        (np.full((1, 2, 3), np.nan), ValueError, "segments must be finite"),
        (np.full((1, 2, 3), np.inf), ValueError, "segments must be finite"),
        ("abc", TypeError, "segments must be numeric"),
    ],
)
def test_bad_segments(segments, error, match):
    with pytest.raises(error, match=match):
        StereoSpace(segments)


@pytest.mark.parametrize(
    ("args", "error", "match"),
    [
        ((0, 0.5, 3, 0.5), ValueError, r"region \(0, 3\) does not exist"),
        ((-1, 0.5, 0, 0.5), ValueError, "does not exist"),
        ((2, 0.5, 1, 0.5), ValueError, r"i <= j; \(2, 1\) is region \(1, 2\) with the eyes swapped"),
        ((0.0, 0.5, 1, 0.5), TypeError, "region must hold integers"),
        ((0, 1.5, 1, 0.5), ValueError, r"li must lie in \[0, 1\]"),
        ((0, 0.5, 1, -0.1), ValueError, r"lj must lie in \[0, 1\]"),
        ((0, np.nan, 1, 0.5), ValueError, "li must be finite"),
        ((0, "a", 1, 0.5), TypeError, "li must be a real number"),
    ],
)
def test_bad_point_arguments(args, error, match):
    with pytest.raises(error, match=match):
        SQUARE.point(*args)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"point": [0, 0, 0]}, ValueError, r"point must have shape \(4,\)"),
        ({"point": [0, 0, np.nan, 1]}, ValueError, "point must be finite"),
        ({"point": [0, 0, 0, -1]}, ValueError, "interocular distance >= 0"),
        ({"region": (0,)}, TypeError, "region must be a pair"),
        ({"region": (1, 0)}, ValueError, "eyes swapped"),
        ({"near": (0.1,)}, ValueError, r"near must have shape \(2,\)"),
        ({"near": (0.1, 2.0)}, ValueError, r"lj must lie in \[0, 1\]"),
    ],
)
def test_bad_parameters_arguments(kwargs, error, match):
    args = {"point": SQUARE.point(0, 0.2, 1, 0.7), "region": (0, 1)} | kwargs
    with pytest.raises(error, match=match):
        SQUARE.parameters(args.pop("point"), **args)


def test_bad_points_and_states():
    with pytest.raises(ValueError, match=r"params must have shape \(N, 2\)"):
        SQUARE.points(np.zeros((3, 3)), region=(0, 1))
    with pytest.raises(ValueError, match=r"params must lie in \[0, 1\]"):
        SQUARE.points([[0.5, 1.5]], region=(0, 1))
    with pytest.raises(ValueError, match="li <= lj on the triangle"):
        SQUARE.points([[0.5, 0.4]], region=(1, 1))
    with pytest.raises(ValueError, match="params must be finite"):
        SQUARE.points([[0.5, np.inf]], region=(0, 1))
    with pytest.raises(TypeError, match="state must be a StereoState"):
        SQUARE.eyes((0, 0.1, 1, 0.2))
    with pytest.raises(TypeError, match="region must be a pair"):
        StereoState((0, 1, 2), 0.1, 0.2)
    with pytest.raises(ValueError, match="lj must be finite"):
        StereoState((0, 1), 0.1, np.nan)
    with pytest.raises(ValueError, match="does not exist"):
        SQUARE.eyes(StereoState((0, 7), 0.1, 0.2))


def test_locate_finds_the_first_region_holding_the_point():
    # (0.5, 0, 0, 0.6) is on triangle (0, 0) only; the ladder's rungs (0, 1) start at s_w = 1
    state = SQUARE.locate([0.5, 0, 0, 0.6])
    assert state.region == (0, 0)
    assert_allclose((state.li, state.lj), (0.2, 0.8), atol=1e-12)
    p = SQUARE.point(1, 0.3, 2, 0.9)
    state = SQUARE.locate(p)
    assert state.region == (1, 2)
    assert_allclose((state.li, state.lj), (0.3, 0.9), atol=1e-12)
    # of the two mirror solutions on the ladder, the one oriented as the current view
    p = SQUARE.point(0, 0.2, 1, 0.7)
    state = SQUARE.locate(p, current=StereoState((0, 1), 0.9, 0.1))
    assert state.region == (0, 1)
    assert_allclose((state.li, state.lj), (0.7, 0.2), atol=1e-12)
    with pytest.raises(ValueError, match=r"not in the stereospace: its best fit, in region \(0, 0\), is 0.781 away"):
        SQUARE.locate([0.5, 0, -0.5, 0.6])
    with pytest.raises(ValueError, match="point must be finite"):
        SQUARE.locate([0.5, 0, np.inf, 0.6])
