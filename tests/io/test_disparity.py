"""Disparity maps: Middlebury PNG/PGM with a scale (0 = unknown), PFM (inf = unknown), NPY (NaN)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_array_equal
from PIL import Image

from vergence.io import read_disparity, read_pfm, write_disparity


def test_real_tsukuba_ground_truth(shared_data):
    path = shared_data / "stereo" / "tsukuba" / "groundtruth.png"
    disparity = read_disparity(path, scale=16)
    raw = np.asarray(Image.open(path).convert("L")).astype(np.float32)
    assert disparity.shape == (288, 384) and disparity.dtype == np.float32
    assert_array_equal(np.isnan(disparity), raw == 0)  # 0 = unknown (the border) -> NaN
    assert_array_equal(disparity[raw > 0], raw[raw > 0] / 16)
    assert np.nanmin(disparity) == 5.0 and np.nanmax(disparity) == 14.0  # tsukuba spans 5..14 px


def test_real_venus_pgm_equals_its_png(shared_data):
    venus = shared_data / "stereo" / "venus"
    from_pgm = read_disparity(venus / "disp2.pgm", scale=8)
    from_png = read_disparity(venus / "groundtruth.png", scale=8)  # SOURCES.md: the same map
    assert from_pgm.shape == (383, 434)
    assert_array_equal(from_pgm, from_png)
    assert_array_equal(from_pgm[0, :3], np.asarray(Image.open(venus / "disp2.pgm"))[0, :3] / 8)


def test_scale_rules(tmp_path):
    png = tmp_path / "d.png"
    write_disparity(png, np.array([[1.0, 2.0]]), scale=4)
    with pytest.raises(ValueError, match=r"scale is required for a \.png disparity map .*tsukuba"):
        read_disparity(png)
    with pytest.raises(ValueError, match="scale must be > 0; got 0"):
        read_disparity(png, scale=0)
    with pytest.raises(TypeError, match="scale must be a real number; got str"):
        read_disparity(png, scale="16")
    pfm = tmp_path / "d.pfm"
    write_disparity(pfm, np.array([[1.0, 2.0]]))
    with pytest.raises(ValueError, match=r"scale applies to \.png/\.pgm disparity maps only"):
        read_disparity(pfm, scale=16)
    with pytest.raises(ValueError, match=r"scale applies to \.png/\.pgm"):
        write_disparity(tmp_path / "e.npy", np.ones((2, 2)), scale=2)
    with pytest.raises(ValueError, match=r"scale is required for a \.pgm"):
        write_disparity(tmp_path / "e.pgm", np.ones((2, 2)))


@pytest.mark.parametrize("suffix", [".png", ".pgm"])
def test_integer_round_trip_with_unknown(tmp_path, suffix):
    disparity = np.array([[0.25, 1.5, np.nan], [4095.9375, np.nan, 100.0]])
    path = tmp_path / f"d{suffix}"
    write_disparity(path, disparity, scale=16)
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert raw.dtype == np.uint16
    assert_array_equal(raw, [[4, 24, 0], [65535, 0, 1600]])  # round(d * 16), NaN -> 0
    assert_array_equal(read_disparity(path, scale=16), disparity.astype(np.float32))


def test_pfm_stores_unknown_as_inf_and_npy_as_nan(tmp_path):
    disparity = np.array([[2.5, np.nan], [-1.0, 7.0]])
    pfm, npy = tmp_path / "d.pfm", tmp_path / "d.npy"
    write_disparity(pfm, disparity)
    write_disparity(npy, disparity)
    assert_array_equal(read_pfm(pfm), [[2.5, np.inf], [-1.0, 7.0]])  # Middlebury 2014
    assert_array_equal(np.load(npy), disparity.astype(np.float32))
    for path in (pfm, npy):
        out = read_disparity(path)
        assert out.dtype == np.float32
        assert_array_equal(out, disparity.astype(np.float32))


def test_float_files_inf_reads_as_unknown_and_zero_is_a_disparity(tmp_path):
    path = tmp_path / "z.npy"
    np.save(path, np.array([[0.0, np.inf, -np.inf, 3.0, np.nan]], np.float32))
    assert_array_equal(read_disparity(path), [[0.0, np.nan, np.nan, 3.0, np.nan]])
    pfm = tmp_path / "z.pfm"
    pfm.write_bytes(b"Pf\n3 1\n-1\n" + np.array([0.0, 1.0, np.inf], "<f4").tobytes())
    assert_array_equal(read_disparity(pfm), [[0.0, 1.0, np.nan]])


@pytest.mark.parametrize("suffix", [".pfm", ".npy"])
def test_float_formats_keep_zero_and_negative_disparities(tmp_path, suffix):
    d = np.array([[0.0, -2.5, np.nan, 7.0]], np.float32)
    write_disparity(tmp_path / f"d{suffix}", d)
    assert_array_equal(read_disparity(tmp_path / f"d{suffix}"), d)


@settings(max_examples=25, deadline=None)
@given(
    arrays(np.int64, (3, 4), elements=st.integers(0, 65535)),
    st.sampled_from([1, 2, 8, 16, 256]),
)
def test_png_round_trip_property(tmp_path_factory, levels, scale):
    disparity = np.where(levels == 0, np.nan, levels / scale)
    path = tmp_path_factory.mktemp("prop") / "d.png"
    write_disparity(path, disparity, scale=scale)
    assert_array_equal(read_disparity(path, scale=scale), disparity.astype(np.float32))


@pytest.mark.parametrize(
    ("disparity", "scale", "message"),
    [
        (np.array([[4096.0]]), 16, r"must round into \[1, 65535\] for 16-bit \.png .*got \[65536, 65536\]"),
        (np.array([[-1.0, 1.0]]), 16, r"round into \[1, 65535\] .*got \[-16, 16\]"),
        (np.array([[0.01]]), 16, r"round into \[1, 65535\] .*got \[0, 0\]"),
        (np.array([[0.0, 1.0]]), 16, r"round into \[1, 65535\] .*use \.pfm or \.npy .*got \[0, 16\]"),
        (np.array([[np.inf]]), 16, "must not contain inf"),
        (np.zeros((2, 2, 1)) + 1, 16, r"shape \(H, W\) and not be empty; got \(2, 2, 1\)"),
        (np.zeros((0, 2)), 16, "not be empty"),
    ],
)
def test_write_errors(tmp_path, disparity, scale, message):
    with pytest.raises(ValueError, match=message):
        write_disparity(tmp_path / "d.png", disparity, scale=scale)
    assert list(tmp_path.iterdir()) == []


def test_write_type_and_extension_errors(tmp_path):
    with pytest.raises(TypeError, match="disparity must be a real-valued array; got dtype bool"):
        write_disparity(tmp_path / "d.pfm", np.ones((2, 2), bool))
    with pytest.raises(ValueError, match=r"unknown disparity extension '\.jpg'; expected one of \.npy, \.pfm"):
        write_disparity(tmp_path / "d.jpg", np.ones((2, 2)))


def test_read_errors(tmp_path):
    colour = tmp_path / "c.png"
    Image.fromarray(np.array([[[1, 2, 3]]], np.uint8), "RGB").save(colour)
    with pytest.raises(ValueError, match=r"c\.png: a disparity map must be single-channel \(H, W\); got shape \(1, 1, 3"):
        read_disparity(colour, scale=1)
    grey_rgb = tmp_path / "g.png"
    Image.fromarray(np.array([[[8, 8, 8], [0, 0, 0]]], np.uint8), "RGB").save(grey_rgb)
    assert_array_equal(read_disparity(grey_rgb, scale=8), [[1.0, np.nan]])  # equal channels: grey
    empty = tmp_path / "e.png"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match=r"e\.png: the file is empty"):
        read_disparity(empty, scale=1)
    truncated = tmp_path / "t.pgm"
    truncated.write_bytes(b"P5\n4 4\n255\n" + bytes(7))
    with pytest.raises(ValueError, match=r"t\.pgm: Netpbm data is truncated"):
        read_disparity(truncated, scale=1)
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_disparity(tmp_path / "none.pfm")
    with pytest.raises(IsADirectoryError, match="it is a directory"):
        read_disparity(tmp_path, scale=1)
    (tmp_path / "d.tiff").write_bytes(b"II*\x00")
    with pytest.raises(ValueError, match=r"unknown disparity extension '\.tiff'"):
        read_disparity(tmp_path / "d.tiff")
    colour_pfm = tmp_path / "c.pfm"
    colour_pfm.write_bytes(b"PF\n1 1\n-1\n" + np.array([1, 2, 3], "<f4").tobytes())
    with pytest.raises(ValueError, match="must be single-channel"):
        read_disparity(colour_pfm)
    bad_npy = tmp_path / "b.npy"
    np.save(bad_npy, np.array([["a"]]))
    with pytest.raises(ValueError, match="disparity data must be numeric; got <U1"):
        read_disparity(bad_npy)
