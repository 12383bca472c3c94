"""S3 end to end: glass and mirrors made fusible by per-pixel, per-layer camera offsets (S3 §3).

:func:`specular_stereo` composes the public stages of :mod:`vergence.specular` on a scene and a
shifted-sensor rig:

1. the physical pair and its analysis (S3 §3.1-3.2): the table of the left eye at ``y = m / k``
   (:func:`~vergence.specular.tabulate_offsets`) and ``g(y)`` (:func:`~vergence.specular.analyse_table`);
2. the offsets (S3 §3.4): :class:`~vergence.specular.OffsetPlanner` (low-resolution descent,
   importance-weighted joint bilateral upsampling);
3. the final render, each layer of the left eye from its own per-pixel camera
   (:func:`~vergence.specular.render_offsets`), measured again as an independent matcher would: its
   positions matched against the right eye (:func:`~vergence.specular.layer_disparity`), importance
   and rivalry of that pair;
4. S3 §4's baselines, *on-surface* and *near-surface* (:func:`~vergence.specular.on_surface`,
   :func:`~vergence.specular.near_surface`).

A scene with nothing specular in view (no layer past the first has a surface in either eye) stops
after the physical pair: the result is that pair (``specular`` False). A scene with a mirror or glass
and ``max_depth = 0`` (no specular layer at all) is refused before anything is rendered.

Every arcmin figure is for the pair shown with ``fit`` on the display (:func:`~vergence.specular.fit_display`:
stretched to the screen's width, or one image pixel per display pixel); the report states it
(``display``) and gives, per layer and per mirror or glass object, the plain share of matched pixels
inside the comfort zone beside the importance-weighted one (:mod:`vergence.specular.shares`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
import dataclasses
from dataclasses import dataclass, field

import numpy as np

from vergence.camera import Camera
from vergence.specular.cost import COST_WEIGHTS, CostTerms, disparity_cost
from vergence.specular.display_fit import display_block, fit_display
from vergence.specular.shares import LayerState, specular_objects
from vergence.specular.importance_factors import importance
from vergence.specular.lightness import PerceivedLightness, layer_lightness, pixels_per_degree
from vergence.specular.matching import MATCH_WINDOW, disparity_arcmin, layer_disparity
from vergence.specular.offsets import render_offsets, tabulate_offsets
from vergence.specular.planning import PLAN_FACTOR, OffsetPlanner
from vergence.specular.render_check import RenderCheck, repair_render
from vergence.specular.result_report import specular_report
from vergence.specular.rivalry_map import rivalry
from vergence.specular.surface_baselines import NEAR_SURFACE_ARCMIN, near_surface, on_surface
from vergence.specular.table_file import SpecularTable
from vergence.specular.tabulated import analyse_table
from vergence.viewing.comfort import ComfortZone
from vergence.viewing.geometry import Display, check_display

__all__ = ["DEFAULT_VARIANT", "MAX_TABLE_BYTES", "SpecularResult", "offset_table_bytes", "specular_from_table",
           "specular_stereo"]

#: The absolute term :func:`specular_stereo` uses unless told otherwise (chosen in docs/specular.md).
DEFAULT_VARIANT = "comfort"
#: Largest memory of the offset table and its analysis (the renders' limit, MAX_RENDER_BYTES): beyond
#: it the request is refused before anything is rendered (:func:`offset_table_bytes`).
MAX_TABLE_BYTES = 8 * 2**30
# Peak bytes per offset, layer and pixel of a run: the table's radiance, disparity and distance and
# the analysis's disparity, rivalry and importance are 40 B of float32; the process peaked at 3.09 GiB
# for glasses 512 x 512, D = 2, k = 32 (33 x 7 x 262144 entries: 55 B each, /usr/bin/time -v
# vergence specular glasses --width 512 --height 512)
_PEAK_BYTES = 56


def offset_table_bytes(width: int, height: int, *, k: int, max_depth: int) -> int:
    """Estimated peak memory (bytes) of :func:`specular_stereo` for a ``width x height`` rig: its
    offset table and analysis, ``(k + 1) N W H`` entries of about 56 B (measured), ``N = 2^(D+1) - 1``.

    >>> offset_table_bytes(512, 512, k=32, max_depth=2) / 2**30
    3.158203125
    """
    return (k + 1) * (2 ** (max_depth + 1) - 1) * width * height * _PEAK_BYTES

Progress = Callable[[float, str], None]


@dataclass(frozen=True, slots=True, eq=False)
class SpecularResult:
    """:func:`specular_stereo`'s renders, offsets, measurements and timings.

    Attributes
    ----------
    physical_left, right, optimised_left, on_surface_left, near_surface_left : RenderResult
        The left eyes of the four methods and the shared right eye. ``optimised_left`` holds what
        the per-pixel cameras saw.
    y : (N, H, W) float32
        The offsets (1: physical).
    before, after : LayerState
        The physical left eye and the optimised one, each measured against the right eye.
    cost_before, cost_after : CostTerms
        S3 Eq. 2 of those states, with the physical pair's importance (with S3's variant the data
        term of ``before`` is 0; with ours it equals the absolute term: both measure the distance
        to the target zone).
    zone : ComfortZone
    specular : bool
        False when nothing specular is in view (then the optimised eye is the physical one).
    seconds : dict of str to float
        Wall time per stage.
    settings : dict
        What was asked (k, variant, alpha, factor, ...), JSON-ready.
    render_check, render_check_raw : RenderCheck or None
        Layer pixels lost or foreign in the final render against the physical left eye
        (:func:`~vergence.specular.check_render`), after the repair (``render_check``, 0 by
        construction) and as first traced (``render_check_raw``: what was repaired); None when
        nothing is specular.
    """

    physical_left: object
    right: object
    optimised_left: object
    on_surface_left: object
    near_surface_left: object
    y: np.ndarray
    before: LayerState
    after: LayerState
    cost_before: CostTerms
    cost_after: CostTerms
    zone: ComfortZone
    specular: bool
    seconds: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    _session: _Session | None = field(default=None, repr=False)
    render_check: RenderCheck | None = None
    render_check_raw: RenderCheck | None = None

    def reoptimise(
        self,
        *,
        alpha: object = None,
        variant: str | None = None,
        maps: Mapping[str, object] | None = None,
        progress: Progress | None = None,
    ) -> SpecularResult:
        """The same run with new weights or painted maps: the table is reused (S3 §3.4, interactive).

        Re-solves the offsets with the kept :class:`~vergence.specular.OffsetPlanner`, renders the
        left eye with the new per-pixel cameras and measures it again, as :func:`specular_stereo`
        does; the physical pair and the baselines are this result's. ``alpha`` and ``variant``
        default to this run's; ``maps`` replaces its maps (None: no maps).

        Raises
        ------
        ValueError
            If this result keeps no planner (:meth:`release` was called), or on a bad weight, variant or map.
        """
        if self._session is None:
            raise ValueError("this result keeps no table to re-optimise with (released); run specular_stereo again")
        alpha = self.settings["alpha"] if alpha is None else alpha
        variant = self.settings["variant"] if variant is None else variant
        return _optimise(self._session, alpha=alpha, variant=variant, maps=maps, progress=progress)

    def table(self) -> object:
        """The offset table of this run with what re-solving it needs, for
        :func:`~vergence.specular.write_specular_table` (:class:`~vergence.specular.SpecularTable`).

        Raises
        ------
        ValueError
            If the run kept no table (``specular_stereo(..., keep_table=True)``), or nothing is specular.
        """
        s = self._session
        if s is None or s.analysis is None:
            why = "nothing specular is in view" if not self.specular else "run specular_stereo with keep_table=True"
            raise ValueError(f"this result keeps no offset table: {why}")
        return SpecularTable(analysis=s.analysis, physical_left=s.physical_left, right=s.right_render,
                             zone=s.zone, exposure=s.exposure, epsilon=s.epsilon, window=s.window,
                             settings=dict(self.settings))  # fmt: skip

    def release(self) -> SpecularResult:
        """This result without the planner and renderer :meth:`reoptimise` keeps (frees their memory)."""
        return dataclasses.replace(self, _session=None)

    def report(self) -> dict:
        """JSON-ready figures (:func:`~vergence.specular.result_report.specular_report`): the display
        geometry they assume, cost terms before and after, and per layer, pooled and per mirror or glass
        object the plain share of matched pixels inside the comfort zone beside the importance-weighted one."""
        return specular_report(self)


def _state(left, right, right_lightness, display, exposure, epsilon, window) -> tuple[LayerState, float]:  # noqa: ANN001
    """The layers of ``left`` measured against ``right`` and the match's cutoff (``epsilon`` None: S3's default)."""
    match = layer_disparity(left.position, right.position, window=window, epsilon=epsilon)
    lit = layer_lightness(left.radiance, left.position, display, exposure=exposure)
    pair = PerceivedLightness(left=lit, right=right_lightness, exposure=exposure,
                              pixels_per_degree=pixels_per_degree(display, left.camera.width))  # fmt: skip
    state = LayerState(disparity=disparity_arcmin(match.disparity_px, display).astype(np.float32),
                       importance=importance(pair, match).weight, rivalry=rivalry(pair, match).rivalry,
                       present=np.isfinite(left.position).all(axis=-1))  # fmt: skip
    return state, match.epsilon


def _has_specular(scene: object) -> bool:
    """Whether any object of ``scene`` is a mirror or glass (else no layer past the first can exist)."""
    from vergence.render.scene import Glass, Mirror

    return any(isinstance(scene.materials[obj.material], Glass | Mirror) for obj in scene.objects)


def _cost(state: LayerState, original: LayerState, **kw: object) -> CostTerms:
    # importance of the physical pair for both states (S3 §3.2; the objective holds it fixed)
    return disparity_cost(state.disparity, state.rivalry, original.importance, original.disparity, **kw)


def specular_stereo(
    scene: object,
    left: Camera,
    right: Camera,
    display: Display,
    *,
    k: int = 32,
    max_depth: int = 2,
    samples: int = 16,
    alpha: object = COST_WEIGHTS,
    variant: str = DEFAULT_VARIANT,
    zone: ComfortZone | None = None,
    maps: Mapping[str, object] | None = None,
    factor: int = PLAN_FACTOR,
    near_arcmin: float = NEAR_SURFACE_ARCMIN,
    fit: str = "screen",
    keep_table: bool = False,
    progress: Progress | None = None,
) -> SpecularResult:
    """Make the glass and mirrors of ``scene`` fusible on ``display`` (S3 §3): offsets, renders, figures.

    Parameters
    ----------
    scene : vergence.render.Scene or vergence.render.Tracer
    left, right : Camera
        A shifted-sensor rig (:func:`vergence.rigs.stereo_pair`).
    display : vergence.viewing.Display
        Where the pair is shown; its resolution must be known.
    fit : {"screen", "native"}
        How the image is shown on ``display`` (:func:`~vergence.specular.fit_display`): stretched to
        its width (default, as full screen) or one image pixel per display pixel. Every arcmin
        figure (disparity, the CSF's scale, the comfort zone's share) is for that geometry.
    keep_table : bool
        Keep the table's analysis in the result, for :meth:`SpecularResult.table` (it stays in memory).
    k : int
        Offset steps of the table (S3: 32), in [2, :data:`~vergence.specular.MAX_OFFSET_STEPS`].
    max_depth, samples
        As :func:`vergence.render.render` (S3 uses D = 2).
    alpha, maps
        The cost's weights and painted per-layer maps (:func:`~vergence.specular.disparity_cost`).
    variant : {"comfort", "screen"}
        The absolute term: S3's ``"screen"`` or ours, only what lies outside ``zone``.
    zone : ComfortZone, optional
        The display's comfort zone (default :class:`~vergence.viewing.ComfortZone`'s ±60 arcmin).
    factor : int
        The planner's reduction (:class:`~vergence.specular.OffsetPlanner`).
    near_arcmin : float
        The near-surface baseline's offset (:func:`~vergence.specular.near_surface`).
    progress : callable(fraction, message), optional

    Returns
    -------
    SpecularResult

    Raises
    ------
    TypeError, ValueError
        On a bad rig, display, k, factor, near_arcmin, weight or map, before the table is rendered
        (except the render options, checked by the first render).
    """
    from vergence.render.tonemap import auto_exposure
    from vergence.render.limits import check_max_depth
    # the checks tabulate_offsets, OffsetPlanner and near_surface make, here before the first render
    from vergence.specular.offsets import check_rig, check_steps, tracer_of
    from vergence.specular.planning import check_factor
    from vergence.specular.surface_baselines import check_offset_arcmin

    tracer = tracer_of(scene)  # one Mitsuba scene for the table and the final render
    left, right = check_rig(left, right)
    k = check_steps(k)
    max_depth = check_max_depth(max_depth)
    factor = check_factor(factor)
    try:
        near_arcmin = check_offset_arcmin(near_arcmin)
    except (TypeError, ValueError) as exc:  # named as this function's caller knows it
        raise type(exc)(str(exc).replace("offset_arcmin", "near_arcmin", 1)) from exc
    check_display(display, resolution=True)
    screen_display, display = display, fit_display(display, left.width, fit=fit)  # what the image occupies
    if not isinstance(keep_table, bool):
        raise TypeError(f"keep_table must be a bool; got {type(keep_table).__name__}")
    if max_depth == 0 and _has_specular(tracer.scene):
        raise ValueError("max_depth 0 traces no specular layer (the first hit only), but the scene has mirror or glass "
                         "objects: use max_depth >= 1 (S3: 2)")  # fmt: skip
    zone = ComfortZone() if zone is None else zone
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a vergence.viewing.ComfortZone; got {type(zone).__name__}")
    n_layers = 2 ** (max_depth + 1) - 1
    table_bytes = offset_table_bytes(left.width, left.height, k=k, max_depth=max_depth)
    if table_bytes > MAX_TABLE_BYTES:
        raise ValueError(f"the offset table of {left.width}x{left.height} pixels, {n_layers} layers and k = {k} would take about "
                         f"{table_bytes / 2**30:.1f} GiB (limit {MAX_TABLE_BYTES / 2**30:.0f} GiB, MAX_TABLE_BYTES): "
                         "lower k, the image size or max_depth")  # fmt: skip
    cost_kw = {"alpha": alpha, "variant": variant, "zone": (zone.min_arcmin, zone.max_arcmin)}
    empty = np.zeros((2 ** (max_depth + 1) - 1, left.height, left.width, 2))  # the weights and maps checked
    disparity_cost(empty, empty[..., 0], empty[..., 0], empty, maps=maps, **cost_kw)  # now, not after the table
    report = progress if progress is not None else (lambda f, m: None)
    seconds: dict[str, float] = {}
    settings = {"scene": tracer.scene.name, "k": k, "max_depth": max_depth, "samples": samples, "variant": variant,
                "alpha": [float(a) for a in alpha], "factor": factor, "near_surface_arcmin": near_arcmin,
                "maps": sorted(maps or {}), "display": display_block(screen_display, left.width, fit=fit),
                "objects": specular_objects(tracer.scene)}  # fmt: skip

    def stage(lo: float, hi: float) -> Progress:
        return lambda f, m: report(lo + (hi - lo) * f, m)

    t0 = time.perf_counter()
    table = None
    if _has_specular(tracer.scene):
        table = tabulate_offsets(tracer, left, right, k=k, max_depth=max_depth, samples=samples,
                                 progress=stage(0.0, 0.6))  # fmt: skip
        seconds["tabulate_render"], seconds["tabulate_match"] = table.seconds_render, table.seconds_match
        phys, right_res, epsilon, window = table.left, table.right, table.epsilon, table.window
    else:  # no mirror or glass at all: the physical pair is the answer
        phys, right_res = (tracer.render(cam, max_depth=max_depth, samples=samples) for cam in (left, right))
        epsilon, window = None, MATCH_WINDOW  # the physical match's own cutoff (S3 §3.2)
    exposure = auto_exposure(np.asarray(phys.beauty, dtype=np.float64))
    right_lit = layer_lightness(right_res.radiance, right_res.position, display, exposure=exposure)
    specular = bool(np.isfinite(phys.position[1:]).any() or np.isfinite(right_res.position[1:]).any())
    before, epsilon = _state(phys, right_res, right_lit, display, exposure, epsilon, window)
    settings["match_epsilon_m"] = epsilon  # the cutoff of every match of the run
    analysis = None
    if specular and table is not None:
        analysis = analyse_table(table, display, exposure=exposure, progress=stage(0.6, 0.8))
        seconds["tabulate_analyse"] = analysis.seconds
    del table  # the radiance of every offset is no longer needed
    report(0.8, "baselines: on-surface, near-surface")
    session = _session(tracer, left, right, display, zone, samples, phys, right_res, right_lit, exposure, epsilon,
                       window, before, analysis, factor=factor, near_arcmin=near_arcmin, specular=specular,
                       settings=settings, seconds=seconds, t0=t0, keep_table=keep_table)  # fmt: skip
    del analysis  # the planner keeps its reduced table (and the session the analysis, with keep_table)
    return _optimise(session, alpha=alpha, variant=variant, maps=maps, progress=stage(0.8, 1.0))


def _session(tracer, left, right, display, zone, samples, phys, right_res, right_lit, exposure, epsilon, window,  # noqa: ANN001
             before, analysis, *, factor, near_arcmin, specular, settings, seconds, t0, keep_table) -> _Session:  # noqa: ANN001  # fmt: skip
    """The planner on ``analysis`` (None: nothing to plan) and the baselines, kept with the physical pair
    for :func:`_optimise`; ``seconds`` gains ``plan_reduce``, ``baselines`` and ``total`` (since ``t0``)."""
    planner = None
    if analysis is not None:
        planner = OffsetPlanner(analysis, factor=factor)
        seconds["plan_reduce"] = planner.seconds_reduce
    t1 = time.perf_counter()
    on_res = on_surface(phys, right_res)
    near_res = near_surface(phys, right_res, display, offset_arcmin=near_arcmin)
    seconds["baselines"] = time.perf_counter() - t1
    return _Session(tracer=tracer, left=left, right=right, display=display, zone=zone, samples=samples,
                    physical_left=phys, right_render=right_res, right_lightness=right_lit, exposure=exposure,
                    epsilon=epsilon, window=window, before=before, planner=planner, on_surface_left=on_res,
                    near_surface_left=near_res, specular=specular, settings=settings,
                    seconds={**seconds, "total": time.perf_counter() - t0},
                    analysis=analysis if keep_table else None)  # fmt: skip


@dataclass(frozen=True, slots=True, eq=False)
class _Session:
    """What :meth:`SpecularResult.reoptimise` reuses: the renderer, the rig, the physical pair and its
    measurement, the planner (None when nothing is specular), the baselines, and the first run's
    settings and stage times (``seconds["total"]`` up to the plan)."""

    tracer: object
    left: Camera
    right: Camera
    display: Display
    zone: ComfortZone
    samples: int
    physical_left: object
    right_render: object
    right_lightness: np.ndarray
    exposure: float
    epsilon: float
    window: int
    before: LayerState
    planner: OffsetPlanner | None
    on_surface_left: object
    near_surface_left: object
    specular: bool
    settings: dict
    seconds: dict
    analysis: object = None  # the table's OffsetAnalysis, kept for SpecularResult.table (keep_table)


def _optimise(session: _Session, *, alpha: object, variant: str, maps: Mapping[str, object] | None,
              progress: Progress | None) -> SpecularResult:  # fmt: skip
    """S3 §3.4 on a session: the offsets for these weights, the final render and its measurement."""
    report = progress if progress is not None else (lambda f, m: None)
    s = session
    phys, before = s.physical_left, s.before
    cost_kw = {"alpha": alpha, "variant": variant, "zone": (s.zone.min_arcmin, s.zone.max_arcmin)}
    n, h, w = phys.n_layers, phys.camera.height, phys.camera.width
    cost_before = _cost(before, before, maps=maps, **cost_kw)  # also checks the weights and maps before the render
    seconds = dict(s.seconds)
    settings = {**s.settings, "variant": variant, "alpha": [float(a) for a in alpha], "maps": sorted(maps or {})}
    t0 = time.perf_counter()
    if s.planner is not None:
        report(0.0, "solving the offsets")
        plan = s.planner.solve(maps=maps, **cost_kw)
        seconds["plan_solve"] = plan.seconds
        report(0.3, "final render with per-pixel cameras")
        t1 = time.perf_counter()
        optimised = render_offsets(s.tracer, s.left, s.right, plan.y, samples=s.samples)
        repaired = repair_render(s.tracer, s.left, s.right, plan.y, phys, optimised, samples=s.samples)
        optimised, y, checks = repaired.render, repaired.y, (repaired.after, repaired.before)
        seconds["final_render"] = time.perf_counter() - t1
        after, _ = _state(optimised, s.right_render, s.right_lightness, s.display, s.exposure, s.epsilon, s.window)
    else:
        optimised, y, after, checks = phys, np.ones((n, h, w), np.float32), before, (None, None)
    seconds["total"] = s.seconds["total"] + time.perf_counter() - t0
    report(1.0, "done")
    return SpecularResult(physical_left=phys, right=s.right_render, optimised_left=optimised,
                          on_surface_left=s.on_surface_left, near_surface_left=s.near_surface_left, y=y,
                          before=before, after=after, cost_before=cost_before,
                          cost_after=_cost(after, before, maps=maps, **cost_kw), zone=s.zone, specular=s.specular,
                          seconds=seconds, settings=settings, _session=session, render_check=checks[0],
                          render_check_raw=checks[1])  # fmt: skip


def specular_from_table(
    table: SpecularTable,
    scene: object,
    *,
    alpha: object = None,
    variant: str | None = None,
    maps: Mapping[str, object] | None = None,
    factor: int | None = None,
    progress: object = None,
) -> object:
    """Re-solve a stored table for new weights or maps, render the final left eye and measure it.

    The result is what :func:`~vergence.specular.specular_stereo` returns with the same options
    (the planner, the final render and the measurements run again; the table and the physical pair
    are the stored ones).

    Parameters
    ----------
    table : SpecularTable
    scene : vergence.render.Scene or vergence.render.Tracer
        The scene the table was made of (its name must be the table's ``settings["scene"]``).
    alpha, variant : optional
        The cost's weights and absolute term; default the table run's.
    maps : mapping, optional
        Painted maps (:func:`~vergence.specular.disparity_cost`).
    factor : int, optional
        The planner's reduction; default the table run's.
    progress : callable(fraction, message), optional

    Returns
    -------
    SpecularResult

    Raises
    ------
    TypeError, ValueError
        A table that is not one, a scene of another name, a bad weight, variant, factor or map.
    """
    from vergence.specular.offsets import tracer_of
    from vergence.specular.planning import check_factor

    if not isinstance(table, SpecularTable):
        raise TypeError(f"table must be a SpecularTable; got {type(table).__name__}")
    tracer = tracer_of(scene)
    s = dict(table.settings)
    if tracer.scene.name != s.get("scene"):
        raise ValueError(f"scene is {tracer.scene.name!r}, but the table was made of {s.get('scene')!r}")
    factor = check_factor(s["factor"] if factor is None else factor)
    alpha = s["alpha"] if alpha is None else alpha
    variant = s["variant"] if variant is None else variant
    t0 = time.perf_counter()
    display = table.analysis.display
    phys, right_res = table.physical_left, table.right
    right_lit = layer_lightness(right_res.radiance, right_res.position, display, exposure=table.exposure)
    before, _ = _state(phys, right_res, right_lit, display, table.exposure, table.epsilon, table.window)
    settings = {**s, "factor": factor}
    session = _session(tracer, phys.camera, right_res.camera, display, table.zone, int(s["samples"]), phys, right_res,
                       right_lit, table.exposure, table.epsilon, table.window, before, table.analysis,
                       factor=factor, near_arcmin=float(s["near_surface_arcmin"]), specular=True, settings=settings,
                       seconds={"measure_physical": time.perf_counter() - t0}, t0=t0, keep_table=False)  # fmt: skip
    return _optimise(session, alpha=alpha, variant=variant, maps=maps, progress=progress)
