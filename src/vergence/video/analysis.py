"""Comfort analysis of a stereo or 2D + depth clip on a display, per frame and per shot.

For each analysed frame the disparity map ``D = x_left - x_right`` (pixels of the full-resolution
views, positive in front of the screen; ``docs/conventions.md``) comes from

- a stereo clip: the library's matcher on the pair (:func:`vergence.depth.compute_disparity`, as
  ``vergence match``), unmatched pixels left out (``keep_invalid=True``), the views padded so that
  the edges are matched too; the left edge band is judged on the right view's disparity (a crossed
  point at the left edge of the left view has no match in the right one);
- a 2D + depth clip: the parallax ``vergence synthesize`` would give it
  (:func:`vergence.synthesis.plan_parallax`, budget mode), with one linear mapping per shot fitted to
  the shot's nearness range (what a per-shot conversion renders; one image is a one-frame shot).

The image fills the display's width: ``N / W`` display pixels per view pixel, so the screen
parallax is ``s = -D N / W`` display pixels and its vergence change comes from
:func:`vergence.viewing.arcmin_from_pixels` (positive behind the screen). The analysis reports it with
the sign of ``D`` (``disparity_arcmin``, ``comfort_zone_arcmin``: positive in front of the screen,
``docs/conventions.md``), so each ``pN`` key of either unit holds the N-th percentile and ``p99`` is the
nearest content. Then, per frame:

- percentiles 1, 5, 50, 95, 99 of ``D`` (:data:`PERCENTILES`);
- the share of pixels outside the :class:`~vergence.viewing.ComfortZone` and the share past the
  divergence limit ``b'/W'`` (S0 Eq. 8, :attr:`vergence.viewing.Display.divergence_disparity`);
- a stereo-window violation: crossed disparity (``D > WINDOW_MIN_PX``) on at least
  :data:`WINDOW_SHARE` of the pixels of the left or right edge band (:data:`WINDOW_BAND` of the width):
  an object in front of the screen cut by the frame's edge;
- for a stereo clip, the vertical disparity of SIFT matches (:func:`vergence.depth.measure_row_alignment`),
  median of ``|y_right - y_left|``, on views reduced to at most ``VERTICAL_MAX_WIDTH`` px wide.

A stereo clip is matched in each shot's search range, found from its features unless given, and
checked for saturation (:mod:`vergence.video.search`): each frame and shot carries the range it was
searched in (``search_px``), the frames matched again in a widened range, those still saturated, and
``on_bound``, the percentiles that sit within 1 px of the range (a figure there is a bound, not a
measure).

Per shot (cuts from :func:`vergence.video.detect_cuts`): the percentiles of all its pixels (from a
histogram of :data:`HISTOGRAM_STEP_PX` bins), each as an angle (``disparity_arcmin``: the vergence
change of the p-th percentile of ``D``, signed as ``D``), the shares and the frames where they happen,
the count of window violations, and a suggested retargeting ``D' = scale D + shift_px`` that brings the
shot's 1st-99th percentile range inside the comfort zone (and before the divergence limit): a shift of
convergence (horizontal image translation) when the range fits the zone, else the linear map of the
range onto the zone. The comfort zone is a limit, not a target: ``vergence convert`` maps each shot's
range onto its budget (``+-budget_arcmin``, 30 by default, half the default zone), and the suggestion's
``convert`` entry gives the ``scale`` and ``shift_px`` that conversion applies, for comparison.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from vergence.video._histogram import HISTOGRAM_STEP_PX, PERCENTILES, ShotHistogram
from vergence.video._matching import match_padded as _match
from vergence.video.cuts import CUT_THRESHOLD, MIN_SHOT_FRAMES, detect_cuts
from vergence.video.search import FEATURE_MAX_WIDTH, SATURATION_SHARE, feature_alignment, match_searched, on_bound, shot_search_ranges
from vergence.video.sources import DepthClip, StereoClip

if TYPE_CHECKING:
    from vergence.viewing import ComfortZone, Display

__all__ = [
    "HISTOGRAM_STEP_PX",
    "PERCENTILES",
    "VERTICAL_MAX_WIDTH",
    "WINDOW_BAND",
    "WINDOW_MIN_PX",
    "WINDOW_SHARE",
    "ClipAnalysis",
    "FrameStats",
    "ShotStats",
    "analyze_clip",
]

# Edge band of the stereo window, share of the width (at least 2 columns), the crossed disparity that
# counts (half a pixel: below it matching noise), and the share of the band that makes a violation.
WINDOW_BAND = 0.02
WINDOW_MIN_PX = 0.5
WINDOW_SHARE = 0.1
# Vertical disparity is measured on views reduced to at most this width (SIFT on a 1080p pair costs
# about 2 s on 2 cores, as much as the matching); the offsets are scaled back to full-resolution px.
VERTICAL_MAX_WIDTH = FEATURE_MAX_WIDTH
# Largest thumbnail side kept per shot (for the report).
_THUMBNAIL_PX = 320


def _keys(values: object) -> dict[str, float]:
    return {f"p{p}": float(v) for p, v in zip(PERCENTILES, values)}


@dataclass(frozen=True, slots=True)
class FrameStats:
    """One analysed frame. ``disparity_px`` maps ``"p1"``...``"p99"`` to pixels; shares are of its known pixels."""

    frame: int
    disparity_px: dict[str, float]
    outside_comfort: float
    diverging: float
    window_violation: bool
    vertical_px: float | None
    search_px: tuple[int, int] | None = None
    on_bound: tuple[str, ...] = ()
    saturated: bool = False

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["search_px"] = None if self.search_px is None else list(self.search_px)
        d["on_bound"] = list(self.on_bound)
        return d


@dataclass(frozen=True, slots=True)
class ShotStats:
    """One shot, ``[start, end)``; see the module docstring for each field."""

    start: int
    end: int
    disparity_px: dict[str, float]
    disparity_arcmin: dict[str, float]
    outside_comfort: float
    outside_frames: tuple[int, ...]
    diverging: float
    diverging_frames: tuple[int, ...]
    window_violations: int
    window_frames: tuple[int, ...]
    vertical_px: float | None
    suggestion: dict
    search: dict | None = None
    on_bound: tuple[str, ...] = ()

    @property
    def saturated(self) -> bool:
        """Stereo: some frame still had its matches piled at a bound of the search after the widened pass."""
        search = self.search
        return bool(search and (search["saturated_frames"] or search["features_outside"] > SATURATION_SHARE))

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["on_bound"] = list(self.on_bound)
        d["saturated"] = self.saturated
        for name in ("outside_frames", "diverging_frames", "window_frames"):
            d[name] = list(d[name])
        return d


@dataclass(frozen=True, slots=True, eq=False)
class ClipAnalysis:
    """Result of :func:`analyze_clip`; :meth:`to_dict` is the JSON of ``vergence analyze``."""

    kind: str
    frames: int
    fps: float
    width: int
    height: int
    every: int
    display: dict
    zone_arcmin: tuple[float, float]
    zone_px: tuple[float, float]
    divergence_px: float
    shots: tuple[ShotStats, ...]
    per_frame: tuple[FrameStats, ...]
    change: np.ndarray
    thumbnails: tuple[np.ndarray, ...] = field(default=(), repr=False)
    options: dict = field(default_factory=dict)

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per stereo shot whose matches still pile up at a bound of the search, or whose percentiles
        sit on one (those figures are the bound, not the content)."""
        lines = []
        for k, shot in enumerate(self.shots):
            if shot.search is None:
                continue
            lo, hi = shot.search["search_px"]
            where = f"shot {k} (frames {shot.start}-{shot.end - 1})"
            if shot.saturated:
                lines.append(f"{where}: its content reaches past the disparity search range ({lo} .. {hi} px): "
                             f"{shot.search['saturated_frames']} frames with matches piled up at a bound"
                             f"{'' if shot.search['search_source'] == 'given' else ' after widening'}, "
                             f"{100 * shot.search['features_outside']:.0f} % of its features outside; its figures "
                             "are cut there: give a wider search range")  # fmt: skip
            if shot.on_bound:
                values = ", ".join(f"{key} {shot.disparity_px[key]:+.1f}" for key in shot.on_bound)
                lines.append(f"{where}: {values} px sit on the disparity search bound ({lo} .. {hi} px): a bound, "
                             "not a measure")  # fmt: skip
        return tuple(lines)

    def to_dict(self) -> dict:
        """Plain JSON-ready dict (no thumbnails)."""
        return {
            "kind": self.kind,
            "frames": self.frames,
            "fps": self.fps,
            "width": self.width,
            "height": self.height,
            "every": self.every,
            "display": dict(self.display),
            "comfort_zone_arcmin": list(self.zone_arcmin),
            "comfort_zone_px": list(self.zone_px),
            "divergence_px": self.divergence_px,
            **self.options,
            "cut_rule": {"threshold": CUT_THRESHOLD, "min_shot_frames": MIN_SHOT_FRAMES},
            "shots": [s.to_dict() for s in self.shots],
            "per_frame": [f.to_dict() for f in self.per_frame],
            "histogram_change": [float(c) for c in self.change],
            "warnings": list(self.warnings),
        }


def _to_screen_px(d: np.ndarray | float, scale: float) -> np.ndarray | float:
    return -np.asarray(d, dtype=np.float64) * scale


def _suggest(d1: float, d99: float, lo: float, hi: float) -> dict:
    """``D' = scale D + shift`` bringing ``[d1, d99]`` inside ``[lo, hi]`` (module docstring)."""
    if lo <= d1 and d99 <= hi:
        scale, shift, action = 1.0, 0.0, "none"
    elif d99 - d1 <= hi - lo:
        scale, shift, action = 1.0, (lo - d1 if d1 < lo else hi - d99), "shift"
    else:
        scale = (hi - lo) / (d99 - d1)
        shift, action = lo - scale * d1, "shift and scale"
    return {"action": action, "scale": scale, "shift_px": shift, "range_px": [scale * d1 + shift, scale * d99 + shift]}


def _fill(d1: float, d99: float, lo: float, hi: float, *, budget_arcmin: float) -> dict:
    """What ``vergence convert`` does to a shot whose range is ``[d1, d99]``: ``D' = scale D + shift`` onto the
    budget ``[lo, hi]`` (D, px), filling it (:mod:`vergence.video.convert`, one linear psi per shot)."""
    if not d99 > d1:
        return {"budget_arcmin": budget_arcmin, "scale": None, "shift_px": None, "range_px": [lo, hi]}
    scale = (hi - lo) / (d99 - d1)
    return {"budget_arcmin": budget_arcmin, "scale": scale, "shift_px": lo - scale * d1, "range_px": [lo, hi]}


def analyze_clip(
    clip: StereoClip | DepthClip,
    display: Display,
    *,
    zone: ComfortZone | None = None,
    every: int = 1,
    min_disparity: int | None = None,
    max_disparity: int | None = None,
    method: str = "sgbm",
    budget_arcmin: float = 30.0,
    vertical: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> ClipAnalysis:
    """Analyse the comfort of ``clip`` on ``display``, per frame and per shot (module docstring).

    Parameters
    ----------
    clip : StereoClip or DepthClip
        From :func:`~vergence.video.open_stereo` or :func:`~vergence.video.open_depth_clip`.
    display : vergence.viewing.Display
        With its ``resolution``; the view fills its width.
    zone : vergence.viewing.ComfortZone, optional
        Default ``ComfortZone()`` (+-60 arcmin).
    every : int
        Analyse frames ``0, every, 2 every, ...`` (matching is the slow part); cuts are found on all frames.
    min_disparity, max_disparity : int, optional
        Stereo clips: the matcher's search range, px; a bound not given is found per shot from the
        content and widened where the matches pile up at it (:mod:`vergence.video.search`).
    method : str
        Stereo clips: a matcher of :data:`vergence.depth.MATCHERS`.
    budget_arcmin : float
        The budget of ``vergence synthesize`` and ``vergence convert`` (+-A arcmin): a 2D + depth clip's
        parallax is planned into it per shot; each shot's suggestion gives convert's mapping onto it.
    vertical : bool
        Stereo clips: measure the vertical disparity of feature matches.
    progress : callable(done, total), optional
        Called after each analysed frame.

    Returns
    -------
    ClipAnalysis

    Raises
    ------
    ValueError
        Bad options, a display without resolution, and the errors of reading the clip, matching
        (an untextured frame) or planning the parallax (a flat depth shot).
    """
    from vergence.viewing import ComfortZone, arcmin_from_pixels, check_display

    if not isinstance(clip, StereoClip | DepthClip):
        raise TypeError(f"clip must be a StereoClip or a DepthClip; got {type(clip).__name__}")
    check_display(display, resolution=True)
    zone = ComfortZone() if zone is None else zone
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    if (isinstance(budget_arcmin, bool) or not isinstance(budget_arcmin, int | float | np.number)
            or not 0 < budget_arcmin <= 600):  # fmt: skip
        raise ValueError(f"budget_arcmin must be a number in (0, 600]; got {budget_arcmin!r}")
    if isinstance(every, bool) or not isinstance(every, int | np.integer) or every < 1:
        raise ValueError(f"every must be an integer >= 1; got {every!r}")
    from vergence.depth import MATCHERS

    if not isinstance(method, str) or method not in MATCHERS:
        raise ValueError(f"method must be one of {', '.join(MATCHERS)}; got {method!r}")
    stereo = isinstance(clip, StereoClip)
    width, height = clip.width, clip.height
    if stereo:
        for name, v in (("min_disparity", min_disparity), ("max_disparity", max_disparity)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, int | np.integer)):
                raise TypeError(f"{name} must be an integer number of pixels; got {type(v).__name__}")
        if min_disparity is not None and max_disparity is not None and min_disparity >= max_disparity:
            raise ValueError(f"min_disparity must be < max_disparity; got {min_disparity} and {max_disparity}")
        options = {"matcher": method, "min_disparity": None if min_disparity is None else int(min_disparity),
                   "max_disparity": None if max_disparity is None else int(max_disparity)}  # fmt: skip
    else:
        options = {"depth_kind": clip.kind, "budget_arcmin": float(budget_arcmin)}

    scale = display.resolution / width  # display px per view px
    zone_screen = zone.pixels(display)  # (crossed < 0, uncrossed > 0) display px
    # convert's budget in D (what vergence convert maps each shot onto; its default for a stereo clip too)
    budget_screen = ComfortZone(crossed_arcmin=budget_arcmin, uncrossed_arcmin=budget_arcmin).pixels(display)
    budget_d = (-budget_screen[1] / scale, -budget_screen[0] / scale)
    divergence_screen = display.divergence_disparity * display.resolution  # S0 Eq. (8) in display px
    # The zone in D (view px): crossed limit in front (D > 0), uncrossed behind, never past divergence.
    zone_d = (-min(zone_screen[1], divergence_screen) / scale, -zone_screen[0] / scale)

    # Pass 1: cuts (all frames), and for 2D + depth the nearness range of each frame.
    nearness: list[tuple[float, float]] = []
    if stereo:
        cuts = detect_cuts(clip.lefts())
    else:
        from vergence.synthesis import nearness_from_depth

        def colour_frames():
            for image, depth in clip.pairs():
                q = nearness_from_depth(depth, kind=clip.kind)
                nearness.append((float(np.nanmin(q)), float(np.nanmax(q))))
                yield image

        cuts = detect_cuts(colour_frames())
    # The search range of each shot: from its features unless both bounds are given (vergence.video.search).
    searches = shot_search_ranges(clip, cuts.shots, min_disparity=min_disparity,
                                  max_disparity=max_disparity) if stereo else []  # fmt: skip
    shot_of = np.zeros(clip.frames, np.int64)
    for s, (a, b) in enumerate(cuts.shots):
        shot_of[a:b] = s
    mappings = []
    if not stereo:
        from vergence.synthesis import plan_parallax

        for a, b in cuts.shots:
            q_lo = min(n[0] for n in nearness[a:b])
            q_hi = max(n[1] for n in nearness[a:b])
            row = np.full((1, width), q_lo, np.float32)
            row[0, -1] = q_hi  # the shot's nearness range at the clip's width: the budget in px depends on it
            mappings.append(plan_parallax(row, kind="disparity", budget_arcmin=budget_arcmin, display=display).mapping)

    # Pass 2: the analysed frames.
    analysed = list(range(0, clip.frames, every))
    per_frame: list[FrameStats] = []
    hist = [ShotHistogram(width) for _ in cuts.shots]
    counts = np.zeros((len(cuts.shots), 3), np.int64)  # known, outside, diverging
    extremes = np.tile([np.inf, -np.inf], (len(cuts.shots), 1))
    thumbs: dict[int, np.ndarray] = {}
    bounds = [(r.lo, r.hi) for r in searches]
    saturated = [0] * len(cuts.shots)  # frames still saturated after the widened pass
    widened = [0] * len(cuts.shots)  # frames matched a second time in a widened range
    band = max(2, int(round(WINDOW_BAND * width)))
    wanted = set(analysed)
    for k, (a, b) in enumerate(clip.pairs()):
        if k not in wanted:
            continue
        s = int(shot_of[k])
        if stereo:
            searched = match_searched(a, b, searches[s], method, lo=bounds[s][0], hi=bounds[s][1])
            d, lo_d, hi_d = searched.disparity, searched.lo, searched.hi
            bounds[s] = (lo_d, hi_d)  # a widened range holds for the rest of the shot
            saturated[s] += searched.saturated
            widened[s] += searched.widened
            # The left edge band seen from the right view (a crossed point at the left edge of the left
            # view has no match: it lies left of the right view's frame).
            strip = min(width, band + 2 * (hi_d - lo_d))
            right_view = _match(np.ascontiguousarray(b[:, :strip][:, ::-1]), np.ascontiguousarray(a[:, :strip][:, ::-1]),
                                lo_d, hi_d, method)[:, ::-1]  # fmt: skip
            left_band = right_view[:, :band]
        else:
            from vergence.synthesis import plan_parallax

            d = -plan_parallax(b, kind=clip.kind, mapping=mappings[s], display=display).parallax_px.astype(np.float64)
        known = np.isfinite(d)
        values = d[known]
        if values.size == 0:
            raise ValueError(f"frame {k}: no pixel has a disparity (nothing matched)")
        screen = _to_screen_px(values, scale)
        angle = np.asarray(arcmin_from_pixels(screen, display))
        outside = (angle < zone.min_arcmin) | (angle > zone.max_arcmin)
        diverging = screen > divergence_screen
        if not stereo:
            left_band = d[:, :band]
        violation = bool(_crossed_share(left_band) >= WINDOW_SHARE or _crossed_share(d[:, -band:]) >= WINDOW_SHARE)
        dy = None
        if stereo and vertical:
            alignment = feature_alignment(a, b)  # None: too few features, or RANSAC found no model
            dy = None if alignment is None else alignment.median_abs_dy_px
        frame_pct = _keys(np.percentile(values, PERCENTILES))
        per_frame.append(FrameStats(frame=k, disparity_px=frame_pct,
                                    outside_comfort=float(outside.mean()), diverging=float(diverging.mean()),
                                    window_violation=violation, vertical_px=dy,
                                    search_px=(lo_d, hi_d) if stereo else None,
                                    on_bound=tuple(on_bound(frame_pct, lo_d, hi_d)) if stereo else (),
                                    saturated=bool(stereo and searched.saturated)))  # fmt: skip
        hist[s].add(values)
        extremes[s] = min(extremes[s, 0], values.min()), max(extremes[s, 1], values.max())
        counts[s] += (values.size, int(outside.sum()), int(diverging.sum()))
        if s not in thumbs:
            thumbs[s] = _thumbnail(a)
        if progress is not None:
            progress(len(per_frame), len(analysed))

    shots = []
    for s, (start, end) in enumerate(cuts.shots):
        frames = [f for f in per_frame if start <= f.frame < end]
        if not frames:  # a shot shorter than `every` between two analysed frames
            continue
        pct = hist[s].percentiles(*extremes[s])
        # the vergence change of the p-th percentile of D, signed as D (positive in front: rises with D)
        angles = -np.asarray(arcmin_from_pixels(_to_screen_px(pct, scale), display))
        dys = [f.vertical_px for f in frames if f.vertical_px is not None]
        suggestion = _suggest(float(pct[0]), float(pct[-1]), *zone_d)
        suggestion["target"] = "comfort zone"
        suggestion["range_arcmin"] = [-float(v) for v in arcmin_from_pixels(
            _to_screen_px(np.array(suggestion["range_px"]), scale), display)]  # fmt: skip
        suggestion["convert"] = _fill(float(pct[0]), float(pct[-1]), *budget_d, budget_arcmin=float(budget_arcmin))
        known, outside, diverging = (int(v) for v in counts[s])
        shots.append(ShotStats(
            start=start, end=end, disparity_px=_keys(pct), disparity_arcmin=_keys(angles),
            outside_comfort=outside / known, outside_frames=tuple(f.frame for f in frames if f.outside_comfort > 0),
            diverging=diverging / known, diverging_frames=tuple(f.frame for f in frames if f.diverging > 0),
            window_violations=sum(f.window_violation for f in frames),
            window_frames=tuple(f.frame for f in frames if f.window_violation),
            vertical_px=float(np.median(dys)) if dys else None, suggestion=suggestion,
            search=None if not stereo else {**searches[s].to_dict(), "search_px": list(bounds[s]),
                                            "widened_frames": widened[s], "saturated_frames": saturated[s]},
            on_bound=tuple(on_bound(_keys(pct), *bounds[s])) if stereo else (),
        ))  # fmt: skip
    return ClipAnalysis(
        kind="stereo" if stereo else "2d+depth", frames=clip.frames, fps=float(clip.fps), width=width, height=height,
        every=int(every), display=dataclasses.asdict(display), zone_arcmin=(-zone.max_arcmin, -zone.min_arcmin),
        zone_px=(float(zone_d[0]), float(zone_d[1])), divergence_px=float(-divergence_screen / scale),
        shots=tuple(shots), per_frame=tuple(per_frame), change=cuts.change,
        thumbnails=tuple(thumbs[s] for s in sorted(thumbs)), options=options,
    )  # fmt: skip


def _crossed_share(d: np.ndarray) -> float:
    """Share of an edge band's pixels with a crossed disparity above WINDOW_MIN_PX (unknown pixels count as not)."""
    with np.errstate(invalid="ignore"):
        return float((d > WINDOW_MIN_PX).mean())


def _thumbnail(view: np.ndarray) -> np.ndarray:
    import cv2

    h, w = view.shape[:2]
    k = min(1.0, _THUMBNAIL_PX / max(h, w))
    if k == 1.0:
        return np.array(view)
    return cv2.resize(view, (max(1, round(w * k)), max(1, round(h * k))), interpolation=cv2.INTER_AREA)
