"""The Quadri-Rig of S0 §5 ("being on the field"): real cameras that stand in for a virtual rig.

The director places a virtual shifted-sensor rig (S0 §2) where no camera can go, e.g. on the pitch.
Real cameras stand on the plane ``setback`` metres behind the virtual cameras, perpendicular to the
viewing direction. For each scene element (a point ``p_e``, e.g. the centre of gravity of the subject)
and each virtual eye ``v``, one real camera (S0 §5, Fig. 6):

- **position** (epipolar consistency, minimal angular deviation): where the line from ``p_e`` through
  ``v`` meets the real plane, ``c = p_e + k (v - p_e)`` with ``k = (z_e + s)/z_e``, ``z_e`` the depth of
  ``p_e`` in front of the virtual cameras and ``s`` the setback;
- **orientation**: the virtual eye's;
- **focal length** (S0 Eq. (10)): ``f_e = f_v (z_e + s)/z_e = k f_v``, the same resolution on the element;
- **principal point**: ``pp_c = pp_v + f_v (c - v)_{x,y} / z_e`` (camera-frame offsets), so that the plane
  through ``p_e`` facing the cameras is imaged pixel for pixel as the virtual eye images it.

The two real cameras of an element are ``k b_v`` apart. N elements give 2N cameras. Pure geometry.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array
from vergence.camera import Camera
from vergence.rigs._shifted import check_rig_length
from vergence.rigs.cameras import RIG_EYES, RigCamera, check_element_name
from vergence.rigs.stereo import stereo_pair

__all__ = ["QUADRI_MAX_FOCAL_RATIO", "QUADRI_WARN_FOCAL_RATIO", "QuadriRig", "plan_quadri_rig"]

# The focal ratio k = (z_e + s) / z_e of an element's real cameras grows without bound as the element
# nears the virtual cameras' plane (z_e -> 0): an element 2 mm in front with a 20 m setback asks for
# 10,001x the virtual focal length and cameras kilometres apart. Past 1000x no lens exists (the longest
# broadcast zooms reach about 100x their own widest focal length): refused. Past 20x, warned: the real
# cameras stand more than 19 element depths behind the virtual ones and see the element at grazing
# resolution of everything nearer.
QUADRI_MAX_FOCAL_RATIO = 1000.0
QUADRI_WARN_FOCAL_RATIO = 20.0


@dataclass(frozen=True, slots=True, eq=False)
class QuadriRig:
    """A planned Quadri-Rig (S0 §5): the virtual rig and its real cameras.

    Attributes
    ----------
    center : Camera
        The virtual rig's centre camera (the shot's camera).
    left, right : Camera
        The virtual eyes (:func:`~vergence.rigs.stereo_pair` of ``center``): the views to synthesise.
    setback : float
        Distance from the virtual cameras back to the real camera plane, metres.
    elements : tuple of (str, ndarray)
        The elements' names and world points ``(3,)``, in the order given.
    cameras : tuple of RigCamera
        Two per element, element by element, left eye then right eye; named ``f"{element}_{eye}"``.
    warnings : tuple of str
        One line each for what can be built but is absurd (a focal ratio past
        :data:`QUADRI_WARN_FOCAL_RATIO`, a virtual baseline longer than an element's depth).
    """

    center: Camera
    left: Camera
    right: Camera
    setback: float
    elements: tuple[tuple[str, np.ndarray], ...]
    cameras: tuple[RigCamera, ...]
    warnings: tuple[str, ...] = ()

    def sources(self, eye: str) -> tuple[RigCamera, ...]:
        """The real cameras serving ``eye`` (``"left"`` or ``"right"``), in element order."""
        if eye not in RIG_EYES:
            raise ValueError(f"eye must be one of {', '.join(RIG_EYES)}; got {eye!r}")
        return tuple(c for c in self.cameras if c.eye == eye)

    def virtual(self, eye: str) -> Camera:
        """The virtual eye ``"left"`` or ``"right"``."""
        if eye not in RIG_EYES:
            raise ValueError(f"eye must be one of {', '.join(RIG_EYES)}; got {eye!r}")
        return self.left if eye == "left" else self.right

    @property
    def baselines(self) -> dict[str, float]:
        """Distance between each element's two real cameras, metres: ``b_e = b_v (z_e + s)/z_e`` (S0 §5)."""
        by_name = {(c.element, c.eye): c.camera.center for c in self.cameras}
        return {name: float(np.linalg.norm(by_name[name, "right"] - by_name[name, "left"])) for name, _ in self.elements}

    def to_dict(self) -> dict[str, object]:
        """JSON-ready plan: ``{"rig": "quadri", "setback", "virtual": {"center", "left", "right"},
        "elements": [{"name", "point", "baseline"}], "cameras": [RigCamera.to_dict()...]}``."""
        baselines = self.baselines
        return {
            "rig": "quadri",
            "setback": self.setback,
            "virtual": {"center": self.center.to_dict(), "left": self.left.to_dict(), "right": self.right.to_dict()},
            "elements": [{"name": n, "point": p.tolist(), "baseline": baselines[n]} for n, p in self.elements],
            "cameras": [c.to_dict() for c in self.cameras],
        }


def _elements(elements: object) -> list[tuple[str, np.ndarray]]:
    """``elements`` as ``[(name, point)]``: a mapping name -> point or a sequence of (name, point) pairs."""
    if isinstance(elements, Mapping):
        pairs = list(elements.items())
    elif isinstance(elements, Sequence) and not isinstance(elements, str | bytes):
        pairs = list(elements)
    else:
        raise TypeError(f"elements must be a sequence of (name, point) pairs or a mapping; got {type(elements).__name__}")
    if not pairs:
        raise ValueError("elements must hold at least one (name, point); got none")
    out: list[tuple[str, np.ndarray]] = []
    for k, pair in enumerate(pairs):
        if not isinstance(pair, tuple | list) or len(pair) != 2:
            raise TypeError(f"elements[{k}] must be a (name, point) pair; got {pair!r}")
        name = check_element_name(pair[0], what=f"elements[{k}] name")
        if any(name == other for other, _ in out):
            raise ValueError(f"elements[{k}] name {name!r} is used twice; element names must be unique")
        point = as_float_array(f"element {name!r} point", pair[1], shape=(3,))
        out.append((name, point))
    return out


def plan_quadri_rig(
    camera: Camera, *, baseline: float, convergence: float, setback: float, elements: object
) -> QuadriRig:
    """Place the real cameras of a Quadri-Rig for a virtual rig (S0 §5, Eq. (10)).

    Parameters
    ----------
    camera : Camera
        The virtual rig's centre camera; its optical axis is the viewing direction.
    baseline, convergence : float
        ``b_v`` and ``H_v`` of the virtual shifted-sensor rig (S0 §2), metres, in ``LENGTH_RANGE``.
    setback : float
        Distance ``s`` from the virtual cameras back to the real camera plane, metres, > 0.
    elements : sequence of (name, point) or mapping name -> point
        Scene elements, each a world point ``(3,)`` (metres) in front of the virtual cameras; names
        unique, matching :data:`~vergence.rigs.cameras.ELEMENT_NAME_PATTERN`.

    Returns
    -------
    QuadriRig
        With ``2 N`` cameras: for element e and eye v (left, right), the centre
        ``c = p_e + k (v - p_e)``, ``k = (z_e + s)/z_e``, the virtual eye's rotation and
        ``K_c = K_v [[k, 0, -dx/z_e], [0, k, -dy/z_e], [0, 0, 1]]`` with ``(dx, dy)`` the camera-frame
        offset of ``v`` from ``c``: focal lengths ``k f_v`` (S0 Eq. (10)) and principal point
        ``pp_v + f_v (c - v)/z_e``.

    Raises
    ------
    TypeError
        ``camera`` not a Camera; malformed ``elements``.
    ValueError
        ``setback`` not > 0 (or outside ``LENGTH_RANGE``); no elements; a duplicate or malformed name; a
        non-finite point; an element behind or on the virtual cameras' plane, or behind the real
        camera plane, or so close in front of the virtual cameras' plane that its focal ratio
        ``k = (z_e + s)/z_e`` exceeds :data:`QUADRI_MAX_FOCAL_RATIO` (the message names the element).

    A rig that can be built but is absurd is planned with one-line :attr:`QuadriRig.warnings`: a
    focal ratio past :data:`QUADRI_WARN_FOCAL_RATIO`; a virtual baseline longer than an element's
    depth (its eyes would converge by more than 53 degrees on it; no display fuses that). Since ``s > 0`` and ``z_e > 0``, ``k > 1``: every
        real camera stands behind the virtual one, never past its element.

    Notes
    -----
    Why the element plane images identically: a point ``X`` at depth ``z_e`` is at ``(X_v, Y_v, z_e)``
    from ``v`` and at ``(X_v + dx, Y_v + dy, k z_e)`` from ``c``, so its normalised coordinates from ``c``
    are ``A (X_v/z_e, Y_v/z_e, 1)`` with ``A = [[1/k, 0, dx/(k z_e)], [0, 1/k, dy/(k z_e)], [0, 0, 1]]``;
    ``K_c = K_v A^-1`` gives the virtual eye's pixels.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> cam = look_at([3.5, 0, 45], [3.5, 0, 60], [0, -1, 0], fov_deg=40, width=64, height=48)
    >>> rig = plan_quadri_rig(cam, baseline=1.0, convergence=15.0, setback=45.0,
    ...                       elements=[("subject", [0.5, 0.0, 60.0])])
    >>> left = rig.cameras[0]
    >>> left.name, left.camera.center.round(6).tolist(), round(left.camera.focal_px / cam.focal_px, 12)
    ('subject_left', [10.5, 0.0, 0.0], 4.0)
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a vergence.camera.Camera; got {type(camera).__name__}")
    left, right = stereo_pair(camera, baseline=baseline, convergence=convergence)
    s = check_rig_length("setback", setback)
    items = _elements(elements)
    forward = camera.R[2]
    b_v = float(np.linalg.norm(right.center - left.center))
    cameras = []
    warnings: list[str] = []
    for name, point in items:
        z_e = float(forward @ (point - camera.center))  # depth in front of the virtual cameras
        if z_e <= -s:
            raise ValueError(f"element {name!r} at {point.tolist()} is behind the real camera plane "
                             f"({-z_e:g} m behind the virtual cameras, setback {s:g} m)")  # fmt: skip
        if z_e <= 0:
            raise ValueError(f"element {name!r} at {point.tolist()} is behind or on the virtual cameras "
                             f"(depth {z_e:g} m); it must be in front of them")  # fmt: skip
        k = (z_e + s) / z_e  # S0 Eq. (10): f_e / f_v = distance real -> element / distance virtual -> element
        if k > QUADRI_MAX_FOCAL_RATIO:
            raise ValueError(f"element {name!r} at {point.tolist()} is {z_e:.3g} m in front of the virtual cameras' plane: "
                             f"its real cameras would need {k:.4g}x the virtual focal length and stand "
                             f"{k * b_v:.4g} m apart (at most {QUADRI_MAX_FOCAL_RATIO:g}x: place it at least "
                             f"{s / (QUADRI_MAX_FOCAL_RATIO - 1):.3g} m in front)")  # fmt: skip
        if k > QUADRI_WARN_FOCAL_RATIO:
            warnings.append(f"element {name!r} is only {z_e:.3g} m in front of the virtual cameras: its real cameras "
                            f"need {k:.4g}x the virtual focal length (above {QUADRI_WARN_FOCAL_RATIO:g}x)")  # fmt: skip
        if b_v > z_e:
            warnings.append(f"the virtual baseline {b_v:.4g} m is longer than element {name!r}'s depth {z_e:.4g} m: "
                            f"the eyes converge by {math.degrees(2 * math.atan(b_v / (2 * z_e))):.0f} degrees on it; "
                            "no display fuses that")  # fmt: skip
        for eye, virtual in (("left", left), ("right", right)):
            center = point + k * (virtual.center - point)  # on the line (p_e, v), on the real plane (S0 Fig. 6)
            dx, dy = camera.R[:2] @ (virtual.center - center)
            A_inv = np.array([[k, 0.0, -dx / z_e], [0.0, k, -dy / z_e], [0.0, 0.0, 1.0]])
            K = virtual.K @ A_inv
            if not (np.isfinite(K).all() and np.isfinite(center).all()):
                raise ValueError(f"element {name!r} at {point.tolist()} gives a non-finite camera (depth {z_e:g} m "
                                 f"in front of the virtual cameras, focal ratio {k:g})")  # fmt: skip
            cam = Camera(K=K, R=camera.R, t=-camera.R @ center, width=camera.width, height=camera.height)
            cameras.append(RigCamera(name=f"{name}_{eye}", element=name, eye=eye, camera=cam))
    for _, point in items:
        point.setflags(write=False)
    return QuadriRig(center=camera, left=left, right=right, setback=s, elements=tuple(items), cameras=tuple(cameras),
                     warnings=tuple(warnings))
