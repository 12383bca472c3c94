"""The whole-image offset plan (S3 §3.4): the low-resolution solve and its importance-weighted,
edge-aware upsampling, checked against the per-pixel descent it wraps."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from vergence.specular import IMPORTANCE_FLOOR, OffsetAnalysis, OffsetPlanner, optimise_offsets
from vergence.viewing import Display

ZONE = (-60.0, 60.0)


def _analysis(k=8, n=3, h=12, w=16, seed=0):
    """Disparity that scales with the offset (d(y) = y x physical), rivalry growing as y leaves 1."""
    rng = np.random.default_rng(seed)
    ys = np.arange(k + 1) / k
    physical = rng.normal(0.0, 120.0, (n, h, w, 2)).astype(np.float32)
    physical[..., 1] *= 0.05
    disparity = (ys[:, None, None, None, None] * physical[None]).astype(np.float32)
    rivalry = ((1 - ys)[:, None, None, None] * rng.uniform(0, 3, (n, h, w))[None]).astype(np.float32)
    importance = np.broadcast_to(rng.uniform(0, 1, (n, h, w)).astype(np.float32), (k + 1, n, h, w)).copy()
    importance[:, 2, :, : w // 2] = 0.0  # half of layer 3 unimportant
    return OffsetAnalysis(offsets=ys, disparity=disparity, rivalry=rivalry, importance=importance,
                          exposure=1.0, display=Display.preset("samsung-2233rz"), seconds=0.0)  # fmt: skip


def test_factor_one_radius_zero_is_the_per_pixel_descent_on_the_physical_importance():
    a = _analysis()
    plan = OffsetPlanner(a, factor=1, radius=0, blur_radius=0).solve(variant="comfort", zone=ZONE)
    # the physical pair's importance, at least the floor on every matched pixel
    weight = np.maximum(a.importance[-1], IMPORTANCE_FLOOR)
    sol = optimise_offsets(a.disparity, a.rivalry, weight, a.original, variant="comfort", zone=ZONE)
    assert_array_equal(plan.y, sol.y.astype(np.float32))
    assert np.all(plan.y[0] == 1.0)
    # the unimportant half of layer 3 is solved too (the floor): its far pixels come in
    far = np.abs(a.original[2, ..., 0]) > 200
    assert plan.y[2][far & (a.importance[-1, 2] == 0)].max() < 0.5


def test_a_block_without_a_match_takes_its_neighbours_offset_not_a_constant():
    """One surface at 150' (brought in to y = 45 / 150 = 0.3) with a hole of unmatched pixels:
    the hole's offset is filled from around it (push-pull), not set to 1 (issue 26's stripes)."""
    k, h, w = 16, 16, 24
    ys = np.arange(k + 1) / k
    physical = np.zeros((2, h, w, 2), np.float32)
    physical[1, ..., 0] = 150.0
    disparity = (ys[:, None, None, None, None] * physical[None]).astype(np.float32)
    disparity[:, 1, 4:12, 8:16] = np.nan  # no match there at any offset
    importance = np.ones((k + 1, 2, h, w), np.float32)
    importance[:, 1, 4:12, 8:16] = 0.0
    a = OffsetAnalysis(offsets=ys, disparity=disparity, rivalry=np.zeros((k + 1, 2, h, w), np.float32),
                       importance=importance, exposure=1.0, display=Display.preset("samsung-2233rz"),
                       seconds=0.0)  # fmt: skip
    plan = OffsetPlanner(a, factor=4).solve(variant="comfort", zone=ZONE)
    np.testing.assert_allclose(plan.y[1], 0.3, atol=0.01)


def test_the_plan_pulls_far_layers_in_and_is_full_resolution():
    a = _analysis(h=24, w=32)
    plan = OffsetPlanner(a, factor=4).solve(variant="comfort", zone=ZONE)
    assert plan.y.shape == (3, 24, 32) and plan.y_low.shape == (3, 6, 8) and plan.factor == 4
    far = (np.abs(a.original[1, ..., 0]) > 200) & (a.importance[-1, 1] > 0.5)
    near = (np.abs(a.original[1, ..., 0]) < 30) & (a.importance[-1, 1] > 0.5)
    assert plan.y[1][far].mean() < plan.y[1][near].mean()
    assert not plan.y.flags.writeable


def test_resolving_with_new_weights_reuses_the_reduction_and_changes_the_answer():
    a = _analysis(h=24, w=32)
    planner = OffsetPlanner(a, factor=2)
    first = planner.solve(variant="comfort", zone=ZONE)
    data_heavy = planner.solve(alpha=(1, 1, 10, 100), variant="comfort", zone=ZONE)
    assert data_heavy.y[1:].mean() > first.y[1:].mean()  # a heavy data term keeps the physical stereo
    maps = {t: np.ones((3, 24, 32)) for t in ("absolute", "relative", "rivalry", "data")}
    for t in maps:
        maps[t][1] = 0.0  # layer 2 painted out of every term: frozen at y = 1
    painted = planner.solve(variant="comfort", zone=ZONE, maps=maps)
    assert np.all(painted.y_low[1] == 1.0) and np.all(painted.y[1] == 1.0)
    assert painted.y[2].min() < 1.0  # the other layers still move
    half = {t: m.copy() for t, m in maps.items()}
    for t in half:
        half[t][1, :, 16:] = 1.0  # the right half of layer 2 painted back in
    partly = planner.solve(variant="comfort", zone=ZONE, maps=half)
    assert np.all(partly.y[1][:, :16] == 1.0) and partly.y[1][:, 16:].min() < 1.0


def test_the_blur_evens_out_a_surface_but_keeps_its_edge():
    """One layer, two surfaces: the left half far behind the zone (150'), the right half inside it
    (10'); rivalry of random strength makes the per-pixel solutions scatter. The blurred plan varies less
    within each half than the raw descent, and the two halves keep their own offsets."""
    k, h, w = 16, 16, 32
    ys = np.arange(k + 1) / k
    physical = np.zeros((2, h, w, 2), np.float32)
    physical[1, :, : w // 2, 0], physical[1, :, w // 2 :, 0] = 150.0, 10.0
    disparity = (ys[:, None, None, None, None] * physical[None]).astype(np.float32)
    rng = np.random.default_rng(1)
    # rivalry of the physical pair, falling to 0 at mono, RMS up to 20 ΔL*: scattered solutions
    rivalry = (ys[:, None, None, None] * rng.uniform(0, 400, (2, h, w))[None]).astype(np.float32)
    importance = np.broadcast_to(rng.uniform(0.2, 1, (2, h, w)).astype(np.float32), (k + 1, 2, h, w)).copy()
    a = OffsetAnalysis(offsets=ys, disparity=disparity, rivalry=rivalry, importance=importance, exposure=1.0,
                       display=Display.preset("samsung-2233rz"), seconds=0.0)  # fmt: skip
    raw = OffsetPlanner(a, factor=1, radius=0, blur_radius=0).solve(variant="comfort", zone=ZONE).y[1]
    blurred = OffsetPlanner(a, factor=1, radius=0).solve(variant="comfort", zone=ZONE).y[1]
    for half in (np.s_[:, : w // 2], np.s_[:, w // 2 :]):
        assert blurred[half].std() < 0.5 * raw[half].std()
    # the edge: the far half's offsets do not leak into the near half (a 140' step, sigma_range 6')
    assert abs(blurred[:, : w // 2].mean() - raw[:, : w // 2].mean()) < 0.05
    assert abs(blurred[:, w // 2 :].mean() - raw[:, w // 2 :].mean()) < 0.05


def test_bad_inputs():
    a = _analysis()
    with pytest.raises(TypeError, match="OffsetAnalysis"):
        OffsetPlanner("analysis")
    for kwargs, match in (({"factor": 0}, "factor"), ({"radius": -1}, "radius"), ({"sigma_range": 0}, "sigma_range"),
                          ({"sigma_space": np.nan}, "sigma_space"), ({"blur_radius": 17}, "blur_radius"),
                          ({"blur_sigma": -1.0}, "blur_sigma")):  # fmt: skip
        with pytest.raises(ValueError, match=match):
            OffsetPlanner(a, **kwargs)
    planner = OffsetPlanner(a)
    with pytest.raises(ValueError, match="data weight map must have shape"):
        planner.solve(maps={"data": np.ones((3, 2, 2))})
    with pytest.raises(ValueError, match="unknown terms"):
        planner.solve(maps={"flatness": np.ones((3, 12, 16))})
    with pytest.raises(ValueError, match="finite and >= 0"):
        planner.solve(maps={"data": -np.ones((3, 12, 16))})
    with pytest.raises(ValueError, match="comfort variant needs zone"):
        planner.solve(variant="comfort")
