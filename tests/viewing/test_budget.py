"""Tests of vergence.viewing.budget: the depth budget and its JSON against hand-worked S0 §2 values."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vergence.viewing.budget import (
    DIVERGENCE_FLAG_ULPS,
    DEFAULT_DEPTH_FACTORS,
    DepthBudget,
    DepthSample,
    default_depths,
    depth_budget,
)
from vergence.viewing.geometry import Display, Shooting

# Hand values are short decimal products: a few roundings.
RTOL = 1e-12

EPS = float(np.finfo(float).eps)
RIG = Shooting(baseline=0.26, convergence=30.0, window=3.0)  # f = 10
TV = Display(eye_separation=0.065, distance=3.0, width=1.2, resolution=1920)  # f' = 2.5


def test_json_matches_hand_computation():
    # b_div = b'W/W' = 0.065*3/1.2; b_round = b'H/H' = 0.065*30/3; f/f' = 10/2.5.
    # b'W - bW' = -0.117, bHW' = 9.36, b'H'W = 0.585, bH'W = 2.34; divergence beyond 80 m.
    out = depth_budget(RIG, TV, [30.0, 60.0, 90.0]).to_dict()
    assert list(out) == ["divergence_baseline", "roundness_baseline", "focal_ratio", "divergence_depth", "depths", "warnings"]
    # d(60) = (0.26/3)(1/2) = 0.0433 lies inside the +-60 arcmin zone at 3 m (+-3 tan(1 deg)/1.2 = 0.0436);
    # 90 m diverges (issue 9: divergence is a warning in the JSON and on stderr).
    assert out["warnings"] == ["the eyes diverge at z = 90 m (beyond z = 80 m): baseline b = 0.26 m exceeds "
                               "b_div = 0.1625 m (S0 Eq. 3)"]
    assert out["divergence_baseline"] == pytest.approx(0.1625, rel=RTOL)
    assert out["roundness_baseline"] == pytest.approx(0.65, rel=RTOL)
    assert out["focal_ratio"] == pytest.approx(4.0, rel=RTOL)
    d60, d90 = 0.26 / 3 * 30 / 60, 0.26 / 3 * 60 / 90
    expected = [
        {"depth": 30.0, "disparity": 0.0, "parallax_px": 0.0, "perceived_depth": 3.0, "roundness": 0.4,
         "diverges": False},
        {"depth": 60.0, "disparity": d60, "parallax_px": d60 * 1920, "perceived_depth": 60 * 0.585 / 2.34,
         "roundness": 1.0, "diverges": False},
        {"depth": 90.0, "disparity": d90, "parallax_px": d90 * 1920, "perceived_depth": None,
         "roundness": 2.34 / (90 * -0.117 + 9.36), "diverges": True},
    ]
    assert len(out["depths"]) == 3
    for got, want in zip(out["depths"], expected):
        assert list(got) == list(want)
        for key, value in want.items():
            if isinstance(value, float):
                assert got[key] == pytest.approx(value, rel=RTOL, abs=1e-15), key
            else:
                assert got[key] is value, key
    assert out["depths"][2]["roundness"] == pytest.approx(-2.0, rel=RTOL)  # Eq. (4) as is past divergence
    json.dumps(out, allow_nan=False)  # strict JSON: no NaN or inf anywhere


def test_parallax_px_only_when_the_resolution_is_known():
    out = depth_budget(RIG, Display(0.065, 3.0, 1.2), [45.0]).to_dict()
    assert list(out["depths"][0]) == ["depth", "disparity", "perceived_depth", "roundness", "diverges"]
    assert depth_budget(RIG, Display(0.065, 3.0, 1.2), [45.0]).samples[0].parallax_px is None


def test_result_fields_and_divergence_depth():
    budget = depth_budget(RIG, TV, [30.0])
    assert isinstance(budget, DepthBudget) and isinstance(budget.samples[0], DepthSample)
    assert budget.divergence_depth == pytest.approx(80.0, rel=RTOL)
    assert depth_budget(Shooting(0.1, 30.0, 3.0), TV, [30.0]).divergence_depth == math.inf
    with pytest.raises(dataclasses.FrozenInstanceError):
        budget.focal_ratio = 1.0  # type: ignore[misc]


def test_exactly_parallel_eyes_give_null_depth_and_roundness_without_divergence():
    # Dyadic numbers make the Eq. (2) denominator exactly zero: z (b'W - bW') + bHW' = -0.5 z + 4 at z = 8.
    rig, display = Shooting(1.0, 4.0, 1.0), Display(0.5, 2.0, 1.0)
    s = depth_budget(rig, display, [8.0]).samples[0]
    assert s.disparity == 0.5 == display.divergence_disparity
    assert s.perceived_depth is None and s.roundness is None and s.diverges is False
    json.dumps(depth_budget(rig, display, [8.0]).to_dict(), allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(b_over_b_div=st.floats(1.001, 100.0), H=st.floats(0.5, 100.0), W=st.floats(0.1, 50.0))
def test_the_reported_divergence_depth_is_where_the_samples_turn_parallel(b_over_b_div, H, W):
    # The depth the budget prints ("eyes diverge beyond z") is reported as parallel eyes (z' = inf ->
    # null, not diverging), the float below it as a finite depth and the float above as diverging, even
    # where the reported disparity rounds an ulp past b'/W' (40 m in the README: d = 0.054166666666666675).
    rig = Shooting(b_over_b_div * 0.065 * W / 1.2, H, W)
    z_div = depth_budget(rig, TV, [H]).divergence_depth
    depths = [math.nextafter(z_div, 0.0), z_div, math.nextafter(z_div, math.inf)]
    below, at, above = depth_budget(rig, TV, depths).samples
    assert below.perceived_depth is not None and below.perceived_depth > 0 and not below.diverges
    assert at.perceived_depth is None and at.roundness is None and not at.diverges
    assert above.perceived_depth is None and above.diverges
    assert DIVERGENCE_FLAG_ULPS * EPS * z_div >= math.nextafter(z_div, math.inf) - z_div  # the band holds them


def test_the_flag_follows_the_reported_disparity_away_from_the_limit():
    # Issue 9: b/W = 6e8 against b'/W' = 9.2e-9 put divergence within an ulp of H, and the z-form flagged
    # z = H (d = 0) as diverging. Away from the limit the flag is d > b'/W' (S0 Eq. 8) on the reported d.
    rig = Shooting(1088.2641991636679, 1.4329443467964356, 1.8137187195233712e-06)
    display = Display(0.0004698117716817455, 0.0003132103786608234, 51027.87555034109)
    depths = [rig.convergence, math.nextafter(rig.convergence, math.inf), 2 * rig.convergence]
    for s in depth_budget(rig, display, depths).samples:
        assert s.diverges == (s.disparity > display.divergence_disparity)


def test_baseline_equal_to_the_reported_divergence_baseline_never_diverges():
    # b'W/W' times W' need not round back to b'W: the reported b_div must still be safe at any depth.
    for W in (0.3, 1.7, 2.9, 3.0, 7.3):
        b_div = depth_budget(Shooting(0.1, 30.0, W), TV, [30.0]).divergence_baseline
        budget = depth_budget(Shooting(b_div, 30.0, W), TV, [30.0, 1e9, 1e15])
        assert budget.divergence_depth == math.inf
        assert not any(s.diverges for s in budget.samples)


def test_default_depths_are_multiples_of_the_convergence_distance():
    assert DEFAULT_DEPTH_FACTORS == (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
    assert default_depths(RIG) == (15.0, 22.5, 30.0, 45.0, 60.0, 90.0, 150.0, 300.0)
    budget = depth_budget(RIG, TV)
    assert [s.depth for s in budget.samples] == list(default_depths(RIG))
    assert [s.diverges for s in budget.samples] == [False] * 5 + [True] * 3  # past 80 m


def test_depth_order_is_kept_and_a_scalar_depth_is_accepted():
    budget = depth_budget(RIG, TV, np.array([60.0, 15.0, 30.0]))
    assert [s.depth for s in budget.samples] == [60.0, 15.0, 30.0]
    assert [s.depth for s in depth_budget(RIG, TV, 42.0).samples] == [42.0]


@settings(max_examples=40, deadline=None)
@given(b=st.floats(0.01, 10.0), H=st.floats(0.1, 100.0), W=st.floats(0.1, 50.0), z=st.floats(0.05, 1e4))
def test_orthostereoscopic_budget(b, H, W, z):
    budget = depth_budget(Shooting(b, H, W), Display(b, H, W), [z])
    s = budget.samples[0]
    assert s.roundness == pytest.approx(1.0, rel=1e-14)
    assert s.perceived_depth == pytest.approx(z, rel=1e-14)
    assert budget.focal_ratio == pytest.approx(1.0, rel=1e-15)
    assert budget.divergence_baseline == pytest.approx(b, rel=1e-15) and not s.diverges


@settings(max_examples=40, deadline=None)
@given(b=st.floats(0.01, 2.0), H=st.floats(0.5, 100.0), W=st.floats(0.1, 50.0), z=st.floats(0.1, 1e3))
def test_budget_is_consistent_with_eq1b_and_eq8(b, H, W, z):
    budget = depth_budget(Shooting(b, H, W), TV, [z])
    s = budget.samples[0]
    limit = TV.divergence_disparity
    assert s.diverges == (s.disparity > limit)  # Eq. (8)
    if s.perceived_depth is not None:
        assert s.perceived_depth == pytest.approx(0.065 * 3.0 / (0.065 - 1.2 * s.disparity), rel=1e-9)  # Eq. (1b)
    assert s.parallax_px == pytest.approx(s.disparity * 1920, rel=RTOL)
    assert budget.focal_ratio == pytest.approx(budget.roundness_baseline / budget.divergence_baseline, rel=RTOL)


@pytest.mark.parametrize("depths, error, match", [
    ([], ValueError, r"^depths must be a non-empty 1-D sequence of metres; got shape \(0,\)"),
    ([[10.0, 20.0]], ValueError, r"^depths must be a non-empty 1-D sequence of metres; got shape \(1, 2\)"),
    ([10.0, -5.0], ValueError, r"^depths must be > 0 \(in front of the cameras\); got -5"),
    ([0.0], ValueError, r"^depths must be > 0 \(in front of the cameras\); got 0"),
    ([10.0, math.nan], ValueError, r"^depths must be > 0 metres or inf \(a point at infinity\); got nan$"),
    ([-math.inf], ValueError, r"^depths must be > 0 metres or inf \(a point at infinity\); got -inf$"),
    ([1e21], ValueError, r"^depths must lie in \[1e-06, 1e\+20\] m; got 1e\+21$"),
    (["far"], TypeError, "^depths must be numeric; got list"),
])
def test_bad_depths(depths, error, match):
    with pytest.raises(error, match=match):
        depth_budget(RIG, TV, depths)


def test_bad_set_ups():
    with pytest.raises(TypeError, match="^shooting must be a Shooting; got tuple"):
        depth_budget((0.1, 30.0, 3.0), TV)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="^display must be a vergence.viewing.Display; got str"):
        depth_budget(RIG, "tv-55")  # type: ignore[arg-type]


def test_result_validation():
    s = depth_budget(RIG, TV, [30.0]).samples[0]
    with pytest.raises(ValueError, match="^perceived_depth must be None where the eyes diverge; got 3"):
        dataclasses.replace(s, diverges=True)
    with pytest.raises(ValueError, match=r"^depth must be > 0 \(inf allowed\); got -1.0$"):
        dataclasses.replace(s, depth=-1.0)
    budget = depth_budget(RIG, TV, [30.0])
    with pytest.raises(ValueError, match="^samples must be a non-empty sequence of DepthSample"):
        dataclasses.replace(budget, samples=())
    with pytest.raises(ValueError, match="^focal_ratio must be > 0; got 0"):
        dataclasses.replace(budget, focal_ratio=0.0)
    with pytest.raises(ValueError, match=r"^divergence_depth must be > 0 \(inf if none\); got nan$"):
        dataclasses.replace(budget, divergence_depth=math.nan)


def test_a_point_at_infinity_has_the_limit_figures():
    # Issue 9: `budget --depth inf` was refused while `mapping` takes it. At z = inf, S0 Eq. (1a) gives
    # d = b/W, Eq. (2) z' = b'H'W/(b'W - bW') (finite below b_div), Eq. (4) rho -> 0.
    rig = Shooting(0.1, 30.0, 3.0)  # b/W = 1/30 < b'/W' = 0.054: no divergence
    far, = depth_budget(rig, TV, [math.inf]).samples
    assert far.disparity == pytest.approx(0.1 / 3.0, rel=RTOL)
    assert far.perceived_depth == pytest.approx(0.065 * 3.0 * 3.0 / (0.065 * 3.0 - 0.1 * 1.2), rel=1e-12)
    assert far.roundness == 0.0 and not far.diverges
    assert far.to_dict()["depth"] is None  # JSON has no infinity
    beyond, = depth_budget(RIG, TV, [math.inf]).samples  # b = 0.26 > b_div = 0.1625: diverges
    assert beyond.diverges and beyond.perceived_depth is None and beyond.roundness is None
    json.dumps(depth_budget(RIG, TV, [30.0, math.inf]).to_dict(), allow_nan=False)
