"""The colour-gated temporal filter of disparity and the flicker measure (vergence.video.stability)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.video import STABILIZE_ALPHA, STATIC_THRESHOLD, disparity_flicker, stabilize_disparity

# The kernel computes in float32 like the reference below: a few float32 roundings.
KERNEL_RTOL = 1e-6


def _reference(previous_frame, frame, previous, disparity, threshold, alpha):
    """Slow, obviously-correct loop over pixels (the module docstring's rule)."""
    g0, g1 = previous_frame.mean(axis=2), frame.mean(axis=2)
    out = np.empty(disparity.shape, np.float64)
    for y in range(disparity.shape[0]):
        for x in range(disparity.shape[1]):
            static = abs(g1[y, x] - g0[y, x]) <= threshold
            p, d = float(previous[y, x]), float(disparity[y, x])
            if static and np.isfinite(p):
                out[y, x] = p + alpha * (d - p) if np.isfinite(d) else p
            else:
                out[y, x] = d
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_matches_the_reference_loop(seed):
    rng = np.random.default_rng(seed)
    h, w = 9, 13
    f0 = rng.random((h, w, 3)).astype(np.float32)
    f1 = f0 + (rng.random((h, w, 1)) < 0.5) * rng.uniform(-0.2, 0.2, (h, w, 1)).astype(np.float32)
    f1 = np.clip(f1, 0, 1).astype(np.float32)
    prev = rng.normal(0, 5, (h, w)).astype(np.float32)
    d = rng.normal(0, 5, (h, w)).astype(np.float32)
    prev[rng.random((h, w)) < 0.2] = np.nan
    d[rng.random((h, w)) < 0.2] = np.nan
    got = stabilize_disparity(f0, f1, prev, d, threshold=0.05, alpha=0.3)
    want = _reference(f0, f1, prev, d, 0.05, 0.3)
    assert got.dtype == np.float32
    assert_allclose(got, want, rtol=KERNEL_RTOL, equal_nan=True)


def test_static_pixels_average_and_moving_ones_follow():
    still = np.full((1, 3, 3), 0.5, np.float32)
    moved = still.copy()
    moved[0, 2] += 2 * STATIC_THRESHOLD  # the third pixel changes colour
    previous = np.array([[4.0, 4.0, 4.0]])
    new = np.array([[8.0, np.nan, 8.0]])
    out = stabilize_disparity(still, moved, previous, new)
    # static and known: 4 + alpha (8 - 4); static, new unknown: keeps 4; moving: takes 8.
    assert_allclose(out, [[4.0 + STABILIZE_ALPHA * 4.0, 4.0, 8.0]])
    assert_allclose(stabilize_disparity(still, moved, previous, new, alpha=1.0), [[8.0, 4.0, 8.0]])


def test_noise_on_a_static_scene_falls_as_the_exponential_average_says():
    rng = np.random.default_rng(3)
    frame = np.full((64, 64, 3), 0.4, np.float32)
    raw = [5.0 + rng.normal(0, 0.5, (64, 64)).astype(np.float32) for _ in range(40)]
    filtered = [raw[0]]
    for d in raw[1:]:
        filtered.append(stabilize_disparity(frame, frame, filtered[-1], d))
    before = disparity_flicker([frame] * 40, raw).mean_px
    after = disparity_flicker([frame] * 40, filtered).mean_px
    # Steady state of y_t = y_{t-1} + a (d_t - y_{t-1}) on white noise of variance s^2: var(y) = s^2 a / (2 - a),
    # the change a (d_t - y_{t-1}) has variance a^2 s^2 (1 + a / (2 - a)), the raw change 2 s^2 (both Gaussian:
    # mean absolute values in the ratio of their spreads).
    a = STABILIZE_ALPHA
    expected = a * np.sqrt(1.0 + a / (2.0 - a)) / np.sqrt(2.0)
    assert after / before == pytest.approx(expected, rel=0.1)


def test_flicker_by_hand_skips_cuts_and_moving_pixels():
    frames = [np.zeros((1, 2, 3))] * 4
    d = [np.array([[1.0, 0.0]]), np.array([[2.0, 0.0]]), np.array([[9.0, 0.0]]), np.array([[9.5, 0.0]])]
    # pairs (0,1) and (2,3); the cut at 2 drops the jump 2 -> 9: mean of |1|, 0, |0.5|, 0 over 4 pixels
    f = disparity_flicker(frames, d, cuts=[2])
    assert f.pairs == 2 and f.mean_px == pytest.approx(1.5 / 4) and f.static_share == 1.0
    moving = [np.zeros((1, 2, 3)), np.ones((1, 2, 3))]
    f = disparity_flicker(moving, d[:2])
    assert f.pairs == 1 and np.isnan(f.mean_px) and f.static_share == 0.0


def test_refusals():
    f = np.zeros((2, 2, 3))
    with pytest.raises(ValueError, match=r"disparity must have shape \(2, 2\) \(H, W\) of previous_frame; got \(2, 3\)"):
        stabilize_disparity(f, f, np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"alpha must be a number in \(0, 1\]; got 0"):
        stabilize_disparity(f, f, np.zeros((2, 2)), np.zeros((2, 2)), alpha=0)
    with pytest.raises(ValueError, match=r"threshold must be a number in \[0, 1\); got -0.1"):
        disparity_flicker([f], [np.zeros((2, 2))], threshold=-0.1)
    with pytest.raises(ValueError, match="frames and disparities must have one length; one of them ends after 1"):
        disparity_flicker([f, f], [np.zeros((2, 2))])
    with pytest.raises(ValueError, match=r"previous_frame must have shape \(H, W, 3\); got \(2, 2\)"):
        stabilize_disparity(np.zeros((2, 2)), f, np.zeros((2, 2)), np.zeros((2, 2)))
