"""Sparse points for a collection whose camera file gives none: match features, triangulate, filter.

S2 §3.1 starts from the sparse point cloud of a structure-from-motion run ([SCD06]); a Middlebury
``*_par.txt`` (Seitz et al. 2006) gives the cameras but no points, so we make them with the cameras
held fixed: SIFT features (Lowe 2004) matched between each image and its nearest cameras with
Lowe's ratio test, each match triangulated by the linear (DLT) method of Hartley & Zisserman
(2003, §12.2), and kept only when it reprojects within :data:`MAX_REPROJECTION_ERROR_PX` of both
features and lies in front of both cameras. Conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import cv2
import numpy as np

from vergence._validate import as_float_array
from vergence.camera import Camera

__all__ = [
    "MATCH_NEIGHBOURS",
    "MAX_REPROJECTION_ERROR_PX",
    "RATIO_TEST",
    "project_distorted",
    "triangulate_points",
]

# A triangulated point is kept when it reprojects within this distance of its feature in both views.
# Calibrated cameras (Middlebury's are good to a fraction of a pixel) and SIFT's sub-pixel keypoints
# put true matches well under 1 px; 1.5 px keeps them and drops matches off the epipolar line.
MAX_REPROJECTION_ERROR_PX = 1.5
# Lowe's (2004, §7.1) distance-ratio test: the best match must be clearly better than the second best;
# 0.8 is his value (drops 90 % of false matches, fewer than 5 % of correct ones).
RATIO_TEST = 0.8
# Each image is matched with its k nearest cameras (by centre) only: all pairs would be quadratic in
# the number of images, and far cameras see the object from too different a side to match.
MATCH_NEIGHBOURS = 4
# Pairs whose optical axes differ by more than this are not matched: SIFT is invariant to in-plane
# rotation and scale but not to large out-of-plane turns (Lowe 2004 reports ~50 % repeatability at 50°).
_MAX_MATCH_ANGLE_DEG = 50.0
# SIFT keypoints kept per image (strongest first): enough for hundreds of points on a 640 x 480
# image and a bounded matching cost.
_MAX_FEATURES = 4000

Progress = Callable[[float, str], None]


def projection_matrix(camera: Camera) -> np.ndarray:
    """``P = K [R | t]`` (3, 4)."""
    return camera.K @ np.hstack([camera.R, camera.t[:, None]])


def triangulate_points(camera_a: Camera, camera_b: Camera, pixels_a: object, pixels_b: object) -> np.ndarray:
    """Linear (DLT) triangulation of matched pixels seen by two calibrated cameras.

    Each row of ``A X = 0`` is ``x p3^T - p1^T`` and ``y p3^T - p2^T`` for both cameras
    (Hartley & Zisserman 2003, Eq. (12.2)); ``X`` is the right singular vector of the smallest
    singular value, dehomogenised.

    Parameters
    ----------
    camera_a, camera_b : Camera
        The two cameras (distortion-free: undistort the pixels first).
    pixels_a, pixels_b : (N, 2) array
        Matched (x, y) pixels.

    Returns
    -------
    (N, 3) float64
        World points; NaN where the solution is at infinity.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=64, height=48)
    >>> b = look_at([1, 0, 0], [1, 0, 1], [0, -1, 0], fov_deg=60, width=64, height=48)
    >>> X = [[0.5, 0.2, 3.0]]
    >>> triangulate_points(a, b, a.project(X)[0], b.project(X)[0]).round(9).tolist()
    [[0.5, 0.2, 3.0]]
    """
    for name, cam in (("camera_a", camera_a), ("camera_b", camera_b)):
        if not isinstance(cam, Camera):
            raise TypeError(f"{name} must be a Camera; got {type(cam).__name__}")
    pa = as_float_array("pixels_a", pixels_a, shape=(None, 2))
    pb = as_float_array("pixels_b", pixels_b, shape=(None, 2))
    if pa.shape != pb.shape:
        raise ValueError(f"pixels_b must have the shape of pixels_a {pa.shape}; got {pb.shape}")
    return _dlt(projection_matrix(camera_a), projection_matrix(camera_b), pa, pb)


def _dlt(Pa: np.ndarray, Pb: np.ndarray, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    if len(pa) == 0:
        return np.zeros((0, 3))
    A = np.stack([pa[:, :1] * Pa[2] - Pa[0], pa[:, 1:] * Pa[2] - Pa[1],
                  pb[:, :1] * Pb[2] - Pb[0], pb[:, 1:] * Pb[2] - Pb[1]], axis=1)  # H&Z Eq. (12.2)  # fmt: skip
    # Rows scaled to unit norm: the same solution, better conditioned (H&Z §4.4.4).
    A /= np.linalg.norm(A, axis=2, keepdims=True)
    Xh = np.linalg.svd(A)[2][:, -1]
    with np.errstate(divide="ignore", invalid="ignore"):
        X = Xh[:, :3] / Xh[:, 3:]
    X[~np.isfinite(X).all(axis=1)] = np.nan
    return X


def project_distorted(camera: Camera, distortion: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Pixels of ``points`` through ``camera`` with OpenCV ``(k1, k2, p1, p2)`` lens distortion.

    ``x_n = (X_c / Z_c, Y_c / Z_c)``, ``r^2 = |x_n|^2``, ``x_d = x_n (1 + k1 r^2 + k2 r^4)`` plus the
    tangential terms (Brown 1966, OpenCV's model), pixel ``K [x_d, 1]``. NaN for points with
    ``Z_c <= 0``.
    """
    k1, k2, p1, p2 = (float(v) for v in distortion)
    cam = points @ camera.R.T + camera.t
    z = cam[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = cam[:, 0] / z, cam[:, 1] / z
    r2 = x * x + y * y
    radial = 1.0 + k1 * r2 + k2 * r2 * r2
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    K = camera.K
    pix = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)
    pix[~(z > 0)] = np.nan
    return pix


def match_neighbours(cameras: Sequence[Camera], k: int) -> list[tuple[int, int]]:
    """Pairs ``(i, j)``, ``i < j``: each camera with its ``k`` nearest (by centre) that look within 50°."""
    centres = np.array([c.center for c in cameras])
    axes = np.array([c.R[2] for c in cameras])
    dist = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    cos_max = np.cos(np.radians(_MAX_MATCH_ANGLE_DEG))
    pairs = set()
    for i in range(len(cameras)):
        order = [j for j in np.argsort(dist[i], kind="stable") if j != i and axes[i] @ axes[j] >= cos_max]
        pairs.update((min(i, j), max(i, j)) for j in order[:k])
    return sorted((int(a), int(b)) for a, b in pairs)


def _features(gray: np.ndarray, camera: Camera, distortion: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SIFT keypoints (undistorted pixels), descriptors and the keypoints as measured, of an 8-bit image."""
    sift = cv2.SIFT_create(nfeatures=_MAX_FEATURES)
    kps, desc = sift.detectAndCompute(gray, None)
    if desc is None:
        return np.zeros((0, 2)), np.zeros((0, 128), np.float32), np.zeros((0, 2))
    raw = np.array([kp.pt for kp in kps], np.float64).reshape(-1, 2)
    pts = raw
    if np.any(distortion != 0):
        pts = cv2.undistortPoints(raw[:, None], camera.K, distortion, P=camera.K)[:, 0].astype(np.float64)
    return pts, desc, raw


def _ratio_matches(desc_a: np.ndarray, desc_b: np.ndarray) -> np.ndarray:
    """(M, 2) indices of the matches that pass Lowe's ratio test, one-to-one in both directions."""
    if len(desc_a) < 2 or len(desc_b) < 2:
        return np.zeros((0, 2), np.int64)
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(desc_a, desc_b, k=2)
    good = [(m.queryIdx, m.trainIdx) for m, n in knn if m.distance < RATIO_TEST * n.distance]
    if not good:
        return np.zeros((0, 2), np.int64)
    arr = np.array(good, np.int64)
    counts = np.bincount(arr[:, 1])
    return arr[counts[arr[:, 1]] == 1]  # a feature of b claimed by two features of a is ambiguous


def triangulate_collection(
    cameras: Sequence[Camera],
    distortion: np.ndarray,
    grays: Callable[[int], np.ndarray],
    *,
    neighbours: int = MATCH_NEIGHBOURS,
    progress: Progress | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Match each image with its nearest cameras and triangulate (see the module notes).

    Returns ``(points (P, 3), observations (2P, 2) as (point, camera), pixels (2P, 2), candidates)``,
    where ``candidates`` counts the matches that reprojected well before the in-front test (so the
    caller can tell "no matches" from "points behind every camera"). Pixels are as measured
    (distorted); the triangulation uses them undistorted.
    """
    n = len(cameras)
    feats = []
    for i in range(n):
        feats.append(_features(grays(i), cameras[i], distortion[i]))
        if progress is not None:
            progress(0.5 * (i + 1) / n, f"features of image {i + 1}/{n}")
    pairs = match_neighbours(cameras, neighbours)
    points, obs, pix, candidates = [], [], [], 0
    for done, (i, j) in enumerate(pairs, start=1):
        m = _ratio_matches(feats[i][1], feats[j][1])
        pa, pb = feats[i][0][m[:, 0]], feats[j][0][m[:, 1]]
        X = _dlt(projection_matrix(cameras[i]), projection_matrix(cameras[j]), pa, pb)
        err_a = _reprojection_error(cameras[i], X, pa)
        err_b = _reprojection_error(cameras[j], X, pb)
        small = (np.abs(err_a) <= MAX_REPROJECTION_ERROR_PX) & (np.abs(err_b) <= MAX_REPROJECTION_ERROR_PX)
        candidates += int(small.sum())
        front = _depth(cameras[i], X) > 0
        front &= _depth(cameras[j], X) > 0
        keep = small & front
        base = sum(len(p) for p in points)
        idx = base + np.arange(int(keep.sum()))
        points.append(X[keep])
        obs += [np.stack([idx, np.full_like(idx, i)], 1), np.stack([idx, np.full_like(idx, j)], 1)]
        pix += [feats[i][2][m[keep, 0]], feats[j][2][m[keep, 1]]]
        if progress is not None:
            progress(0.5 + 0.5 * done / len(pairs), f"matched pair {done}/{len(pairs)}")
    if not points:
        return np.zeros((0, 3)), np.zeros((0, 2), np.int64), np.zeros((0, 2)), 0
    return np.concatenate(points), np.concatenate(obs).astype(np.int64), np.concatenate(pix), candidates


def _depth(camera: Camera, X: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return X @ camera.R[2] + camera.t[2]


def _reprojection_error(camera: Camera, X: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Distance from the projection of ``X`` (ignoring which side of the camera) to ``pixels``; NaN at infinity."""
    h = X @ projection_matrix(camera)[:, :3].T + projection_matrix(camera)[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        proj = h[:, :2] / h[:, 2:]
        return np.linalg.norm(proj - pixels, axis=1)
