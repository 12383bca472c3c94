"""Zoom, pan and the jump between regions of the stereospace (S2 §4.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.stereospace import JUMP_CONE_DEG, MOVE_EVENTS, StereoSpace, StereoState, pan, pan_sign, tangent, zoom

# Two parallel unit segments 1 apart: regions (0, 0), (0, 1), (1, 1).
LADDER = StereoSpace([[[0, 0, 0], [1, 0, 0]], [[0, 1, 0], [1, 1, 0]]])
# A polyline: segment 1 continues segment 0.
POLYLINE = StereoSpace([[[0, 0, 0], [1, 0, 0]], [[1, 0, 0], [2, 0, 0]]])
# Where the jump lands, in parameter: the tessellation is refined to about 5e-4 (JUMP_SAMPLES).
JUMP_TOL = 2e-3


def _sw(space, state):
    return space.point(state.region[0], state.li, state.region[1], state.lj)[3]


coord = st.floats(-5.0, 5.0, allow_nan=False)
inner = st.floats(0.05, 0.95)


@settings(max_examples=60, deadline=None)
@given(seg=st.lists(coord, min_size=12, max_size=12), li=inner, lj=inner)
def test_gradient_matches_finite_differences(seg, li, lj):
    space = StereoSpace(np.array(seg).reshape(2, 2, 3))
    state = StereoState((0, 1), li, lj)
    if _sw(space, state) < 1e-2:  # s_w is not differentiable where the eyes meet
        return
    h = 1e-6
    fd = [
        (space.point(0, li + h, 1, lj)[3] - space.point(0, li - h, 1, lj)[3]) / (2 * h),
        (space.point(0, li, 1, lj + h)[3] - space.point(0, li, 1, lj - h)[3]) / (2 * h),
    ]
    # central differences: error ~ h² s_w''' plus round-off ~ 1e-16 * 10 / h
    assert_allclose(space.gradient(state), fd, rtol=0, atol=1e-6)


def test_gradient_by_hand():
    # eyes (0.2, 0, 0) and (0.7, 1, 0): d = (-0.5, -1, 0), u_i = u_j = (1, 0, 0)
    g = LADDER.gradient(StereoState((0, 1), 0.2, 0.7))
    assert_allclose(g, np.array([-0.5, 0.5]) / math.hypot(0.5, 1.0), atol=1e-15)


@pytest.mark.parametrize(("region", "li", "lj"), [((0, 1), 0.2, 0.7), ((0, 0), 0.3, 0.8), ((0, 1), 0.9, 0.4)])
def test_pan_keeps_the_interocular_distance_to_first_order(region, li, lj):
    space = StereoSpace([[[0, 0, 0], [1, 0, 0.2]], [[0.3, 1, 0], [1.2, 1.4, 0]]])
    state = StereoState(region, li, lj)
    T = tangent(space, state)
    assert abs(T @ space.gradient(state)) < 1e-15
    assert_allclose(np.linalg.norm(T), 1.0)
    errors = []
    for v in (1e-3, 5e-4):
        moved = pan(space, state, v)
        assert moved.event == "moved"
        errors.append(abs(_sw(space, moved.state) - _sw(space, state)))
        mid_shift = space.point(region[0], moved.state.li, region[1], moved.state.lj)[:3] - space.point(region[0], li, region[1], lj)[:3]
        assert_allclose(np.linalg.norm(mid_shift), v, rtol=1e-9)  # the mid-point is affine in (li, lj)
    if region == (0, 0):  # on a triangle s_w = |lj - li| |u|: exactly constant along T = (1, 1)/√2
        assert max(errors) < 1e-14
        return
    assert errors[0] < 0.05 * 1e-3  # far below the step
    assert 0.2 < errors[1] / errors[0] < 0.3  # second order: halving the step quarters the error


def test_pan_moves_along_the_baseline():
    state = StereoState((0, 0), 0.2, 0.5)  # first eye at x = 0.2, second at x = 0.5
    moved = pan(LADDER, state, 0.1)
    assert moved.event == "moved"
    assert_allclose((moved.state.li, moved.state.lj), (0.3, 0.6), atol=1e-12)
    assert_allclose(_sw(LADDER, moved.state), 0.3, atol=1e-12)


@pytest.mark.parametrize("v", [0.05, -0.05, 0.01])
def test_zoom_changes_the_interocular_distance_by_v(v):
    space = StereoSpace([[[0, 0, 0], [1, 0, 0.2]], [[0.3, 1, 0], [1.2, 1.4, 0]]])
    state = StereoState((0, 1), 0.4, 0.6)
    moved = zoom(space, state, v)
    assert moved.event == "moved"
    change = _sw(space, moved.state) - _sw(space, state)
    assert abs(change - v) < 2 * v * v  # first order in v
    assert zoom(space, state, 0.0).state == state


def test_zoom_where_the_gradient_vanishes():
    # eyes on the triangle's diagonal coincide: s_w grows along (-1, 1) by exactly v
    moved = zoom(LADDER, StereoState((0, 0), 0.5, 0.5), 0.2)
    assert moved.event == "moved"
    assert_allclose((moved.state.li, moved.state.lj), (0.4, 0.6), atol=1e-12)
    # eyes straight across the ladder: s_w = 1 is the minimum, it grows to 1.1 exactly
    moved = zoom(LADDER, StereoState((0, 1), 0.5, 0.5), 0.1)
    assert_allclose(_sw(LADDER, moved.state), 1.1, atol=1e-12)
    # nothing has an interocular distance below 0
    assert zoom(LADDER, StereoState((0, 0), 0.5, 0.5), -0.1).event == "stopped"


def test_zoom_slides_along_the_border():
    # at lj = 1 the gradient (-1, 1)/√... pushes lj out: only li moves, s_w still grows by v
    moved = zoom(LADDER, StereoState((0, 0), 0.5, 1.0), 0.1)
    assert moved.event == "moved"
    assert_allclose((moved.state.li, moved.state.lj), (0.4, 1.0), atol=1e-12)


def test_jump_none_in_the_cone_stops_at_the_border():
    # At the top of triangle (0, 0), p = (0.5, 0, 0, 1), zooming in heads along +s_w. The ladder's
    # region (0, 1) is 0.5 away in y and at most √2 - 1 higher: at least atan(0.5 / 0.414) = 50.4° off.
    top = StereoState((0, 0), 0.0, 1.0)
    moved = zoom(LADDER, top, 0.1)
    assert moved == type(moved)(top, "stopped")
    assert JUMP_CONE_DEG == 40.0


def test_jump_lands_on_the_closest_point_in_the_cone():
    # With a 60° cone the closest point of region (0, 1) is on the cone: Δy = 0.5, Δs_w = 0.5 / tan 60°,
    # mid-point x = 0.5 (li + lj = 1) and s_w = √((lj - li)² + 1) = 1 + 0.5 / tan 60°.
    moved = zoom(LADDER, StereoState((0, 0), 0.0, 1.0), 0.1, cone_deg=60.0)
    assert moved.event == "jumped"
    assert moved.state.region == (0, 1)
    gap = math.sqrt((1 + 0.5 / math.tan(math.radians(60))) ** 2 - 1)
    # of the two mirror solutions the one with the baseline along +x (the current orientation)
    assert_allclose((moved.state.li, moved.state.lj), ((1 - gap) / 2, (1 + gap) / 2), atol=JUMP_TOL)


def test_jump_along_a_polyline_then_slide():
    # At the top of triangle (0, 0) the eyes are the ends of segment 0; region (0, 1) holds the same
    # pair at (0, 0), and zooming in goes on there with the second eye on segment 1.
    moved = zoom(POLYLINE, StereoState((0, 0), 0.0, 1.0), 0.3)
    assert moved.event == "jumped"
    assert moved.state.region == (0, 1)
    assert_allclose((moved.state.li, moved.state.lj), (0.0, 0.0), atol=JUMP_TOL)
    moved = zoom(POLYLINE, moved.state, 0.3)
    assert moved.event == "moved"
    assert_allclose(moved.state.li, 0.0, atol=JUMP_TOL)
    assert_allclose(_sw(POLYLINE, moved.state), 1.3, atol=JUMP_TOL)
    assert set(MOVE_EVENTS) == {"moved", "jumped", "stopped"}


def test_pan_off_the_end_stops():
    moved = pan(LADDER, StereoState((0, 0), 0.2, 0.5), -0.3)
    assert moved.event == "stopped"
    assert_allclose((moved.state.li, moved.state.lj), (0.0, 0.3), atol=1e-12)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: zoom(LADDER, StereoState((0, 0), 0.2, 0.5), np.nan), ValueError, "v must be finite"),
        (lambda: pan(LADDER, StereoState((0, 0), 0.2, 0.5), "1"), TypeError, "v must be a real number"),
        (lambda: zoom(LADDER, StereoState((0, 0), 0.2, 0.5), 0.1, cone_deg=95), ValueError, r"cone_deg must lie in \[0, 90\]"),
        (lambda: pan(LADDER, StereoState((0, 0), 0.5, 0.2), 0.1), ValueError, "li must be <= lj"),
        (lambda: zoom(LADDER, (0, 0, 0.1, 0.2), 0.1), TypeError, "state must be a StereoState"),
        (lambda: tangent(LADDER, StereoState((0, 2), 0.1, 0.2)), ValueError, "does not exist"),
    ],
)
def test_bad_navigation_arguments(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_jump_keeps_the_orientation_of_the_eyes():
    # On a ring of 10 cameras the pair (camera 0, camera 1) is also in region (1, 9) with the eyes
    # swapped; the jump must go on with camera 0 as the first eye, i.e. to region (0, 1) at (0, 0).
    # There the second eye moves on along segment 1, which turns by 36°: s_w grows at cos 36° = 0.81
    # and the view position moves at 0.5, atan(0.5 / 0.81) = 31.7° off the zoom: inside the cone.
    t = np.linspace(0.0, 2 * np.pi, 11)
    ring = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1)
    space = StereoSpace(np.stack([ring[:-1], ring[1:]], axis=1))
    top = StereoState((0, 0), 0.0, 1.0)
    moved = zoom(space, top, 0.05)
    assert moved.event == "jumped"
    assert moved.state.region == (0, 1)
    assert_allclose((moved.state.li, moved.state.lj), (0.0, 0.0), atol=JUMP_TOL)
    before, after = np.diff(space.eyes(top), axis=0)[0], np.diff(space.eyes(moved.state), axis=0)[0]
    assert before @ after > 0.9 * (before @ before)


def test_vectorised_coarse_search_matches_the_per_region_loop():
    from vergence.stereospace.navigation import _closest_in_cone, _coarse_candidates

    rng = np.random.default_rng(3)
    space = StereoSpace(rng.uniform(-1, 1, (4, 2, 3)))
    p = space.point(1, 0.3, 2, 0.6)
    baseline = np.diff(space._eyes((1, 2), 0.3, 0.6), axis=0)[0]
    unit = np.array([0.3, -0.2, 0.1, 1.0]) / np.linalg.norm([0.3, -0.2, 0.1, 1.0])
    cos_max = math.cos(math.radians(50.0))
    fast = {c.region: c for c in _coarse_candidates(space, (1, 2), p, unit, cos_max, baseline)}
    slow = {}
    for region in space.regions:
        found = _closest_in_cone(space, region, p, unit, cos_max, baseline, refinements=0)
        if region != (1, 2) and found is not None:
            slow[region] = found
    assert len(slow) >= 3
    assert fast.keys() == slow.keys()
    for region, c in slow.items():
        assert (fast[region].agrees, fast[region].distance) == (c.agrees, pytest.approx(c.distance, abs=1e-14))
        assert_allclose(fast[region].lam, c.lam)


@settings(max_examples=40, deadline=None)
@given(seg=st.lists(coord, min_size=18, max_size=18), li=st.floats(0, 1), lj=st.floats(0, 1), v=st.floats(-2.0, 2.0))
def test_moves_stay_in_the_space(seg, li, lj, v):
    space = StereoSpace(np.array(seg).reshape(3, 2, 3))
    for region in ((0, 2), (1, 1)):
        a, b = (min(li, lj), max(li, lj)) if region == (1, 1) else (li, lj)
        state = StereoState(region, a, b)
        for move in (zoom(space, state, v), pan(space, state, v)):
            assert move.event in MOVE_EVENTS
            space.check_state(move.state)  # a valid state of this space
            if move.event != "jumped":
                assert move.state.region == region
        zoomed = zoom(space, state, v)
        if v > 0 and zoomed.event == "moved":  # s_w is convex in (li, lj): a step up the gradient rises
            assert _sw(space, zoomed.state) >= _sw(space, state) - 1e-12


@pytest.mark.parametrize("seed", range(6))
def test_compiled_coarse_search_matches_the_per_region_loop_on_larger_spaces(seed):
    """The Numba kernel against its slow twin (``_closest_in_cone`` without refinement, region by
    region) on random spaces of 9 segments (45 regions, triangles included), random cones and moves."""
    from vergence.stereospace.navigation import _closest_in_cone, _coarse_candidates

    rng = np.random.default_rng(100 + seed)
    space = StereoSpace(rng.uniform(-1, 1, (9, 2, 3)))
    current = (int(rng.integers(0, 4)), int(rng.integers(4, 9)))
    li, lj = rng.uniform(0, 1, 2)
    p = space.point(current[0], li, current[1], lj)
    baseline = np.diff(space._eyes(current, li, lj), axis=0)[0]
    i, j = sorted(int(k) for k in rng.integers(0, 9, 2))
    unit = space.point(i, 0.5, j, 0.5) - p + 0.2 * rng.normal(size=4)
    unit /= np.linalg.norm(unit)  # towards the space, so that some regions lie in the cone
    cos_max = math.cos(math.radians(float(rng.uniform(30.0, 80.0))))
    fast = {c.region: c for c in _coarse_candidates(space, current, p, unit, cos_max, baseline)}
    slow = {}
    for region in space.regions:
        found = _closest_in_cone(space, region, p, unit, cos_max, baseline, refinements=0)
        if region != current and found is not None:
            slow[region] = found
    assert len(slow) >= 3 and fast.keys() == slow.keys()
    for region, c in slow.items():
        assert fast[region].agrees == c.agrees
        assert fast[region].distance == pytest.approx(c.distance, abs=1e-12)
        assert_allclose(fast[region].lam, c.lam)


# Three unit segments end to end along x: the eyes can walk the whole row.
ROW = StereoSpace([[[0, 0, 0], [1, 0, 0]], [[1, 0, 0], [2, 0, 0]], [[2, 0, 0], [3, 0, 0]]])


@pytest.mark.parametrize("v", [1.2, 0.9, 1.45])
def test_a_pan_past_a_jump_spends_its_whole_step(v):
    # Eyes at x = 0.5 and 1.5 (view position x = 1, interocular 1). A pan by v moves the view position
    # to x = 1 + v in the world: 0.5 inside region (0, 1), the rest after the jump (the tree before
    # issue 27 stopped at x = 1.5, the landing point, dropping the remainder).
    start = StereoState((0, 1), 0.5, 0.5)
    moved = pan(ROW, start, v)
    assert moved.event == "jumped"
    eyes = ROW.eyes(moved.state)
    assert_allclose(eyes.mean(axis=0), [1.0 + v, 0.0, 0.0], atol=JUMP_TOL)
    assert_allclose(eyes[1] - eyes[0], [1.0, 0.0, 0.0], atol=JUMP_TOL)  # same interocular, same order
    back = pan(ROW, moved.state, -v)
    assert_allclose(ROW.eyes(back.state).mean(axis=0), [1.0, 0.0, 0.0], atol=2 * JUMP_TOL)


def test_a_pan_past_the_last_region_stops_there_after_jumping():
    moved = pan(ROW, StereoState((0, 1), 0.5, 0.5), 5.0)
    assert moved.event == "jumped"  # jumped once, then stopped at the row's end
    assert_allclose(ROW.eyes(moved.state), [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]], atol=JUMP_TOL)


# ---------------------------------------------------------------- which pan is "right" (issue 30)
def test_pan_sign_by_hand():
    """LADDER's segment 0 runs along +x; a view looking along +z with up -y has its right at +x
    (camera frame: x = y x z with y = -up): from the first eye (x = 0.2) towards the second (0.5) is
    right, from the second towards the first (the state read the other way round) too."""
    forward, up = [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]
    assert pan_sign(LADDER, StereoState((0, 0), 0.2, 0.5), forward=forward, up=up) == 1.0
    assert pan_sign(LADDER, StereoState((0, 0), 0.2, 0.5), forward=[0.0, 0.0, -1.0], up=up) == -1.0
    moved = pan(LADDER, StereoState((0, 0), 0.2, 0.5), 0.1 * pan_sign(LADDER, StereoState((0, 0), 0.2, 0.5),
                                                                          forward=[0.0, 0.0, -1.0], up=up))
    assert moved.state.li < 0.2  # looking along -z, right is -x


@pytest.mark.parametrize("bad", [[0.0, 1.0], [np.nan, 0.0, 1.0]])
def test_pan_sign_refuses_bad_directions(bad):
    with pytest.raises(ValueError, match="forward must be 3 finite numbers"):
        pan_sign(LADDER, StereoState((0, 0), 0.2, 0.5), forward=bad, up=[0.0, -1.0, 0.0])


def test_right_presses_move_kermit_right_in_the_world(shared_data):
    """Issue 30: on kermit the eyes' order flips inside region (13, 15) (the baseline turns past the
    view's axis), so the page's old rule (pan by -step when the pair is swapped) went back and forth
    (map x -0.09, +0.08, -0.13, +0.03, -0.18). With :func:`pan_sign` every right press moves the eyes'
    midpoint (world positions, the library's eyes) along the start view's world right, until it stops."""
    from vergence.stereospace import PreparedCollection, eye_order, load_collection, pair_cameras, start_state
    from vergence.viewing import Display

    folder = shared_data / "collections" / "kermit"
    prepared = PreparedCollection(load_collection(folder / "bundle.out", images=folder), grid_step=16)
    space, col, cams, up = prepared.space, prepared.collection, prepared.segment_cameras, prepared.up
    start = start_state(prepared, Display.preset("desktop-24"))[0]
    first, second = pair_cameras(space, col, start, segment_cameras=cams)
    right = np.cross(first.R[2] + second.R[2], up)  # the start view's world right, fixed for the walk
    step = 0.25 * space.point(start.region[0], start.li, start.region[1], start.lj)[3]  # the page's pan step

    def walk(rule):
        state, xs = start, [float(space.eyes(start).mean(axis=0) @ right)]
        for _ in range(8):
            a, b = pair_cameras(space, col, state, segment_cameras=cams)
            move = pan(space, state, step * rule(state, a, b))
            if move.event == "stopped":
                break
            state = move.state
            xs.append(float(space.eyes(state).mean(axis=0) @ right))
        return np.diff(xs)

    new = walk(lambda s, a, b: pan_sign(space, s, forward=a.R[2] + b.R[2], up=up))
    assert len(new) >= 6 and (new > 0).all(), new
    old = walk(lambda s, a, b: -1.0 if eye_order(a, b, up) else 1.0)
    assert (old < 0).any(), old  # the flag's rule goes back: the walk above would catch a return to it
