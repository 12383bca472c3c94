"""Which way is up, and which eye is the left one, on collections whose photos are rolled (S2 §4.2).

Checked against world positions, never against the rule the code uses: a ring of cameras around a
point cloud with a known world up (+y), some cameras rolled about their optical axes by 90 to 180
degrees; and dino (shared data), whose photos are all rolled 90 degrees from its ring, with every
third camera rolled a further 180 degrees.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_allclose

from vergence.camera import Camera, look_at
from vergence.stereospace import (
    Collection,
    StereoState,
    collection_up,
    eye_order,
    pair_quality,
    pan,
    space_from_graph,
    camera_graph,
    stereo_pair,
)
from vergence.viewing import Display

UP = np.array([0.0, 1.0, 0.0])  # the synthetic ring's world up
N_RING = 24


def _rolled(cam: Camera, angle: float) -> Camera:
    """``cam`` turned by ``angle`` about its optical axis (camera frame z): ``R' = Rz R``, same centre."""
    c, s = math.cos(angle), math.sin(angle)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Camera(K=cam.K, R=Rz @ cam.R, t=Rz @ cam.t, width=cam.width, height=cam.height)


def _ring(rolls: dict[int, float]) -> Collection:
    """24 cameras on a circle of radius 3 around a cloud of points at the origin, image up +y, camera k
    rolled by ``rolls[k]`` radians. The images are never read (the views are drawn by a callable)."""
    cams = []
    for k in range(N_RING):
        a = 2 * math.pi * k / N_RING
        cam = look_at([3 * math.cos(a), 0.0, 3 * math.sin(a)], [0, 0, 0], UP, fov_deg=50, width=64, height=48)
        cams.append(_rolled(cam, rolls.get(k, 0.0)))
    pts = np.random.default_rng(5).uniform(-0.6, 0.6, (300, 3))
    return Collection(names=tuple(f"c{k}.png" for k in range(N_RING)), cameras=tuple(cams),
                      image_paths=tuple(f"c{k}.png" for k in range(N_RING)), points=pts)  # fmt: skip


def _blank(_prepared, cam: Camera) -> np.ndarray:
    return np.zeros((cam.height, cam.width), dtype=np.float32)


# 12 of 24 cameras rolled: 150 and 180 degrees on pairs of neighbours (their segments' cameras are
# rolled past 90 degrees), 90 degrees on a third camera of every six.
ROLLS = {k: math.radians({1: 150, 2: 180, 4: 90}[k % 6]) for k in range(N_RING) if k % 6 in (1, 2, 4)}


def _consecutive_states(col: Collection, count: int) -> list[StereoState]:
    """The states halfway along two consecutive ring segments, going round the ring."""
    space, ends = space_from_graph(col, camera_graph(col))
    order = {tuple(sorted(e)): s for s, e in enumerate(ends.tolist())}
    states = []
    for k in range(count):
        a, b, c = k % len(col), (k + 1) % len(col), (k + 2) % len(col)
        s1, s2 = order[tuple(sorted((a, b)))], order[tuple(sorted((b, c)))]
        states.append(StereoState((min(s1, s2), max(s1, s2)), 0.5, 0.5))
    return states


def test_collection_up_of_a_partly_rolled_ring_is_the_world_up():
    """12 of 24 cameras rolled by 90-180 degrees: the mean image-up shrinks to a third, the up does not move."""
    col = _ring(ROLLS)
    mean_up = np.array([-c.R[1] for c in col.cameras]).mean(axis=0)
    assert np.linalg.norm(mean_up) < 0.4
    assert_allclose(collection_up(col.cameras), UP, atol=1e-9)
    everyone_upside_down = _ring({k: math.pi for k in range(N_RING) if k % 4})  # 18 of 24 rolled 180: votes say -y
    assert_allclose(collection_up(everyone_upside_down.cameras), -UP, atol=1e-9)


def test_sixteen_consecutive_pairs_of_a_rolled_ring_keep_one_orientation():
    """Around the ring, each rectified pair's rows run down the world (R[1] . up < 0) and its left eye
    stands to the world left of its right eye, seen along the left eye's view (x_right - x_left along
    forward x up > 0), whichever eye of the state it is. The rule this replaces (the first eye's
    image x axis) turns some of these pairs upside down."""
    col = _ring(ROLLS)
    old_orientation = set()
    for state in _consecutive_states(col, 16):
        res = stereo_pair(col, state, method=_blank)
        cam_l, cam_r = res.rectified
        assert cam_l.R[1] @ UP < -0.99 and cam_r.R[1] @ UP < -0.99  # upright (the ring is level)
        right_of_view = np.cross(cam_l.R[2], UP)
        assert (cam_r.center - cam_l.center) @ right_of_view > 0
        first, second = res.cameras
        assert_allclose(cam_l.center, (second if res.swapped else first).center, atol=1e-12)
        old_swapped = bool((second.center - first.center) @ first.R[0] < 0.0)
        old_left = second if old_swapped else first
        old_orientation.add(bool(np.cross(old_left.R[2], (first.center + second.center - 2 * old_left.center)) @ UP > 0))
    assert old_orientation == {False, True}  # the old rule flips on this path


def test_pair_quality_orders_the_eyes_as_the_pair():
    col = _ring(ROLLS)
    display = Display(eye_separation=0.065, distance=0.6, width=0.52, resolution=1920)
    for state in _consecutive_states(col, 6):
        res = stereo_pair(col, state, method=_blank)
        assert pair_quality(col, res.cameras, display)["swapped"] == res.swapped


def test_panning_right_moves_the_stereo_camera_right_in_the_world():
    """Issue 30: the page pans by +v, or -v when the pair is swapped (positive pan runs from the first
    eye to the second). On the rolled ring each right-arrow press must move the stereo camera (the
    eyes' midpoint) to the world right of the view, every time."""
    col = _ring(ROLLS)
    space, _ = space_from_graph(col, camera_graph(col))
    state = _consecutive_states(col, 1)[0]
    moved = 0
    for _ in range(16):
        res = stereo_pair(col, state, method=_blank)
        before = space.eyes(state).mean(axis=0)
        right_of_view = np.cross(res.rectified[0].R[2], UP)
        move = pan(space, state, -0.05 if res.swapped else 0.05)
        if move.event == "stopped":
            break
        step = space.eyes(move.state).mean(axis=0) - before
        assert step @ right_of_view > 0, f"pressed right, moved {step @ right_of_view:+.3f} m"
        state, moved = move.state, moved + 1
    assert moved >= 8


def test_eye_order_falls_back_to_the_image_axis_for_a_baseline_along_up():
    a = look_at([0, 0, 0], [0, 0, 5], UP, fov_deg=60, width=64, height=48)
    b = look_at([0, 0.1, 0], [0, 0.1, 5], UP, fov_deg=60, width=64, height=48)
    assert eye_order(a, b, UP) == bool((b.center - a.center) @ a.R[0] < 0)


def test_dino_rolled_further_keeps_one_orientation(dino):
    """dino's photos are rolled 90 degrees from its ring (their up axes lie in the ring's plane, their
    x axes along its normal: the old rule's cosine is ~0); every third camera rolled 180 degrees more.
    16 consecutive ring states keep one orientation: the rectified down axis on one side of the ring's
    normal, the left eye on the same side of the view."""
    base, _ = dino  # the session's triangulated dino (conftest)
    cams = tuple(_rolled(c, math.pi) if k % 3 == 0 else c for k, c in enumerate(base.cameras))
    col = Collection(names=base.names, cameras=cams, image_paths=base.image_paths, points=base.points)
    centers = col.centers
    normal = np.linalg.svd(centers - centers.mean(axis=0))[2][2]
    signs = set()
    for state in _consecutive_states(col, 16):
        cam_l, cam_r = stereo_pair(col, state, method=_blank).rectified
        assert abs(cam_l.R[1] @ normal) > 0.9  # the baseline runs along the ring: rows across it
        signs.add(bool(cam_l.R[1] @ normal > 0))
        signs.add(bool((cam_r.center - cam_l.center) @ np.cross(cam_l.R[2], normal) < 0))
    assert len(signs) == 1
