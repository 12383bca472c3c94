"""Shoot a shot file: render the rig's real cameras, synthesise the director's pair, measure it (S0 §5–7).

One call, :func:`render_shot`, does what ``vergence rig render`` does, without writing files:

- **Quadri-Rig** (S0 §5): every real camera and both virtual eyes are ray-traced; each virtual eye is
  synthesised by image-based rendering (:func:`vergence.synthesis.render_ibr`, ULR or Bayesian
  weights) from all 2N real cameras (S0 Table 1 blends 4; the weights pick per pixel, mostly the
  eye's own camera of each element: 34.15 dB against 33.24 dB from the eye's two cameras alone, ULR
  on the stadium, ``python -m tools.rig_choices``), and compared with the virtual eye ray-traced directly.
- **Tri-Rig** (S0 §6): the director's, subject and background cameras are ray-traced; the left image
  is the director's; the right image is synthesised in the reference right camera of the distorted
  world (every source pixel through phi, z-buffer on the distorted depth, ULR angles undistorted by
  D phi^-1, S0 Fig. 10) and compared with the curved-ray truth: each straight ray of the reference
  right camera followed as the curve phi^-1(ray) in the real scene
  (:meth:`vergence.render.Tracer.render_curved`). S0 could not evaluate this image; we can.

Every image of one shot (sources, results, truth) is tone-mapped with one exposure, so they compare
pixel for pixel. PSNR and DSSIM are measured over the pixels some source sees (the coverage mask).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["RIG_SOURCES", "RIG_WEIGHTS", "SHOT_SUPERSAMPLE", "ShotRender", "check_ibr_settings", "measure_against_truth",
           "render_shot"]

# --sources choices of `vergence rig render` (a Quadri-Rig's eyes): "all" blends all 2N real cameras
# into each virtual eye (the weights choose per pixel; our default), "eye" only the eye's own N cameras,
# as S0 §5 synthesises each eye (the setup of S0 Table 1).
RIG_SOURCES = ("all", "eye")

# --weights choices of `vergence rig render`: name -> the IBR weightings it runs.
RIG_WEIGHTS = {"ulr": ("ulr",), "bayesian": ("bayesian",), "both": ("ulr", "bayesian")}

# Rays per pixel, k x k, in every ray-traced image of a shot (sources and truth alike). Chosen on the
# stadium Quadri-Rig (the scene we tuned on): k = 1, 2, 3 give 30.1, 33.7, 34.2 dB (ULR, left eye):
# resampling an aliased source cannot match an aliased truth; 3 costs 2.25 times the rays of 2.
SHOT_SUPERSAMPLE = 3

# The curved-ray truth starts this fraction of the nearest source depth in front of the camera: every
# surface the sources see lies beyond it.
_NEAR_FRACTION = 0.5

# Colour of a pixel no source sees, in error images (the grey error scale cannot reach it).
_HOLE_RGB = (0.1, 0.2, 0.8)

Progress = Callable[[float, str], None]


@dataclass(frozen=True, eq=False)
class ShotRender:
    """Everything :func:`render_shot` made, in memory.

    Attributes
    ----------
    shot : Shot
    rig : QuadriRig or TriRig
    exposure : float
        The one exposure every image was tone-mapped with.
    cameras : dict of str -> (image, depth)
        Each real camera's tone-mapped image (H, W, 3) float32 and depth (H, W) metres (NaN: sky).
    truth : dict of eye -> image
        The ray-traced truth of each eye (for a Tri-Rig, the right one through curved rays).
    results : dict of method -> dict of eye -> IBRResult
        The synthesised eyes (a Tri-Rig's left eye is the director's image, not synthesised: absent).
    images : dict of method -> dict of eye -> image
        The stereo pair each method gives (a Tri-Rig's left image is the director's).
    mapped_disparity : ndarray or None
        Tri-Rig: the left image's mapped disparity in pixels (x_left - x_right), NaN where nothing is seen.
    report : dict
        Per method and eye: PSNR (dB) and DSSIM over covered pixels and the coverage fraction; timings.
    """

    shot: object
    rig: object
    exposure: float
    cameras: dict
    truth: dict
    results: dict
    images: dict
    mapped_disparity: np.ndarray | None
    report: dict = field(default_factory=dict)

    def error_image(self, method: str, eye: str, *, gain: float = 4.0) -> np.ndarray:
        """The synthesised ``eye`` of ``method`` against its truth: ``gain |image - truth|``, grey, mean over
        the channels (:func:`vergence.synthesis.error_image`); pixels no source sees (the coverage's holes) blue.

        Returns
        -------
        (H, W, 3) float32 in [0, 1]

        Raises
        ------
        KeyError
            For a method that was not run, or an eye that was not synthesised (a Tri-Rig's left eye is the
            director's image); the message lists the ones there are.
        """
        from vergence.synthesis import error_image

        made = [f"{m}/{e}" for m, eyes in self.results.items() for e in eyes]
        if eye not in self.results.get(method, {}):
            raise KeyError(f"no synthesised {method}/{eye} eye; synthesised: {', '.join(made)}")
        res = self.results[method][eye]
        rgb = np.repeat(error_image(self.images[method][eye], self.truth[eye], gain=gain)[..., None], 3, axis=-1)
        rgb[~res.coverage] = _HOLE_RGB
        return rgb


def render_shot(
    shot: object,
    *,
    weights: Sequence[str] = ("ulr", "bayesian"),
    samples: int = 16,
    supersample: int = SHOT_SUPERSAMPLE,
    sources: str = "all",
    k: int | None = None,
    occlusion_tolerance: float | None = None,
    deformation_cap: float | None = None,
    progress: Progress | None = None,
) -> ShotRender:
    """Render the real cameras of ``shot``, synthesise the director's stereo pair and measure it.

    Parameters
    ----------
    shot : Shot
        From :func:`vergence.rigs.load_shot`.
    weights : sequence of str
        IBR weightings to run, each in :data:`vergence.synthesis.IBR_WEIGHTS`.
    samples : int
        Ambient-occlusion rays per diffuse hit (as ``vergence render --samples``).
    supersample : int
        k x k sub-pixel rays per pixel in every ray-traced image (sources and truth alike):
        anti-aliased sources resample without aliasing, and the truth is compared at the same footing.
    sources : str
        A Quadri-Rig's sources per eye, in :data:`RIG_SOURCES`: ``"all"`` 2N real cameras,
        ``"eye"`` the eye's own N (S0's setup). A Tri-Rig's right eye is always made from its three
        cameras (``"all"``).
    k, occlusion_tolerance, deformation_cap : optional
        :func:`vergence.synthesis.render_ibr`'s ULR source count (an integer >= 1), visibility test's
        relative depth tolerance (> 0) and Bayesian deformation cap (>= 1); None: its defaults. Checked
        before anything is rendered; the report's ``ibr`` states the values used.
    progress : callable(fraction, message), optional

    Returns
    -------
    ShotRender

    Raises
    ------
    ValueError
        An unknown weighting or ``sources`` (``"eye"`` for a Tri-Rig), ``samples`` or ``supersample`` < 1, a rig the planner refuses, a render
        past the renderer's documented limits, real cameras that see nothing of the scene (checked
        before the virtual eyes or the curved-ray truth are traced) or none of an eye's view (0 %
        coverage: nothing to measure).
    """
    from vergence.rigs.shot import Shot
    from vergence.synthesis import IBR_WEIGHTS

    if not isinstance(shot, Shot):
        raise TypeError(f"shot must be a vergence.rigs.Shot; got {type(shot).__name__}")
    if isinstance(weights, str) or not weights or any(w not in IBR_WEIGHTS for w in weights):
        raise ValueError(f"weights must be a non-empty list of {', '.join(IBR_WEIGHTS)}; got {weights!r}")
    for name, value in (("samples", samples), ("supersample", supersample)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1; got {value!r}")
    if sources not in RIG_SOURCES:
        raise ValueError(f"sources must be one of {', '.join(RIG_SOURCES)}; got {sources!r}")
    if sources == "eye" and shot.rig != "quadri":
        raise ValueError("sources 'eye' applies to a Quadri-Rig; a Tri-Rig's right eye is made from its three cameras")
    ibr = check_ibr_settings(k, occlusion_tolerance, deformation_cap)
    say = progress or (lambda _f, _m: None)
    rig = shot.plan()
    if shot.rig == "quadri":
        result = _render_quadri(shot, rig, tuple(weights), samples, supersample, sources, ibr, say)
    else:
        result = _render_tri(shot, rig, tuple(weights), samples, supersample, ibr, say)
    result.report["ibr"] = ibr
    return result


def check_ibr_settings(k: object, tolerance: object, cap: object) -> dict:
    """render_ibr's k, occlusion_tolerance and deformation_cap for render_shot, checked as render_ibr checks them
    (None: its default)."""
    from vergence._validate import check_positive, check_positive_int
    from vergence.synthesis.ibr import IBR_OCCLUSION_TOLERANCE, ULR_K
    from vergence.synthesis.ibr_bayes import BAYES_DEFORMATION_CAP

    out = {"k": check_positive_int("k", ULR_K if k is None else k),
           "occlusion_tolerance": check_positive("occlusion_tolerance",
                                                 IBR_OCCLUSION_TOLERANCE if tolerance is None else tolerance),
           "deformation_cap": check_positive("deformation_cap", BAYES_DEFORMATION_CAP if cap is None else cap)}
    if out["deformation_cap"] < 1.0:  # Pujades et al. 2014's cap on the deformation weight: at least 1
        raise ValueError(f"deformation_cap must be >= 1; got {out['deformation_cap']:g}")
    return out


def _tracer(shot: object) -> object:
    from vergence.render import Tracer, open_scene

    cam = shot.camera
    return Tracer(open_scene(shot.scene, width=cam.width, height=cam.height))


def _trace_all(tracer, named, samples, supersample, say, start, span):  # noqa: ANN001, ANN202
    """Render the (name, camera) pairs through ``Tracer.render_many`` (side by side up to its ``WAVEFRONT_SLOTS``
    rays a level): name -> RenderResult, reporting progress over [start, start + span]."""
    names = ", ".join(n for n, _ in named)
    report = lambda f, m: say(start + span * f, f"ray-tracing {names}: {m}")  # noqa: E731
    results = tracer.render_many([c for _, c in named], samples=samples, supersample=supersample, progress=report)
    return dict(zip((n for n, _ in named), results))


class _Stages:
    """Wall seconds per stage of a shot, in order (``report.json``'s ``timings``)."""

    def __init__(self) -> None:
        self.start = self.mark = time.perf_counter()
        self.seconds: dict[str, float] = {}

    def done(self, stage: str) -> None:
        now = time.perf_counter()
        self.seconds[stage] = round(self.seconds.get(stage, 0.0) + now - self.mark, 3)
        self.mark = now

    def report(self, ray_tracing: Sequence[str]) -> dict:
        """The stages' seconds, their sum for ``ray_tracing_s`` (the one figure before per-stage times) and the total."""
        return {"ray_tracing_s": round(sum(self.seconds.get(k, 0.0) for k in ray_tracing), 2),
                "total_s": round(time.perf_counter() - self.start, 2), "stages_s": dict(self.seconds)}  # fmt: skip


def _tone(beauty: np.ndarray, exposure: float) -> np.ndarray:
    from vergence.render import tonemap

    return np.ascontiguousarray(tonemap(beauty, exposure=exposure), dtype=np.float32)


def _tonemapped(results: dict, exposure: float) -> dict:
    return {k: _tone(r.beauty, exposure) for k, r in results.items()}


def measure_against_truth(image: np.ndarray, truth: np.ndarray, coverage: np.ndarray,
                          proxy_depth: np.ndarray | None = None) -> dict:
    """PSNR and DSSIM over the covered pixels (a window reaching a hole compares its black), DSSIM
    from the windows wholly inside the covered area (``dssim_inside``, None where none is) with the
    share of the image those windows centre on (``inside``), the coverage, and, given the proxy's
    depth, PSNR and DSSIM of the whole image with its holes filled (``psnr_filled``, ``dssim_filled``):
    each run of holes along a row takes the colour of its farther neighbour, S1's background fill
    (:func:`vergence.synthesis.fill_holes`), so a method cannot gain by leaving pixels out."""
    from scipy.ndimage import minimum_filter

    from vergence.metrics import SSIM_WINDOW, dssim, psnr
    from vergence.synthesis import fill_holes

    covered = float(coverage.mean())
    if not coverage.any():
        return {"psnr": None, "dssim": None, "dssim_inside": None, "inside": 0.0, "coverage": 0.0}
    p = psnr(image, truth, mask=coverage)
    whole = minimum_filter(coverage.astype(np.uint8), size=SSIM_WINDOW, mode="constant", cval=0).astype(bool)
    inside = round(float(whole.mean()), 6)
    d_in = round(dssim(image, truth, mask=coverage, whole_windows=True), 6) if whole.any() else None
    out = {"psnr": None if math.isinf(p) else round(p, 3), "dssim": round(dssim(image, truth, mask=coverage), 6),
           "dssim_inside": d_in, "inside": inside, "coverage": round(covered, 6)}  # fmt: skip
    if proxy_depth is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            nearness = np.where(coverage & np.isfinite(proxy_depth), 1.0 / proxy_depth, 0.0)  # sky: the farthest
        filled, _ = fill_holes(image, nearness, ~coverage)
        filled = np.nan_to_num(filled)  # a row with no covered pixel stays black
        pf = psnr(filled, truth)
        out["psnr_filled"] = None if math.isinf(pf) else round(pf, 3)
        out["dssim_filled"] = round(dssim(filled, truth), 6)
    return out


def _check_seen(renders: dict, names: Sequence[str]) -> None:
    """Refuse a rig whose real cameras see nothing of the scene (every depth is sky): nothing to synthesise."""
    if not any(np.isfinite(np.asarray(renders[n].depth)).any() for n in names):
        raise ValueError(f"the rig's real cameras ({', '.join(names)}) see nothing of the scene (every depth is sky): "
                         "0 % coverage; check that they stand above the ground and face the scene")  # fmt: skip


def _check_covered(coverage: np.ndarray, eye: str, method: str) -> None:
    """Refuse an eye no real camera sees any of (0 % coverage): no figure can be measured."""
    if not coverage.any():
        raise ValueError(f"the real cameras see none of the {eye} eye's view ({method}: 0 % coverage): "
                         "nothing to measure; check that they stand above the ground and face the scene")  # fmt: skip


def _sources(names: Sequence[str], rig_cams: dict, images: dict, renders: dict) -> list:
    from vergence.synthesis import IBRSource

    return [IBRSource(camera=rig_cams[n], image=images[n], depth=np.asarray(renders[n].depth, dtype=np.float64))
            for n in names]  # fmt: skip


def _render_quadri(shot, rig, methods, samples, supersample, sources, ibr, say) -> ShotRender:  # noqa: ANN001
    from vergence.render import auto_exposure
    from vergence.synthesis import render_ibr

    stages = _Stages()
    tracer = _tracer(shot)
    stages.done("scene")
    real = [(rc.name, rc.camera) for rc in rig.cameras]
    renders = _trace_all(tracer, real, samples, supersample, say, 0.0, 0.4)
    stages.done("real_cameras")
    _check_seen(renders, [n for n, _ in real])  # before the virtual eyes are traced
    named = real + [("virtual_left", rig.left), ("virtual_right", rig.right)]
    renders.update(_trace_all(tracer, named[len(real):], samples, supersample, say, 0.4, 0.2))
    stages.done("virtual_eyes")
    exposure = auto_exposure(renders["virtual_left"].beauty)  # one exposure for every image of the shot
    images = _tonemapped(renders, exposure)
    stages.done("tone_mapping")
    cams = dict(named)
    truth = {"left": images["virtual_left"], "right": images["virtual_right"]}
    results: dict = {}
    report: dict = {}
    for mi, method in enumerate(methods):
        results[method], report[method] = {}, {}
        for ei, eye in enumerate(("left", "right")):
            say(0.6 + 0.4 * (2 * mi + ei) / (2 * len(methods)), f"{method}: synthesising the {eye} eye")
            # all 2N: ULR and Bayesian weigh them per pixel; "eye": the eye's own N (S0 §5)
            names = [rc.name for rc in (rig.cameras if sources == "all" else rig.sources(eye))]
            res = render_ibr(rig.left if eye == "left" else rig.right, _sources(names, cams, images, renders),
                             weights=method, **ibr)  # fmt: skip
            stages.done(f"ibr_{method}")
            _check_covered(res.coverage, eye, method)
            results[method][eye] = res
            report[method][eye] = measure_against_truth(res.image, truth[eye], res.coverage, res.proxy_depth)
            stages.done("measures")
    pairs = {m: {eye: results[m][eye].image for eye in ("left", "right")} for m in methods}
    say(1.0, "done")
    cameras = {rc.name: (images[rc.name], np.asarray(renders[rc.name].depth)) for rc in rig.cameras}
    timing = stages.report(("scene", "real_cameras", "virtual_eyes"))
    return ShotRender(shot=shot, rig=rig, exposure=float(exposure), cameras=cameras, truth=truth, results=results,
                      images=pairs, mapped_disparity=None,
                      report={"sources": sources, "methods": report, "timings": timing})  # fmt: skip


def _render_tri(shot, rig, methods, samples, supersample, ibr, say) -> ShotRender:  # noqa: ANN001
    from vergence.render import auto_exposure
    from vergence.synthesis import render_ibr

    stages = _Stages()
    tracer = _tracer(shot)
    stages.done("scene")
    named = [(rc.name, rc.camera) for rc in rig.cameras]
    renders = _trace_all(tracer, named, samples, supersample, say, 0.0, 0.1)
    stages.done("real_cameras")
    director = renders["director"]
    _check_seen(renders, [n for n, _ in named])
    depths = np.concatenate([np.asarray(r.depth, dtype=np.float64).ravel() for r in renders.values()])
    depths = depths[np.isfinite(depths)]
    dist = rig.distortion
    near_real = _NEAR_FRACTION * float(depths.min())
    near = float(dist.depth(near_real))
    if not (math.isfinite(near) and near > 0):
        raise ValueError(f"the distortion maps the nearest depth {near_real:g} m to {near:g} m: no curved-ray truth")
    say(0.1, "ray-tracing the right truth through curved rays")
    truth_right = _curved_beauty(tracer, rig.reference_right, dist.inverse, near, samples, supersample,
                                 lambda f, m: say(0.1 + 0.8 * f, f"curved-ray truth: {m}"))  # fmt: skip
    stages.done("curved_truth")
    exposure = auto_exposure(director.beauty)
    images = _tonemapped(renders, exposure)
    images["truth_right"] = _tone(truth_right, exposure)
    stages.done("tone_mapping")
    cams = dict(named)
    truth = {"left": images["director"], "right": images["truth_right"]}
    results: dict = {}
    report: dict = {}
    for mi, method in enumerate(methods):
        say(0.9 + 0.1 * mi / len(methods), f"{method}: synthesising the right eye")
        res = render_ibr(rig.reference_right, _sources([n for n, _ in named], cams, images, renders), weights=method,
                         distortion=dist, **ibr)  # fmt: skip
        stages.done(f"ibr_{method}")
        _check_covered(res.coverage, "right", method)
        results[method] = {"right": res}
        everywhere = np.ones(res.coverage.shape, dtype=bool)
        left = measure_against_truth(images["director"], truth["left"], everywhere)
        report[method] = {"left": {**left, "note": "the director's image"},
                          "right": measure_against_truth(res.image, truth["right"], res.coverage, res.proxy_depth)}
        stages.done("measures")
    pairs = {m: {"left": images["director"], "right": results[m]["right"].image} for m in methods}
    say(1.0, "done")
    cameras = {n: (images[n], np.asarray(renders[n].depth)) for n, _ in named}
    timing = stages.report(("scene", "real_cameras", "curved_truth"))
    return ShotRender(shot=shot, rig=rig, exposure=float(exposure), cameras=cameras, truth=truth, results=results,
                      images=pairs, mapped_disparity=mapped_disparity(rig, np.asarray(director.depth)),
                      report={"methods": report, "timings": timing})  # fmt: skip


def _curved_beauty(tracer, camera, to_world, near: float, samples: int, k: int, progress=None) -> np.ndarray:  # noqa: ANN001
    """The curved-ray image of ``camera`` with k x k rays per pixel, averaged in linear radiance.

    Traced as a camera k times finer (``fx k``, ``cx_k = k (cx + 1/2) - 1/2``: the k x k fine pixel
    centres tile each pixel) and box-filtered, as :meth:`Tracer.render`'s ``supersample`` does.
    """
    from vergence.camera import Camera
    from vergence.render import trace_curved

    K = np.array(camera.K, dtype=np.float64)
    if k > 1:
        K[0, 0] *= k
        K[1, 1] *= k
        K[0, 2] = k * (K[0, 2] + 0.5) - 0.5
        K[1, 2] = k * (K[1, 2] + 0.5) - 0.5
    fine = Camera(K=K, R=camera.R, t=camera.t, width=camera.width * k, height=camera.height * k)
    res = trace_curved(tracer, fine, to_world, near=near, far=math.inf, samples=samples, progress=progress)
    beauty = np.asarray(res.beauty, dtype=np.float64)
    return beauty.reshape(camera.height, k, camera.width, k, 3).mean(axis=(1, 3)).astype(np.float32)


def mapped_disparity(rig: object, depth: np.ndarray) -> np.ndarray:
    """The Tri-Rig left image's disparity after psi, in pixels, x_left - x_right (NaN where no surface).

    S0 Eq. (1a) gives ``d = D_r(z)`` as a fraction of the window width (``d = x_r - x_l``); psi maps it
    (S0 §6) and the window spans the director's image width, so ``x_left - x_right = -psi(D_r(z)) width``.
    """
    ref = rig.reference
    z = np.asarray(depth, dtype=np.float64)
    out = np.full(z.shape, np.nan)
    ok = np.isfinite(z) & (z > 0)
    d = (ref.baseline / ref.window) * (1.0 - ref.convergence / z[ok])  # S0 Eq. (1a)
    out[ok] = -np.asarray(rig.mapping.psi(d), dtype=np.float64) * rig.director.width
    return out.astype(np.float32)
