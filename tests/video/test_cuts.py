"""Shot cuts: the histogram-jump rule of vergence.video.cuts, on hand-made frames and on the rendered clips."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.video import CUT_THRESHOLD, MIN_SHOT_FRAMES, detect_cuts, histogram_change, open_depth_clip, open_stereo


def _flat(value, n):
    return [np.full((6, 8, 3), value, np.float32) for _ in range(n)]


def test_histogram_change_by_hand():
    # half the pixels of each channel move from bin 0 to bin 31: distance 1/2
    a = np.zeros((2, 2, 3))
    b = a.copy()
    b[0] = 1.0
    assert histogram_change(a, b) == 0.5
    assert histogram_change(b, a) == 0.5
    # a camera move that only rearranges the colours changes nothing
    rng = np.random.default_rng(1)
    frame = rng.random((8, 8, 3))
    assert histogram_change(frame, frame[:, ::-1]) == 0.0


def test_a_jump_at_the_threshold_cuts_and_just_below_does_not():
    # one channel's mass: a share s of the pixels change bin in all three channels -> distance s
    def frames(share):
        a = np.zeros((10, 10, 3), np.float32)
        b = a.copy()
        b.reshape(-1, 3)[: int(round(share * 100))] = 1.0
        return [a] * 8 + [b] * 8

    assert detect_cuts(frames(CUT_THRESHOLD)).shots == ((0, 8), (8, 16))
    assert detect_cuts(frames(CUT_THRESHOLD - 0.01)).shots == ((0, 16),)


def test_shots_shorter_than_the_minimum_are_not_cut():
    frames = _flat(0.1, 8) + _flat(0.9, MIN_SHOT_FRAMES - 1) + _flat(0.1, 8)
    # the jump back after MIN_SHOT_FRAMES - 1 bright frames would end a shot that is too short
    assert detect_cuts(frames).shots == ((0, 8), (8, 16 + MIN_SHOT_FRAMES - 1))
    assert detect_cuts(frames, min_shot=1).shots == ((0, 8), (8, 8 + MIN_SHOT_FRAMES - 1),
                                                      (8 + MIN_SHOT_FRAMES - 1, 16 + MIN_SHOT_FRAMES - 1))


def test_refusals():
    with pytest.raises(ValueError, match="frames must hold at least one frame; got none"):
        detect_cuts([])
    with pytest.raises(ValueError, match=r"frame must have shape \(H, W, 3\); got \(4, 4\)"):
        detect_cuts([np.zeros((4, 4))])
    with pytest.raises(ValueError, match="threshold must be in"):
        detect_cuts(_flat(0.1, 2), threshold=0.0)
    with pytest.raises(ValueError, match="min_shot must be an integer >= 1"):
        detect_cuts(_flat(0.1, 2), min_shot=0)


def test_the_cut_of_the_rendered_clips_is_found_exactly(clips):
    for clip in (open_stereo(clips.stereo), open_depth_clip(clips.rgbd)):
        found = detect_cuts(clip.lefts())
        assert found.cuts == clips.cuts
        assert found.shots == ((0, clips.cuts[0]), (clips.cuts[0], clips.frames))
        # the margin: camera moves stay far below the threshold, the cut far above
        inside = np.delete(found.change[1:], clips.cuts[0] - 1)
        assert inside.max() < CUT_THRESHOLD / 3 and found.change[clips.cuts[0]] > CUT_THRESHOLD
