"""Comfort analysis of the rendered clips against their truth (disparity and depth of every frame)."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.video import (
    HISTOGRAM_STEP_PX,
    PERCENTILES,
    WINDOW_BAND,
    WINDOW_MIN_PX,
    WINDOW_SHARE,
    analyze_clip,
    open_depth_clip,
    open_stereo,
)
from vergence.video._histogram import ShotHistogram
from vergence.video.analysis import _suggest
from vergence.viewing import ComfortZone, Display, arcmin_from_pixels, pixels_from_arcmin

TV = Display.preset("tv-55")
# SGBM on the 160x90 H.264 clip (crf 12) against the rendered truth: measured worst 0.53 px (the
# median of the stadium, on the receding grass); percentiles of a whole shot, so a few bad matches
# barely move them.
STEREO_TOL_PX = 0.75
# Shares of the pixels outside the comfort zone / past divergence: measured within 0.03 of the truth.
SHARE_TOL = 0.06
# 2D + depth: 8-bit inverse depth through H.264, then the per-shot linear budget mapping (about 3.4 px
# per 255 levels here): measured within 0.05 px of the mapping applied to the true depth.
DEPTH_TOL_PX = 0.15
# Vertical disparity of a rectified rendered pair: SIFT keypoints are localised to about 0.2 px.
VERTICAL_TOL_PX = 0.5


def _window_frames(disparity, start, end):
    """Truth of the window rule: crossed disparity on WINDOW_SHARE of an edge band of WINDOW_BAND."""
    band = max(2, int(round(WINDOW_BAND * disparity.shape[2])))
    frames = []
    for k in range(start, end):
        d = disparity[k]
        # the left band of the right view: where the left view's edge pixels land, x_r = x_l - D
        left = np.nanmean(d[:, :band] > WINDOW_MIN_PX)  # the truth has no occlusion gap at the edges
        right = np.nanmean(d[:, -band:] > WINDOW_MIN_PX)
        if left >= WINDOW_SHARE or right >= WINDOW_SHARE:
            frames.append(k)
    return tuple(frames)


@pytest.fixture(scope="module")
def stereo_analysis(clips):
    return analyze_clip(open_stereo(clips.stereo), TV)


def test_stereo_percentiles_match_the_rendered_truth(stereo_analysis, clips, truth):
    assert [(s.start, s.end) for s in stereo_analysis.shots] == [(0, clips.cuts[0]), (clips.cuts[0], clips.frames)]
    for shot in stereo_analysis.shots:
        expected = np.nanpercentile(truth["disparity"][shot.start:shot.end], PERCENTILES)
        got = np.array([shot.disparity_px[f"p{p}"] for p in PERCENTILES])
        np.testing.assert_allclose(got, expected, atol=STEREO_TOL_PX)
    # the tabletop spans the screen plane, the stadium lies behind it
    table, stadium = stereo_analysis.shots
    assert table.disparity_px["p1"] < 0 < table.disparity_px["p99"]
    assert stadium.disparity_px["p50"] < -5


def test_arcmin_are_the_angles_of_the_pixel_percentiles(stereo_analysis):
    scale = TV.resolution / stereo_analysis.width  # the 160-px view fills the 1920-px screen
    for shot in stereo_analysis.shots:
        for key, px in shot.disparity_px.items():
            # D in front of the screen (> 0) is a crossed parallax, a negative vergence change; reported with D's sign
            assert shot.disparity_arcmin[key] == pytest.approx(-arcmin_from_pixels(-px * scale, TV), abs=1e-9)
        # one sign for both units: each pN key holds the N-th percentile, rising with N
        for values in (shot.disparity_px, shot.disparity_arcmin):
            assert list(values.values()) == sorted(values.values())
        assert np.sign(shot.disparity_arcmin["p99"]) == np.sign(shot.disparity_px["p99"])
    # by hand: 1 view px = 12 screen px of 1.2176 m / 1920 at 3 m, about 8.7 arcmin
    one = arcmin_from_pixels(-12.0, TV)
    assert one == pytest.approx(-2 * np.degrees(np.arctan(12 * 1.2176 / 1920 / 2 / 3.0)) * 60, rel=0.01)


def test_comfort_divergence_and_window_against_the_truth(stereo_analysis, truth):
    scale = TV.resolution / stereo_analysis.width
    zone = ComfortZone()
    for shot in stereo_analysis.shots:
        d = truth["disparity"][shot.start:shot.end]
        d = d[np.isfinite(d)]
        angle = arcmin_from_pixels(-d * scale, TV)
        outside = np.mean((angle < zone.min_arcmin) | (angle > zone.max_arcmin))
        diverging = np.mean(-d * scale > TV.divergence_disparity * TV.resolution)
        assert shot.outside_comfort == pytest.approx(outside, abs=SHARE_TOL)
        assert shot.diverging == pytest.approx(diverging, abs=SHARE_TOL)
        assert shot.window_frames == _window_frames(truth["disparity"], shot.start, shot.end)
        assert shot.vertical_px is not None and 0 <= shot.vertical_px < VERTICAL_TOL_PX
    table, stadium = stereo_analysis.shots
    assert table.outside_comfort < 0.001 and table.window_violations == table.end - table.start  # a few stray matches
    assert stadium.outside_comfort > 0.3 and stadium.window_violations == 0
    assert stadium.outside_frames == tuple(range(stadium.start, stadium.end))


def test_the_suggestion_brings_each_shot_inside_the_zone(stereo_analysis):
    lo, hi = stereo_analysis.zone_px
    scale = TV.resolution / stereo_analysis.width
    for shot in stereo_analysis.shots:
        s = shot.suggestion
        a, b = (s["scale"] * shot.disparity_px[k] + s["shift_px"] for k in ("p1", "p99"))
        assert s["range_px"] == pytest.approx([a, b])
        assert lo - 1e-9 <= a and b <= hi + 1e-9
        assert -60 - 1e-9 <= s["range_arcmin"][0] <= s["range_arcmin"][1] <= 60 + 1e-9
        # what vergence convert would do: the range onto its +-30 arcmin budget, filled
        c = s["convert"]
        assert c["budget_arcmin"] == 30.0
        a, b = (c["scale"] * shot.disparity_px[k] + c["shift_px"] for k in ("p1", "p99"))
        assert [a, b] == pytest.approx(c["range_px"])
        assert a == pytest.approx(-pixels_from_arcmin(30.0, TV) / scale, rel=1e-6)  # behind: uncrossed +30
        assert b == pytest.approx(-pixels_from_arcmin(-30.0, TV) / scale, rel=1e-6)  # in front: crossed -30
    table, stadium = stereo_analysis.shots
    assert table.suggestion["action"] == "none" and table.suggestion["scale"] == 1.0
    # the stadium fits the zone once pushed forward: a convergence shift, its far end on the zone's
    assert stadium.suggestion["action"] == "shift" and stadium.suggestion["shift_px"] > 0
    assert stadium.suggestion["range_px"][0] == pytest.approx(lo)


def test_suggest_by_hand():
    assert _suggest(-1.0, 2.0, -5.0, 5.0) == {"action": "none", "scale": 1.0, "shift_px": 0.0, "range_px": [-1.0, 2.0]}
    assert _suggest(-8.0, 0.0, -5.0, 5.0)["shift_px"] == 3.0
    assert _suggest(2.0, 7.0, -5.0, 5.0)["shift_px"] == -2.0
    s = _suggest(-10.0, 10.0, -5.0, 5.0)
    assert (s["action"], s["scale"], s["shift_px"], s["range_px"]) == ("shift and scale", 0.5, 0.0, [-5.0, 5.0])


def test_a_narrow_zone_asks_for_a_scale(clips):
    zone = ComfortZone(crossed_arcmin=20.0, uncrossed_arcmin=20.0)
    result = analyze_clip(open_stereo(clips.stereo), TV, zone=zone, every=6, vertical=False)
    assert [f.frame for f in result.per_frame] == [0, 6, 12, 18] and result.every == 6
    table = result.shots[0]
    assert table.suggestion["action"] == "shift and scale" and table.suggestion["scale"] < 1
    assert table.suggestion["range_px"] == pytest.approx(list(result.zone_px))
    assert table.vertical_px is None


def test_rgbd_disparity_is_the_per_shot_budget_mapping_of_the_true_depth(clips, truth):
    budget = 30.0
    result = analyze_clip(open_depth_clip(clips.rgbd), TV, budget_arcmin=budget)
    per_px = TV.resolution / clips.width
    b = min(pixels_from_arcmin(budget, TV), -pixels_from_arcmin(-budget, TV)) / per_px  # synthesize's budget in px
    for shot in result.shots:
        q = 1.0 / truth["depth"][shot.start:shot.end].astype(np.float64)
        # vergence synthesize: input parallax -q mapped linearly onto [-b, b]; D = -P
        p = -q
        parallax = -b + 2 * b * (p - p.min()) / (p.max() - p.min())
        expected = np.percentile(-parallax, PERCENTILES)
        got = np.array([shot.disparity_px[f"p{k}"] for k in PERCENTILES])
        np.testing.assert_allclose(got, expected, atol=DEPTH_TOL_PX)
        assert shot.outside_comfort == 0 and -budget - 0.01 <= min(shot.disparity_arcmin.values())
        assert max(shot.disparity_arcmin.values()) <= budget + 0.01
        assert shot.vertical_px is None


def test_a_single_stereo_image_is_a_clip_of_one_frame(clips, tmp_path, truth):
    from vergence.io import write_image

    frame = next(open_stereo(clips.stereo).reader.frames())
    image = tmp_path / "pair_LRF_Full_SBS.png"
    write_image(image, frame)
    result = analyze_clip(open_stereo(image), TV)
    assert result.frames == 1 and [(s.start, s.end) for s in result.shots] == [(0, 1)]
    expected = np.nanpercentile(truth["disparity"][0], 50)
    assert result.shots[0].disparity_px["p50"] == pytest.approx(expected, abs=STEREO_TOL_PX)


def test_shot_histogram_percentiles_against_numpy():
    rng = np.random.default_rng(3)
    values = np.concatenate([rng.normal(-3.0, 2.0, 5000), rng.normal(4.0, 0.5, 3000)])
    hist = ShotHistogram(64)
    hist.add(values[:4000])
    hist.add(values[4000:])
    got = hist.percentiles(values.min(), values.max())
    np.testing.assert_allclose(got, np.percentile(values, PERCENTILES), atol=HISTOGRAM_STEP_PX)
    # pieces merged (convert pools a shot's pieces): the same percentiles, within the exact extremes
    first, second = ShotHistogram(64), ShotHistogram(64)
    first.add(values[:3000])
    second.add(values[3000:])
    first.merge(second)
    np.testing.assert_allclose(first.pooled(), np.percentile(values, PERCENTILES), atol=HISTOGRAM_STEP_PX)
    assert (first.lo, first.hi) == (values.min(), values.max())
    assert np.isnan(ShotHistogram(64).pooled()).all()


def test_analysis_refusals(clips):
    clip = open_stereo(clips.stereo)
    with pytest.raises(ValueError, match="every must be an integer >= 1; got 0"):
        analyze_clip(clip, TV, every=0)
    with pytest.raises(ValueError, match="display resolution is unknown"):
        analyze_clip(clip, Display(0.065, 3.0, 1.2))
    with pytest.raises(TypeError, match="clip must be a StereoClip or a DepthClip; got str"):
        analyze_clip("clip.mp4", TV)
    with pytest.raises(ValueError, match="min_disparity must be < max_disparity; got 4 and 4"):
        analyze_clip(clip, TV, min_disparity=4, max_disparity=4)


def test_vertical_disparity_on_reduced_views_is_scaled_back(clips, monkeypatch):
    # a real vertical offset: the right view moved down by 2 px; measured on views halved in width
    # (VERTICAL_MAX_WIDTH = 80 for the 160-px clip) and scaled back to full-resolution pixels
    import vergence.video.analysis as analysis
    from vergence.video import StereoClip

    clip = open_stereo(clips.stereo)

    class Shifted(StereoClip):
        def pairs(self, start=0, stop=None):
            for left, right in StereoClip.pairs(self, start, stop):
                yield left, np.concatenate([right[:1].repeat(2, axis=0), right[:-2]], axis=0)

    shifted = Shifted(clip.reader, clip.layout)
    full = analyze_clip(shifted, TV, every=12)
    monkeypatch.setattr(analysis, "VERTICAL_MAX_WIDTH", 80)
    reduced = analyze_clip(shifted, TV, every=12)
    for a, b in zip(full.shots, reduced.shots):
        assert a.vertical_px == pytest.approx(2.0, abs=VERTICAL_TOL_PX)
        assert b.vertical_px == pytest.approx(2.0, abs=VERTICAL_TOL_PX)


@pytest.mark.parametrize("layout", ["half-sbs", "tb"])
def test_other_layouts_measure_disparity_in_full_resolution_pixels(clips, truth, tmp_path, layout):
    # The first shot repacked: half side by side squeezes each view to half its width (the disparity
    # halves in the file, and is doubled back by the stretch); top-bottom keeps it.
    import cv2

    from vergence.video import VideoWriter, layout_video_name

    n = clips.cuts[0]
    path = tmp_path / layout_video_name("repacked", layout)
    w, h = clips.width, clips.height
    size = (w, h) if layout == "half-sbs" else (w, 2 * h)
    with VideoWriter(path, fps=24, width=size[0], height=size[1], crf=12) as video:
        for left, right in open_stereo(clips.stereo).pairs(0, n):
            if layout == "half-sbs":
                left, right = (cv2.resize(v, (w // 2, h), interpolation=cv2.INTER_AREA) for v in (left, right))
                video.write(np.clip(np.concatenate([left, right], axis=1), 0, 1))
            else:
                video.write(np.concatenate([left, right], axis=0))
    clip = open_stereo(path)
    assert clip.layout == layout and (clip.width, clip.height) == (w, h)
    result = analyze_clip(clip, TV, every=4, vertical=False)
    expected = np.nanpercentile(truth["disparity"][:n], 50)
    # half width: one file pixel is two view pixels, so twice the full-resolution tolerance
    tol = 2 * STEREO_TOL_PX if layout == "half-sbs" else STEREO_TOL_PX
    assert result.shots[0].disparity_px["p50"] == pytest.approx(expected, abs=tol)
