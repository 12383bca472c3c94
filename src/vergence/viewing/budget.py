"""The depth budget of a shooting set-up on a display: S0 Eq. (1)–(6) at chosen scene depths (S0 §2).

One call answers "what will a viewer see?": the baselines that bound the rig (no divergence, Eq. 3;
roundness 1 on the convergence plane, Eq. 5), their ratio (the focal ratio f/f', Eq. 6), and at each
scene depth the disparity (Eq. 1a), the perceived depth (Eq. 2), the roundness (Eq. 4) and whether
the eyes diverge. ``vergence budget`` prints it; :mod:`vergence.report.budget_plot` draws it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from vergence._validate import check_finite
from vergence.viewing._shared import check_depths, check_type, depth_ratio, real_array
from vergence.viewing.comfort import ComfortZone
from vergence.viewing.geometry import (
    CARDBOARD_ROUNDNESS,
    Display,
    Shooting,
    check_display,
    disparity,
    divergence_baseline,
    divergence_depth,
    focal_ratio,
    perceived_depth_from_depth,
    roundness,
    roundness_baseline,
)

__all__ = ["DEFAULT_DEPTH_FACTORS", "DIVERGENCE_FLAG_ULPS", "DepthBudget", "DepthSample", "default_depths", "depth_budget"]

# Scene depths sampled when none are given, as multiples of the convergence distance H: the
# foreground at H/2, the subject on the convergence plane (d = 0), and a background out to 10 H
# (where d is 90 % of its limit b/W, so divergence, if the rig has any, usually shows).
DEFAULT_DEPTH_FACTORS: tuple[float, ...] = (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)

# Half-width, in machine epsilons of divergence_depth, of the band of depths around it where the reported
# disparity is the limit b'/W' to its rounding (z_div itself is rounded, and d amplifies that by
# H/(z_div - H)): there the ``diverges`` flag follows the exact sign of Eq. (2) at divergence_depth; elsewhere
# it is d > b'/W' on the reported d. 4 covers z_div and its neighbouring floats.
DIVERGENCE_FLAG_ULPS = 4


@dataclass(frozen=True, slots=True)
class DepthSample:
    """The budget at one scene depth (S0 §2).

    Attributes
    ----------
    depth : float
        Scene depth z in metres; ``inf`` for a point at infinity (``null`` in :meth:`to_dict`, as JSON
        has no infinity).
    disparity : float
        Normalised disparity d, a fraction of W (S0 Eq. 1a).
    parallax_px : float or None
        Screen parallax ``x_r - x_l = d · N`` in display pixels (positive behind the screen; the
        opposite sign of a matcher's ``disparity_px``), or None when the display resolution is unknown.
    perceived_depth : float or None
        Perceived depth z' in metres (S0 Eq. 2), None when the eyes diverge (or are exactly parallel).
    roundness : float or None
        rho of S0 Eq. (4) as is (negative where the eyes diverge); None only where it is infinite
        (the eyes exactly parallel at this depth).
    diverges : bool
        Whether the eyes diverge at this depth: ``d > b'/W'`` on the reported ``disparity`` (S0 Eq. 3
        and 8), except within :data:`DIVERGENCE_FLAG_ULPS` of :attr:`DepthBudget.divergence_depth`, where
        d is the limit to its rounding and the exact sign of Eq. (2) decides: at that depth itself the
        eyes are parallel (``perceived_depth`` and ``roundness`` None, ``diverges`` False).
    """

    depth: float
    disparity: float
    parallax_px: float | None
    perceived_depth: float | None
    roundness: float | None
    diverges: bool

    def __post_init__(self) -> None:
        if isinstance(self.depth, bool) or not isinstance(self.depth, float | int) or not self.depth > 0:
            raise ValueError(f"depth must be > 0 (inf allowed); got {self.depth!r}")
        check_finite("disparity", self.disparity)
        for name in ("parallax_px", "perceived_depth", "roundness"):
            if getattr(self, name) is not None:
                check_finite(name, getattr(self, name))
        if self.diverges and self.perceived_depth is not None:
            raise ValueError(f"perceived_depth must be None where the eyes diverge; got {self.perceived_depth:g}")

    @property
    def note(self) -> str:
        """What a viewer meets at this depth, as ``vergence budget`` and the demo page print it:
        ``"eyes diverge"`` (S0 Eq. 8), ``"eyes parallel"`` (z' infinite, at the divergence limit),
        ``"cardboard"`` (roundness below :data:`~vergence.viewing.geometry.CARDBOARD_ROUNDNESS`), or ``""``."""
        if self.diverges:
            return "eyes diverge"
        if self.perceived_depth is None:
            return "eyes parallel"
        if self.roundness is not None and self.roundness < CARDBOARD_ROUNDNESS:
            return "cardboard"
        return ""

    def to_dict(self) -> dict[str, float | bool | None]:
        """The JSON object of one depth; ``parallax_px`` is left out when the resolution is unknown."""
        depth = self.depth if math.isfinite(self.depth) else None  # JSON has no inf: null is infinity
        out: dict[str, float | bool | None] = {"depth": depth, "disparity": self.disparity}
        if self.parallax_px is not None:
            out["parallax_px"] = self.parallax_px
        out.update(perceived_depth=self.perceived_depth, roundness=self.roundness, diverges=self.diverges)
        return out


@dataclass(frozen=True, slots=True)
class DepthBudget:
    """Result of :func:`depth_budget`.

    Attributes
    ----------
    divergence_baseline : float
        ``b_div = b'W/W'`` (S0 Eq. 3), metres: the largest baseline that never makes the eyes diverge.
    roundness_baseline : float
        ``b_round = b'H/H'`` (S0 Eq. 5 with rho = 1), metres: roundness 1 at the convergence distance.
    focal_ratio : float
        ``f/f' = b_round/b_div`` (S0 Eq. 6).
    divergence_depth : float
        Scene depth beyond which the eyes diverge with this baseline, ``inf`` if none.
    samples : tuple of DepthSample
        One per requested depth, in the order given.
    warnings : tuple of str
        One line each: samples where the eyes diverge (S0 Eq. 8), samples outside the default
        :class:`~vergence.viewing.comfort.ComfortZone` (±60 arcmin). Empty when all is well.
    """

    divergence_baseline: float
    roundness_baseline: float
    focal_ratio: float
    divergence_depth: float
    samples: tuple[DepthSample, ...]
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for f in fields(self)[:3]:
            if check_finite(f.name, getattr(self, f.name)) <= 0:
                raise ValueError(f"{f.name} must be > 0; got {getattr(self, f.name):g}")
        if not self.divergence_depth > 0:
            raise ValueError(f"divergence_depth must be > 0 (inf if none); got {self.divergence_depth}")
        object.__setattr__(self, "samples", tuple(self.samples))
        if not self.samples or not all(isinstance(s, DepthSample) for s in self.samples):
            raise ValueError("samples must be a non-empty sequence of DepthSample")
        object.__setattr__(self, "warnings", tuple(self.warnings))
        if not all(isinstance(w, str) for w in self.warnings):
            raise TypeError("warnings must be a sequence of str")

    def to_dict(self) -> dict[str, object]:
        """The JSON of ``vergence budget --json``: baselines, focal ratio, the depth beyond which the eyes
        diverge (``divergence_depth``, None when they never do) and the depths."""
        return {
            "divergence_baseline": self.divergence_baseline,
            "roundness_baseline": self.roundness_baseline,
            "focal_ratio": self.focal_ratio,
            "divergence_depth": self.divergence_depth if math.isfinite(self.divergence_depth) else None,
            "depths": [s.to_dict() for s in self.samples],
            "warnings": list(self.warnings),
        }


def default_depths(shooting: Shooting) -> tuple[float, ...]:
    """Scene depths used when none are given: :data:`DEFAULT_DEPTH_FACTORS` times ``H``."""
    check_type("shooting", shooting, Shooting)
    return tuple(k * shooting.convergence for k in DEFAULT_DEPTH_FACTORS)


def depth_budget(shooting: Shooting, display: Display, depths: object = None) -> DepthBudget:
    """Divergence and roundness baselines, focal ratio, and per-depth disparity, z' and roundness.

    Parameters
    ----------
    shooting : Shooting
        The rig: baseline b, convergence distance H, window width W.
    display : Display
        The viewing set-up: eye separation b', distance H', screen width W' (resolution optional).
    depths : array_like of float, optional
        Scene depths in metres, each > 0 and at most :data:`~vergence.viewing.geometry.MAX_SCENE_DEPTH`,
        or ``inf`` (a point at infinity: d = b/W, roundness 0); a scalar or 1-D, any order, kept as given. Default:
        :func:`default_depths`, i.e. 0.5, 0.75, 1, 1.5, 2, 3, 5 and 10 times H.

    Returns
    -------
    DepthBudget
        ``to_dict()`` gives the JSON of ``vergence budget --json``.

    Raises
    ------
    TypeError
        If ``shooting`` or ``display`` has the wrong type.
    ValueError
        If ``depths`` is empty, not 1-D, or holds NaN, -inf, a value <= 0 or out of range.

    Notes
    -----
    S0 §2: ``d = (b/W)(z - H)/z`` (Eq. 1a), ``z' = z b'H'W / (z(b'W - bW') + bHW')`` (Eq. 2),
    ``b_div = b'W/W'`` (Eq. 3), ``rho = bH'W / (z(b'W - bW') + bHW')`` (Eq. 4),
    ``b_round = b'H/H'`` (Eq. 5), ``f/f' = b_round/b_div`` (Eq. 6). The eyes diverge where the
    denominator of Eq. (2) is negative, i.e. ``d > b'/W'``.

    Examples
    --------
    >>> budget = depth_budget(Shooting(0.26, 30.0, 3.0), Display(0.065, 3.0, 1.2), [30.0, 60.0])
    >>> round(budget.divergence_baseline, 6), round(budget.roundness_baseline, 6), budget.focal_ratio
    (0.1625, 0.65, 4.0)
    >>> [round(s.perceived_depth, 4) for s in budget.samples]
    [3.0, 15.0]
    """
    if not isinstance(shooting, Shooting):
        raise TypeError(f"shooting must be a Shooting; got {type(shooting).__name__}")
    check_display(display)
    if depths is None:
        z = np.array(default_depths(shooting))
    else:
        z = np.atleast_1d(real_array("depths", depths, allow_inf=True))
        if z.ndim != 1 or z.size == 0:
            raise ValueError(f"depths must be a non-empty 1-D sequence of metres; got shape {z.shape}")
        bad = np.isnan(z) | np.isneginf(z)
        if bad.any():
            raise ValueError(f"depths must be > 0 metres or inf (a point at infinity); got {z[bad][0]}")
        if (z <= 0).any():
            raise ValueError(f"depths must be > 0 (in front of the cameras); got {z.min():g}")
    finite = np.isfinite(z)
    z_fin = np.where(finite, z, shooting.convergence)  # the z-forms below only see finite depths
    check_depths("depths", z_fin)  # the documented range of a finite depth
    # Eq. (1a); at z = inf its limit b/W.
    d = np.where(finite, np.atleast_1d(disparity(z_fin, shooting)), shooting.baseline / shooting.window)
    # Eq. (2) and (4) in the form that is exact where it is used (issue 9: at extreme set-ups the
    # z-form cancelled, giving d = 0 a perceived depth of 0 or a divergence). With
    # gap = 1 - d/(b'/W') = (b' - W'd)/b', the denominator of Eq. (2) and (4) is z W b' gap, so
    # z' = H'/gap (Eq. 1b of Eq. 1a) and rho = b H'/(b' z gap): exact while gap >= 1/2 (d <= b'/(2W'),
    # no cancellation). Nearer the limit, the z-forms of geometry (exact sign at divergence_depth).
    limit = display.divergence_disparity
    gap = 1.0 - d / limit
    near = gap >= 0.5
    # At z = inf only the gap form applies (z' of Eq. 1b at d = b/W; rho -> 0, Eq. 4's limit).
    use_gap = near | ~finite
    with np.errstate(divide="ignore", invalid="ignore"):
        zp_gap = depth_ratio(display.distance, gap)
        rho_gap = shooting.baseline * display.distance / (display.eye_separation * z * np.where(near, gap, 1.0))
    zp_z = np.asarray(perceived_depth_from_depth(z_fin, shooting, display))  # NaN exactly past divergence_depth
    zp = np.where(use_gap, zp_gap, zp_z)
    rho = np.where(use_gap, np.where(finite, rho_gap, 0.0), roundness(z_fin, shooting, display))
    # The flag is Eq. (8) on the reported disparity, d > b'/W', except within DIVERGENCE_FLAG_ULPS of
    # divergence_depth, where d is the limit to its rounding and the exact sign of the z-form decides (the
    # eyes are parallel at that depth: 40 m in the README, whose d rounds an ulp past b'/W'). A z_div at or
    # below H is a rounded one (mathematically z_div > H, as d(z_div) = b'/W' > 0): d decides everywhere.
    # A flagged depth is never perceived; where the z-form says "diverges" but the flag does not, the
    # eyes are parallel to rounding (z' and rho null).
    z_div = divergence_depth(shooting, display)
    band = DIVERGENCE_FLAG_ULPS * np.finfo(float).eps * z_div
    at_limit = finite & (np.abs(z_fin - z_div) <= band) if math.isfinite(z_div) and z_div > shooting.convergence \
        else np.zeros(z.shape, dtype=bool)
    diverges = np.where(at_limit, np.isnan(zp_z), d > limit)
    zp = np.where(diverges | ~np.isfinite(zp), np.nan, zp)
    rho = np.where((diverges & (rho >= 0)) | (~diverges & (rho < 0)), np.nan, rho)
    samples = tuple(
        DepthSample(
            depth=float(z[i]),
            disparity=float(d[i]),
            parallax_px=None if display.resolution is None else float(d[i] * display.resolution),
            perceived_depth=float(zp[i]) if math.isfinite(zp[i]) else None,
            roundness=float(rho[i]) if math.isfinite(rho[i]) else None,
            diverges=bool(diverges[i]),
        )
        for i in range(z.size)
    )
    b_div = divergence_baseline(shooting.window, display)  # Eq. (3)
    return DepthBudget(
        divergence_baseline=b_div,
        roundness_baseline=roundness_baseline(shooting.convergence, display),  # Eq. (5)
        focal_ratio=focal_ratio(shooting, display),  # Eq. (6)
        divergence_depth=z_div,
        samples=samples,
        warnings=_warnings(samples, shooting, display, b_div, z_div),
    )


def _depth_list(samples: list[DepthSample]) -> str:
    return ", ".join("inf" if math.isinf(s.depth) else f"{s.depth:.4g}" for s in samples) + " m"


def _warnings(samples: tuple[DepthSample, ...], shooting: Shooting, display: Display, b_div: float,
              z_div: float) -> tuple[str, ...]:
    """The lines of :attr:`DepthBudget.warnings`: divergence (S0 Eq. 3, 8), then the comfort zone."""
    out = []
    diverging = [s for s in samples if s.diverges]
    if diverging:
        beyond = f"beyond z = {z_div:.4g} m" if math.isfinite(z_div) else "at infinity"
        out.append(f"the eyes diverge at z = {_depth_list(diverging)} ({beyond}): baseline b = {shooting.baseline:.4g} m "
                   f"exceeds b_div = {b_div:.4g} m (S0 Eq. 3)")
    zone = ComfortZone()
    try:
        lo, hi = zone.disparities(display)
    except ValueError as exc:  # a display whose eyes already converge near 180 degrees
        out.append(f"the comfort zone (±{zone.crossed_arcmin:g} arcmin) does not exist on this display: {exc}")
        return tuple(out)
    outside = [s for s in samples if not s.diverges and not lo <= s.disparity <= hi]
    if outside:
        out.append(f"outside the comfort zone (±{zone.crossed_arcmin:g} arcmin of vergence: d from {lo:+.4g} to "
                   f"{hi:+.4g} of the screen width): z = {_depth_list(outside)}")
    return tuple(out)
