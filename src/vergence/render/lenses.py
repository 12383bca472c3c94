"""Image formation beyond the pinhole: the equidistant fisheye lens (primary rays and projection).

The fisheye is S3's "non-standard image formation" (S3 §3.2, Fig. 3): straight rays from one
centre, but the angle ``theta`` from the optical axis maps linearly to the image radius,
``r = f theta`` (equidistant projection), with ``f = (width / 2) / (fov / 2)`` so that the
horizontal field of view spans the full image width. Pixels with ``theta >= 90 deg`` (outside the
image circle of a 180 deg lens) have no ray. Frames and pixel conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array, check_finite, check_positive_int
from vergence.camera import MIN_FOV_DEG, Camera

__all__ = ["FisheyeCamera", "MIN_FOV_DEG"]

# The narrowest field of view, shared with the pinhole of vergence.camera.look_at (1e-3 deg): at
# MAX_RENDER_SIDE pixels the focal length stays under 2e9 px for the pinhole and the fisheye
# (``(width/2) / (fov/2)``). A subnormal field of view used to divide by a zero tangent.


def check_min_fov(fov_deg: float) -> None:
    """Refuse a positive field of view (degrees) narrower than :data:`MIN_FOV_DEG`."""
    if 0.0 < fov_deg < MIN_FOV_DEG:
        raise ValueError(f"fov_deg must be >= {MIN_FOV_DEG:g} deg (MIN_FOV_DEG); got {fov_deg:g}")


@dataclass(frozen=True, slots=True, eq=False)
class FisheyeCamera:
    """An equidistant fisheye camera ``r = f theta`` with pose ``x_cam = R x_world + t``.

    Parameters
    ----------
    R : (3, 3) array
        World-to-camera rotation.
    t : (3,) array
        World-to-camera translation, metres.
    width, height : int
        Image size in pixels.
    fov_deg : float
        Horizontal field of view across the full width, degrees, in (0, 180].
    principal_point : (cx, cy), optional
        Centre of the image circle in pixels; defaults to ``((width-1)/2, (height-1)/2)``.

    Examples
    --------
    >>> cam = FisheyeCamera(R=np.eye(3), t=np.zeros(3), width=101, height=101, fov_deg=180.0)
    >>> pix, depth = cam.project([[1.0, 0.0, 1.0]])  # 45 deg off axis: r = f pi/4 = 25.25 px
    >>> [round(float(v), 6) for v in pix[0]], depth.tolist()
    ([75.25, 50.0], [1.0])
    """

    R: np.ndarray
    t: np.ndarray
    width: int
    height: int
    fov_deg: float
    principal_point: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        width = check_positive_int("width", self.width)
        height = check_positive_int("height", self.height)
        pose = Camera(K=np.eye(3), R=self.R, t=self.t, width=width, height=height)  # validates R and t
        fov = check_finite("fov_deg", self.fov_deg)
        if not 0.0 < fov <= 180.0:
            raise ValueError(f"fov_deg must lie in (0, 180] for a fisheye; got {fov:g}")
        check_min_fov(fov)
        if self.principal_point is None:
            pp = ((width - 1) / 2.0, (height - 1) / 2.0)
        else:
            arr = as_float_array("principal_point", self.principal_point, shape=(2,))
            pp = (float(arr[0]), float(arr[1]))
        for name, value in (("R", pose.R), ("t", pose.t), ("width", width), ("height", height),
                            ("fov_deg", fov), ("principal_point", pp)):  # fmt: skip
            object.__setattr__(self, name, value)

    @property
    def focal_px(self) -> float:
        """Pixels per radian, ``f = (width / 2) / (fov / 2)``."""
        return (self.width / 2.0) / math.radians(self.fov_deg / 2.0)

    @property
    def center(self) -> np.ndarray:
        """Optical centre in world coordinates, ``-R^T t``."""
        return -self.R.T @ self.t

    def project(self, points_world: object) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(..., 2)`` (NaN where ``theta >= 90 deg``) and camera-frame depth ``z`` of world points."""
        p = as_float_array("points_world", points_world)
        if p.ndim == 0 or p.shape[-1] != 3:
            raise ValueError(f"points_world must have shape (..., 3); got {p.shape}")
        cam = p @ self.R.T + self.t
        rho = np.hypot(cam[..., 0], cam[..., 1])
        theta = np.arctan2(rho, cam[..., 2])
        scale = np.divide(self.focal_px * theta, rho, out=np.zeros_like(rho), where=rho > 0)  # r / rho
        cx, cy = self.principal_point
        pixels = np.stack([cx + scale * cam[..., 0], cy + scale * cam[..., 1]], axis=-1)
        pixels[theta >= math.pi / 2] = np.nan
        return pixels, cam[..., 2]

    def ray_directions(self) -> np.ndarray:
        """Unit world directions ``(H, W, 3)`` through the pixel centres; NaN outside the image circle."""
        ys, xs = np.mgrid[0 : self.height, 0 : self.width].astype(np.float64)
        cx, cy = self.principal_point
        dx, dy = xs - cx, ys - cy
        r = np.hypot(dx, dy)
        theta = r / self.focal_px
        s = np.divide(np.sin(theta), r, out=np.full_like(r, 1.0 / self.focal_px), where=r > 0)
        d_cam = np.stack([s * dx, s * dy, np.cos(theta)], axis=-1)
        d_cam[theta >= math.pi / 2] = np.nan
        return d_cam @ self.R

    def to_dict(self) -> dict:
        """JSON-ready description (``model`` = ``"fisheye-equidistant"``)."""
        return {
            "model": "fisheye-equidistant",
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "width": self.width,
            "height": self.height,
            "fov_deg": self.fov_deg,
            "principal_point": list(self.principal_point),
            "focal_px": self.focal_px,
            "center": self.center.tolist(),
        }
