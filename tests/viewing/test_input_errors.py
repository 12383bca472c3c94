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
