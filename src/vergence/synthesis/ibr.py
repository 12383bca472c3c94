"""Multi-view image-based rendering: a target view blended from several sources with depth (S0 §5–6).

One primitive shared by the Quadri-Rig, the Tri-Rig and StereoSpace: a target
:class:`~vergence.camera.Camera`, sources (each a camera, an image and its depth map) and, per target
pixel, a 3D proxy point: the sources' depths forward-warped into the target with a z-buffer (source
pixel quads drawn as triangles, so the proxy has no cracks; no triangle across a depth
discontinuity), or a given target depth. Per pixel and source, the proxy point is projected into the
source, tested for field of view and visibility against the source's depth (the occlusion test of
SIBR's ULR; without it, occluders ghost onto the surfaces behind them) and its colour sampled; the
colours are blended with Unstructured Lumigraph weights (Buehler et al. 2001) or the Bayesian
weights of Pujades et al. 2014 (:mod:`vergence.synthesis.ibr_bayes`). Pixels no source sees stay
holes (:func:`vergence.synthesis.fill_holes` fills them if wanted).

Under a world distortion ``phi`` (S0 §6, the Tri-Rig) the target camera lives in the distorted
world: source points are distorted before they are projected into the target, and proxy points are
undistorted (``phi^-1``) before they are projected into the sources. Angles and distances are
measured in the undistorted world only (S0 Fig. 10).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from vergence._validate import check_positive, check_positive_int
from vergence.camera import Camera
from vergence.synthesis import _ibr_stages
from vergence.synthesis._checks import check_camera, check_depth_values, check_image, check_method, check_nonnegative
from vergence.synthesis.ibr_source import IBRSource
from vergence.synthesis.ibr_bayes import (
    BAYES_DEFORMATION_CAP,
    BAYES_GEOMETRIC_CAP,
    BAYES_GRADIENT_THRESHOLD,
    BAYES_SIGMA_DEPTH,
    BAYES_SIGMA_SENSOR,
    bayesian_weights,
)

__all__ = ["IBRResult", "IBR_INTERPOLATIONS", "IBR_LINK_LIMIT_PX", "IBR_WEIGHTS", "render_ibr"]

IBR_WEIGHTS = ("ulr", "bayesian")
# Forward-warped proxy: neighbouring source pixels are one surface when moving one to the other's depth
# moves it at most this many target pixels (the gradient rule of S1 Sec. IV.B.1). DIBR uses 1 px for
# views a few centimetres apart; IBR sources stand metres away (S0's real cameras: up to tens of metres
# behind the virtual eye), where a slanted surface legitimately moves several target pixels per source
# pixel, and 1 px cuts grazing ground into stripes. Chosen on the stadium Quadri-Rig (the scene we tuned
# on, `python -m tools.rig_choices`): coverage 87 % at 1 px, 92 % at 3 px, 98 % at 10 px (30 px: 97 %,
# facets across edges occlude).
IBR_LINK_LIMIT_PX = 10.0
# Source colour sampling: Catmull-Rom bicubic inside a surface (Keys 1981; the default: +0.35 dB over
# bilinear on the stadium Quadri-Rig, the scene we tuned on, `python -m tools.rig_choices`) or bilinear
# (what a GPU's texture unit does).
IBR_INTERPOLATIONS = ("cubic", "linear")
# ULR defaults of SIBR's ulr_v3.frag (Inria GraphDeco): the 4 best sources, angle penalty in radians
# (alpha = 1) plus 0.1 times the relative resolution penalty.
ULR_K = 4
ULR_ALPHA = 1.0
ULR_BETA = 0.1
# Field of view as a penalty (Buehler et al. 2001, Sec. 4: penalty_fov), not a hard cut: a source's
# penalty grows as gamma (band / e - 1)^2 when its pixel lies e < band pixels from its image's edge,
# band = ULR_FOV_BAND times the image's smaller side (5 %: 13.5 px of a 480x270 camera), without bound
# as e -> 0, so a source leaving its field of view fades out. gamma = 0.001: the penalty reaches 0.1 rad
# (5.7 degrees) 1.2 px from the edge of a 480x270 camera. Chosen on the stadium shots (the scenes we
# tuned on, `python -m tools.rig_ulr`): gamma 0 / 0.001 / 0.01 / 0.1 / 1 give 34.17 / 34.15 / 34.10 /
# 34.05 / 34.00 dB on the Quadri-Rig's left eye (a wider fade averages fewer cameras near their borders).
ULR_FOV_BAND = 0.05
ULR_GAMMA = 0.001
# The threshold never exceeds this multiple of the best visible penalty (see render_ibr's Notes): with
# fewer than k visible sources Buehler's k-th penalty does not exist and SIBR's padding makes every
# weight equal; a source more than 2x as far off (in penalty) as the best gets no weight. On the
# stadium shots (the scenes we tuned on, `python -m tools.rig_ulr`) 1.5 / 2 / 3 / 4 / 10 give 47.64 /
# 47.60 / 47.59 / 47.59 / 47.40 dB on the Tri-Rig's right eye and 34.16 / 34.15 / 34.14 / 34.14 / 34.14
# dB on the Quadri-Rig's left; 2 for a gentler fade-in than 1.5. SIBR's equal weights score 48.11 on
# that Tri-Rig: its three sources' independent render noise averages out (docs/shots.md).
ULR_RELATIVE_THRESHOLD = 2.0
# SIBR floors both penalties at 1e-4: a source at the target's own centre still has a positive
# penalty, so the threshold (a multiple of a penalty) is never 0.
ULR_PENALTY_FLOOR = 1e-4
# SIBR's threshold is 1.0000001 times the k-th penalty: the k-th source gets a weight of 1e-7, not 0,
# so a pixel whose k best sources tie (or that one source sees) keeps a positive weight sum.
ULR_THRESHOLD_SCALE = 1.0000001
# Visibility: a source pixel agrees with the projected proxy point when their camera-frame depths
# differ by at most this fraction of the depth. SIBR tests |depth_proj - depth_map| < 1e-2; made
# relative here so one tolerance serves any scene scale. Tested on the source pixel nearest to the
# projection (within half a pixel), so a surface whose depth changes by up to 2 % per source pixel
# still passes.
IBR_OCCLUSION_TOLERANCE = 0.01
# ... plus the change of the source pixel's surface between its centre and the projection: its depth
# slope (metres per source pixel, the smaller of its two one-sided differences per axis) times the
# distance, the slope capped at this fraction of the depth per pixel. Ground seen at a grazing angle
# changes depth by several per cent per pixel and failed the 1 % test, turning into stripes ("zebra")
# where every camera sees it; a surface more edge-on than the cap widens the test no further, so an
# occluder's thin edge cannot pass for a slope. 0: the relative test alone. Chosen on the stadium
# Quadri-Rig (`python -m tools.rig_choices`, docs/shots.md).
IBR_OCCLUSION_SLOPE_CAP = 0.1
# Bayesian weights: re-weightings on the current estimate after the first pass (which has no image
# gradient); the weights of Pujades et al. 2014 change little after a few passes.
BAYES_ITERATIONS = 3


@dataclass(frozen=True, slots=True)
class IBRResult:
    """Output of :func:`render_ibr`.

    Attributes
    ----------
    image : (h, w, 3) float32
        The blended target view, 0 where no source sees the proxy.
    weights : (S, h, w) float32
        Per-source blending weights, summing to 1 where covered, 0 where a source is not used.
    coverage : (h, w) bool
        Some source sees the proxy point (and has a positive weight).
    proxy_depth : (h, w) float64
        Target camera-frame depth of the proxy (in the distorted world under a distortion), NaN none.
    proxy_points : (h, w, 3) float64
        Undistorted world points of the proxy, NaN none.
    method : str
        ``"ulr"`` or ``"bayesian"``.
    """

    image: np.ndarray
    weights: np.ndarray
    coverage: np.ndarray
    proxy_depth: np.ndarray
    proxy_points: np.ndarray
    method: str


def render_ibr(
    target: Camera,
    sources: Sequence[IBRSource],
    *,
    weights: str = "ulr",
    proxy_depth: object = None,
    distortion: object = None,
    k: int = ULR_K,
    alpha: float = ULR_ALPHA,
    beta: float = ULR_BETA,
    gamma: float = ULR_GAMMA,
    relative_threshold: float = ULR_RELATIVE_THRESHOLD,
    occlusion_tolerance: float = IBR_OCCLUSION_TOLERANCE,
    occlusion_slope_cap: float = IBR_OCCLUSION_SLOPE_CAP,
    gradient_limit: float | None = IBR_LINK_LIMIT_PX,
    interpolation: str = "cubic",
    iterations: int = BAYES_ITERATIONS,
    sigma_sensor: float = BAYES_SIGMA_SENSOR,
    sigma_depth: float = BAYES_SIGMA_DEPTH,
    deformation_cap: float = BAYES_DEFORMATION_CAP,
    gradient_threshold: float = BAYES_GRADIENT_THRESHOLD,
    geometric_cap: float = BAYES_GEOMETRIC_CAP,
    progress: Callable[[float, str], object] | None = None,
) -> IBRResult:
    """Render the ``target`` view from ``sources`` by image-based rendering (ULR or Bayesian weights).

    Parameters
    ----------
    target : Camera
        The desired view (in the distorted world when ``distortion`` is given).
    sources : sequence of IBRSource
        At least one source view with its depth.
    weights : {"ulr", "bayesian"}
        Blending weights: Unstructured Lumigraph Rendering (Buehler et al. 2001) or the Bayesian
        weights of Pujades et al. 2014 (S0 ref. [33]).
    proxy_depth : (h, w) array, optional
        The target's camera-frame depth of the geometric proxy (metres, > 0, NaN = none; in the
        distorted world under a distortion). Default: every source's depth forward-warped into the
        target (the nearest surface wins).
    distortion : object, optional
        A world distortion ``phi`` (e.g. ``vergence.rigs.WorldDistortion``) with vectorised
        ``forward(p)``, ``inverse(q)`` ((..., 3) -> (..., 3), NaN where undefined) and
        ``jacobian(p)`` ((..., 3) -> (..., 3, 3), ``D phi`` at undistorted points).
    k : int
        ULR: the number of sources blended per pixel, >= 1 (SIBR ulr_v3: 4).
    alpha, beta : float
        ULR: weights of the angle penalty (radians) and of the relative resolution penalty,
        >= 0, not both 0 (SIBR ulr_v3: 1 and 0.1).
    gamma : float
        ULR: weight of the field-of-view penalty, >= 0 (0.001; 0: the field of view is a hard cut).
    relative_threshold : float
        ULR: the threshold is at most this multiple of the best visible penalty, >= 1 (2; inf:
        Buehler's k-th penalty alone, equal weights when fewer than k sources see the point).
    occlusion_tolerance : float
        Relative depth agreement of the visibility test, > 0 (0.01 = 1 %).
    occlusion_slope_cap : float
        The visibility test also allows the source surface's depth change between its pixel centre and
        the projection (its one-sided depth slope), the slope capped at this fraction of the depth per
        pixel, >= 0 (0.1; 0: the relative test alone).
    gradient_limit : float or None
        Forward-warped proxy: two neighbouring source pixels are one surface when moving one of them
        to the other's depth shifts its target position by at most this many pixels (as in
        :func:`~vergence.synthesis.warp_to_camera`); None: point splats only. Default
        :data:`IBR_LINK_LIMIT_PX` (10 px: IBR sources stand far from the target).
    interpolation : str
        Source colour sampling, in :data:`IBR_INTERPOLATIONS`: ``"cubic"`` (Catmull-Rom, Keys 1981,
        where the 4x4 pixels around the sample are all one surface, clamped to the range of the 4
        nearest; bilinear near an occlusion edge) or ``"linear"`` (bilinear everywhere).
    iterations : int
        Bayesian: re-weightings on the current estimate after the first pass, >= 0.
    sigma_sensor, sigma_depth, deformation_cap, gradient_threshold, geometric_cap : float
        Bayesian: passed to :func:`~vergence.synthesis.bayesian_weights` (see there for meanings
        and units): sensor noise (colour units, 1/255), relative depth uncertainty ``dz / z``
        (0.01), cap of the resolution weight ``|det D tau|^-1`` (>= 1; 20, the authors' choice, 1
        their other variant), cap of ``|grad u|`` (luminance per pixel, 0.01), cap of sigma_geom (0.5).
    progress : callable(fraction, message), optional
        Told about each stage.

    Returns
    -------
    IBRResult

    Raises
    ------
    TypeError
        A target that is not a Camera, sources that are not IBRSource, a distortion without
        ``forward``/``inverse``/``jacobian``, non-numeric options.
    ValueError
        No sources, an unknown weights name, a proxy depth of the wrong shape, inf or <= 0,
        non-finite or out-of-range options.

    Notes
    -----
    ULR (Buehler et al. 2001, Sec. 4; SIBR ``ulr_v3.frag``), for the proxy point ``p``, the desired
    ray ``r``, a visible source centred at ``C_i`` whose pixel ``(u, v)`` lies ``e`` pixels inside the
    edge of its ``W x H`` image (``e = min(u + 1/2, W - 1/2 - u, v + 1/2, H - 1/2 - v)``)::

        fov_i     = gamma (band_i / e - 1)^2 if e < band_i else 0,   band_i = 0.05 min(W, H)
        penalty_i = alpha max(1e-4, angle(p - C_i, r)) + beta max(1e-4, (|p - C_i| - |r|) / |p - C_i|) + fov_i
        thresh    = 1.0000001 * min(k-th smallest penalty, relative_threshold * smallest penalty)
        w_i       = max(0, 1 - penalty_i / thresh) for the k best, 0 otherwise;  normalised.

    Why the ``min``: Buehler's threshold, the k-th penalty, gives the k-th source weight 0, so a
    source enters or leaves the set continuously. With ``m < k`` visible sources there is no k-th
    penalty; SIBR pads the set with penalties of 1e5, which in the limit gives every visible
    source the same weight whatever its penalty, and the weights jump from equal to penalty-based
    when a k-th source comes into view. Counting a source that does not see the point as a penalty
    of +inf (the limit of ``fov_i`` at its image's edge), the k-th smallest penalty is +inf while
    ``m < k`` and falls continuously as the k-th source comes into view; ``min(k-th,
    relative_threshold * best)`` is then a continuous function of all penalties (an order
    statistic and a minimum of continuous functions), finite whenever one source sees the point,
    and equal to Buehler's threshold when the k best are within ``relative_threshold`` of each
    other. So the weights are continuous in the penalties everywhere: the worst visible source
    fades in from 0 as its penalty falls below ``relative_threshold`` times the best, also with
    fewer than k sources, and a source entering through the edge of its image enters with weight 0.
    Only the occlusion test remains a hard cut. A lone source gets weight 1. Without distortion
    ``r = p - D`` (``D`` the target centre). Under a distortion (S0 §6, Fig. 10), with ``p'`` the
    distorted proxy point and ``c`` the target centre, the desired ray is undistorted by the
    Jacobian, ``r = D phi(p)^-1 (p' - c)``, and ``|r|`` is the desired distance of the resolution
    term: both are exact for an affine ``phi`` (then ``r = p - phi^-1(c)``), and first-order
    otherwise.

    Visibility: the proxy point must project inside the source's pixel rectangle (the hull of its
    pixel centres widened by half a pixel, sampled clamped to the hull), in front of it, and its depth agree within ``occlusion_tolerance`` with that of the source pixel
    nearest to the projection; the colour is the bilinear sample over the agreeing pixels among the
    4 around it (renormalised, so an occluder's colour never bleeds onto the surface behind it);
    with ``interpolation="cubic"``, the clamped Catmull-Rom sample where all 16 around it agree.

    Bayesian (Pujades et al. 2014): ``w = bayesian_weights(None, ...)``, ``u`` = the normalised
    blend, then ``iterations`` times ``w = bayesian_weights(u, ...)``, ``u`` = the blend.

    Examples
    --------
    A wall 2 m away seen by two cameras 20 cm apart (grey 0.45 and 0.55), rendered halfway between
    them; each edge pixel lies within half a pixel of the far camera's image (its pixel rectangle),
    so both cameras see every pixel. Fewer than k = 4 sources: the threshold is twice the best
    penalty, so the weights follow the penalties (which differ by 1 % at pixel 1: 0.0408 and 0.0412
    rad), not equal. With k = 2 the worse of the two gets weight 0, except where they tie (the centre).

    >>> from vergence.camera import look_at
    >>> def cam(x):
    ...     return look_at([x, 0, 0], [x, 0, 1], [0, -1, 0], fov_deg=90, width=5, height=1)
    >>> grey = np.full((1, 5, 3), 0.5, dtype=np.float32)
    >>> sources = [IBRSource(cam(x), grey + x / 2, np.full((1, 5), 2.0)) for x in (-0.1, 0.1)]
    >>> res = render_ibr(cam(0.0), sources)
    >>> res.coverage.all(), res.weights[0].astype(float).round(3).tolist()
    (np.True_, [[0.508, 0.502, 0.5, 0.498, 0.492]])
    >>> res = render_ibr(cam(0.0), sources, k=2)
    >>> res.weights[0].round(3).tolist(), res.image[..., 0].astype(float).round(3).tolist()
    ([[1.0, 1.0, 0.5, 0.0, 0.0]], [[0.45, 0.45, 0.5, 0.55, 0.55]])
    """
    target = check_camera("target", target)
    srcs = _check_sources(sources)
    method = check_method("weights", weights, IBR_WEIGHTS)
    interp = check_method("interpolation", interpolation, IBR_INTERPOLATIONS)
    given = None if proxy_depth is None else _check_proxy_depth(proxy_depth, target)
    if given is None and not any(np.isfinite(s.depth).any() for s in srcs):
        raise ValueError("sources must see some surface: every source depth is NaN, so there is no proxy to render")
    if distortion is not None:
        _check_distortion(distortion)
    k = check_positive_int("k", k)
    alpha = check_nonnegative("alpha", alpha)
    beta = check_nonnegative("beta", beta)
    if alpha + beta == 0.0:
        raise ValueError("alpha and beta must not both be 0 (every ULR penalty would be 0)")
    gamma = check_nonnegative("gamma", gamma)
    relative = _check_relative_threshold(relative_threshold)
    tol = check_positive("occlusion_tolerance", occlusion_tolerance)
    slope_cap = check_nonnegative("occlusion_slope_cap", occlusion_slope_cap)
    limit = None if gradient_limit is None else check_nonnegative("gradient_limit", gradient_limit)
    if isinstance(iterations, bool) or not isinstance(iterations, int | np.integer):
        raise TypeError(f"iterations must be an integer; got {type(iterations).__name__}")
    if iterations < 0:
        raise ValueError(f"iterations must be >= 0; got {iterations}")
    bayes = {
        "sigma_sensor": check_positive("sigma_sensor", sigma_sensor),
        "sigma_depth": check_positive("sigma_depth", sigma_depth),
        "deformation_cap": check_positive("deformation_cap", deformation_cap),
        "gradient_threshold": check_positive("gradient_threshold", gradient_threshold),
        "geometric_cap": check_positive("geometric_cap", geometric_cap),
    }
    if bayes["deformation_cap"] < 1.0:
        raise ValueError(f"deformation_cap must be >= 1; got {bayes['deformation_cap']:g}")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable(fraction, message) or None; got {type(progress).__name__}")
    say = progress or (lambda _f, _m: None)

    say(0.0, "proxy: sources forward-warped into the target" if given is None else "proxy: given depth")
    depth_t = _ibr_stages.forward_proxy(target, srcs, distortion, limit) if given is None else given
    say(0.2, "proxy points: back-projected" + ("" if distortion is None else " and undistorted"))
    points_t = _ibr_stages.backproject(target, depth_t)  # in the distorted world under a distortion
    points = points_t if distortion is None else _ibr_stages.call_distortion(distortion.inverse, "inverse", points_t)
    if method == "ulr":
        say(0.3, f"ULR: {len(srcs)} sources sampled and blended")
        rays = np.zeros((0, 0, 3))
        if distortion is not None:
            rays = _ibr_stages.desired_rays(distortion, points, points_t, target.center)
        settings = _ibr_stages.ULRSettings(tol, slope_cap, interp == "cubic", k, alpha, beta, gamma, relative,
                                           ULR_FOV_BAND, ULR_PENALTY_FLOOR, ULR_THRESHOLD_SCALE)
        w, image, coverage = _ibr_stages.ulr_fused(points, rays, target.center, srcs, settings)
    else:
        say(0.3, f"sampling {len(srcs)} sources")
        pixels, visible, colours = _ibr_stages.sample_sources(points, srcs, tol, slope_cap, True, interp == "cubic")
        cameras = [s.camera for s in srcs]
        estimate = None
        for it in range(iterations + 1):
            say(0.5 + 0.5 * it / (iterations + 1), f"Bayesian weights, pass {it + 1} of {iterations + 1}")
            omega = bayesian_weights(estimate, points, pixels, visible, target, cameras, distortion=distortion, **bayes)
            w = np.array(omega, dtype=np.float32, order="C")
            image, coverage = _ibr_stages.blend(w, visible, colours)
            estimate = image
    say(1.0, "done")
    return IBRResult(image=image, weights=w, coverage=coverage, proxy_depth=depth_t, proxy_points=points, method=method)


# ---------------------------------------------------------------------------------------------- checks


def _check_relative_threshold(value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"relative_threshold must be a number; got {type(value).__name__}")
    v = float(value)
    if math.isnan(v) or v < 1.0:
        raise ValueError(f"relative_threshold must be >= 1 (inf: the k-th penalty alone); got {v:g}")
    return v


def _check_sources(sources: object) -> list[IBRSource]:
    if isinstance(sources, IBRSource) or not isinstance(sources, Sequence):
        raise TypeError(f"sources must be a sequence of IBRSource; got {type(sources).__name__}")
    if len(sources) == 0:
        raise ValueError("sources must hold at least one IBRSource; got none")
    for i, s in enumerate(sources):
        if not isinstance(s, IBRSource):
            raise TypeError(f"sources[{i}] must be an IBRSource; got {type(s).__name__}")
    return list(sources)


def _check_proxy_depth(proxy_depth: object, target: Camera) -> np.ndarray:
    if np.iscomplexobj(proxy_depth):
        raise TypeError("proxy_depth must be real; got a complex array")
    try:
        z = np.array(proxy_depth, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"proxy_depth must be numeric; got {type(proxy_depth).__name__}") from exc
    size = (target.height, target.width)
    if z.shape != size:
        raise ValueError(f"proxy_depth must have shape {size} matching the target camera; got {z.shape}")
    check_depth_values("proxy_depth", z)
    return z


def _check_distortion(distortion: object) -> None:
    missing = [m for m in ("forward", "inverse", "jacobian") if not callable(getattr(distortion, m, None))]
    if missing:
        raise TypeError(f"distortion must have callable forward, inverse and jacobian (a WorldDistortion); "
                        f"{type(distortion).__name__} lacks {', '.join(missing)}")
