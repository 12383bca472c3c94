"""Effect of a disparity mapping psi on the perceived scene (S0 §6, Eq. (7)–(9)).

For any increasing psi applied to the disparity ``d(z)`` of a reference rig ``(b_r, H, W)`` (S0
Eq. 1a) and shown on a display ``(b', H', W')``: the mapped perceived depth (Eq. 7), the
divergence bound (Eq. 8) and the mapped roundness (Eq. 9); and, inverted, the value and slope psi
must take for a director's depth and roundness constraint (S0 §6). Lengths in metres; disparities
are fractions of the image width (``docs/conventions.md``); depths may be inf.
"""

from __future__ import annotations

import math

import numpy as np

from vergence.viewing._shared import (
    IN_FRONT_OF_VIEWER,
    check_length_or_inf,
    check_roundness,
    check_scene_depths,
    disparity_array,
    float_or_array,
    perceived_depth_array,
)
from vergence.viewing.geometry import Display, Shooting, check_display
from vergence.viewing.mapping_operators import DisparityMapping

__all__ = [
    "mapped_perceived_depth",
    "mapped_roundness",
    "psi_slope_for_roundness",
    "psi_value_for_depth",
]


def psi_value_for_depth(perceived: float, display: Display) -> float:
    """``psi(d_e) = (b'/W')(1 - H'/z'_e)``: the value giving perceived depth ``z'_e`` (S0 Eq. 1b inverted).

    ``b'/W'`` (the divergence limit, S0 Eq. 8) for ``z'_e = inf``.

    Examples
    --------
    >>> psi_value_for_depth(3.0, Display(0.065, 3.0, 1.2))
    0.0
    """
    zp = check_length_or_inf("perceived", perceived, where=IN_FRONT_OF_VIEWER)
    check_display(display)
    limit = display.divergence_disparity
    return limit if math.isinf(zp) else limit * (1.0 - display.distance / zp)


def psi_slope_for_roundness(
    roundness: float, depth: float, perceived: float, reference: Shooting, display: Display
) -> float:
    """``psi'(d_e) = rho_e z_e b' / (b_r z'_e)``: the slope giving roundness ``rho_e`` (S0 Eq. (9)).

    Examples
    --------
    >>> psi_slope_for_roundness(1.0, 30.0, 3.0, Shooting(0.65, 30.0, 3.0), Display(0.065, 3.0, 1.2))
    1.0
    """
    rho = check_roundness("roundness", roundness)
    z = check_length_or_inf("depth", depth)
    zp = check_length_or_inf("perceived", perceived, where=IN_FRONT_OF_VIEWER)
    if math.isinf(z) or math.isinf(zp):
        raise ValueError(f"depth and perceived must be finite for a roundness (psi' = rho z b'/(b_r z')); got {z:g}, {zp:g}")
    _check_setup(None, reference, display)
    return rho * z * display.eye_separation / (reference.baseline * zp)


def _check_setup(psi: object, reference: object, display: object) -> None:
    if psi is not None and not isinstance(psi, DisparityMapping):
        raise TypeError(f"psi must be a DisparityMapping; got {type(psi).__name__}")
    if not isinstance(reference, Shooting):
        raise TypeError(f"reference must be a Shooting; got {type(reference).__name__}")
    check_display(display)


def mapped_perceived_depth(
    z: object, psi: DisparityMapping, reference: Shooting, display: Display
) -> float | np.ndarray:
    """Perceived depth of scene depth ``z`` under psi: ``z'_psi = b'H' / (b' - W' psi(d(z)))`` (S0 Eq. 7).

    ``d(z)`` uses the reference rig; inf where psi reaches ``b'/W'``, NaN where it passes it (divergence).
    ``z`` may hold inf.

    Examples
    --------
    >>> from vergence.viewing.mapping_operators import LinearMapping
    >>> half = LinearMapping(-1.0, 1.0, -0.5, 0.5)  # psi(d) = d/2
    >>> round(mapped_perceived_depth(60.0, half, Shooting(0.3, 30.0, 3.0), Display(0.065, 3.0, 1.2)), 6)
    5.571429
    """
    _check_setup(psi, reference, display)
    d = disparity_array(check_scene_depths("z", z), reference)
    # Eq. (7) is Eq. (1b) of psi(d): inf exactly where psi reaches b'/W', NaN past it.
    return float_or_array(perceived_depth_array(np.asarray(psi(d), dtype=np.float64), display))  # Eq. (7)


def mapped_roundness(z: object, psi: DisparityMapping, reference: Shooting, display: Display) -> float | np.ndarray:
    """Roundness of scene depth ``z`` under psi: ``rho_psi = b H' psi'(d) / (z (b' - W' psi(d)))`` (S0 Eq. 9).

    Reduces to S0 Eq. (4) for the identity. 0 at ``z = inf`` below the divergence limit; NaN where
    ``psi = b'/W'`` with ``psi' = 0`` (perceived at infinity: no depth to compare with a width);
    negative where psi passes ``b'/W'`` (Eq. 9 as is, like Eq. 4 where the eyes diverge).

    Examples
    --------
    >>> from vergence.viewing.mapping_operators import LinearMapping
    >>> half = LinearMapping(-1.0, 1.0, -0.5, 0.5)  # psi(d) = d/2
    >>> round(mapped_roundness(30.0, half, Shooting(0.65, 30.0, 3.0), Display(0.065, 3.0, 1.2)), 12)
    0.5
    """
    _check_setup(psi, reference, display)
    zz = check_scene_depths("z", z)
    d = disparity_array(zz, reference)
    value, slope = np.asarray(psi(d)), np.asarray(psi.derivative(d))
    gap = 1.0 - value / display.divergence_disparity  # (b' - W' psi)/b', exactly 0 at psi = b'/W'
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = reference.baseline * display.distance * slope / (zz * display.eye_separation * gap)  # Eq. (9)
    return float_or_array(rho)

