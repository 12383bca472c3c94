"""Fusiello-Trucco-Verri rectification of a calibrated pair, and a check of its row alignment.

Fusiello et al. 2000 (restated in S2 §3.2): both cameras keep their centres and
are rotated to share one orientation whose x axis is the baseline, so conjugate points lie on the
same image row. Conventions: ``docs/conventions.md`` (x right, y down, z forward; pixel centres at
integers; disparity ``x_left - x_right``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from vergence._validate import as_float_array, as_image, check_bool, check_in_range, check_positive, readonly_copy
from vergence.camera import Camera

__all__ = ["Rectification", "RectifiedPair", "RowAlignment", "measure_row_alignment", "rectify_cameras", "rectify_pair"]

# A rectified image may be at most this many times the larger input area; beyond it the epipole is
# in or near the image and a planar rectification stretches it without bound (FTV's known limit).
_MAX_AREA_GROWTH = 16.0
# Boundary samples per image edge used to find the rectified extent (enough for lens distortion).
_EDGE_SAMPLES = 64
# The baseline must exceed this fraction of the larger distance of the centres from the world
# origin (plus 1e-12 absolute): below it, the two centres are the same point to double precision.
_MIN_BASELINE_REL = 1e-9
# The new y axis is k x r1 (k: old left optical axis): below this sine of the angle between the
# baseline and k, that cross product has no reliable direction.
_MIN_AXIS_SINE = 1e-6


@dataclass(frozen=True, slots=True, eq=False)
class Rectification:
    """Rectified cameras and the homographies that map original pixels onto them.

    Attributes
    ----------
    left_camera, right_camera : Camera
        Rectified cameras: same rotation and focal lengths, centres unchanged (Fusiello et al. 2000:
        ``P_n = A [R | -R c]``).
    left_homography, right_homography : (3, 3) arrays
        ``T_k = Q_nk Q_ok^-1`` (Fusiello et al. 2000): ``m_rectified ~ T_k m_original`` for undistorted pixels.
    baseline : float
        Distance between the centres, in world units.
    """

    left_camera: Camera
    right_camera: Camera
    left_homography: np.ndarray
    right_homography: np.ndarray
    baseline: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "left_homography", readonly_copy(self.left_homography))
        object.__setattr__(self, "right_homography", readonly_copy(self.right_homography))

    @property
    def focal_px(self) -> float:
        """Common horizontal focal length of the rectified pair, pixels."""
        return self.left_camera.focal_px

    @property
    def doffs_px(self) -> float:
        """``cx_right - cx_left``: depth is ``focal_px * baseline / (disparity + doffs_px)``."""
        return float(self.right_camera.K[0, 2] - self.left_camera.K[0, 2])

    def to_dict(self) -> dict:
        """JSON-ready description: cameras, homographies, baseline, focal length, doffs."""
        return {
            "left_camera": self.left_camera.to_dict(),
            "right_camera": self.right_camera.to_dict(),
            "left_homography": self.left_homography.tolist(),
            "right_homography": self.right_homography.tolist(),
            "baseline": self.baseline,
            "focal_px": self.focal_px,
            "doffs_px": self.doffs_px,
        }


@dataclass(frozen=True, slots=True, eq=False)
class RectifiedPair:
    """Resampled images of a rectified pair, their valid-pixel masks and the geometry."""

    left: np.ndarray
    right: np.ndarray
    left_valid: np.ndarray
    right_valid: np.ndarray
    rectification: Rectification


@dataclass(frozen=True, slots=True, eq=False)
class RowAlignment:
    """Vertical offsets ``|y_right - y_left|`` (pixels) of the matched features of a rectified pair, and their
    horizontal disparities ``x_left - x_right`` (pixels, same order; empty when not measured)."""

    abs_dy_px: np.ndarray
    disparity_px: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        object.__setattr__(self, "abs_dy_px", readonly_copy(np.ravel(self.abs_dy_px)))
        object.__setattr__(self, "disparity_px", readonly_copy(np.ravel(self.disparity_px)))
        if self.disparity_px.size not in (0, self.abs_dy_px.size):
            raise ValueError(f"disparity_px must be empty or hold one value per match ({self.abs_dy_px.size}); "
                             f"got {self.disparity_px.size}")

    @property
    def matches(self) -> int:
        """Number of RANSAC-consistent matches measured."""
        return int(self.abs_dy_px.size)

    @property
    def median_abs_dy_px(self) -> float:
        """Median vertical offset, pixels."""
        return float(np.median(self.abs_dy_px))

    @property
    def p90_abs_dy_px(self) -> float:
        """90th percentile of the vertical offset, pixels."""
        return float(np.percentile(self.abs_dy_px, 90))

    def to_dict(self) -> dict:
        """``{"median_abs_dy_px": px, "p90_abs_dy_px": px, "matches": n}``."""
        return {"median_abs_dy_px": self.median_abs_dy_px, "p90_abs_dy_px": self.p90_abs_dy_px,
                "matches": self.matches}


def _distortion(name: str, value: object) -> np.ndarray:
    if value is None:
        return np.zeros(4)
    d = as_float_array(name, value).ravel()
    if d.size not in (4, 5, 8):
        raise ValueError(f"{name} must hold OpenCV coefficients (k1, k2, p1, p2[, k3...]); got {d.size} values")
    return d


def _boundary(cam: Camera) -> np.ndarray:
    """Points along the four edges of the image area ``[-0.5, W-0.5] x [-0.5, H-0.5]``."""
    s = np.linspace(0.0, 1.0, _EDGE_SAMPLES)
    x0, x1, y0, y1 = -0.5, cam.width - 0.5, -0.5, cam.height - 0.5
    xs, ys = x0 + s * (x1 - x0), y0 + s * (y1 - y0)
    return np.concatenate([np.stack([xs, np.full_like(s, y0)], 1), np.stack([xs, np.full_like(s, y1)], 1),
                           np.stack([np.full_like(s, x0), ys], 1), np.stack([np.full_like(s, x1), ys], 1)])


def _undistort(points: np.ndarray, cam: Camera, dist: np.ndarray) -> np.ndarray:
    if not dist.any():
        return points
    out = cv2.undistortPoints(points.reshape(-1, 1, 2).astype(np.float64), cam.K, dist, P=cam.K)
    return out.reshape(-1, 2)


def _extent(points: np.ndarray, T: np.ndarray, side: str) -> tuple[float, float, float, float]:
    h = np.concatenate([points, np.ones((len(points), 1))], 1) @ T.T
    if not (h[:, 2] > 0).all():
        raise ValueError(f"the {side} image cannot be rectified onto a plane: part of it maps behind the "
                         "rectified camera (the epipole lies inside the image)")
    xy = h[:, :2] / h[:, 2:3]
    return float(xy[:, 0].min()), float(xy[:, 0].max()), float(xy[:, 1].min()), float(xy[:, 1].max())


def rectify_cameras(
    left: Camera,
    right: Camera,
    *,
    left_distortion: object = None,
    right_distortion: object = None,
    common_principal_point: bool = False,
    up: object = None,
) -> Rectification:
    """Rectify a calibrated pair (Fusiello et al. 2000) and size the outputs to keep both images in view.

    Parameters
    ----------
    left, right : Camera
        The original cameras; ``right`` must lie to the right of ``left`` (positive x in the left frame).
    left_distortion, right_distortion : array of 4, 5 or 8 floats, optional
        OpenCV lens distortion of each camera (``CameraSet.distortion``), used for the extents.
    common_principal_point : bool
        If True, both rectified cameras share one K (disparity maps straight to depth, ``doffs = 0``)
        and the output spans the union of both extents; by default each image is centred in its own
        frame (narrower outputs, disparities near zero at the convergence distance) and the
        horizontal offset is reported as :attr:`Rectification.doffs_px`.
    up : (3,) array, optional
        A world up direction (e.g. :func:`vergence.stereospace.collection_up` of rolled photos).
        When given, the order of the pair is checked against it instead of the left camera's x
        axis: the rectified image's down axis must not point up (``r2 . up <= 0``), whatever the
        cameras' roll.

    Returns
    -------
    Rectification

    Raises
    ------
    ValueError
        On a zero baseline, a baseline along the left optical axis, a right camera on the left (or,
        with ``up``, a pair whose rectified images would be upside down), a non-finite or zero
        ``up``, or an output that would grow past 16 times the input area (epipole in or near the image).

    Notes
    -----
    Fusiello et al. 2000: ``r1 = (c_right - c_left)/|.|``, ``r2 = k x r1`` with k the old left optical axis,
    ``r3 = r1 x r2``; ``A = (A_1 + A_2)/2`` with zero skew; ``T_k = A R (K_k R_k)^-1``. The principal
    points of A are then shifted so the rectified image extents fit in the output (same vertical shift
    for both, which keeps the rows aligned).

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> a = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    >>> b = look_at([0.1, 0, 0], [0.1, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    >>> rect = rectify_cameras(a, b)
    >>> round(rect.baseline, 6), bool(np.allclose(rect.left_homography, np.eye(3)))
    (0.1, True)
    """
    if not isinstance(left, Camera) or not isinstance(right, Camera):
        raise TypeError("left and right must be Camera instances")
    common_principal_point = check_bool("common_principal_point", common_principal_point)
    d_l, d_r = _distortion("left_distortion", left_distortion), _distortion("right_distortion", right_distortion)
    c1, c2 = left.center, right.center
    # c_right - c_left as in S2 §3.2; the c_left - c_right of Fusiello et al. 2000's listing turns both images by 180 deg
    v1 = c2 - c1
    baseline = float(np.linalg.norm(v1))
    scale = max(np.linalg.norm(c1), np.linalg.norm(c2))
    if baseline <= _MIN_BASELINE_REL * scale + 1e-12:
        raise ValueError(f"the cameras must have distinct centres (baseline > 0); got baseline {baseline:g}")
    r1 = v1 / baseline
    if up is None and float(r1 @ left.R[0]) <= 0.0:
        raise ValueError("the right camera lies to the left of the left camera (negative x in the left camera "
                         "frame); swap the two images")
    v2 = np.cross(left.R[2], r1)  # k = old left optical axis
    if np.linalg.norm(v2) < _MIN_AXIS_SINE:
        raise ValueError("the baseline is along the left optical axis; the pair cannot be rectified")
    r2 = v2 / np.linalg.norm(v2)
    if up is not None:
        up_w = as_float_array("up", up, shape=(3,))
        if not np.linalg.norm(up_w) > 0.0:
            raise ValueError("up must be a non-zero direction; got (0, 0, 0)")
        if float(r2 @ up_w) > 0.0:
            raise ValueError("the rectified images would be upside down (their down axis points along up); "
                             "swap the two images")
    r3 = np.cross(r1, r2)
    R = np.stack([r1, r2, r3])
    A = (left.K + right.K) / 2.0
    A[0, 1] = 0.0
    A[0, 2] = A[1, 2] = 0.0  # principal points are placed below from the extents
    T_l = A @ R @ left.R.T @ np.linalg.inv(left.K)
    T_r = A @ R @ right.R.T @ np.linalg.inv(right.K)
    ext_l = _extent(_undistort(_boundary(left), left, d_l), T_l, "left")
    ext_r = _extent(_undistort(_boundary(right), right, d_r), T_r, "right")
    y0, y1 = min(ext_l[2], ext_r[2]), max(ext_l[3], ext_r[3])
    height = max(1, math.ceil(y1 - y0 - 1e-9))
    cy = -0.5 - y0 + (height - (y1 - y0)) / 2.0
    if common_principal_point:
        x0, x1 = min(ext_l[0], ext_r[0]), max(ext_l[1], ext_r[1])
        width = max(1, math.ceil(x1 - x0 - 1e-9))
        cx_l = cx_r = -0.5 - x0 + (width - (x1 - x0)) / 2.0
    else:
        w_l, w_r = ext_l[1] - ext_l[0], ext_r[1] - ext_r[0]
        width = max(1, math.ceil(max(w_l, w_r) - 1e-9))
        cx_l = -0.5 - ext_l[0] + (width - w_l) / 2.0
        cx_r = -0.5 - ext_r[0] + (width - w_r) / 2.0
    area_in = max(left.width * left.height, right.width * right.height)
    if width * height > _MAX_AREA_GROWTH * area_in:
        raise ValueError(f"rectification would need a {width}x{height} output, over {_MAX_AREA_GROWTH:g} times the "
                         "input area: the epipole is in or near the image (baseline close to the viewing direction)")
    cams, homs = [], []
    for cam, c, cx in ((left, c1, cx_l), (right, c2, cx_r)):
        Ak = A.copy()
        Ak[0, 2], Ak[1, 2] = cx, cy
        cams.append(Camera(K=Ak, R=R, t=-R @ c, width=width, height=height))  # P_n = A [R | -R c]
        homs.append(Ak @ R @ cam.R.T @ np.linalg.inv(cam.K))  # T = Q_n Q_o^-1 (Fusiello et al. 2000)
    return Rectification(cams[0], cams[1], homs[0], homs[1], baseline)


def _resample(image: np.ndarray, cam: Camera, dist: np.ndarray, new: Camera) -> tuple[np.ndarray, np.ndarray]:
    R_rel = new.R @ cam.R.T
    mx, my = cv2.initUndistortRectifyMap(cam.K, dist, R_rel, new.K, (new.width, new.height), cv2.CV_32FC1)
    out = cv2.remap(image, mx, my, interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    valid = (mx >= 0) & (mx <= cam.width - 1) & (my >= 0) & (my <= cam.height - 1)
    return np.clip(out, 0.0, 1.0).astype(np.float32), valid


def rectify_pair(
    left_image: object,
    right_image: object,
    left_camera: Camera,
    right_camera: Camera,
    *,
    left_distortion: object = None,
    right_distortion: object = None,
    common_principal_point: bool = False,
) -> RectifiedPair:
    """Rectify a calibrated stereo pair: cameras, homographies and bilinearly resampled images.

    Parameters
    ----------
    left_image, right_image : (H, W) or (H, W, C) arrays
        Images in [0, 1] (or uint8/uint16), both grey or both colour; each must match its camera's size.
    left_camera, right_camera : Camera
        Calibrated cameras of the two images.
    left_distortion, right_distortion, common_principal_point
        As :func:`rectify_cameras`; distortion is removed in the same resampling step.

    Returns
    -------
    RectifiedPair
        ``left``/``right`` float32 images (black outside the original image), boolean masks of the
        pixels that come from inside the original images, and the :class:`Rectification`.

    Raises
    ------
    ValueError
        On an image whose size differs from its camera's, a grey/colour mix, or the geometric
        errors of :func:`rectify_cameras`.
    """
    left = as_image("left_image", left_image)
    right = as_image("right_image", right_image)
    if (left.ndim == 3) != (right.ndim == 3) or (left.ndim == 3 and left.shape[2] != right.shape[2]):
        raise ValueError(f"left_image and right_image must both be grey or both colour; got shapes "
                         f"{left.shape} and {right.shape}")
    for name, img, cam in (("left_image", left, left_camera), ("right_image", right, right_camera)):
        if not isinstance(cam, Camera):
            raise TypeError(f"{name.replace('image', 'camera')} must be a Camera; got {type(cam).__name__}")
        if img.shape[:2] != (cam.height, cam.width):
            raise ValueError(f"{name} must have shape ({cam.height}, {cam.width}) to match its camera; "
                             f"got {img.shape[:2]}")
    rect = rectify_cameras(left_camera, right_camera, left_distortion=left_distortion,
                           right_distortion=right_distortion, common_principal_point=common_principal_point)
    d_l, d_r = _distortion("left_distortion", left_distortion), _distortion("right_distortion", right_distortion)
    out_l, val_l = _resample(left, left_camera, d_l, rect.left_camera)
    out_r, val_r = _resample(right, right_camera, d_r, rect.right_camera)
    return RectifiedPair(out_l, out_r, val_l, val_r, rect)


def _grey_u8(name: str, image: object) -> np.ndarray:
    img = as_image(name, image)
    if img.ndim == 3:
        img = cv2.cvtColor(img[..., :3], cv2.COLOR_RGB2GRAY) if img.shape[2] >= 3 else img[..., 0]
    return np.rint(img * 255.0).astype(np.uint8)  # as_image: values in [0, 1]


def measure_row_alignment(
    left: object,
    right: object,
    *,
    ratio: float = 0.75,
    ransac_threshold_px: float = 1.0,
    seed: int = 0,
) -> RowAlignment:
    """Match SIFT features between two rectified images and measure their vertical offsets.

    Features are matched with Lowe's ratio test; outliers are removed by a RANSAC fundamental
    matrix (which does not assume rectification, so it does not bias the measure). The statistic
    is ``|y_right - y_left|`` over the inliers: near zero for a well rectified pair.

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) images
        The rectified pair.
    ratio : float
        Lowe's ratio-test threshold in (0, 1].
    ransac_threshold_px : float
        RANSAC inlier distance to the epipolar line, pixels.
    seed : int
        State of OpenCV's USAC random generator (the measure is reproducible).

    Raises
    ------
    ValueError
        If fewer than 8 matches survive (no fundamental matrix can be fitted).
    """
    gl, gr = _grey_u8("left", left), _grey_u8("right", right)
    ratio = check_in_range("ratio", ratio, 0.0, 1.0)
    thr = check_positive("ransac_threshold_px", ransac_threshold_px)
    sift = cv2.SIFT_create()
    kl, dl = sift.detectAndCompute(gl, None)
    kr, dr = sift.detectAndCompute(gr, None)
    if dl is None or dr is None or len(kl) < 2 or len(kr) < 2:
        raise ValueError("too few SIFT features to measure the row alignment (need textured images)")
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(dl, dr, k=2)
    good = [m[0] for m in pairs if len(m) == 2 and m[0].distance < ratio * m[1].distance]
    if len(good) < 8:
        raise ValueError(f"only {len(good)} SIFT matches pass the ratio test; at least 8 are needed")
    pl = np.float64([kl[m.queryIdx].pt for m in good])
    pr = np.float64([kr[m.trainIdx].pt for m in good])
    params = cv2.UsacParams()
    params.threshold, params.confidence, params.maxIterations = thr, 0.999, 10000
    params.randomGeneratorState = int(seed)
    params.sampler, params.score, params.loMethod = cv2.SAMPLING_UNIFORM, cv2.SCORE_METHOD_MSAC, cv2.LOCAL_OPTIM_INNER_LO
    _, inl = cv2.findFundamentalMat(pl, pr, params)
    if inl is None or int(inl.sum()) < 8:
        raise ValueError("RANSAC found fewer than 8 consistent matches; the images may not overlap")
    keep = inl.ravel().astype(bool)
    return RowAlignment(np.abs(pr[keep, 1] - pl[keep, 1]), pl[keep, 0] - pr[keep, 0])
