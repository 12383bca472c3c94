"""Disparity mapping psi built from director constraints (S0 §6, Eq. (7)–(9)).

The director asks, for chosen scene depths ``z_e``, for a perceived depth ``z'_e`` and optionally a
roundness ``rho_e``. With a reference rig ``(b_r, H, W)`` (whose disparity is ``d(z)``, S0 Eq. 1a)
and a display ``(b', H', W')``, each constraint becomes a control point of psi:

- ``d_e = d(z_e)`` (``b_r/W`` for ``z_e = inf``);
- ``psi(d_e) = (b'/W')(1 - H'/z'_e)`` (``b'/W'`` for ``z'_e = inf``), the inverse of S0 Eq. (1b);
- ``psi'(d_e) = rho_e z_e b' / (b_r z'_e)`` for a roundness constraint (S0 Eq. 9 solved for psi').

psi interpolates them with the Gregory–Delbourgo rational Hermite interpolant (monotone, no
overshoot; a plain cubic Hermite violates S0 Eq. 8 for long lenses), continues with slope
``psi'(d_0)`` below the nearest control point (slope 1, the identity's, unless a roundness there says
otherwise) and saturates towards the divergence limit ``b'/W'`` above the farthest (S0 Eq. 8).
Lengths in metres; disparities are fractions of the image width (``docs/conventions.md``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vergence.viewing._shared import (
    IN_FRONT_OF_VIEWER,
    check_length,
    check_length_or_inf,
    check_roundness,
    check_scene_depths,
    disparity_array,
    perceived_depth_array,
)
from vergence.viewing.comfort import ComfortZone
from vergence.viewing.geometry import (
    LENGTH_RANGE,
    MAX_SCENE_DEPTH,
    Display,
    Shooting,
    check_display,
    scene_depth_from_disparity,
)
from vergence.viewing.mapping_hermite import pchip_slopes
from vergence.viewing.mapping_operators import DisparityMapping, RationalHermiteMapping
from vergence.viewing.mapping_perception import (
    mapped_perceived_depth,
    mapped_roundness,
    psi_slope_for_roundness,
    psi_value_for_depth,
)

__all__ = [
    "CHECK_SAMPLES",
    "ConstrainedMapping",
    "ControlPoint",
    "DirectorConstraint",
    "MappingSamples",
    "psi_from_constraints",
]

# Disparities at which psi is checked for monotonicity and divergence, evenly over [d(near), d(far)].
CHECK_SAMPLES = 4097

_FORMAT = "expected 'z=Z,perceived=Z[,roundness=R]' (Z may be inf)"


def _num(v: float) -> str:
    return "inf" if math.isinf(v) else f"{v:g}"


@dataclass(frozen=True, slots=True)
class DirectorConstraint:
    """A director's wish for the element at scene depth ``depth`` (S0 §6).

    ``perceived_depth`` is where the viewer should see it (``inf``: at the divergence limit, eyes
    parallel); ``roundness`` (optional) its depth-to-width magnification (1 = round, S0 Eq. 4).
    ``depth`` may be ``inf`` (the background at infinity). A roundness cannot be asked where the
    perceived depth is infinite (psi' must be 0 there: psi reaches its bound b'/W'), nor at an infinite
    depth (psi' would have to be infinite).

    Examples
    --------
    >>> str(DirectorConstraint.from_string("z=30, perceived=3, roundness=1"))
    'z=30,perceived=3,roundness=1'
    """

    depth: float
    perceived_depth: float
    roundness: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "depth", check_length_or_inf("depth", self.depth))
        object.__setattr__(
            self, "perceived_depth", check_length_or_inf("perceived_depth", self.perceived_depth, where=IN_FRONT_OF_VIEWER)
        )
        if self.roundness is not None:
            try:
                rho = check_roundness("roundness", self.roundness)
            except ValueError as exc:
                raise ValueError(f"{exc} (psi' = roundness z b'/(b_r z'))") from None
            if math.isinf(self.perceived_depth):
                raise ValueError("roundness cannot be prescribed where perceived_depth is inf (psi' must be 0 there)")
            if math.isinf(self.depth):
                raise ValueError("roundness cannot be prescribed at depth inf (psi' = rho z b'/(b_r z') would be inf)")
            object.__setattr__(self, "roundness", rho)

    def __str__(self) -> str:
        text = f"z={_num(self.depth)},perceived={_num(self.perceived_depth)}"
        return text if self.roundness is None else f"{text},roundness={_num(self.roundness)}"

    @classmethod
    def from_string(cls, text: str) -> DirectorConstraint:
        """Parse ``"z=Z,perceived=Z'[,roundness=R]"``; a malformed string is a one-line ValueError naming it."""
        if not isinstance(text, str):
            raise TypeError(f"constraint must be a string; got {type(text).__name__}")
        fields: dict[str, float] = {}
        for part in text.split(","):
            match = re.fullmatch(r"\s*(z|perceived|roundness)\s*=\s*([^\s=]+)\s*", part)
            if match is None:
                raise ValueError(f"constraint {text!r} is malformed: {_FORMAT}; got part {part.strip()!r}")
            key, raw = match.groups()
            if key in fields:
                raise ValueError(f"constraint {text!r} is malformed: {key} given twice")
            try:
                fields[key] = float(raw)
            except ValueError:
                raise ValueError(f"constraint {text!r} is malformed: {key}={raw!r} is not a number") from None
        missing = [k for k in ("z", "perceived") if k not in fields]
        if missing:
            raise ValueError(f"constraint {text!r} is malformed: {_FORMAT}; missing {', '.join(missing)}")
        try:
            return cls(fields["z"], fields["perceived"], fields.get("roundness"))
        except ValueError as exc:
            # Name the keys of the string, not the fields behind them.
            message = str(exc)
            for field, key in (("perceived_depth", "perceived"), ("depth", "z")):
                if message.startswith(field + " "):
                    message = key + message[len(field):]
            raise ValueError(f"constraint {text!r}: {message}") from None


@dataclass(frozen=True, slots=True)
class ControlPoint:
    """A control point of psi: ``psi(disparity) = value``, ``psi'(disparity) = slope`` (S0 §6).

    ``prescribed`` tells whether the slope comes from a roundness (or an infinite perceived depth,
    slope 0) rather than from an estimate (PCHIP, or 1 at the nearest point).
    """

    disparity: float
    value: float
    slope: float
    prescribed: bool


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class MappingSamples:
    """psi and its effect sampled over the scene: one entry per disparity, evenly spaced in d.

    ``depth`` is the scene depth (inf at ``d = b_r/W``), ``mapped`` psi(d), ``perceived_depth`` S0
    Eq. (7) (inf at the divergence limit, NaN past it) and ``roundness`` S0 Eq. (9).
    """

    disparity: np.ndarray
    depth: np.ndarray
    mapped: np.ndarray
    perceived_depth: np.ndarray
    roundness: np.ndarray

    def __post_init__(self) -> None:
        n = np.shape(self.disparity)
        for name in ("depth", "mapped", "perceived_depth", "roundness"):
            if np.shape(getattr(self, name)) != n:
                raise ValueError(f"{name} must have shape {n} matching disparity; got {np.shape(getattr(self, name))}")


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class ConstrainedMapping:
    """psi built from director constraints, with its report (S0 §6, Eq. (7)–(9)).

    Attributes
    ----------
    psi : RationalHermiteMapping
        The mapping; callable on disparities, with ``derivative`` and ``inverse``.
    control_points : tuple of ControlPoint
        One per constraint, sorted by depth.
    constraints : tuple of DirectorConstraint
        The constraints, sorted by depth.
    reference : Shooting
        Reference rig ``(b_r, H, W)`` whose disparity ``d(z)`` psi maps.
    display : Display
        Viewing set-up ``(b', H', W')``.
    near, far : float
        Scene depth range (``far`` may be inf).
    monotone : bool
        psi non-decreasing with psi' >= 0 on :data:`CHECK_SAMPLES` disparities over ``[d(near), d(far)]``
        and at the control points.
    diverges : bool
        psi above ``b'/W'`` anywhere on those samples (S0 Eq. 8 violated).
    """

    psi: RationalHermiteMapping
    control_points: tuple[ControlPoint, ...]
    constraints: tuple[DirectorConstraint, ...]
    reference: Shooting
    display: Display
    near: float
    far: float
    monotone: bool
    diverges: bool

    def __post_init__(self) -> None:
        if not isinstance(self.psi, DisparityMapping):
            raise TypeError(f"psi must be a DisparityMapping; got {type(self.psi).__name__}")
        if len(self.control_points) != len(self.constraints):
            raise ValueError(
                f"control_points must match constraints ({len(self.constraints)}); got {len(self.control_points)}"
            )
        if not 0 < self.near < self.far:
            raise ValueError(f"far must be > near {self.near:g} > 0; got {self.far:g}")

    @property
    def divergence_limit(self) -> float:
        """``b'/W'``: psi must stay at or below it (S0 Eq. 8)."""
        return self.display.divergence_disparity

    @property
    def disparity_range(self) -> tuple[float, float]:
        """``(d(near), d(far))`` with the reference rig (S0 Eq. 1a)."""
        lo, hi = disparity_array(np.array([self.near, self.far]), self.reference)
        return float(lo), float(hi)

    def _grid(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``n`` disparities evenly over ``[d(near), d(far)]`` and their scene depths (S0 Eq. 1c),
        the end depths set to ``near`` and ``far`` exactly."""
        d = np.linspace(*self.disparity_range, n)
        z = np.asarray(scene_depth_from_disparity(d, self.reference), dtype=np.float64)
        z[0], z[-1] = self.near, self.far
        return d, z

    def perceived_depth(self, z: object) -> float | np.ndarray:
        """Mapped perceived depth at scene depth ``z`` (S0 Eq. 7); see :func:`mapped_perceived_depth`."""
        return mapped_perceived_depth(z, self.psi, self.reference, self.display)

    def roundness(self, z: object) -> float | np.ndarray:
        """Mapped roundness at scene depth ``z`` (S0 Eq. 9); see :func:`mapped_roundness`."""
        return mapped_roundness(z, self.psi, self.reference, self.display)

    def min_roundness(self) -> tuple[float, float]:
        """Lowest mapped roundness (S0 Eq. 9) over the scene, and the scene depth where it occurs.

        Between two control points psi may flatten (its slope is free there), and Eq. (9) can dip
        below the cardboard threshold (rho < 0.3) even when every constraint is round: the report
        shows this minimum. It is searched at the depths of :data:`CHECK_SAMPLES` disparities evenly
        over ``[d(near), d(far)]`` and at the constraints' depths, finite ones only (at ``z = inf``
        Eq. (9) is 0, or undefined where psi reaches ``b'/W'``).

        Returns
        -------
        (float, float)
            ``(rho_min, z)``; ``rho_min`` is negative where psi passes ``b'/W'`` (the eyes diverge).

        Examples
        --------
        >>> m = psi_from_constraints(Shooting(0.65, 30.0, 3.0), Display(0.065, 3.0, 1.2),
        ...                          ["z=30,perceived=3,roundness=1", "z=80,perceived=9"], near=20.0, far=100.0)
        >>> rho, z = m.min_roundness()
        >>> round(rho, 3), round(z, 1)
        (0.163, 55.2)
        """
        _, z = self._grid(CHECK_SAMPLES)
        z = np.concatenate([z, [c.depth for c in self.constraints]])  # the control points' own depths
        z = z[np.isfinite(z)]
        rho = np.asarray(self.roundness(z), dtype=np.float64)  # Eq. (9)
        # NaN only where psi = b'/W' with psi' = 0; never at ``near``, below the first control point.
        k = int(np.nanargmin(np.where(np.isfinite(rho), rho, np.nan)))
        return float(rho[k]), float(z[k])

    def sample(self, n: int = 201) -> MappingSamples:
        """psi, perceived depth and roundness at ``n >= 2`` disparities evenly spaced over ``[d(near), d(far)]``.

        The first and last samples are exactly ``near`` and ``far``.
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
            raise ValueError(f"n must be an integer >= 2; got {n!r}")
        d, z = self._grid(int(n))
        return self._samples(d, z)

    def at_depths(self, depths: object) -> MappingSamples:
        """psi, perceived depth and roundness at the given scene depths (metres, inf allowed), in order.

        Raises
        ------
        ValueError
            If a depth is not > 0, is NaN, or lies outside ``[near, far]``.
        """
        z = np.atleast_1d(check_scene_depths("depths", depths))
        if z.ndim != 1 or z.size == 0:
            raise ValueError(f"depths must be a non-empty 1-D sequence of metres; got shape {z.shape}")
        outside = (z < self.near) | (z > self.far)
        if outside.any():
            raise ValueError(f"depths must lie in the scene [{self.near:g}, {_num(self.far)}] m (near, far); "
                             f"got {_num(float(z[outside][0]))}")
        return self._samples(disparity_array(z, self.reference), z)

    def _samples(self, d: np.ndarray, z: np.ndarray) -> MappingSamples:
        mapped = np.asarray(self.psi(d))
        return MappingSamples(
            disparity=d,
            depth=z,
            mapped=mapped,
            perceived_depth=perceived_depth_array(mapped, self.display),  # Eq. (7): Eq. (1b) of psi(d)
            roundness=np.asarray(self.roundness(z)),  # Eq. (9)
        )

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per problem a viewer would meet: divergence (S0 Eq. 8), psi not monotone, mapped
        disparities outside the default :class:`~vergence.viewing.comfort.ComfortZone` (±60 arcmin)."""
        out = []
        limit = self.divergence_limit
        if self.diverges:
            out.append(f"psi passes the divergence limit b'/W' = {limit:.4g} inside [near, far]: the eyes diverge "
                       f"there (S0 Eq. 8)")
        if not self.monotone:
            out.append("psi is not monotone: depth order is reversed somewhere in [near, far]")
        lo, hi = (float(v) for v in np.asarray(self.psi(np.array(self.disparity_range))))
        zone = ComfortZone()
        try:
            zone_lo, zone_hi = zone.disparities(self.display)
        except ValueError as exc:  # a display whose eyes already converge near 180 degrees
            out.append(f"the comfort zone (±{zone.crossed_arcmin:g} arcmin) does not exist on this display: {exc}")
            return tuple(out)
        if lo < zone_lo or min(hi, limit) > zone_hi:
            out.append(f"mapped disparities from {lo:+.4g} to {hi:+.4g} screen widths leave the comfort zone "
                       f"(±{zone.crossed_arcmin:g} arcmin of vergence: {zone_lo:+.4g} to {zone_hi:+.4g})")
        return tuple(out)

    def to_dict(self, *, samples: int = 201, depths: object = None) -> dict[str, object]:
        """The JSON report of ``vergence mapping --json``; infinite depths and non-finite figures become None.

        ``samples`` disparities evenly spaced over ``[d(near), d(far)]`` (201 for the CLI); with
        ``depths``, the samples are those scene depths instead (``--depth``).

        ``{"reference": {"baseline", "convergence", "window"}, "display": {"eye_separation", "distance",
        "width"}, "near", "far", "control_points": [{"disparity", "value", "slope"}...], "samples":
        [{"depth", "disparity", "mapped", "perceived_depth", "roundness"}...], "monotone": bool,
        "diverges": bool, "warnings": [str...]}``. JSON has no infinity: a ``null`` depth (``far``
        included) is infinitely far, a ``null`` perceived depth is at or past the divergence limit.
        """
        s = self.sample(samples) if depths is None else self.at_depths(depths)

        def num(v: float) -> float | None:
            return float(v) if math.isfinite(v) else None

        ref, display = self.reference, self.display
        return {
            "reference": {"baseline": ref.baseline, "convergence": ref.convergence, "window": ref.window},
            "display": {"eye_separation": display.eye_separation, "distance": display.distance,
                        "width": display.width},
            "near": self.near,
            "far": num(self.far),
            "control_points": [
                {"disparity": cp.disparity, "value": cp.value, "slope": cp.slope} for cp in self.control_points
            ],
            "samples": [
                {"depth": num(z), "disparity": float(d), "mapped": float(m), "perceived_depth": num(zp),
                 "roundness": num(r)}
                for z, d, m, zp, r in zip(s.depth, s.disparity, s.mapped, s.perceived_depth, s.roundness)
            ],
            "monotone": bool(self.monotone),
            "diverges": bool(self.diverges),
            "warnings": list(self.warnings),
        }


def _as_constraint(k: int, c: object) -> DirectorConstraint:
    if isinstance(c, DirectorConstraint):
        return c
    if isinstance(c, str):
        return DirectorConstraint.from_string(c)
    if isinstance(c, tuple | list) and len(c) in (2, 3):
        try:
            return DirectorConstraint(*c)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"constraints[{k}] {tuple(c)}: {exc}") from None
    raise TypeError(
        f"constraints[{k}] must be a DirectorConstraint, a string or a (z, perceived[, roundness]) tuple; "
        f"got {c!r}"
    )


def psi_from_constraints(
    reference: Shooting,
    display: Display,
    constraints: Sequence[DirectorConstraint | str | tuple[float, ...]],
    *,
    near: float,
    far: float,
) -> ConstrainedMapping:
    """Build the monotone C1 disparity mapping psi honouring director constraints (S0 §6).

    Parameters
    ----------
    reference : Shooting
        Reference rig ``(b_r, H, W)``: ``d(z) = (b_r/W)(1 - H/z)`` (S0 Eq. 1a). S0 uses ``b_round``
        (Fig. 8 right) or ``b_div`` (Fig. 8 left).
    display : Display
        Viewing set-up ``(b', H', W')``.
    constraints : sequence
        :class:`DirectorConstraint`, ``"z=Z,perceived=Z'[,roundness=R]"`` strings or
        ``(z, perceived[, roundness])`` tuples, in any order; depths and perceived depths may be inf.
    near, far : float
        Nearest and farthest scene depth (m), ``0 < near < far``; ``far`` may be inf. Every constraint
        must lie in ``[near, far]``.

    Returns
    -------
    ConstrainedMapping
        psi, its control points, and the report (monotone, diverges, Eq. 7 and Eq. 9 as methods).

    Raises
    ------
    ValueError
        Naming the constraint: a depth or perceived depth <= 0 or NaN; a roundness <= 0 (psi' <= 0),
        or a roundness at an infinite depth or perceived depth; two constraints at one depth (or so
        close that their disparities coincide); perceived depths not increasing with scene depth; a
        value past the divergence limit ``b'/W'`` (a constraint beyond one perceived at infinity);
        the nearest constraint perceived at infinity; a constraint nearer than ``near`` or farther
        than ``far``; ``near >= far``.
    TypeError
        If ``reference`` or ``display`` has the wrong type.

    Notes
    -----
    Control point of constraint e: ``d_e = d(z_e)``, ``psi(d_e) = (b'/W')(1 - H'/z'_e)``,
    ``psi'(d_e) = rho_e z_e b'/(b_r z'_e)`` (S0 Eq. (9) at ``d_e``); slope 0 where ``z'_e = inf``. Slopes not
    prescribed are Fritsch–Carlson (PCHIP) estimates, except at the nearest control point, where the
    slope is 1 so that psi continues as the identity's slope below it (our extension; S0 §6 leaves
    it open); PCHIP's end formula
    gives 0 at the farthest point when the values decelerate sharply, and psi is then flat beyond
    it (give a roundness there to avoid it). Between control
    points psi is the Gregory–Delbourgo interpolant; above the farthest it saturates towards
    ``b'/W'`` (:class:`RationalHermiteMapping` with ``ceiling = b'/W'``).

    Examples
    --------
    The Tri-Rig of S0 §6: reference ``b_round``, subject at H round and on the screen, background at
    infinity perceived at infinity.

    >>> display = Display(eye_separation=0.065, distance=3.0, width=1.2)   # f' = 2.5
    >>> rig = Shooting(baseline=0.65, convergence=30.0, window=3.0)         # f = 10, b = b_round
    >>> m = psi_from_constraints(rig, display, ["z=30,perceived=3,roundness=1", "z=inf,perceived=inf"],
    ...                          near=20.0, far=float("inf"))
    >>> [(round(p.disparity, 6), round(p.value, 6), p.slope) for p in m.control_points]
    [(0.0, 0.0, 1.0), (0.216667, 0.054167, 0.0)]
    >>> m.monotone, m.diverges
    (True, False)
    """
    if not isinstance(reference, Shooting):
        raise TypeError(f"reference must be a Shooting; got {type(reference).__name__}")
    check_display(display)
    z_near = check_length("near", near, (LENGTH_RANGE[0], MAX_SCENE_DEPTH))
    z_far = check_length_or_inf("far", far)
    if not z_near < z_far:
        raise ValueError(f"far must be > near {z_near:g}; got {z_far:g}")
    if isinstance(constraints, str | DirectorConstraint):
        constraints = [constraints]
    items = sorted((_as_constraint(k, c) for k, c in enumerate(constraints)), key=lambda c: c.depth)
    if not items:
        raise ValueError("constraints must hold at least one constraint; got none")
    limit = display.divergence_disparity
    for c in items:
        if not z_near <= c.depth <= z_far:
            raise ValueError(f"constraint {c} lies outside the scene: near = {z_near:g}, far = {_num(z_far)}")
    for a, b in zip(items, items[1:]):
        if a.depth == b.depth:
            raise ValueError(f"constraints {a} and {b} are at the same depth")
        if math.isinf(a.perceived_depth):
            raise ValueError(
                f"constraint {b} needs a value past the divergence limit b'/W' = {limit:g}: the nearer "
                f"constraint {a} already maps to it (perceived depths must increase with scene depth)"
            )
        if not a.perceived_depth < b.perceived_depth:
            raise ValueError(f"constraints {a} and {b}: perceived depths must increase with scene depth")
    if math.isinf(items[0].perceived_depth):
        raise ValueError(
            f"constraint {items[0]}: the nearest constraint cannot be perceived at infinity "
            f"(psi would equal b'/W' = {limit:g} at every nearer depth)"
        )

    depths = np.array([c.depth for c in items])
    knots = disparity_array(depths, reference)
    for k in np.flatnonzero(np.diff(knots) <= 0):
        raise ValueError(
            f"constraints {items[k]} and {items[k + 1]} are too close: "
            "their disparities d(z) coincide in floating point"
        )
    values = np.array([psi_value_for_depth(c.perceived_depth, display) for c in items])
    for c, v in zip(items, values):
        if math.isfinite(c.perceived_depth) and v >= limit:
            raise ValueError(
                f"constraint {c}: the perceived depth is so far that psi rounds to the divergence limit "
                f"b'/W' = {limit:g}; ask for perceived=inf instead"
            )
    for k in np.flatnonzero(np.diff(values) <= 0):
        raise ValueError(
            f"constraints {items[k]} and {items[k + 1]} are too close: "
            "their values psi = (b'/W')(1 - H'/z') coincide in floating point"
        )
    estimates = pchip_slopes(knots, values) if len(items) > 1 else np.ones(1)
    estimates[0] = 1.0  # identity slope below the nearest control point (our extension of S0 §6)
    slopes, prescribed = [], []
    for c, est in zip(items, estimates):
        if c.roundness is not None:
            slopes.append(psi_slope_for_roundness(c.roundness, c.depth, c.perceived_depth, reference, display))
        elif math.isinf(c.perceived_depth):
            slopes.append(0.0)  # psi reaches its bound b'/W' there: psi' = 0
        else:
            slopes.append(float(est))
        prescribed.append(c.roundness is not None or math.isinf(c.perceived_depth))
    psi = RationalHermiteMapping(knots, values, np.array(slopes), ceiling=limit)
    points = tuple(
        ControlPoint(float(x), float(y), float(s), p) for x, y, s, p in zip(knots, values, slopes, prescribed)
    )

    lo, hi = disparity_array(np.array([z_near, z_far]), reference)
    d = np.union1d(np.linspace(lo, hi, CHECK_SAMPLES), knots)
    value, slope = np.asarray(psi(d)), np.asarray(psi.derivative(d))
    monotone = bool(np.all(np.diff(value) >= 0) and np.all(slope >= 0))
    diverges = bool(np.any(value > limit))
    return ConstrainedMapping(
        psi=psi,
        control_points=points,
        constraints=tuple(items),
        reference=reference,
        display=display,
        near=z_near,
        far=z_far,
        monotone=monotone,
        diverges=diverges,
    )
