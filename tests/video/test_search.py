"""The disparity search range found from the content (vergence.video.search), on synthetic clips of textured
planes at known disparities (tests/support/stereo_planes.py): the range of issue 28's clip (36-95 px at 480 px
per view, beyond the old default of +-64 px) and a second, different one (uncrossed and far crossed content)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from stereo_planes import HARD_SHOTS, OTHER_SHOTS, shot_truth, write_planes_clip

from vergence.video import open_stereo
from vergence.video.analysis import analyze_clip
from vergence.video.search import (
    SATURATION_SHARE,
    SearchRange,
    match_searched,
    on_bound,
    search_from_disparities,
    shot_search_ranges,
)
from vergence.viewing import DISPLAY_PRESETS

# Frames per shot (the fewest a shot may have: vergence.video.cuts.MIN_SHOT_FRAMES) and the rows of a view: small
# enough for a few seconds per clip on 2 cores.
FRAMES = 6
HEIGHT = 96
# Issue 28's tolerance on a shot's p50/p95: max(3 px, 5 %).
ABS_PX, REL = 3.0, 0.05


def _clip(tmp_path_factory, name, shots, width, seed):
    path = tmp_path_factory.mktemp(name) / f"{name}_LRF_Full_SBS.mp4"
    truth = write_planes_clip(path, shots, width=width, height=HEIGHT, frames_per_shot=FRAMES, seed=seed)
    return open_stereo(path), truth


@pytest.fixture(scope="module")
def hard(tmp_path_factory):
    return _clip(tmp_path_factory, "hard", HARD_SHOTS, 480, 0)


@pytest.fixture(scope="module")
def other(tmp_path_factory):
    return _clip(tmp_path_factory, "other", OTHER_SHOTS, 640, 5)


def _check_shots(result, truth):
    assert [(s.start, s.end) for s in result.shots] == [(0, FRAMES), (FRAMES, 2 * FRAMES)]
    for shot in result.shots:
        expected = shot_truth(truth, shot.start, shot.end)
        for key in ("p50", "p95"):
            tolerance = max(ABS_PX, REL * abs(expected[key]))
            assert abs(shot.disparity_px[key] - expected[key]) <= tolerance, (shot.start, key, shot.disparity_px, expected)
        assert shot.search["search_source"] == "content"
        assert not shot.saturated and shot.on_bound == ()
    assert result.warnings == ()


def test_hard_clip_found_by_default(hard):
    """Issue 28's clip: true 36-95 px at 480 px per view; the default search finds it (p50, p95 within max(3 px, 5 %))."""
    clip, truth = hard
    result = analyze_clip(clip, DISPLAY_PRESETS["tv-55"], every=2, vertical=False)
    _check_shots(result, truth)
    for shot in result.shots:  # the range holds the content: it was not the old +-64
        lo, hi = shot.search["search_px"]
        assert lo < 36 and hi > 95


def test_other_clip_found_by_default(other):
    """A second clip, other disparities and grain: uncrossed -110..-40 px, then -20..+120 px, at 640 px per view."""
    clip, truth = other
    _check_shots(analyze_clip(clip, DISPLAY_PRESETS["tv-55"], every=2, vertical=False), truth)


def test_given_range_too_narrow_is_flagged(hard):
    """The old default (+-64) given by hand: kept, but the shots are flagged saturated and their top percentiles on the bound."""
    clip, _ = hard
    result = analyze_clip(clip, DISPLAY_PRESETS["tv-55"], every=3, vertical=False, min_disparity=-64, max_disparity=64)
    for shot in result.shots:
        assert shot.search["search_source"] == "given" and shot.search["search_px"] == [-64, 64]
        assert shot.saturated and "p99" in shot.on_bound
    assert len(result.warnings) == 2 * len(result.shots)
    assert all("disparity search" in line for line in result.warnings)
    data = result.to_dict()
    assert data["warnings"] == list(result.warnings) and data["shots"][0]["saturated"] is True


def test_estimated_bound_widened_once(hard):
    """A frame matched in an estimated range short of its content is matched again with that bound moved out."""
    clip, truth = hard
    left, right = next(iter(clip.pairs(0, 1)))
    frame = match_searched(left, right, SearchRange(-64, 64, "content"), "sgbm")
    assert frame.widened and (frame.lo, frame.hi) == (-64, 64 + 128)
    assert not frame.saturated
    known = np.isfinite(frame.disparity) & np.isfinite(truth[0])
    assert_allclose(np.median(frame.disparity[known]), np.median(truth[0][known]), atol=ABS_PX)
    fixed = match_searched(left, right, SearchRange(-64, 64, "given", fixed=(True, True)), "sgbm")
    assert not fixed.widened and fixed.at_bounds[1] > SATURATION_SHARE


def test_ranges_from_features(hard):
    clip, _ = hard
    found = shot_search_ranges(clip, [(0, FRAMES), (FRAMES, 2 * FRAMES)])
    for r, shot in zip(found, HARD_SHOTS):
        low, high = min(shot.top_px, shot.bottom_px, shot.front_px), max(shot.top_px, shot.bottom_px, shot.front_px)
        assert r.source == "content" and r.features >= 8
        assert low - 40 <= r.lo < low and high < r.hi <= high + 40
    mixed = shot_search_ranges(clip, [(0, FRAMES)], min_disparity=-5)
    assert mixed[0].lo == -5 and mixed[0].fixed == (True, False) and mixed[0].hi > 95
    given = shot_search_ranges(clip, [(0, FRAMES)], min_disparity=-5, max_disparity=7)
    assert (given[0].lo, given[0].hi, given[0].source) == (-5, 7, "given")


def test_search_from_disparities_by_hand():
    # p1..p99 of 0..100 is 1..99; margin max(16, 0.25 * 98 = 24.5)
    assert search_from_disparities(np.linspace(0.0, 100.0, 10001), 1000) == (-24, 124)
    # a narrow spread takes the 16 px minimum; the range stays inside +-width/2
    assert search_from_disparities(np.full(50, 10.0), 1000) == (-6, 26)
    assert search_from_disparities(np.linspace(-300.0, 300.0, 1001), 400) == (-200, 200)
    with pytest.raises(ValueError, match="no finite"):
        search_from_disparities(np.array([np.nan]), 100)


def test_on_bound():
    assert on_bound({"p1": -63.0, "p50": 0.0, "p99": 62.9}, -64, 64) == ["p1"]
    assert on_bound({"p1": -62.9, "p99": 64.0}, -64, 64) == ["p99"]


def test_given_range_missing_far_content_is_flagged(other):
    """Content wholly beyond a given bound is mostly left unmatched, not piled up at it: its features still say so."""
    clip, _ = other
    result = analyze_clip(clip, DISPLAY_PRESETS["tv-55"], every=3, vertical=False, min_disparity=-64, max_disparity=64)
    first = result.shots[0]  # true -110..-40 px
    assert first.search["features_outside"] > 0.2 and first.saturated
    assert any(line.startswith("shot 0 ") and "outside" in line for line in result.warnings)


def test_match_warns_when_the_matches_pile_up_at_a_bound():
    """vergence match (compute_disparity): a textured plane at 40 px searched up to 24 px piles up at the bound and
    is warned about; searched up to 64 px it is not (issue 28: every command that matches)."""
    from vergence.depth import compute_disparity
    from vergence.depth.matching import bound_shares

    rng = np.random.default_rng(3)
    import cv2

    texture = np.clip(cv2.resize(rng.random((40, 90)).astype(np.float32), (360, 160), interpolation=cv2.INTER_CUBIC),
                      0.0, 1.0)
    left, right = texture[:, :-40], texture[:, 40:]  # left x is right x - 40: D = 40 everywhere
    short = compute_disparity(left, right, max_disparity=24, keep_invalid=True)
    assert any("upper bound (24 px)" in w for w in short.warnings), short.warnings
    wide = compute_disparity(left, right, max_disparity=64, keep_invalid=True)
    assert not any("bound" in w for w in wide.warnings), wide.warnings
    assert bound_shares(wide.disparity, 0, 64) == (0.0, 0.0)
