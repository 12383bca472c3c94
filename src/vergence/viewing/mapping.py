"""Disparity mapping functions psi (S0 §6, Eq. (7)–(9); Lang et al. 2010).

One import point for the mapping family, implemented in:

- :mod:`~vergence.viewing.mapping_operators`: the operator base class and the linear,
  logarithmic, saliency-histogram and Gregory–Delbourgo (rational Hermite) operators;
- :mod:`~vergence.viewing.mapping_composite`: piecewise operators and temporal blends;
- :mod:`~vergence.viewing.mapping_gradient`: gradient-domain remapping of a disparity map;
- :mod:`~vergence.viewing.mapping_hermite`: the monotone interpolants (Gregory–Delbourgo, PCHIP);
- :mod:`~vergence.viewing.mapping_perception`: what psi does to the perceived scene (S0 Eq. 7–9);
- :mod:`~vergence.viewing.mapping_constraints`: psi from director constraints, with the report
  (monotone, divergence, mapped perceived depth and roundness).

Examples
--------
>>> from vergence.viewing.geometry import Display, Shooting
>>> m = psi_from_constraints(Shooting(0.65, 30.0, 3.0), Display(0.065, 3.0, 1.2),
...                          [DirectorConstraint(30.0, 3.0, roundness=1.0)], near=20.0, far=80.0)
>>> round(float(m.perceived_depth(30.0)), 12), round(float(m.roundness(30.0)), 12)
(3.0, 1.0)
"""

from vergence.viewing.mapping_composite import BlendedMapping, PiecewiseMapping, temporal_mapping, temporal_weights
from vergence.viewing.mapping_constraints import (
    CHECK_SAMPLES,
    ConstrainedMapping,
    ControlPoint,
    DirectorConstraint,
    MappingSamples,
    psi_from_constraints,
)
from vergence.viewing.mapping_gradient import gradient_domain_mapping
from vergence.viewing.mapping_hermite import (
    gregory_delbourgo,
    gregory_delbourgo_derivative,
    gregory_delbourgo_inverse,
    pchip_slopes,
)
from vergence.viewing.mapping_operators import (
    DisparityMapping,
    LinearMapping,
    LogMapping,
    RationalHermiteMapping,
    SaliencyMapping,
    bisect_inverse,
)
from vergence.viewing.mapping_perception import (
    mapped_perceived_depth,
    mapped_roundness,
    psi_slope_for_roundness,
    psi_value_for_depth,
)

__all__ = [
    "BlendedMapping",
    "CHECK_SAMPLES",
    "ConstrainedMapping",
    "ControlPoint",
    "DirectorConstraint",
    "DisparityMapping",
    "LinearMapping",
    "LogMapping",
    "MappingSamples",
    "PiecewiseMapping",
    "RationalHermiteMapping",
    "SaliencyMapping",
    "bisect_inverse",
    "gradient_domain_mapping",
    "gregory_delbourgo",
    "gregory_delbourgo_derivative",
    "gregory_delbourgo_inverse",
    "mapped_perceived_depth",
    "mapped_roundness",
    "pchip_slopes",
    "psi_from_constraints",
    "psi_slope_for_roundness",
    "psi_value_for_depth",
    "temporal_mapping",
    "temporal_weights",
]
