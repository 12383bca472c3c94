"""Pinhole cameras: projection, back-projection, ``look_at`` and interpolation.

Conventions (see ``docs/conventions.md``): camera frame x right, y down, z forward; column
vectors, ``x_cam = R @ x_world + t``; ``K`` in pixels; pixel (x, y) = (column, row) with pixel
centres at integer coordinates; depth is the camera-frame z in metres (not the ray length).
Off-axis principal points (S0's sensor shift) are allowed anywhere, even outside the image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array, check_finite, check_in_range, check_positive_int, readonly_copy

__all__ = ["Camera", "MIN_FOCAL_PX", "MIN_FOV_DEG", "interpolate", "look_at"]

MIN_FOCAL_PX = 1e-6
"""Shortest focal length a :class:`Camera` takes, pixels: a field of view within 1e-4 deg of 180 deg
over 32768 px still has fx above it, and pixel offsets divided by it stay far inside the float range
(a subnormal fx made ``ray_directions`` overflow to inf)."""

MIN_FOV_DEG = 1e-3
"""Narrowest horizontal field of view :func:`look_at` builds, degrees (3.6 arcsec): narrower than any
imaging telescope's field (Hubble's WFC3 spans about 0.04 deg), and it keeps the focal length
``width / (2 tan(fov / 2))`` finite where a subnormal field of view would divide by a zero tangent."""

# A rotation matrix must satisfy R R^T = I and det R = 1 to this absolute tolerance: loose enough
# for matrices read from 6-digit text files (Middlebury, Bundler), tight enough to reject scaling.
_ROTATION_TOL = 1e-4


@dataclass(frozen=True, slots=True, eq=False)
class Camera:
    """A pinhole camera ``x_pix ~ K (R x_world + t)``.

    Parameters
    ----------
    K : (3, 3) array
        Intrinsics in pixels: ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` with fx, fy > 0.
    R : (3, 3) array
        World-to-camera rotation (orthonormal, det +1).
    t : (3,) array
        World-to-camera translation in metres; the centre is ``-R.T @ t``.
    width, height : int
        Image size in pixels.

    Raises
    ------
    ValueError
        Non-finite entries, a non-positive focal length, a K whose last row is not (0, 0, 1),
        a non-rotation R, or a non-positive size.

    Examples
    --------
    >>> cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=3)
    >>> pix, depth = cam.project([[0.0, 0.0, 2.0]])
    >>> pix.tolist(), depth.tolist()
    ([[1.0, 1.0]], [2.0])
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width: int
    height: int

    def __post_init__(self) -> None:
        K = as_float_array("K", self.K, shape=(3, 3))
        R = as_float_array("R", self.R, shape=(3, 3))
        t = as_float_array("t", self.t, shape=(3,))
        width = check_positive_int("width", self.width)
        height = check_positive_int("height", self.height)
        if not (K[0, 0] >= MIN_FOCAL_PX and K[1, 1] >= MIN_FOCAL_PX):
            raise ValueError(f"K must have positive focal lengths fx, fy of at least {MIN_FOCAL_PX:g} px "
                             f"(MIN_FOCAL_PX); got {K[0, 0]:g}, {K[1, 1]:g}")
        if K[2, 0] != 0.0 or K[2, 1] != 0.0 or K[2, 2] != 1.0 or K[1, 0] != 0.0:
            raise ValueError(f"K must be upper triangular with last row (0, 0, 1); got {K.tolist()}")
        if not np.allclose(R @ R.T, np.eye(3), atol=_ROTATION_TOL) or abs(np.linalg.det(R) - 1.0) > _ROTATION_TOL:
            raise ValueError(f"R must be a rotation (orthonormal, det +1); got det {np.linalg.det(R):.6g}")
        object.__setattr__(self, "K", readonly_copy(K))
        object.__setattr__(self, "R", readonly_copy(R))
        object.__setattr__(self, "t", readonly_copy(t))
        object.__setattr__(self, "width", width)
        object.__setattr__(self, "height", height)

    # ------------------------------------------------------------------ derived quantities
    @property
    def center(self) -> np.ndarray:
        """Optical centre in world coordinates, ``-R^T t`` (metres)."""
        return -self.R.T @ self.t

    @property
    def focal_px(self) -> float:
        """Horizontal focal length fx in pixels."""
        return float(self.K[0, 0])

    @property
    def principal_point(self) -> tuple[float, float]:
        """Principal point (cx, cy) in pixels."""
        return float(self.K[0, 2]), float(self.K[1, 2])

    @property
    def fov_deg(self) -> float:
        """Horizontal field of view over the full image width, for a centred principal point."""
        return math.degrees(2.0 * math.atan(self.width / (2.0 * self.focal_px)))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Camera):
            return NotImplemented
        return (
            self.width == other.width
            and self.height == other.height
            and np.array_equal(self.K, other.K)
            and np.array_equal(self.R, other.R)
            and np.array_equal(self.t, other.t)
        )

    __hash__ = None  # type: ignore[assignment]

    # ------------------------------------------------------------------ projection
    def project(self, points_world: object) -> tuple[np.ndarray, np.ndarray]:
        """Project world points to pixels and camera-frame depth.

        Parameters
        ----------
        points_world : (..., 3) array
            Points in metres.

        Returns
        -------
        pixels : (..., 2) float64
            (x, y) = (column, row); NaN for points with depth <= 0 (behind or on the centre plane).
        depth : (...,) float64
            The camera-frame z of each point (may be <= 0).
        """
        p = as_float_array("points_world", points_world)
        if p.ndim == 0 or p.shape[-1] != 3:
            raise ValueError(f"points_world must have shape (..., 3); got {p.shape}")
        cam = p @ self.R.T + self.t
        depth = cam[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            proj = cam @ self.K.T
            pixels = proj[..., :2] / proj[..., 2:3]
        pixels[depth <= 0] = np.nan
        return pixels, depth

    def backproject(self, pixels: object, depth: object) -> np.ndarray:
        """Lift pixels with camera-frame depth to world points; inverse of :meth:`project`.

        Parameters
        ----------
        pixels : (..., 2) array
            (x, y) pixel coordinates.
        depth : (...) array
            Camera-frame z in metres, > 0; NaN marks unknown depth and gives NaN points.

        Returns
        -------
        (..., 3) float64 world points.
        """
        pix = as_float_array("pixels", pixels)
        if pix.ndim == 0 or pix.shape[-1] != 2:
            raise ValueError(f"pixels must have shape (..., 2); got {pix.shape}")
        z = as_float_array("depth", depth, allow_nan=True)
        if z.shape != pix.shape[:-1]:
            raise ValueError(f"depth must have shape {pix.shape[:-1]} matching pixels; got {z.shape}")
        if (z <= 0).any():
            raise ValueError("depth must be > 0 (camera-frame z) where known; use NaN for unknown")
        homog = np.concatenate([pix, np.ones(pix.shape[:-1] + (1,))], axis=-1)
        rays = homog @ np.linalg.inv(self.K).T  # z component is 1
        cam = rays * z[..., None]
        return (cam - self.t) @ self.R

    def backproject_depth(self, depth: object) -> np.ndarray:
        """World points ``(H, W, 3)`` of every pixel of a depth map ``(H, W)`` (NaN stays NaN)."""
        z = as_float_array("depth", depth, shape=(self.height, self.width), allow_nan=True)
        return self.backproject(self.pixel_grid(), z)

    def pixel_grid(self) -> np.ndarray:
        """Pixel-centre coordinates ``(H, W, 2)``: ``grid[y, x] = (x, y)``."""
        ys, xs = np.mgrid[0 : self.height, 0 : self.width].astype(np.float64)
        return np.stack([xs, ys], axis=-1)

    def ray_directions(self) -> np.ndarray:
        """Unit world-space ray directions ``(H, W, 3)`` through every pixel centre."""
        homog = np.concatenate([self.pixel_grid(), np.ones((self.height, self.width, 1))], axis=-1)
        d = (homog @ np.linalg.inv(self.K).T) @ self.R
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict:
        """JSON-ready dictionary (``K``, ``R``, ``t``, ``width``, ``height``, plus ``center``)."""
        return {
            "K": self.K.tolist(),
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "width": self.width,
            "height": self.height,
            "center": self.center.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> Camera:
        """Inverse of :meth:`to_dict` (``center`` is ignored: it is derived)."""
        if not isinstance(data, dict):
            raise TypeError(f"camera must be a JSON object; got {type(data).__name__}")
        missing = [k for k in ("K", "R", "t", "width", "height") if k not in data]
        if missing:
            raise ValueError(f"camera is missing field(s) {', '.join(missing)}")
        unknown = sorted(set(data) - {"K", "R", "t", "width", "height", "center"})
        if unknown:
            raise ValueError(f"camera has unknown field(s) {', '.join(unknown)}")
        return cls(K=data["K"], R=data["R"], t=data["t"], width=data["width"], height=data["height"])

    def with_intrinsics(self, K: object) -> Camera:
        """The same pose and size with other intrinsics."""
        return Camera(K=K, R=self.R, t=self.t, width=self.width, height=self.height)


def look_at(
    position: object,
    target: object,
    up: object,
    *,
    fov_deg: float,
    width: int,
    height: int,
    principal_point: tuple[float, float] | None = None,
) -> Camera:
    """A camera at ``position`` looking at ``target`` with square pixels.

    Parameters
    ----------
    position, target, up : (3,) arrays
        Centre, a point on the optical axis, and the world "up" direction (need not be orthogonal
        to the view direction, but not parallel to it).
    fov_deg : float
        Horizontal field of view across the full image width, in degrees, in [:data:`MIN_FOV_DEG`, 180).
    width, height : int
        Image size in pixels.
    principal_point : (cx, cy), optional
        In pixels; defaults to the image centre ``((width - 1) / 2, (height - 1) / 2)``.

    Raises
    ------
    ValueError
        A field of view outside [:data:`MIN_FOV_DEG`, 180), a principal point that is not two finite
        numbers, a zero ``up``, ``target == position`` or ``up`` parallel to the viewing direction.

    Notes
    -----
    ``fx = fy = width / (2 tan(fov / 2))``. Rows of R are the camera's right, down and forward axes
    in world coordinates, so image rows grow opposite to ``up``.
    """
    c = as_float_array("position", position, shape=(3,))
    target_ = as_float_array("target", target, shape=(3,))
    up_ = as_float_array("up", up, shape=(3,))
    fov = check_finite("fov_deg", fov_deg)
    if not 0.0 < fov < 180.0:
        raise ValueError(f"fov_deg must lie strictly between 0 and 180; got {fov:g}")
    if fov < MIN_FOV_DEG:
        raise ValueError(f"fov_deg must be at least {MIN_FOV_DEG:g} (MIN_FOV_DEG); got {fov:g}")
    width = check_positive_int("width", width)
    height = check_positive_int("height", height)
    if not np.any(up_):
        raise ValueError("up must be a non-zero vector; got (0, 0, 0)")
    forward = target_ - c
    if np.linalg.norm(forward) == 0.0:
        raise ValueError("target must differ from position")
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up_)
    if np.linalg.norm(right) < 1e-9 * max(np.linalg.norm(up_), 1e-300):
        raise ValueError("up must not be parallel to the viewing direction (target - position)")
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.stack([right, down, forward])
    f = width / (2.0 * math.tan(math.radians(fov) / 2.0))
    if principal_point is None:
        cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    else:
        cx, cy = as_float_array("principal_point", principal_point, shape=(2,)).tolist()
    K = np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])
    return Camera(K=K, R=R, t=-R @ c, width=width, height=height)


def interpolate(a: Camera, b: Camera, s: float) -> Camera:
    """The camera a fraction ``s`` of the way from ``a`` to ``b``.

    Centres are interpolated linearly, rotations by slerp, intrinsics linearly (S2 §8 with the
    the usual slerp). ``interpolate(a, b, 0) == a`` and ``interpolate(a, b, 1) == b``
    exactly, and ``interpolate(a, b, s)`` equals ``interpolate(b, a, 1 - s)`` up to rounding.

    Raises
    ------
    ValueError
        If ``s`` is outside [0, 1] or the image sizes differ.
    """
    if not isinstance(a, Camera) or not isinstance(b, Camera):
        raise TypeError("a and b must be Camera instances")
    s = check_in_range("s", s, 0.0, 1.0)
    if (a.width, a.height) != (b.width, b.height):
        raise ValueError(f"cameras must share an image size; got {a.width}x{a.height} and {b.width}x{b.height}")
    if s in (0.0, 1.0):  # the endpoints themselves, not slerp's rounding of them
        return a if s == 0.0 else b
    center = (1.0 - s) * a.center + s * b.center
    R = _slerp(a.R, b.R, s)
    K = (1.0 - s) * a.K + s * b.K
    return Camera(K=K, R=R, t=-R @ center, width=a.width, height=a.height)


def _quaternion(R: np.ndarray) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` of the rotation matrix ``R``, from its largest diagonal
    term (Shepperd 1978: no division by a small number at any angle)."""
    t = np.trace(R)
    k = int(np.argmax([t, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        q = np.array([1.0 + t, R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    elif k == 1:
        q = np.array([R[2, 1] - R[1, 2], 1.0 + 2.0 * R[0, 0] - t, R[0, 1] + R[1, 0], R[0, 2] + R[2, 0]])
    elif k == 2:
        q = np.array([R[0, 2] - R[2, 0], R[0, 1] + R[1, 0], 1.0 + 2.0 * R[1, 1] - t, R[1, 2] + R[2, 1]])
    else:
        q = np.array([R[1, 0] - R[0, 1], R[0, 2] + R[2, 0], R[1, 2] + R[2, 1], 1.0 + 2.0 * R[2, 2] - t])
    return q / np.linalg.norm(q)


def _slerp(Ra: np.ndarray, Rb: np.ndarray, s: float) -> np.ndarray:
    """The rotation a fraction ``s`` along the shortest arc from ``Ra`` to ``Rb`` (Shoemake 1985's
    slerp of their unit quaternions): scipy's ``Slerp`` gives the same rotation (tests/test_camera.py), and
    :func:`interpolate` takes a third of the time it took with it (benchmarks/camera_interpolate.py)."""
    qa, qb = _quaternion(Ra), _quaternion(Rb)
    d = float(qa @ qb)
    if d < 0.0:  # q and -q are one rotation: the shorter of the two arcs
        qb, d = -qb, -d
    theta = math.acos(min(1.0, d))
    if theta < 1e-8:  # (nearly) one rotation: the chord is the arc to 1e-17
        q = (1.0 - s) * qa + s * qb
    else:
        q = (math.sin((1.0 - s) * theta) * qa + math.sin(s * theta) * qb) / math.sin(theta)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])

