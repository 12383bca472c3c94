"""Bayesian view-synthesis weights (Pujades, Devernay & Goldluecke, CVPR 2014; S0 ref. [33]).

The generative model of Pujades et al. 2014 sees each source pixel as the target colour plus sensor
noise plus the colour error that a depth error makes along the image gradient:
``v_i(x) = u(tau_i(x)) + eps_s + grad u . d_z tau_i(x) dz``, where ``tau_i`` warps source i to the
target through the geometric proxy and ``beta_i = tau_i^-1``. Changing variables to the target
grid turns its MAP energy into a weighted sum ``sum_i int omega_i(y) (u(y) - v_i(beta_i(y)))^2 dy``
whose weights :func:`bayesian_weights` computes; with no prior the estimate is the normalised blend
``u = sum_i omega_i v_i(beta_i) / sum_i omega_i``, and since ``omega_i`` depends on ``grad u`` the
caller iterates (start from ``grad u = 0``). The blend itself is ``render_ibr``'s
(``vergence.synthesis.ibr``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vergence._validate import check_finite, check_positive
from vergence.camera import Camera
from vergence.synthesis._checks import check_camera, check_image

__all__ = [
    "BAYES_DEFORMATION_CAP",
    "BAYES_DEPTH_CONTINUITY",
    "BAYES_GEOMETRIC_CAP",
    "BAYES_GRADIENT_THRESHOLD",
    "BAYES_MIN_DEFORMATION",
    "BAYES_SIGMA_DEPTH",
    "BAYES_SIGMA_SENSOR",
    "bayesian_weights",
]

# Sensor noise for colours in [0, 1]: one 8-bit code value (the authors' ``_sigma_sensor = 1/255``).
BAYES_SIGMA_SENSOR = 1.0 / 255.0
# Relative depth uncertainty dz / z of the proxy along each source ray (dimensionless; 0.01 = 1 %).
# A relative (log-depth) step is scale-free: scaling scene and rig together leaves it unchanged, as
# it leaves every image unchanged. 1 % is the error of a disparity known to 0.1 px at a 10 px
# disparity: the authors' light-field default (disparity sigma 0.1 px, ``_aux_dmap_sigma``) at the
# disparities of their data sets, and well above the error of a rendered depth map.
BAYES_SIGMA_DEPTH = 0.01
# Cap of the resolution weight |det D tau_i|^-1 (the authors' ``GRAD_W_MAX = 20`` of the
# ``vtv_sr*_unstructured`` kernels). 20 lets a source that samples the surface more densely than the
# target (a longer lens, a closer camera: the Quadri-Rig's whole point, S0 §5) count up to 20 times
# more; a cap of 1 would only ever penalise sparser sources.
BAYES_DEFORMATION_CAP = 20.0
# Largest |grad u| (luminance per pixel) used: longer gradients are scaled down to it keeping their
# direction, so sharp edges do not drive every weight to ~0 (the authors' ``_ugrad_threshold``).
BAYES_GRADIENT_THRESHOLD = 0.01
# Largest sigma_geom: a colour in [0, 1] cannot have a standard deviation above 0.5 (authors' code).
BAYES_GEOMETRIC_CAP = 0.5
# Two target-grid neighbours are one surface for the differences of beta_i when their proxy points'
# distances from source i's centre differ by at most this fraction. A plane seen at angle theta from
# its normal changes depth by about tan(theta) / f per pixel: 5 % keeps planes up to 79 degrees at
# f = 100 px (89 degrees at f = 3000 px) while real occlusion edges (jumps of more than 5 %) cut.
BAYES_DEPTH_CONTINUITY = 0.05
# Smallest resolution weight of a visible source: it keeps the weight of every source that sees the
# point positive (so the normalised blend is defined wherever one does) while a source 1000 times
# sparser in area than the target (about 32 times per axis, a surface seen edge-on) counts for nothing.
BAYES_MIN_DEFORMATION = 1e-3


def bayesian_weights(
    estimate: np.ndarray | None,
    proxy_points: np.ndarray,
    source_pixels: np.ndarray,
    visible: np.ndarray,
    target: Camera,
    cameras: Sequence[Camera],
    *,
    distortion: object | None = None,
    sigma_sensor: float = BAYES_SIGMA_SENSOR,
    sigma_depth: float = BAYES_SIGMA_DEPTH,
    deformation_cap: float = BAYES_DEFORMATION_CAP,
    gradient_threshold: float = BAYES_GRADIENT_THRESHOLD,
    geometric_cap: float = BAYES_GEOMETRIC_CAP,
) -> np.ndarray:
    """Unnormalised Bayesian blending weights ``omega_i(y)`` of S sources on the target grid.

    ``omega_i(y) = m_i(y) |det D tau_i(beta_i(y))|^-1 / (sigma_s^2 + sigma_geom^2)`` with
    ``sigma_geom = sigma_depth |grad u(y) . d_z tau_i(beta_i(y))|`` (Pujades et al. 2014, the MAP
    energy after the change of variables ``y = tau_i(x)``).

    Parameters
    ----------
    estimate : (h, w, 3) or (h, w) array or None
        Current target estimate u (float in [0, 1]); its gradient is the Sobel/8 gradient of the
        luminance ``Y = 0.2126 R + 0.7152 G + 0.0722 B``. ``None``: first pass, ``grad u = 0``,
        i.e. pure resolution weights over ``sigma_s^2``.
    proxy_points : (h, w, 3) array
        Per target pixel, the proxy point in the undistorted world (metres), NaN where there is none.
        h, w are the target camera's height and width.
    source_pixels : (S, h, w, 2) array
        ``beta_i(y)``: the pixel (x, y) of the proxy point in source i; finite where ``visible``.
    visible : (S, h, w) bool array
        ``m_i``: source i sees the proxy point (field of view and depth test); False where the
        proxy point is NaN.
    target : Camera
        The target camera (in the distorted world when ``distortion`` is given).
    cameras : sequence of S Camera
        The source cameras (undistorted world).
    distortion : object or None
        World distortion (S0 §6) with vectorised ``forward(points)`` (``phi``, (..., 3) -> (..., 3))
        and ``jacobian(points)`` (``D phi`` at undistorted points, (..., 3, 3)); the target camera
        lives in the distorted world, ``proxy_points`` and the sources in the real one. It enters the
        geometric term only, so it is not called when ``estimate`` is None.
    sigma_sensor : float
        Sensor noise sigma_s, colour units (> 0).
    sigma_depth : float
        Relative depth uncertainty ``dz / z`` along the source rays (> 0, dimensionless).
    deformation_cap : float
        Largest resolution weight ``|det D tau_i|^-1`` (>= 1). 20 (default) follows the authors'
        ``vtv_sr*_unstructured`` kernels; 1 is their other variant (denser sources get no bonus).
    gradient_threshold : float
        Largest ``|grad u|`` in luminance per pixel (> 0); longer gradients keep their direction.
    geometric_cap : float
        Largest sigma_geom, colour units (> 0).

    Returns
    -------
    (S, h, w) float32 array
        ``omega_i``, 0 exactly where source i is not visible, finite and > 0 where it is.

    Raises
    ------
    TypeError
        A camera that is not a Camera, a non-bool ``visible``, a distortion without ``forward`` and
        ``jacobian``, a non-numeric option.
    ValueError
        Shapes that disagree (with each other, with the target's size, S with ``len(cameras)``),
        inf anywhere, NaN source pixels or proxy points where visible, non-positive or non-finite
        options, ``deformation_cap < 1``.

    Notes
    -----
    *Resolution term.* ``|det D tau_i(beta_i(y))|^-1 = |det D beta_i(y)|`` (inverse function
    theorem), so it is computed where the weight is needed: by differences of ``beta_i``
    (``source_pixels``) over the target grid, as the authors' ``vtv_sr_init_beta_mask_weight``
    kernel does. The alternative, central differences of ``tau_i`` on the source grid Omega_i,
    would need the source depth maps (to build ``tau_i``) and a resampling of the result at
    ``beta_i(y)``, which blurs it across occlusion edges. Each axis takes the central difference
    where both neighbours are on the same surface as y (their proxy points' distances from source
    i's centre agree within :data:`BAYES_DEPTH_CONTINUITY`), the one-sided difference where one
    is, and where an axis has neither (a one-pixel sliver, the edge of the proxy) the determinant
    is 1, the neutral value the authors use at the image border. Differences of an affine map are
    exact, so a plane parallel to both image planes gives ``(f_source / f_target)^2`` to rounding.
    The weight is clamped to ``[BAYES_MIN_DEFORMATION, deformation_cap]``.

    *Geometric term.* ``d_z tau_i`` is the velocity in the target image of the proxy point ``p``
    moving along source i's ray by a relative depth step:
    ``d tau_i / d(log z_i) = J_pi(phi(p)) D phi(p) (p - c_i)`` (pixels per unit relative depth;
    ``phi`` = identity without distortion), analytic, with ``J_pi`` the Jacobian of the target's
    projection. It vanishes for a source at the target's centre (the ray is the target's own).
    ``grad u`` is evaluated at y itself (the weights live on the target grid, so no interpolation
    is needed, unlike the authors' kernel which works on the source grid), then scaled down to norm
    ``gradient_threshold`` when longer; ``sigma_geom`` is clamped to ``geometric_cap``, and set to
    it where ``d_z tau_i`` is undefined (the distorted point behind the target). Flat regions
    (``grad u = 0``) give every visible source ``1 / sigma_s^2``; a larger baseline lowers a
    weight only where the texture runs along the epipolar direction.

    *Unit of sigma_depth.* A relative depth error ``dz_i / z_i`` along source i's ray, so the
    weights do not change when scene and rig are scaled together. The authors' light-field code
    perturbs the disparity d (pixels per unit of view spacing) by ``sigma_d = 0.1``; since
    ``d tau_i / d(log z_i) = -d (c - c_i)`` there, that is ``sigma_depth = sigma_d / |d|``, 1 % at
    10 px of disparity per view (:data:`BAYES_SIGMA_DEPTH`).

    The luminance gradient is the standard 3x3 Sobel/8 (the authors' ``vtv_sr_compute_gradient``
    reads row y - 1 where it means y + 1, which zeroes its vertical component). Where the estimate
    is 0 outside the covered pixels (``render_ibr``'s image), the edge of the coverage is a steep
    gradient like any other, capped at ``gradient_threshold``.

    Examples
    --------
    >>> import numpy as np
    >>> from vergence.camera import look_at
    >>> t = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=90, width=3, height=3)
    >>> pts = t.backproject_depth(np.full((3, 3), 2.0))
    >>> pix, _ = t.project(pts)
    >>> w = bayesian_weights(None, pts, pix[None], np.ones((1, 3, 3), bool), t, [t])
    >>> float(w[0, 1, 1] * BAYES_SIGMA_SENSOR**2)  # the target itself: |det| = 1, 1 / sigma_s^2
    1.0
    """
    from vergence.synthesis import _ibr_bayes_kernels as kern

    target = check_camera("target", target)
    cams = _check_cameras(cameras)
    h, w = target.height, target.width
    points = _float_array("proxy_points", proxy_points, (h, w, 3), "(h, w, 3) with (h, w) the target's size")
    pixels = _float_array("source_pixels", source_pixels, (len(cams), h, w, 2), "(S, h, w, 2) with S = len(cameras)")
    vis = _check_visible(visible, (len(cams), h, w))
    counts = np.empty((h, 4), dtype=np.int64)
    kern.count_invalid_rows(points, pixels, vis, counts)  # one parallel pass over the big arrays
    n_inf_points, n_inf_pixels, n_vis_unknown, n_vis_nan = counts.sum(axis=0)
    if n_inf_points:
        raise ValueError("proxy_points must not contain inf (NaN marks none)")
    if n_inf_pixels:
        raise ValueError("source_pixels must not contain inf (NaN marks none)")
    if n_vis_unknown:
        raise ValueError(f"visible must be False where proxy_points is NaN; got {n_vis_unknown} such source pixels")
    if n_vis_nan:
        raise ValueError(f"source_pixels must be finite where visible; got {n_vis_nan} NaN")
    s_sensor = check_positive("sigma_sensor", sigma_sensor)
    s_depth = check_positive("sigma_depth", sigma_depth)
    cap = check_finite("deformation_cap", deformation_cap)
    if cap < 1.0:
        raise ValueError(f"deformation_cap must be >= 1; got {cap:g}")
    g_thr = check_positive("gradient_threshold", gradient_threshold)
    g_cap = check_positive("geometric_cap", geometric_cap)
    if distortion is not None and not (callable(getattr(distortion, "forward", None)) and callable(getattr(distortion, "jacobian", None))):
        raise TypeError(f"distortion must have callable forward and jacobian methods; got {type(distortion).__name__}")

    has_grad = estimate is not None
    gx = gy = np.zeros((1, 1))
    if has_grad:
        img = check_image("estimate", estimate)
        if img.shape[:2] != (h, w):
            raise ValueError(f"estimate must have shape (h, w) or (h, w, 3) with (h, w) = {(h, w)} the target's size; got {img.shape}")
        img = np.ascontiguousarray(img.reshape(h, w, -1), dtype=np.float64)
        gx, gy = np.empty((h, w)), np.empty((h, w))
        kern.luminance_gradient_rows(img, np.empty((h, w)), gx, gy)
    mapped, jac, has_jac = points, kern.empty_jacobian(), False
    if distortion is not None and has_grad:
        mapped, jac = _distort(distortion, points, np.isfinite(points).all(axis=2))
        has_jac = True

    centers = np.ascontiguousarray([c.center for c in cams], dtype=np.float64)
    out = np.empty((len(cams), h, w), dtype=np.float32)
    kern.bayes_weight_rows(
        points, pixels, vis, centers, mapped, jac, has_jac,
        np.ascontiguousarray(target.K), np.ascontiguousarray(target.R), np.ascontiguousarray(target.t),
        gx, gy, has_grad, s_sensor, s_depth, cap, BAYES_MIN_DEFORMATION, g_thr, g_cap,
        BAYES_DEPTH_CONTINUITY, out,
    )
    return out


def _check_cameras(cameras: object) -> list[Camera]:
    if isinstance(cameras, Camera) or not isinstance(cameras, Sequence) or isinstance(cameras, str):
        raise TypeError(f"cameras must be a sequence of Camera; got {type(cameras).__name__}")
    if len(cameras) == 0:
        raise ValueError("cameras must hold at least one Camera; got none")
    return [check_camera(f"cameras[{i}]", c) for i, c in enumerate(cameras)]


def _float_array(name: str, value: object, shape: tuple[int, ...], described: str) -> np.ndarray:
    """``value`` as a C-contiguous float64 array (a copy only when needed) of exactly ``shape``."""
    if np.iscomplexobj(value):
        raise TypeError(f"{name} must be real; got a complex array")
    arr = np.asarray(value)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must be a float array; got {arr.dtype}")
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {described}, i.e. {shape}; got {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def _check_visible(visible: object, shape: tuple[int, ...]) -> np.ndarray:
    vis = np.asarray(visible)
    if vis.dtype != bool:
        raise TypeError(f"visible must be a boolean array; got {vis.dtype}")
    if vis.shape != shape:
        raise ValueError(f"visible must have shape (S, h, w) = {shape} like source_pixels; got {vis.shape}")
    return np.ascontiguousarray(vis)


def _distort(distortion: object, points: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``phi(p)`` (h, w, 3) and ``D phi(p)`` (h, w, 3, 3) at the known proxy points (NaN elsewhere)."""
    p = points[known]
    q = np.asarray(distortion.forward(p), dtype=np.float64)  # type: ignore[attr-defined]
    if q.shape != p.shape:
        raise ValueError(f"distortion.forward must return shape {p.shape} for points {p.shape}; got {q.shape}")
    d = np.asarray(distortion.jacobian(p), dtype=np.float64)  # type: ignore[attr-defined]
    if d.shape != p.shape + (3,):
        raise ValueError(f"distortion.jacobian must return shape {p.shape + (3,)} for points {p.shape}; got {d.shape}")
    mapped = np.full(points.shape, np.nan)
    mapped[known] = q
    jac = np.full(points.shape + (3,), np.nan)
    jac[known] = d
    return mapped, jac
