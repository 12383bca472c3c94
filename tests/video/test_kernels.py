"""The per-pixel kernels of vergence.video against slow, obviously-correct NumPy references."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.display import LAYOUTS, pack
from vergence.video._kernels import flicker_kernel, grey_kernel, to_uint8_kernel, unit_float_kernel
from vergence.video._shots import packed_uint8


def _views(seed, h=7, w=9):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-0.1, 1.1, (h, w, 3)).astype(np.float32) for _ in range(2)]


@pytest.mark.parametrize("seed", [0, 1])
def test_grey_kernel_is_numpy_float32_sum_in_order(seed):
    frame = np.random.default_rng(seed).random((5, 8, 3)).astype(np.float32)
    expected = ((frame[:, :, 0] + frame[:, :, 1]) + frame[:, :, 2]) * np.float32(1.0 / 3.0)
    assert np.array_equal(grey_kernel(frame), expected)
    assert np.array_equal(grey_kernel(frame[:, ::2]), expected[:, ::2])  # a strided view


def test_unit_float_kernel_is_astype_then_divide():
    rgb = np.arange(256, dtype=np.uint8).reshape(8, 32, 1).repeat(3, axis=2)
    assert np.array_equal(unit_float_kernel(rgb), rgb.astype(np.float32) / np.float32(255.0))


@pytest.mark.parametrize("seed", [0, 1])
def test_to_uint8_kernel_is_clip_scale_round(seed):
    src = _views(seed)[0]
    src[0, 0, 0], src[0, 1, 1] = 0.5 / 255, 1.5 / 255  # ties of rint
    out = np.empty(src.shape, np.uint8)
    to_uint8_kernel(src, out)
    expected = np.empty(src.shape, np.uint8)
    for idx in np.ndindex(src.shape):  # one value at a time
        v = min(max(float(src[idx]), 0.0), 1.0)
        expected[idx] = int(np.rint(np.float32(v) * np.float32(255.0)))
    assert np.array_equal(out, expected)
    nan = np.full((1, 1, 3), np.nan, np.float32)
    to_uint8_kernel(nan, out[:1, :1])
    assert out[0, 0].tolist() == [0, 0, 0]


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_packed_uint8_equals_pack_then_round(layout):
    left, right = _views(3, 6, 8)
    expected = np.clip(pack(np.clip(left, 0, 1), np.clip(right, 0, 1), layout=layout), 0.0, 1.0) * np.float32(255.0)
    got = packed_uint8(np.clip(left, 0, 1), np.clip(right, 0, 1), layout)
    assert got.dtype == np.uint8 and got.shape[:2] == expected.shape[:2]
    assert np.array_equal(got.reshape(expected.shape), np.rint(expected).astype(np.uint8))


def test_flicker_kernel_against_a_loop():
    rng = np.random.default_rng(5)
    g0, g1 = (rng.random((6, 7)).astype(np.float32) for _ in range(2))
    g1[rng.random((6, 7)) < 0.5] = g0[rng.random((6, 7)) < 0.5][0]
    g1[:3] = g0[:3]
    d0, d1 = (rng.normal(0, 3, (6, 7)).astype(np.float32) for _ in range(2))
    d1[0, :3] = np.nan
    total, count = 0.0, 0
    for y in range(6):
        for x in range(7):
            change = abs(float(d1[y, x]) - float(d0[y, x]))
            if abs(np.float32(g1[y, x] - g0[y, x])) <= np.float32(0.03) and np.isfinite(change):
                total, count = total + change, count + 1
    got_total, got_count = flicker_kernel(g0, g1, d0, d1, np.float32(0.03))
    assert got_count == count and count > 10
    assert got_total == pytest.approx(total, rel=1e-6)


def test_rgbd_kernel_is_the_float_split_then_grey():
    from vergence.video._kernels import rgbd_kernel
    from vergence.video.layout import split_frame
    from vergence.video.stability import grey_levels

    rgbd = np.random.default_rng(2).integers(0, 256, (5, 12, 3), dtype=np.uint8)
    image, grey = rgbd_kernel(rgbd)
    colour, depth = split_frame(unit_float_kernel(rgbd), "rgbd")
    assert np.array_equal(image, colour) and image.flags.c_contiguous
    assert np.array_equal(grey, grey_levels(np.ascontiguousarray(depth)))
    assert np.array_equal(grey, grey_levels(depth.astype(np.float64)))  # the NumPy path of grey_levels too


@pytest.mark.parametrize("layout", ["sbs", "tb", "half-sbs"])
def test_stereo_lefts_of_a_video_are_the_left_views_of_its_pairs(tmp_path, layout):
    from vergence.video import VideoWriter, open_stereo
    from vergence.video.layout import layout_video_name

    path = tmp_path / layout_video_name("clip", layout)
    rng = np.random.default_rng(0)
    shape = (32, 48) if layout != "tb" else (64, 24)
    with VideoWriter(path, fps=24, width=shape[1], height=shape[0]) as out:
        for _ in range(3):
            out.write(rng.random((*shape, 3)).astype(np.float32))
    clip = open_stereo(path)
    lefts = list(clip.lefts(1, 3))
    assert len(lefts) == 2 and all(np.array_equal(a, b[0]) for a, b in zip(lefts, clip.pairs(1, 3)))
    assert lefts[0].flags.c_contiguous
