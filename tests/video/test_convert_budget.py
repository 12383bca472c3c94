"""vergence convert uses the budget it is given: each shot's pooled 1st-99th percentile disparity range is mapped
onto +-budget, so the output, matched again, spans most of the budget, stays inside it and keeps the depth order
(synthetic plane clip of issue 28: true 36-95 px at 480 px per view, tests/support/stereo_planes.py)."""

from __future__ import annotations

import numpy as np
import pytest
from stereo_planes import HARD_SHOTS, write_planes_clip

from vergence.video import open_stereo
from vergence.video.analysis import analyze_clip
from vergence.video.convert import convert_clip
from vergence.viewing import DISPLAY_PRESETS, pixels_from_arcmin

FRAMES, HEIGHT, WIDTH = 6, 96, 480
BUDGET_ARCMIN = 30.0
# Issue 28: the output spans at least this share of the budget...
SPAN_SHARE = 0.7
# ...and stays inside it up to matching noise of the output (px of the views, about a 16th of the budget here).
INSIDE_PX = 0.75
# The 1st percentile of the output may pass the budget by this (px): the left edge band (test below).
EDGE_PX = 4.0


@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("budget")
    source = folder / "planes_LRF_Full_SBS.mp4"
    truth = write_planes_clip(source, HARD_SHOTS, width=WIDTH, height=HEIGHT, frames_per_shot=FRAMES)
    display = DISPLAY_PRESETS["tv-55"]
    result = convert_clip(open_stereo(source), folder / "out_LRF_Full_SBS.mp4", display, budget_arcmin=BUDGET_ARCMIN)
    measured = analyze_clip(open_stereo(result.out), display, every=2, vertical=False)
    return result, measured, truth, display


def test_output_spans_the_budget_and_stays_inside(converted):
    result, measured, _, display = converted
    # the budget in D = x_left - x_right of the views: screen parallax -D N / W at -+30 arcmin (behind: positive)
    view_px = WIDTH / display.resolution
    budget_lo = -float(pixels_from_arcmin(BUDGET_ARCMIN, display)) * view_px
    budget_hi = -float(pixels_from_arcmin(-BUDGET_ARCMIN, display)) * view_px
    assert budget_lo < -5 and budget_hi > 5
    assert [(s.start, s.end) for s in measured.shots] == [(s.start, s.end) for s in result.shots]
    for shot in measured.shots:
        d = shot.disparity_px
        assert budget_lo - INSIDE_PX <= d["p5"] and d["p95"] <= budget_hi + INSIDE_PX, (d, budget_lo, budget_hi)
        # Not yet p1: the band at the left edge that the source's right view does not see (x < D, 36-95 px here)
        # has no source disparity; re-matched on the output it reads up to 3 px past the budget (1-2 % of pixels).
        assert budget_lo - EDGE_PX <= d["p1"] and d["p99"] <= budget_hi + INSIDE_PX, (d, budget_lo, budget_hi)
        assert (d["p99"] - d["p1"]) >= SPAN_SHARE * (budget_hi - budget_lo), (d, budget_lo, budget_hi)
        assert (d["p95"] - d["p5"]) >= SPAN_SHARE * (budget_hi - budget_lo), (d, budget_lo, budget_hi)
        assert not shot.saturated and shot.on_bound == ()


def test_shot_range_is_pooled(converted):
    """The range mapped is the pooled p1..p99 of the shot's pixels (not stray extremes): close to the truth's."""
    result, _, truth, _ = converted
    for shot in result.shots:
        values = truth[shot.start:shot.end][np.isfinite(truth[shot.start:shot.end])]
        p1, p99 = np.percentile(values, [1, 99])
        assert abs(shot.range_in[0] - p1) <= 3.0 and abs(shot.range_in[1] - p99) <= 3.0, (shot.range_in, p1, p99)
        assert shot.search["search_source"] == "content" and not shot.saturated


def test_output_keeps_the_depth_order(converted):
    """Rank correlation of the output's re-matched disparity with the truth, per shot, at least 0.8 (issue 28)."""
    result, measured, truth, _ = converted
    from scipy.stats import spearmanr

    from vergence.video._matching import match_padded

    out = open_stereo(result.out)
    for shot in measured.shots:
        k = shot.start + 1
        left, right = next(iter(out.pairs(k, k + 1)))
        lo, hi = shot.search["search_px"]
        d = match_padded(left, right, lo, hi, "sgbm")
        known = np.isfinite(d) & np.isfinite(truth[k])
        assert known.mean() > 0.5
        assert spearmanr(d[known], truth[k][known]).statistic >= 0.8


def test_conversion_measures_its_output(converted):
    """convert re-matches frames of its own output per shot: the range it reports is the re-match's, the rank
    correlation with the source's disparity is high here, and the figures travel in the JSON."""
    result, measured, _, _ = converted
    data = result.to_dict()
    for k, (shot, again) in enumerate(zip(result.shots, measured.shots)):
        out = shot.output
        assert out is not None and out.frames == (shot.start, (shot.start + shot.end - 1) // 2, shot.end - 1)
        assert out.rank_correlation >= 0.8 and out.order_kept
        # the output's parallax 95 % range against an independent re-match (analyze, on every other frame)
        assert abs(out.disparity_px["p95"] - again.disparity_px["p95"]) <= 0.5
        assert abs(out.disparity_px["p5"] - again.disparity_px["p5"]) <= 1.5
        assert data["shots"][k]["output"]["rank_correlation"] == out.rank_correlation
    # a measured range past the planned one (the left edge band, above) is said, once per such shot, and only then
    past = [k for k, shot in enumerate(result.shots) if shot.output.range_px[0] < shot.range_px[0] - 1.0
            or shot.output.range_px[1] > shot.range_px[1] + 1.0]
    said = [line for line in result.warnings if "past the planned" in line]
    assert len(said) == len(past) and all(line.startswith(f"shot {k} ") for k, line in zip(past, said))
    assert len(result.warnings) == len(said)
