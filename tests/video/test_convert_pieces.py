"""Long shots split into pieces with a warm-up (vergence.video._shots): same frames as the unsplit shot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vergence.video import convert_clip, open_depth_clip, open_stereo
from vergence.video._shots import SPLIT_TOLERANCE, split_shots, warmup_frames
from vergence.video.stability import stabilize_disparity
from vergence.viewing import Display

DISPLAY = Display.preset("tv-55")


def _frames(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _open(clips, kind):
    return open_depth_clip(clips.rgbd) if kind == "2d+depth" else open_stereo(clips.stereo)


def test_split_shots_cover_each_shot_once_in_near_equal_pieces():
    for shots, limit in (([(0, 1)], 1), ([(0, 7), (7, 100)], 10), ([(0, 240), (240, 481)], 240), ([(3, 9)], 0)):
        pieces = split_shots(shots, limit, 25)
        for s, (a, b) in enumerate(shots):
            mine = [(p, q, w) for s2, p, q, w in pieces if s2 == s]
            assert mine[0][0] == a and mine[-1][1] == b and all(x[1] == y[0] for x, y in zip(mine, mine[1:]))
            lengths = [q - p for p, q, _ in mine]
            assert limit == 0 and len(mine) == 1 or max(lengths) <= limit and max(lengths) - min(lengths) <= 1
            assert [w for *_, w in mine] == [0] + [min(25, p - a) for p, _, _ in mine[1:]]


def test_warmup_bounds_what_is_left_of_the_state_before_it():
    for alpha in (0.05, 0.25, 0.5, 0.9):
        k = warmup_frames(alpha)
        assert (1 - alpha) ** k <= SPLIT_TOLERANCE < (1 - alpha) ** (k - 1)
    # the filter itself: two states 10 px apart, K static frames of noise later, differ by at most 1e-3 of that
    rng = np.random.default_rng(0)
    frame = rng.random((8, 8, 3)).astype(np.float32)
    a = np.zeros((8, 8), np.float32)
    b = a + 10.0
    for _ in range(warmup_frames(0.25)):
        d = rng.normal(0, 1, (8, 8)).astype(np.float32)
        a, b = stabilize_disparity(frame, frame, a, d), stabilize_disparity(frame, frame, b, d)
    assert np.abs(a - b).max() <= 10.0 * SPLIT_TOLERANCE


@pytest.mark.parametrize("kind", ["2d+depth", "stereo"])
def test_pieces_whose_warmup_reaches_the_shot_start_give_the_unsplit_bytes(clips, tmp_path, kind):
    # 12-frame shots in pieces of 5: each warm-up reaches back to the shot's first frame, so the filter's
    # state is the unsplit one exactly, and so are the frames and the flicker measured.
    whole = convert_clip(_open(clips, kind), tmp_path / "whole", DISPLAY, split_frames=0)
    split = convert_clip(_open(clips, kind), tmp_path / "split", DISPLAY, split_frames=5)
    assert _frames(whole.out) == _frames(split.out)
    assert split.flicker_after.pairs == whole.flicker_after.pairs == clips.frames - 2
    assert split.flicker_after.mean_px == pytest.approx(whole.flicker_after.mean_px, rel=1e-9)
    assert split.flicker_before.mean_px == pytest.approx(whole.flicker_before.mean_px, rel=1e-9)


def test_a_short_warmup_stays_within_its_tolerance(clips, tmp_path):
    # alpha 0.75: a warm-up of 5 frames; pieces of 4 frames start 8 frames into a shot, past its reach.
    alpha = 0.75
    assert warmup_frames(alpha) == 5
    whole = convert_clip(_open(clips, "2d+depth"), tmp_path / "whole", DISPLAY, split_frames=0, alpha=alpha)
    split = convert_clip(_open(clips, "2d+depth"), tmp_path / "split", DISPLAY, split_frames=4, alpha=alpha)
    from vergence.io import read_image

    worst = max(float(np.abs(read_image(whole.out / name) - read_image(split.out / name)).max())
                for name in _frames(whole.out))  # fmt: skip
    assert worst <= 1 / 255 + 1e-6  # at most one 8-bit level where a rounding tips
    assert split.flicker_after.pairs == whole.flicker_after.pairs
    assert math.isclose(split.flicker_after.mean_px, whole.flicker_after.mean_px, rel_tol=1e-3)


def test_a_stereo_run_stopped_inside_a_split_shot_resumes_to_the_same_frames(clips, tmp_path):
    out = tmp_path / "res"

    def stop_after_first_piece(phase, done, total):
        if phase == "converting" and done == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        convert_clip(open_stereo(clips.stereo), out, DISPLAY, split_frames=4, progress=stop_after_first_piece)
    work = tmp_path / ".res.parts"
    assert [p.name for p in sorted(work.glob("shot_*"))] == ["shot_0000_000000-000004"]
    r = convert_clip(open_stereo(clips.stereo), out, DISPLAY, split_frames=4, resume=True)
    assert [s.reused for s in r.shots] == [False, False]  # shot 0 is partly reused: its psi needs every piece's range
    fresh = convert_clip(open_stereo(clips.stereo), tmp_path / "fresh", DISPLAY, split_frames=4)
    assert _frames(r.out) == _frames(fresh.out)
    assert [s.mapping.gain for s in r.shots] == [s.mapping.gain for s in fresh.shots]


def test_split_frames_is_checked(clips, tmp_path):
    for bad in (-1, 2.5, True):
        with pytest.raises(ValueError, match="split_frames must be an integer >= 0"):
            convert_clip(_open(clips, "2d+depth"), tmp_path / "o", DISPLAY, split_frames=bad)
