"""What a conversion delivered, measured on its output: the disparity of a few re-matched frames per shot.

:func:`vergence.video.convert_clip` plans each shot's parallax range; this module checks it on the file the
user receives. For each shot, :data:`OUTPUT_SAMPLES` frames (first, middle, last) of the output are
matched again (the library's matcher, in the planned range with a margin, widened where the matches pile
up at a bound: :func:`vergence.video.search.match_searched`), giving

- the output's disparity percentiles ``D' = x_left - x_right`` (pooled over the samples), and its
  parallax range ``P = -D'`` (positive behind the screen, as :attr:`ShotConversion.range_px`);
- the flicker the viewer sees: the frame-to-frame change of ``D'`` on static content
  (:class:`~vergence.video.FlickerMeter`), re-matched on :data:`FLICKER_PAIRS` consecutive pairs from the
  middle frame on. It holds the matching noise of the re-match too, so it is an upper bound of the
  output's own flicker, and the figure to set beside the filtered map's (``Conversion.flicker_after``);
- the rank correlation (Spearman's rho) of ``D'`` with the source's own depth cue at the same pixels:
  the source's disparity, matched again in the shot's search range (stereo), or its nearness (2D + depth).
  A retargeting keeps the depth order when rho is near 1; below :data:`DEPTH_ORDER_MIN` the order is
  not kept (a warning).

Only an output that splits into two full views of the source's size is measured (``sbs``, ``tb``); the
others (half-width, anaglyph, interleaved) come back as None.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, replace

import numpy as np

from vergence.video._histogram import PERCENTILES, ShotHistogram
from vergence.video.search import SEARCH_MARGIN_MIN_PX, SearchRange, match_searched, on_bound
from vergence.video.stability import STATIC_THRESHOLD

__all__ = ["DEPTH_ORDER_MIN", "FLICKER_PAIRS", "OUTPUT_SAMPLES", "RANK_PIXELS", "OutputCheck", "measure_output", "measure_shot_output"]

# Frames of each shot matched again on the output (first, middle, last).
OUTPUT_SAMPLES = 3
# Consecutive frame pairs of each shot re-matched for the output's flicker (from the middle frame on).
FLICKER_PAIRS = 2
# Spearman's rho below this: the output does not keep the source's depth order (issue 28 asks r >= 0.8).
DEPTH_ORDER_MIN = 0.8
# Pixels ranked per frame (a regular subsample of those known in both; ranks of 10^5 values cost ~20 ms).
RANK_PIXELS = 50_000


@dataclass(frozen=True, slots=True)
class OutputCheck:
    """One shot of the output, measured (module docstring). ``disparity_px`` holds the pooled percentiles of
    ``D'``; ``range_px`` the parallax ``(-p99, -p1)``; ``on_bound`` the percentiles on the re-match's search bound."""

    frames: tuple[int, ...]
    disparity_px: dict[str, float]
    range_px: tuple[float, float]
    rank_correlation: float
    search_px: tuple[int, int]
    on_bound: tuple[str, ...]
    flicker_px: float = math.nan  # mean |change| of D' on static pixels, px (module docstring)
    flicker_pairs: int = 0
    static_share: float = 0.0

    @property
    def order_kept(self) -> bool:
        return self.rank_correlation >= DEPTH_ORDER_MIN

    def to_dict(self) -> dict:
        """JSON-ready, in the disparity's sign only (``docs/conventions.md``): ``range_px``, the parallax, is left out."""
        d = dataclasses.asdict(self)
        del d["range_px"]
        d.update(frames=list(self.frames), search_px=list(self.search_px), on_bound=list(self.on_bound),
                 order_kept=self.order_kept,
                 flicker_px=None if not math.isfinite(self.flicker_px) else self.flicker_px)  # fmt: skip
        return d


def _samples(start: int, end: int) -> list[int]:
    return sorted({start, (start + end - 1) // 2, end - 1})[:OUTPUT_SAMPLES]


def _rank_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    known = np.isfinite(a) & np.isfinite(b)
    x, y = a[known], b[known]
    step = max(1, x.size // RANK_PIXELS)
    return x[::step], y[::step]


def measure_shot_output(output, source, start: int, end: int, planned_px: tuple[float, float], *, method: str,
                        source_search: SearchRange | None, depth_kind: str | None = None,
                        threshold: float = STATIC_THRESHOLD) -> OutputCheck | None:  # fmt: skip
    """Measure frames ``[start, end)`` of the converted ``output`` (a :class:`~vergence.video.StereoClip` of the
    output file) against ``source`` (the clip converted); ``planned_px`` the parallax range the shot was mapped
    to. ``source_search``: a stereo source's search range for that shot (None for 2D + depth, whose nearness
    comes from ``depth_kind``). ``threshold``: the static-content threshold of the flicker
    (:data:`~vergence.video.STATIC_THRESHOLD`). None when the shot has no pixel known in both."""
    from scipy.stats import spearmanr

    from vergence.video.stability import FlickerMeter, grey_levels

    lo = int(math.floor(-planned_px[1])) - SEARCH_MARGIN_MIN_PX
    hi = int(math.ceil(-planned_px[0])) + SEARCH_MARGIN_MIN_PX
    planned = SearchRange(lo, hi, "planned")
    histogram = ShotHistogram(output.width)
    outs, cues = [], []
    frames = _samples(start, end)
    middle = (start + end - 1) // 2
    steady = list(range(middle, min(end, middle + FLICKER_PAIRS + 1)))  # consecutive frames for the flicker
    meter = FlickerMeter(threshold)
    search_lo, search_hi = lo, hi
    for k in sorted(set(frames) | set(steady)):
        left, right = next(iter(output.pairs(k, k + 1)))
        found = match_searched(left, right, planned, method)
        search_lo, search_hi = min(search_lo, found.lo), max(search_hi, found.hi)
        d_out = found.disparity
        if k in steady:
            meter.add(grey_levels(left), d_out.astype(np.float32))
        if k not in frames:
            continue
        if source_search is not None:
            a, b = next(iter(source.pairs(k, k + 1)))
            cue = match_searched(a, b, source_search, method).disparity
        else:
            from vergence.synthesis import nearness_from_depth

            _, depth = next(iter(source.pairs(k, k + 1)))
            cue = np.asarray(nearness_from_depth(depth, kind=depth_kind), dtype=np.float64)
        histogram.add(d_out[np.isfinite(d_out)])
        x, y = _rank_pairs(d_out, cue)
        outs.append(x)
        cues.append(y)
    x, y = np.concatenate(outs), np.concatenate(cues)
    if x.size < 2 or not histogram.counts.any():
        return None
    pct = {f"p{p}": float(v) for p, v in zip(PERCENTILES, histogram.pooled())}
    rho = float(spearmanr(x, y).statistic) if np.ptp(x) > 0 and np.ptp(y) > 0 else math.nan
    flicker = meter.result()
    return OutputCheck(frames=tuple(frames), disparity_px=pct, range_px=(-pct["p99"], -pct["p1"]),
                       rank_correlation=rho, search_px=(search_lo, search_hi),
                       on_bound=tuple(on_bound(pct, search_lo, search_hi)), flicker_px=flicker.mean_px,
                       flicker_pairs=flicker.pairs, static_share=flicker.static_share)  # fmt: skip


def measure_output(conversions: tuple, clip, out, layout: str, method: str, searches: list,
                   threshold: float = STATIC_THRESHOLD) -> tuple:  # fmt: skip
    """Each shot converted in this run, measured on the output (:mod:`vergence.video.measured`); an output that
    does not split into two views of the source's size is left unmeasured."""
    from vergence.video.layout import STEREO_LAYOUTS
    from vergence.video.sources import StereoClip, open_stereo

    if layout not in STEREO_LAYOUTS or STEREO_LAYOUTS[layout][1]:  # half-width views, anaglyphs: not measured
        return conversions
    output = open_stereo(out, layout=layout, fps=clip.fps)
    if (output.width, output.height) != (clip.width, clip.height):
        return conversions
    stereo = isinstance(clip, StereoClip)
    measured = []
    for s, shot in enumerate(conversions):
        if shot.reused or shot.mapping is None:
            measured.append(shot)
            continue
        check = measure_shot_output(output, clip, shot.start, shot.end, shot.range_px, method=method,
                                    source_search=searches[s] if stereo else None,
                                    depth_kind=None if stereo else clip.kind, threshold=threshold)  # fmt: skip
        measured.append(replace(shot, output=check))
    return tuple(measured)
