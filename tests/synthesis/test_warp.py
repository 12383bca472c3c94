"""Rectified forward/backward warping: kernel vs a slow reference, examples of S1 Sec. IV.B.1's gradient rule, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from vergence.synthesis import backward_warp, forward_warp

# The kernel and the reference below perform the same float32/float64 operations in the same
# order, so they agree to the last bit; this only absorbs a different but equivalent rounding.
KERNEL_ATOL = 1e-6


def slow_forward_warp(img: np.ndarray, disp: np.ndarray, scale: float, limit: float):
    """Obvious per-pixel Python version of the documented forward-warp rule (same arithmetic)."""
    h, w, nc = img.shape
    out = np.zeros((h, w, nc), dtype=np.float32)
    zbuf = np.full((h, w), -np.inf, dtype=np.float32)

    def linked(y, x0, x1):
        return (
            0 <= x0
            and x1 < w
            and not math.isnan(disp[y, x0])
            and not math.isnan(disp[y, x1])
            and abs(scale * (float(disp[y, x1]) - float(disp[y, x0]))) <= limit
        )

    for y in range(h):
        for x in range(w):
            d0 = disp[y, x]
            if math.isnan(d0):
                continue
            a = x - scale * float(d0)
            right, left = linked(y, x, x + 1), linked(y, x - 1, x)
            b = x + 1 - scale * float(disp[y, x + 1]) if right else a
            a_prev = x - 1 - scale * float(disp[y, x - 1]) if left else a
            if right:
                inv = 1.0 / (b - a) if b != a else 0.0
                dd = np.float32(disp[y, x + 1] - d0)
                for xt in range(max(math.ceil(min(a, b)), 0), min(math.floor(max(a, b)), w - 1) + 1):
                    s = np.float32((xt - a) * inv)
                    z = np.float32(d0 + s * dd)
                    if z > zbuf[y, xt]:
                        zbuf[y, xt] = z
                        out[y, xt] = (np.float32(1.0) - s) * img[y, x] + s * img[y, x + 1]
            xn = math.floor(a + 0.5)
            if 0 <= xn < w:
                covered = (right and min(a, b) <= xn <= max(a, b)) or (left and min(a_prev, a) <= xn <= max(a_prev, a))
                if not covered and d0 > zbuf[y, xn]:
                    zbuf[y, xn] = d0
                    out[y, xn] = img[y, x]
    holes = zbuf == -np.inf
    return out, np.where(holes, np.nan, zbuf), holes


@st.composite
def warp_cases(draw):
    h = draw(st.integers(1, 4))
    w = draw(st.integers(2, 24))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    # Quarter-pixel disparities in a few layers, some unknown: jumps, slopes and ties all occur.
    levels = rng.choice([0.0, 0.25, 0.5, 1.0, 3.0, 7.5], size=(h, w))
    disp = (levels + 0.25 * np.arange(w)[None, :] * rng.integers(0, 2)).astype(np.float32)
    disp[rng.random((h, w)) < 0.1] = np.nan
    img = rng.random((h, w, 3), dtype=np.float32)
    scale = draw(st.sampled_from([-1.0, -0.5, 0.0, 0.25, 0.5, 1.0, 2.0]))
    limit = draw(st.sampled_from([0.0, 0.5, 1.0, 3.0]))
    return img, disp, scale, limit


@settings(max_examples=60, deadline=None)
@given(warp_cases())
def test_forward_warp_matches_slow_reference(case):
    img, disp, scale, limit = case
    if np.isnan(disp).all():
        disp[0, 0] = 1.0
    res = forward_warp(img, disp, scale=scale, gradient_limit=limit)
    out, zbuf, holes = slow_forward_warp(img, disp, scale, limit)
    assert_array_equal(res.holes, holes)
    assert_allclose(res.image, out, rtol=0, atol=KERNEL_ATOL)
    assert_allclose(res.nearness, zbuf, rtol=0, atol=KERNEL_ATOL)


def test_step_near_on_the_left_leaves_a_hole_as_wide_as_the_jump():
    # S1 Sec. IV.B.1: d = 15 left of x = 50, 5 right of it; x' = x - d: a 10-px hole at 35..44.
    n = 100
    disp = np.where(np.arange(n) < 50, 15.0, 5.0)[None, :]
    img = np.random.default_rng(0).random((1, n), dtype=np.float32)
    res = forward_warp(img, disp)
    holes = np.flatnonzero(res.holes[0, 20:60]) + 20
    assert holes.tolist() == list(range(35, 45))


def test_smooth_slanted_surface_has_no_gaps():
    # S1 Sec. IV.B.1: d from 0 to -30 over 100 px (stretched by 1.3): every sampling gap is filled.
    n = 100
    disp = -np.linspace(0.0, 30.0, n)[None, :]
    res = forward_warp(np.random.default_rng(1).random((1, n), dtype=np.float32), disp)
    assert not res.holes[0, 40:99].any()


def test_gap_filling_interpolates_linearly_between_neighbours():
    # Two pixels 0.5 apart in disparity stretched by scale 2: targets 0 - 2*0 = 0 and 1 - 2*(-0.5) = 2.
    img = np.array([[0.0, 1.0, 1.0]], dtype=np.float32)
    disp = np.array([[0.0, -0.5, -0.5]])
    res = forward_warp(img, disp, scale=2.0)
    assert_allclose(res.image[0, :3], [0.0, 0.5, 1.0])
    assert_allclose(res.nearness[0, :3], [0.0, -0.25, -0.5])


def test_zbuffer_keeps_the_nearest_surface():
    # Pixel 0 (d = 0, far) and pixel 3 (d = 3, near) both land on column 0; the near one wins.
    img = np.array([[0.2, 0.4, 0.6, 0.8]], dtype=np.float32)
    disp = np.array([[0.0, np.nan, np.nan, 3.0]])
    res = forward_warp(img, disp)
    assert res.image[0, 0] == pytest.approx(0.8)
    assert res.nearness[0, 0] == 3.0
    assert res.holes[0].tolist() == [False, True, True, True]


def test_identity_at_scale_zero():
    rng = np.random.default_rng(3)
    img = rng.random((5, 7, 3), dtype=np.float32)
    disp = rng.random((5, 7)) * 10
    res = forward_warp(img, disp, scale=0.0)
    assert_array_equal(res.image, img)
    assert not res.holes.any()


def test_integer_shift_moves_the_image():
    img = np.random.default_rng(4).random((3, 10), dtype=np.float32)
    res = forward_warp(img, np.full((3, 10), 3.0))
    assert_array_equal(res.image[:, :7], img[:, 3:])
    assert res.holes[:, 7:].all() and not res.holes[:, :7].any()


def test_grey_8_and_16_bit_inputs_give_the_same_warp():
    rng = np.random.default_rng(5)
    u8 = rng.integers(0, 256, (4, 9), dtype=np.uint8)
    disp = np.full((4, 9), 1.5)
    a = forward_warp(u8, disp).image
    b = forward_warp(u8.astype(np.uint16) * 257, disp).image  # same values at 16 bits
    c = forward_warp(u8.astype(np.float32) / 255, disp).image
    assert a.shape == (4, 9) and a.dtype == np.float32
    assert_allclose(a, b, atol=1e-6)
    assert_allclose(a, c, atol=1e-6)


def test_backward_warp_undoes_a_constant_forward_warp():
    img = np.random.default_rng(6).random((2, 12, 3), dtype=np.float32)
    fwd = forward_warp(img, np.full((2, 12), 2.0))
    back, valid = backward_warp(fwd.image, fwd.nearness, scale=-1.0)
    # The forward warp put source x + 2 at x (x = 0..9); backward, x takes x - 2 of that: x = 2..9.
    assert_allclose(back[:, 2:10], img[:, 2:10], atol=1e-7)
    assert valid[:, 2:10].all() and not valid[:, :2].any() and not valid[:, 10:].any()


def test_backward_warp_hand_values():
    img = np.linspace(0, 1, 5, dtype=np.float32)[None, :]
    out, ok = backward_warp(img, np.array([[0.5, np.nan, -0.25, 0.0, 1.0]]))
    assert_allclose(out[0], [0.125, 0.0, 0.4375, 0.75, 0.0])
    assert ok[0].tolist() == [True, False, True, True, False]


@pytest.mark.parametrize(
    ("image", "disparity", "kwargs", "error", "match"),
    [
        (np.zeros((4, 5)), np.zeros((4, 6)), {}, ValueError, r"disparity must have shape \(H, W\) matching image \(4, 5\); got \(4, 6\)"),
        (np.zeros((4, 5)), np.zeros((4, 5, 2)), {}, ValueError, r"disparity must have shape \(H, W\); got \(4, 5, 2\)"),
        (np.zeros((4, 5)), np.full((4, 5), np.inf), {}, ValueError, "disparity must not contain inf"),
        (np.zeros((4, 5)), np.full((4, 5), np.nan), {}, ValueError, "at least one known value; got all unknown"),
        (np.full((4, 5), np.nan, np.float32), np.zeros((4, 5)), {}, ValueError, r"image must be finite"),
        (np.full((4, 5), 2.0, np.float32), np.zeros((4, 5)), {}, ValueError, r"image values must lie in \[0, 1\]"),
        (np.zeros((4, 5), np.int32), np.zeros((4, 5)), {}, TypeError, "image must be float in"),
        (np.zeros((4, 5)), np.zeros((4, 5)), {"scale": np.nan}, ValueError, "scale must be finite"),
        (np.zeros((4, 5)), np.zeros((4, 5)), {"gradient_limit": -1.0}, ValueError, "gradient_limit must be >= 0; got -1"),
    ],
)
def test_forward_warp_bad_input(image, disparity, kwargs, error, match):
    with pytest.raises(error, match=match):
        forward_warp(image, disparity, **kwargs)


def test_inputs_are_not_modified():
    img = np.random.default_rng(7).random((3, 6), dtype=np.float32)
    disp = np.array([[1.0, np.nan, 2.0, 3.0, 0.0, 1.0]] * 3, dtype=np.float32)
    img0, disp0 = img.copy(), disp.copy()
    forward_warp(img, disp)
    backward_warp(img, disp)
    assert_array_equal(img, img0)
    assert_array_equal(disp, disp0)
