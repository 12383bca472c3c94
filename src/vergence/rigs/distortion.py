"""The world distortion phi of the Tri-Rig (S0 §6, Fig. 9): depth remapped along the left camera's rays.

A disparity mapping ``psi`` (S0 Eq. (7)–(9)) changes the disparity a reference rig ``(b_r, H_r, W_r)``
sees. S0 Fig. 9 turns it into a deformation of 3D space: project ``p`` into the left image, warp the
disparity by psi, and back-project with the reference right camera. The result slides ``p`` along its
left-camera ray, from depth ``z`` (camera-frame z of the left camera) to

    z' = D_r^-1(psi(D_r(z))),   D_r(z) = (b_r/W_r)(z - H_r)/z,   D_r^-1(d) = H_r / (1 - W_r d / b_r)

(S0 Eq. (1a) and (1c) of the reference rig), i.e. ``phi(p) = c_l + (z'/z)(p - c_l)``: the left image is
unchanged and the reference right camera (the left camera moved ``b_r`` along its right axis, sensor
shifted by ``fx b_r / H_r``) sees the disparity ``psi(d(z))`` exactly. Rendering the Tri-Rig's right
image = rendering the distorted world with that straight pinhole camera.

Lengths in metres; disparities ``d = x_r - x_l`` as fractions of the window width (S0's sign, see
``docs/conventions.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.camera import Camera
from vergence.rigs._shifted import shifted_right_camera
from vergence.viewing.geometry import Shooting

__all__ = ["WINDOW_RTOL", "WorldDistortion"]

# The reference window must be W_r = H_r width / fx of the left camera (the rig's window is the left
# image); planners compute it with that very formula, so only rounding separates them: 1e-9 relative
# also lets a window read back from 10-digit text through, and refuses any other window.
WINDOW_RTOL = 1e-9


def _as_real(name: str, value: object) -> np.ndarray:
    """``value`` as a float64 array (NaN and inf kept: they mark undefined points); text refused."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        raise TypeError(f"{name} must be numeric; got {type(value).__name__}") from None
    if isinstance(value, str | bytes) or arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be numeric; got {type(value).__name__}")
    return arr.astype(np.float64)


def _as_points(name: str, value: object) -> np.ndarray:
    arr = _as_real(name, value)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3); got {arr.shape}")
    return arr


@dataclass(frozen=True, slots=True, eq=False)
class WorldDistortion:
    """phi: the world as the Tri-Rig's reference right camera must see it (S0 §6, Fig. 9).

    Parameters
    ----------
    left : Camera
        The director's (left) camera; depth ``z`` is its camera-frame z and phi scales about its
        centre ``c_l``.
    reference : Shooting
        Reference rig ``(b_r, H_r, W_r)`` whose disparity psi maps; ``W_r`` must be
        ``H_r * width / fx`` of ``left`` (to :data:`WINDOW_RTOL`): the window is the left image.
    psi : DisparityMapping or callable
        Increasing disparity mapping, vectorised, with ``psi.derivative(d)`` and ``psi.inverse(v)``
        (a :class:`~vergence.viewing.ConstrainedMapping`'s ``psi``).

    Notes
    -----
    Where phi is undefined the result is NaN, never an exception mid-array: points on or behind the
    left camera's centre plane (``z <= 0``), non-finite coordinates, depths whose mapped disparity
    ``psi(d)`` reaches ``b_r/W_r`` (they would be sent to infinity or behind the camera) and, for
    :meth:`inverse`, distorted depths beyond ``depth(inf)`` (no real point maps there).

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> from vergence.viewing import LinearMapping
    >>> cam = look_at([0, 0, 0], [0, 0, -1], [0, 1, 0], fov_deg=10, width=100, height=50)
    >>> H = 30.0; W = H * cam.width / cam.focal_px
    >>> phi = WorldDistortion(cam, Shooting(0.5, H, W), LinearMapping(-1.0, 1.0, -0.5, 0.5))  # psi(d) = d/2
    >>> round(float(phi.depth(60.0)), 6)  # d(60) = (b/W) / 2 is halved: z' = H / (1 - 1/4)
    40.0
    """

    left: Camera
    reference: Shooting
    psi: object

    def __post_init__(self) -> None:
        if not isinstance(self.left, Camera):
            raise TypeError(f"left must be a vergence.camera.Camera; got {type(self.left).__name__}")
        if not isinstance(self.reference, Shooting):
            raise TypeError(f"reference must be a vergence.viewing.Shooting; got {type(self.reference).__name__}")
        missing = [a for a in ("derivative", "inverse") if not callable(getattr(self.psi, a, None))]
        if not callable(self.psi) or missing:
            raise TypeError(f"psi must be callable with .derivative and .inverse methods; got {type(self.psi).__name__}")
        ref = self.reference
        window = ref.convergence * self.left.width / self.left.focal_px
        if not abs(ref.window - window) <= WINDOW_RTOL * window:
            raise ValueError(f"reference window must be H_r * width / fx = {window:.10g} m for the left camera "
                             f"(WINDOW_RTOL {WINDOW_RTOL:g}); got {ref.window:.10g}")  # fmt: skip

    # ------------------------------------------------------------------ reference rig, S0 Eq. (1a), (1c)
    def _disparity(self, z: np.ndarray) -> np.ndarray:
        """``D_r(z) = (b_r/W_r)(z - H_r)/z`` (S0 Eq. 1a); ``b_r/W_r`` at ``z = inf``."""
        ref = self.reference
        with np.errstate(invalid="ignore"):
            ratio = (z - ref.convergence) / z  # (z - H)/z rather than 1 - H/z: exactly 0 at z = H
        return (ref.baseline / ref.window) * np.where(np.isinf(z), 1.0, ratio)

    def _depth_of(self, d: np.ndarray) -> np.ndarray:
        """``D_r^-1(d) = H_r / (1 - W_r d / b_r)`` (S0 Eq. 1c), exact at ``d = 0``; NaN unless > 0 and finite."""
        ref = self.reference
        with np.errstate(divide="ignore", invalid="ignore"):
            z = ref.convergence / (1.0 - (ref.window / ref.baseline) * d)
        return np.where((z > 0) & np.isfinite(z), z, np.nan)

    def _mapped_depth(self, z: np.ndarray) -> np.ndarray:
        """z' of every z (flat float64 array), NaN where undefined."""
        out = np.full(z.shape, np.nan)
        ok = z > 0  # False for NaN
        if ok.any():
            out[ok] = self._depth_of(np.asarray(self.psi(self._disparity(z[ok])), dtype=np.float64))
        return out

    def _psi_inverse(self, v: np.ndarray) -> np.ndarray:
        """psi^-1 of finite values (flat), NaN where no depth z > 0 maps to them.

        ``D_r(z)`` of a real point is below ``b_r/W_r``, so psi of it is below ``psi(b_r/W_r)``: larger
        values have no preimage in front of the camera and are never handed to ``psi.inverse``. A
        mapping whose range is bounded below refuses values under it: those are then inverted one by
        one, NaN where refused (the ConstrainedMapping's psi, linear below its first knot, never does).
        """
        out = np.full(v.shape, np.nan)
        ref = self.reference
        top = float(np.asarray(self.psi(np.array([ref.baseline / ref.window])), dtype=np.float64)[0])
        ok = v < top
        if not ok.any():
            return out
        try:
            out[ok] = np.asarray(self.psi.inverse(v[ok]), dtype=np.float64)
        except ValueError:
            for k in np.flatnonzero(ok):
                try:
                    out[k] = float(np.asarray(self.psi.inverse(v[k : k + 1]), dtype=np.float64)[0])
                except ValueError:
                    out[k] = np.nan
        return out

    # ------------------------------------------------------------------ public maps
    def depth(self, z: object) -> float | np.ndarray:
        """Mapped depth ``z' = D_r^-1(psi(D_r(z)))`` of left-camera depths ``z`` (S0 §6), same shape.

        ``z`` may hold ``inf`` (``D_r(inf) = b_r/W_r``); NaN where undefined (see the class notes).
        """
        arr = _as_real("z", z)
        with np.errstate(invalid="ignore"):
            out = self._mapped_depth(arr.ravel()).reshape(arr.shape)
        return float(out) if out.ndim == 0 else out

    def _frame(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``p - c_l`` and the left-camera depth ``z`` (NaN where not finite or not in front)."""
        rel = points - self.left.center
        with np.errstate(invalid="ignore"):
            z = rel @ self.left.R[2]
            z = np.where(np.isfinite(rel).all(axis=-1) & (z > 0), z, np.nan)
        return rel, z

    def forward(self, points: object) -> np.ndarray:
        """``phi(p) = c_l + (z'/z)(p - c_l)`` (S0 §6, Fig. 9) of points ``(..., 3)``; NaN where undefined.

        The left camera sees ``phi(p)`` at the pixel of ``p``; the reference right camera sees it with
        the disparity ``psi(d(z))`` (:attr:`reference_right`).
        """
        p = _as_points("points", points)
        rel, z = self._frame(p)
        with np.errstate(invalid="ignore"):
            scale = self._mapped_depth(z.ravel()).reshape(z.shape) / z
        return self.left.center + scale[..., None] * rel

    def inverse(self, points: object) -> np.ndarray:
        """``phi^-1(q) = c_l + (z/z_q)(q - c_l)`` with ``z = D_r^-1(psi^-1(D_r(z_q)))`` (S0 §6); NaN where undefined.

        ``psi^-1`` is the mapping's own (closed-form for the Gregory–Delbourgo psi), vectorised.
        """
        q = _as_points("points", points)
        rel, zq = self._frame(q)
        flat = zq.ravel()
        z = np.full(flat.shape, np.nan)
        ok = ~np.isnan(flat)
        if ok.any():
            with np.errstate(invalid="ignore"):
                z[ok] = self._depth_of(self._psi_inverse(self._disparity(flat[ok])))
        scale = z.reshape(zq.shape) / zq
        return self.left.center + scale[..., None] * rel

    def jacobian(self, points: object) -> np.ndarray:
        """``D phi`` at UNDISTORTED points ``(..., 3)``: ``(..., 3, 3)``, NaN where phi is undefined.

        Notes
        -----
        With ``s = z'/z`` and ``e_z`` the left camera's forward axis (``z = e_z . (p - c_l)``)::

            D phi(p) = s I + (p - c_l) (grad s)^T,   grad s = e_z (dz'/dz / z - z'/z^2)
            dz'/dz = (D_r^-1)'(psi(d)) psi'(d) D_r'(z) = psi'(d) (z'/z)^2

        since ``D_r'(z) = b_r H_r/(W_r z^2)`` and ``(D_r^-1)'(delta) = W_r z'^2/(b_r H_r)`` (S0 §6).
        ``J[..., i, j] = d phi_i / d p_j``.
        """
        p = _as_points("points", points)
        rel, z = self._frame(p)
        flat = z.ravel()
        zp = self._mapped_depth(flat)
        slope = np.full(flat.shape, np.nan)
        ok = ~np.isnan(zp)
        if ok.any():
            slope[ok] = np.asarray(self.psi.derivative(self._disparity(flat[ok])), dtype=np.float64)
        with np.errstate(invalid="ignore"):
            s = zp / flat
            dzp = slope * s * s  # dz'/dz = psi'(d) (z'/z)^2
            ds = (dzp - s) / flat  # d(z'/z)/dz = dz'/dz / z - z'/z^2
        s, ds = s.reshape(z.shape), ds.reshape(z.shape)
        grad = ds[..., None] * self.left.R[2]
        return s[..., None, None] * np.eye(3) + rel[..., :, None] * grad[..., None, :]

    @property
    def reference_right(self) -> Camera:
        """The reference right camera: ``left`` moved ``b_r`` along its right axis, ``cx + fx b_r / H_r``.

        Its pixel disparity with ``left`` is ``x_l - x_r = fx b_r (1/z - 1/H_r)`` (S0 Eq. 1a), so it sees
        the distorted world with S0's disparity ``psi(d(z))``.
        """
        return shifted_right_camera(self.left, self.reference.baseline, self.reference.convergence)
