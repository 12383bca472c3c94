"""The Tri-Rig of S0 §6 ("distort the world"): the director's camera, a subject camera, a background camera.

The director frames the shot with one camera (the left image, unchanged) and asks, per scene element,
for a perceived depth and optionally a roundness (:class:`~vergence.viewing.DirectorConstraint`).

1. **Subject camera** (the nearest constraint, with a depth and a roundness): the single rig meeting both
   at ``z_e`` for the director's focal ``f = fx / width`` (S0 §6, from S0 Eq. (2) and (4))::

       b = rho_e z_e b' / z'_e
       H = z'_e z_e b W' / (z'_e z_e b'/f + z'_e b W' - z_e b' H'/f),   W = H / f

   With ``z_e = H``, ``z'_e = H'``, ``rho_e = 1`` this is ``b_round = b' H / H'`` (S0 Eq. (5)).
2. **Background camera** (the farthest constraint; its depth): ``(H, W)`` kept, the baseline giving
   ``z'(z_b) = z'_b`` by S0 Eq. (2)::

       b_3 = b' W (H'/z'_b - 1) / (W' (H/z_b - 1))      (b_div = b'W/W' for z_b, z'_b -> inf, S0 Eq. (3))

3. **psi** from all the constraints on a reference rig, ``"round"`` (the subject rig ``(b, H, W)``:
   S0 Fig. 8 right) or ``"div"`` (``b_div`` with the same ``H, W``: Fig. 8 left), and the world
   distortion phi rendering the right image with the reference right camera (S0 Fig. 9).

Each right camera is the director moved ``b`` along its right axis, its principal point shifted by
``fx b / H`` (the shifted-sensor pair of S0 §2 with the director as left camera). Pure geometry.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from vergence.camera import Camera
from vergence.rigs._shifted import shifted_right_camera
from vergence.rigs.cameras import RigCamera
from vergence.rigs.distortion import WorldDistortion
from vergence.viewing import ConstrainedMapping, DirectorConstraint, Display, Shooting, check_display, psi_from_constraints

__all__ = ["TRI_REFERENCES", "TriRig", "plan_tri_rig"]

TRI_REFERENCES = ("round", "div")
"""Reference rigs for psi (S0 §6, Fig. 8): ``"round"`` the subject rig ``(b_s, H, W)`` (psi compresses the
background, keeps the subject), ``"div"`` the divergence baseline ``b'W/W'`` (psi expands near the
subject, keeps the background)."""


@dataclass(frozen=True, slots=True, eq=False)
class TriRig:
    """A planned Tri-Rig (S0 §6).

    Attributes
    ----------
    director : Camera
        The left camera: the director's, unchanged; its image is the final left image.
    subject, background : Camera
        The right cameras meeting the nearest constraint (depth and roundness) and the farthest (depth).
    reference : Shooting
        Reference rig ``(b_r, H, W)`` whose disparity psi maps; ``H, W`` are the subject rig's.
    reference_right : Camera
        The camera rendering the right image in the distorted world (``distortion.reference_right``).
    mapping : ConstrainedMapping
        psi with its control points and report (``vergence mapping``'s).
    distortion : WorldDistortion
        phi, phi^-1 and D phi for the director's camera, the reference rig and psi.
    display : Display
        The viewing set-up the constraints are for.
    cameras : tuple of RigCamera
        ``director`` (eye left), ``subject`` and ``background`` (eye right).
    """

    director: Camera
    subject: Camera
    background: Camera
    reference: Shooting
    reference_right: Camera
    mapping: ConstrainedMapping
    distortion: WorldDistortion
    display: Display
    cameras: tuple[RigCamera, ...]

    @property
    def warnings(self) -> tuple[str, ...]:
        """psi's comfort warnings (``vergence mapping``'s, :attr:`ConstrainedMapping.warnings`), one line each."""
        return tuple(self.mapping.warnings)

    @property
    def baselines(self) -> dict[str, float]:
        """Distance of the subject and background cameras from the director, metres."""
        return {name: float(math.dist(getattr(self, name).center, self.director.center)) for name in ("subject", "background")}

    def to_dict(self) -> dict[str, object]:
        """JSON-ready plan: ``{"rig": "tri", "display", "reference": {"baseline", "convergence", "window"},
        "reference_right", "baselines", "near", "far" (None = inf), "control_points": [{"disparity", "value",
        "slope"}...] (as ``vergence mapping`` prints them), "cameras": [RigCamera.to_dict()...]}``."""
        ref, display, m = self.reference, self.display, self.mapping
        return {
            "rig": "tri",
            "display": {"eye_separation": display.eye_separation, "distance": display.distance,
                        "width": display.width, "resolution": display.resolution},
            "reference": {"baseline": ref.baseline, "convergence": ref.convergence, "window": ref.window},
            "reference_right": self.reference_right.to_dict(),
            "baselines": self.baselines,
            "near": m.near,
            "far": m.far if math.isfinite(m.far) else None,
            "control_points": [{"disparity": p.disparity, "value": p.value, "slope": p.slope} for p in m.control_points],
            "cameras": [c.to_dict() for c in self.cameras],
        }


def _constraints(constraints: object) -> list[DirectorConstraint]:
    if isinstance(constraints, str | DirectorConstraint) or not isinstance(constraints, Sequence):
        raise TypeError(f"constraints must be a sequence of constraint strings or DirectorConstraints; "
                        f"got {type(constraints).__name__}")  # fmt: skip
    items = []
    for k, c in enumerate(constraints):
        if isinstance(c, str):
            c = DirectorConstraint.from_string(c)
        elif not isinstance(c, DirectorConstraint):
            raise TypeError(f"constraints[{k}] must be a string 'z=Z,perceived=Z[,roundness=R]' or a "
                            f"DirectorConstraint; got {type(c).__name__}")  # fmt: skip
        items.append(c)
    if len(items) < 2:
        raise ValueError(f"constraints must hold at least 2 (the subject's depth and roundness, the background's "
                         f"depth); got {len(items)}")  # fmt: skip
    items.sort(key=lambda c: c.depth)
    for a, b in zip(items, items[1:]):
        if a.depth == b.depth:
            raise ValueError(f"constraints {a} and {b} are at the same depth")
    return items


def _shooting(what: str, constraint: DirectorConstraint, baseline: float, convergence: float, window: float) -> Shooting:
    """A Shooting, or a ValueError naming the constraint that asked for it."""
    if not all(math.isfinite(v) and v > 0 for v in (baseline, convergence, window)):
        raise ValueError(f"constraint {constraint}: no {what} satisfies it (baseline {baseline:g} m, "
                         f"convergence {convergence:g} m, window {window:g} m; all must be finite and > 0)")  # fmt: skip
    try:
        return Shooting(baseline=baseline, convergence=convergence, window=window)
    except ValueError as exc:
        raise ValueError(f"constraint {constraint}: no {what} satisfies it: {exc}") from None


def plan_tri_rig(
    director: Camera,
    display: Display,
    constraints: Sequence[str | DirectorConstraint],
    *,
    reference: str = "round",
    near: float | None = None,
    far: float = math.inf,
) -> TriRig:
    """Plan a Tri-Rig: subject and background cameras, psi and the world distortion (S0 §6).

    Parameters
    ----------
    director : Camera
        The director's camera: the left camera and image. Its focal ``f = fx / width`` fixes ``W = H / f``.
    display : Display
        Viewing set-up ``(b', H', W')``.
    constraints : sequence of str or DirectorConstraint
        At least two, e.g. ``["z=30,perceived=3,roundness=1", "z=65,perceived=6"]``, sorted by depth
        here. The nearest needs a roundness (it fixes the subject camera); the farthest gives the background
        camera; all of them shape psi (one in between shapes psi only).
    reference : str
        ``"round"`` or ``"div"`` (:data:`TRI_REFERENCES`).
    near : float, optional
        Nearest scene depth psi must handle, metres; default half the nearest constraint's depth (psi
        continues below the subject with the slope it has there, so the default only sets where
        monotonicity and divergence are checked).
    far : float
        Farthest scene depth, metres, ``inf`` by default.

    Returns
    -------
    TriRig

    Raises
    ------
    TypeError
        ``director``, ``display`` or a constraint of the wrong type.
    ValueError
        Fewer than two constraints; a malformed one; a nearest constraint without a roundness; a subject
        or background rig that does not exist (a baseline or convergence not finite and > 0, e.g. a
        background nearer than the convergence plane asked to appear behind the screen); constraints psi
        cannot meet (:func:`~vergence.viewing.psi_from_constraints`'s errors), or a psi that is not monotone
        or passes the divergence limit on ``[near, far]``; an unknown ``reference``. Each names the constraint.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> cam = look_at([0, 2.2, 0], [0, 1.1, -30], [0, 1, 0], fov_deg=8, width=480, height=270)
    >>> tv = Display(eye_separation=0.065, distance=3.0, width=1.2176)
    >>> rig = plan_tri_rig(cam, tv, ["z=30,perceived=3,roundness=1", "z=65,perceived=6"])
    >>> {k: round(v, 4) for k, v in rig.baselines.items()}  # b_round = b' H / H' = 0.65 m
    {'subject': 0.65, 'background': 0.208}
    >>> round(rig.reference.convergence, 9), [c.name for c in rig.cameras]
    (30.0, ['director', 'subject', 'background'])
    """
    if not isinstance(director, Camera):
        raise TypeError(f"director must be a vergence.camera.Camera; got {type(director).__name__}")
    check_display(display)
    if reference not in TRI_REFERENCES:
        raise ValueError(f"reference must be one of {', '.join(TRI_REFERENCES)}; got {reference!r}")
    items = _constraints(constraints)
    first, last = items[0], items[-1]
    if first.roundness is None:
        raise ValueError(f"constraint {first}: the nearest constraint sets the subject camera and needs a roundness, "
                         f"e.g. '{first},roundness=1'")  # fmt: skip
    b_, H_, W_ = display.eye_separation, display.distance, display.width
    f = director.focal_px / director.width  # normalised focal H/W of the director (S0 §2)
    z_e, zp_e = first.depth, first.perceived_depth
    b_s = first.roundness * z_e * b_ / zp_e  # S0 §6: depth and roundness at one element
    with_b = zp_e * z_e * b_ / f + zp_e * b_s * W_ - z_e * b_ * H_ / f
    H = zp_e * z_e * b_s * W_ / with_b if with_b != 0 else math.inf
    subject_rig = _shooting("subject rig", first, b_s, H, H / f)
    H, W = subject_rig.convergence, subject_rig.window
    z_b, zp_b = last.depth, last.perceived_depth
    denominator = W_ * (H / z_b - 1.0)  # S0 Eq. (2) solved for b with (H, W) fixed; inf depths give 0 ratios
    b_3 = b_ * W * (H_ / zp_b - 1.0) / denominator if denominator != 0 else math.inf
    _shooting("background camera on the subject rig's convergence", last, b_3, H, W)
    if reference == "round":
        ref = subject_rig
    else:
        ref = Shooting(baseline=b_ * W / W_, convergence=H, window=W)  # b_div, S0 Eq. (3)
    z_near = 0.5 * first.depth if near is None else near
    mapping = psi_from_constraints(ref, display, items, near=z_near, far=far)
    listed = ", ".join(f"'{c}'" for c in items)
    if not mapping.monotone:
        raise ValueError(f"constraints {listed}: psi is not monotone on [near, far] (depth order would reverse)")
    if mapping.diverges:
        raise ValueError(f"constraints {listed}: psi passes the divergence limit b'/W' = {display.divergence_disparity:g} "
                         f"on [near, far] (S0 Eq. 8)")  # fmt: skip
    distortion = WorldDistortion(director, ref, mapping.psi)
    subject = shifted_right_camera(director, b_s, H)
    background = shifted_right_camera(director, b_3, H)
    cameras = (
        RigCamera(name="director", element="director", eye="left", camera=director),
        RigCamera(name="subject", element="subject", eye="right", camera=subject),
        RigCamera(name="background", element="background", eye="right", camera=background),
    )
    return TriRig(director=director, subject=subject, background=background, reference=ref,
                  reference_right=distortion.reference_right, mapping=mapping, distortion=distortion,
                  display=display, cameras=cameras)  # fmt: skip
