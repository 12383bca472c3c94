"""The camera graph and its capture paths: a ring and a walk with known answers, dino and kermit."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.stereospace import (
    MAX_AXIS_ANGLE_DEG,
    MIN_SHARED_POINTS,
    NEAR_FACTOR,
    Collection,
    camera_graph,
    capture_paths,
    load_collection,
)


def _collection(cams, **kw) -> Collection:
    names = tuple(f"c{i}" for i in range(len(cams)))
    return Collection(names=names, cameras=tuple(cams), image_paths=names, **kw)


def _ring(n=12, radius=1.0):
    return [look_at([radius * np.cos(a), radius * np.sin(a), 0], [0, 0, 0], [0, 0, 1], fov_deg=50, width=64, height=48)
            for a in 2 * np.pi * np.arange(n) / n]  # fmt: skip


def _walk(n=6, step=1.0):
    return [look_at([i * step, 0, 0], [i * step, 0, 10], [0, -1, 0], fov_deg=50, width=64, height=48) for i in range(n)]


def test_a_ring_of_12_is_a_cycle_and_its_path_one_closed_polyline():
    graph = camera_graph(_collection(_ring()))
    assert graph.edges.tolist() == sorted([min(k, (k + 1) % 12), max(k, (k + 1) % 12)] for k in range(12))
    np.testing.assert_allclose(graph.axis_angle_deg, 30.0, atol=1e-9)
    np.testing.assert_allclose(graph.baseline, 2 * np.sin(np.radians(15)), atol=1e-12)
    assert graph.neighbours(0) == [1, 11]
    assert capture_paths(graph) == [[*range(12), 0]]


def test_a_walk_joins_cameras_within_three_spacings_and_its_path_is_open():
    graph = camera_graph(_collection(_walk(6)))
    want = [[i, j] for i in range(6) for j in range(i + 1, 6) if j - i <= NEAR_FACTOR]
    assert graph.edges.tolist() == want
    np.testing.assert_allclose(graph.baseline, [j - i for i, j in want])
    assert capture_paths(graph) == [[0, 1, 2, 3, 4, 5]]
    # The thresholds are the rule: one spacing joins only neighbours.
    assert camera_graph(_collection(_walk(6)), near_factor=1.0).edges.tolist() == [[i, i + 1] for i in range(5)]


def test_two_walks_far_apart_give_two_polylines():
    far = [look_at([i, 100, 0], [i, 100, 10], [0, -1, 0], fov_deg=50, width=64, height=48) for i in range(3)]
    assert capture_paths(camera_graph(_collection(_walk(4) + far))) == [[0, 1, 2, 3], [4, 5, 6]]


def test_a_branching_walk_comes_out_as_a_chain_and_a_branch():
    # A T: five cameras along x and two going off from the middle one along y, all looking down +z.
    pos = [[i, 0, 0] for i in range(5)] + [[2, 1, 0], [2, 2, 0]]
    cams = [look_at(p, np.add(p, [0, 0, 10]), [0, -1, 0], fov_deg=50, width=64, height=48) for p in pos]
    paths = capture_paths(camera_graph(_collection(cams), near_factor=1.0))
    assert paths == [[0, 1, 2, 3, 4], [2, 5, 6]]


def test_shared_points_decide_when_the_collection_has_observations():
    cams = _ring(12)
    pts, obs = [], []
    for k in range(12):  # MIN_SHARED_POINTS points seen by k and k+1, except 4 for the pair (5, 6)
        for _ in range(MIN_SHARED_POINTS if k != 5 else 4):
            obs += [[len(pts), k], [len(pts), (k + 1) % 12]]
            pts.append([0.0, 0.0, 0.0])
    pix = np.zeros((len(obs), 2))
    graph = camera_graph(_collection(cams, points=pts, observations=obs, observation_pixels=pix))
    assert [5, 6] not in graph.edges.tolist() and len(graph.edges) == 11
    assert set(graph.shared_points.tolist()) == {MIN_SHARED_POINTS}
    assert capture_paths(graph) == [[5, 4, 3, 2, 1, 0, 11, 10, 9, 8, 7, 6]]  # open: (5, 6) is not an edge


def test_no_overlapping_pairs_is_refused_in_one_line():
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=50, width=64, height=48)
    b = look_at([0.1, 0, 0], [0.1, 0, -1], [0, -1, 0], fov_deg=50, width=64, height=48)  # opposite way
    assert MAX_AXIS_ANGLE_DEG < 180
    with pytest.raises(ValueError, match=r"^the collection has no overlapping pairs of cameras: "):
        camera_graph(_collection([a, b]))
    with pytest.raises(TypeError, match="collection must be a Collection"):
        camera_graph([a, b])
    with pytest.raises(ValueError, match="near_factor must be positive"):
        camera_graph(_collection(_walk(3)), near_factor=0)


def test_dino_is_one_closed_ring_and_kermit_a_connected_walk(shared_data, dino):
    folder = shared_data / "collections"
    graph = camera_graph(dino[0])
    paths = capture_paths(graph)
    assert len(paths) == 1 and paths[0][0] == paths[0][-1] and sorted(paths[0][:-1]) == list(range(48))
    assert (graph.shared_points >= MIN_SHARED_POINTS).all() and (graph.axis_angle_deg <= MAX_AXIS_ANGLE_DEG).all()
    kermit = load_collection(folder / "kermit" / "bundle.out", images=folder / "kermit")
    kgraph = camera_graph(kermit)
    covered = {v for p in capture_paths(kgraph) for v in p}
    assert covered == set(range(9)) and len(kgraph.edges) >= 8
