"""Extreme parameter sets (issue 9: 3,600 random sets gave 20 inconsistent budgets and 19 numpy overflow
warnings): every figure is finite and consistent with the reported disparity, or the call is one clean
ValueError. Warnings are errors in the suite, so an overflow warning fails here too.

``VERGENCE_PROPERTY_EXAMPLES`` sets the number of examples (default small for CI; the fuzz sweep of
issue 9 ran these with 4000).
"""

from __future__ import annotations

import math
import os

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vergence.viewing.budget import DIVERGENCE_FLAG_ULPS, depth_budget
from vergence.viewing.geometry import LENGTH_RANGE, MAX_SCENE_DEPTH, Display, Shooting

EPS = float(np.finfo(float).eps)
EXAMPLES = int(os.environ.get("VERGENCE_PROPERTY_EXAMPLES", "60"))


def _log_uniform(lo_exp: float, hi_exp: float) -> st.SearchStrategy[float]:
    """Lengths spread evenly over decades (a uniform draw would almost never be small)."""
    return st.floats(lo_exp, hi_exp).map(lambda e: 10.0**e)


# Inside the documented ranges: LENGTH_RANGE for rig and display, up to MAX_SCENE_DEPTH for depths.
length = _log_uniform(math.log10(LENGTH_RANGE[0]), math.log10(LENGTH_RANGE[1]))
depth = _log_uniform(math.log10(LENGTH_RANGE[0]), math.log10(MAX_SCENE_DEPTH))
# Anywhere in float64, subnormals and 1e308 included: these must be refused cleanly when out of range.
anything = st.one_of(_log_uniform(-323.0, 308.0), st.sampled_from([5e-324, 1e308, 1.7976931348623157e308]))


def _check_budget(shooting: Shooting, display: Display, depths: list[float]) -> None:
    budget = depth_budget(shooting, display, depths)
    limit = display.divergence_disparity
    for s in budget.samples:  # DepthSample itself refuses non-finite figures
        # Eq. (8) on the disparity reported, except within DIVERGENCE_FLAG_ULPS of divergence_depth
        if not abs(s.depth - budget.divergence_depth) <= DIVERGENCE_FLAG_ULPS * EPS * budget.divergence_depth:
            assert s.diverges == (s.disparity > limit), s
        if s.diverges:
            assert s.perceived_depth is None and (s.roundness is None or s.roundness < 0), s
        else:
            assert s.roundness is None or s.roundness > 0, s
        if s.perceived_depth is not None:
            assert s.perceived_depth > 0, s  # issue 9: 0.0 was reported
        if s.depth == shooting.convergence:  # on the convergence plane: on the screen (S0 Eq. 1b, d = 0)
            assert s.disparity == 0.0 and s.perceived_depth == display.distance, s


@settings(max_examples=EXAMPLES, deadline=None)
@given(b=length, H=length, W=length, bp=length, Hp=length, Wp=length, zs=st.lists(depth, min_size=1, max_size=4))
def test_budget_inside_the_ranges_is_finite_and_consistent(b, H, W, bp, Hp, Wp, zs):
    _check_budget(Shooting(b, H, W), Display(bp, Hp, Wp, resolution=1920), [*zs, H])


@settings(max_examples=EXAMPLES, deadline=None)
@given(b=anything, H=anything, W=anything, bp=anything, Hp=anything, Wp=anything, z=anything)
def test_budget_anywhere_is_consistent_or_one_clean_value_error(b, H, W, bp, Hp, Wp, z):
    try:
        shooting, display = Shooting(b, H, W), Display(bp, Hp, Wp)
        _check_budget(shooting, display, [z])
    except ValueError as exc:
        assert "\n" not in str(exc) and " must " in str(exc)


def test_issue9_fuzz_case_d_zero_flagged_as_diverging():
    # Found by the fuzzer: b/W = 6e8 against b'/W' = 9.2e-9, so divergence starts within an ulp of H;
    # the z-form of Eq. (2) flagged z = H (d = 0) as diverging.
    rig = Shooting(1088.2641991636679, 1.4329443467964356, 1.8137187195233712e-06)
    display = Display(0.0004698117716817455, 0.0003132103786608234, 51027.87555034109)
    (s,) = depth_budget(rig, display, [rig.convergence]).samples
    assert s.disparity == 0.0 and not s.diverges and s.perceived_depth == display.distance
    assert np.isclose(s.roundness, rig.baseline * display.distance / (display.eye_separation * rig.convergence))


@settings(max_examples=EXAMPLES, deadline=None)
@given(b=length, H=length, W=length, bp=length, Hp=length, Wp=length,
       z=st.one_of(depth, st.just(math.inf)), zp=st.one_of(depth, st.just(math.inf)),
       rho=st.one_of(st.none(), _log_uniform(-3.0, 3.0)), near_share=st.floats(1e-3, 1.0))
def test_mapping_inside_the_ranges_is_finite_and_consistent_or_refused(b, H, W, bp, Hp, Wp, z, zp, rho, near_share):
    import json

    from vergence.viewing.mapping import psi_from_constraints

    rig, display = Shooting(b, H, W), Display(bp, Hp, Wp)
    near = max(LENGTH_RANGE[0], near_share * (z if math.isfinite(z) else MAX_SCENE_DEPTH))
    try:
        m = psi_from_constraints(rig, display, [(z, zp, rho)], near=near, far=math.inf)
    except ValueError as exc:  # an unsatisfiable constraint: one line naming what is wrong
        assert "\n" not in str(exc)
        return
    report = m.to_dict(samples=33)
    json.dumps(report, allow_nan=False)  # finite or null, nothing else
    mapped = np.array([s["mapped"] for s in report["samples"]])
    limit = display.divergence_disparity
    if np.any(mapped > limit):
        assert report["diverges"], report  # the flag agrees with the disparities reported
    for s in report["samples"]:
        if s["perceived_depth"] is not None:
            assert s["perceived_depth"] > 0 and s["mapped"] < limit
    assert isinstance(report["warnings"], list)
