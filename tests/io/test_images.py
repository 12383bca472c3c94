"""Image files: PNG 8/16-bit, JPEG, PGM/PPM, Radiance HDR, PFM, NPY; clear errors on bad files."""

from __future__ import annotations

import re

import cv2
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from PIL import Image

from vergence.io import read_image, write_image

# JPEG at quality 95 on a smooth ramp: mean error well under 1 level, max a few levels.
JPEG_MEAN_ABS_ERROR = 1.0 / 255
# Radiance RGBE stores an 8-bit mantissa shared by the three channels: error <= max channel / 2^8
# (rounding of the mantissa; 2^-7 leaves room for the exponent choice).
RGBE_RELATIVE_ERROR = 2.0**-7


def _ramp_rgb(h: int = 6, w: int = 7) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([x / (w - 1), y / (h - 1), (x + y) / (w + h - 2)], axis=2).astype(np.float32)


# --- PNG ---------------------------------------------------------------------------------------


def test_png_8bit_values_are_rounded_levels_read_by_pillow(tmp_path):
    path = tmp_path / "levels.png"
    write_image(path, np.array([[0.0, 0.2, 0.5, 1.0]]))  # 0, 51, 127.5 -> 128 (half to even), 255
    assert_array_equal(np.asarray(Image.open(path)), [[0, 51, 128, 255]])
    assert_array_equal(read_image(path), np.array([[0, 51, 128, 255]], np.float32) / np.float32(255))


def test_png_rgb_channel_order_against_pillow(tmp_path):
    path = tmp_path / "red.png"
    Image.fromarray(np.array([[[255, 0, 0], [0, 0, 255]]], np.uint8), "RGB").save(path)
    assert_array_equal(read_image(path), [[[1, 0, 0], [0, 0, 1]]])
    out = tmp_path / "out.png"
    write_image(out, np.array([[[1.0, 0, 0], [0, 1.0, 0]]]))
    assert_array_equal(np.asarray(Image.open(out).convert("RGB")), [[[255, 0, 0], [0, 255, 0]]])


def test_png_16bit_keeps_every_level(tmp_path):
    levels = np.arange(0, 65536, dtype=np.uint16).reshape(256, 256)
    path = tmp_path / "16.png"
    cv2.imwrite(str(path), levels)  # written by OpenCV, independent of write_image
    out = read_image(path)
    assert out.dtype == np.float32 and out.shape == (256, 256)
    assert_array_equal(out, levels.astype(np.float32) / np.float32(65535))
    assert np.unique(out).size == 65536  # full precision: no two levels merge
    again = tmp_path / "again.png"
    write_image(again, out, bit_depth=16)
    assert_array_equal(cv2.imread(str(again), cv2.IMREAD_UNCHANGED), levels)


def test_png_16bit_rgb_round_trip(tmp_path):
    image = _ramp_rgb()
    path = tmp_path / "rgb16.png"
    write_image(path, image, bit_depth=16)
    expected = np.rint(image.astype(np.float64) * 65535) / 65535
    assert_allclose(read_image(path), expected, rtol=0, atol=1e-7)  # float32 of a 16-bit level


def test_grey_png_stays_two_dimensional(tmp_path):
    path = tmp_path / "g.png"
    write_image(path, np.full((3, 2, 1), 0.5))
    assert read_image(path).shape == (3, 2)


def test_opaque_alpha_is_dropped_and_transparency_refused(tmp_path):
    rgba = np.zeros((2, 3, 4), np.uint8)
    rgba[..., 0] = 200
    rgba[..., 3] = 255
    path = tmp_path / "rgba.png"
    Image.fromarray(rgba, "RGBA").save(path)
    assert_array_equal(read_image(path), np.tile(np.float32([200 / 255, 0, 0]), (2, 3, 1)))
    rgba[1, 2, 3] = 10
    Image.fromarray(rgba, "RGBA").save(path)
    with pytest.raises(ValueError, match=r"rgba\.png: it has an alpha channel with 1 non-opaque pixels"):
        read_image(path)
    grey_alpha = np.stack([np.full((2, 2), 60, np.uint8), np.full((2, 2), 255, np.uint8)], axis=2)
    Image.fromarray(grey_alpha, "LA").save(path)
    assert_array_equal(read_image(path), np.full((2, 2), 60 / 255, np.float32))


def test_palette_png_is_grey_only_when_its_colours_are(tmp_path):
    path = tmp_path / "p.png"
    grey = Image.fromarray(np.array([[0, 128], [255, 128]], np.uint8)).convert("P")
    grey.save(path)
    assert_array_equal(read_image(path), np.array([[0, 128], [255, 128]], np.float32) / 255)
    colour = Image.fromarray(np.array([[0, 1]], np.uint8), "P")
    colour.putpalette([255, 0, 0, 9, 9, 9])
    colour.save(path)
    assert_array_equal(read_image(path), np.array([[[255, 0, 0], [9, 9, 9]]], np.float32) / 255)


def test_real_middlebury_mask_is_grey(shared_data):
    mask = read_image(shared_data / "stereo" / "tsukuba" / "nonocc.png")  # a grey palette PNG
    assert mask.shape == (288, 384)
    assert set(np.unique(mask)) <= {0.0, 1.0}


def test_real_tsukuba_png_matches_pillow(shared_data):
    path = shared_data / "stereo" / "tsukuba" / "im3.png"
    image = read_image(path)
    assert image.shape == (288, 384, 3) and image.dtype == np.float32
    reference = np.asarray(Image.open(path).convert("RGB"), np.float32) / 255
    assert_array_equal(image, reference)


def test_write_refuses_values_outside_unit_range(tmp_path):
    path = tmp_path / "x.png"
    with pytest.raises(ValueError, match=r"values must lie in \[0, 1\] to be written as 8-bit PNG .*\[0, 1\.5\]"):
        write_image(path, np.array([[0.0, 1.5]]))
    with pytest.raises(ValueError, match=r"lie in \[0, 1\] to be written as 16-bit PNG .*got \[-0\.25, 0\]"):
        write_image(path, np.array([[-0.25, 0.0]]), bit_depth=16)
    with pytest.raises(ValueError, match="must be finite to be written as PNG"):
        write_image(path, np.array([[np.nan]]))
    assert list(tmp_path.iterdir()) == []


def test_write_accepts_uint8_and_uint16_arrays(tmp_path):
    path = tmp_path / "u.png"
    write_image(path, np.array([[0, 255]], np.uint8))
    assert_array_equal(read_image(path), [[0, 1]])
    write_image(path, np.array([[0, 65535]], np.uint16), bit_depth=16)
    assert_array_equal(read_image(path), [[0, 1]])


@pytest.mark.parametrize(
    ("kwargs", "image", "error", "message"),
    [
        ({"bit_depth": 12}, np.zeros((2, 2)), ValueError, "bit_depth must be 8 or 16; got 12"),
        ({"bit_depth": True}, np.zeros((2, 2)), TypeError, "bit_depth must be an integer"),
        ({}, np.zeros((2, 2, 4)), ValueError, r"alpha is not written"),
        ({}, np.zeros((2, 2, 2)), ValueError, r"must have shape \(H, W\) or \(H, W, C\)"),
        ({}, np.zeros((0, 2)), ValueError, "must not be empty"),
        ({}, np.zeros((2, 2), np.int32), TypeError, "float in \\[0, 1\\], uint8 or uint16; got int32"),
    ],
)
def test_write_png_bad_input(tmp_path, kwargs, image, error, message):
    with pytest.raises(error, match=message):
        write_image(tmp_path / "x.png", image, **kwargs)


# --- JPEG --------------------------------------------------------------------------------------


def test_jpeg_round_trip_is_close(tmp_path):
    image = _ramp_rgb(32, 40)
    path = tmp_path / "r.jpg"
    write_image(path, image)
    out = read_image(path)
    assert out.shape == image.shape and out.dtype == np.float32
    assert np.abs(out - image).mean() < JPEG_MEAN_ABS_ERROR
    grey = tmp_path / "g.jpeg"
    write_image(grey, image[:, :, 0])
    assert read_image(grey).shape == (32, 40)


def test_jpeg_errors(tmp_path):
    path = tmp_path / "r.jpg"
    with pytest.raises(ValueError, match="bit_depth must be 8 for JPEG; got 16"):
        write_image(path, np.zeros((4, 4)), bit_depth=16)
    write_image(path, _ramp_rgb(32, 40))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"r\.jpg: JPEG data is corrupt or truncated"):
        read_image(path)
    path.write_bytes(b"not a jpeg at all")
    with pytest.raises(ValueError, match=r"r\.jpg: not a JPEG file"):
        read_image(path)


# --- PGM / PPM ---------------------------------------------------------------------------------


def test_real_venus_ppm_and_pgm_match_pillow(shared_data):
    venus = shared_data / "stereo" / "venus"
    image = read_image(venus / "im2.ppm")
    assert image.shape == (383, 434, 3)
    assert_array_equal(image, np.asarray(Image.open(venus / "im2.ppm"), np.float32) / 255)
    grey = read_image(venus / "disp2.pgm")
    assert grey.shape == (383, 434)
    assert_array_equal(grey, np.asarray(Image.open(venus / "disp2.pgm"), np.float32) / 255)


def test_pnm_maxval_scaling_and_plain_format(tmp_path):
    path = tmp_path / "p.pgm"
    path.write_bytes(b"P2\n# a comment\n3 1\n1023\n0 512 1023\n")
    assert_array_equal(read_image(path), np.array([[0, 512, 1023]], np.float32) / np.float32(1023))
    path.write_bytes(b"P5\n2 1\n1023\n" + np.array([1023, 1], ">u2").tobytes())
    assert_array_equal(read_image(path), np.array([[1023, 1]], np.float32) / np.float32(1023))


@pytest.mark.parametrize(("suffix", "shape"), [(".pgm", (3, 4)), (".ppm", (3, 4, 3))])
@pytest.mark.parametrize("bit_depth", [8, 16])
def test_pnm_round_trip(tmp_path, suffix, shape, bit_depth):
    levels = 2**bit_depth - 1
    samples = np.random.default_rng(2).integers(0, levels + 1, shape)
    image = (samples / levels).astype(np.float32)
    path = tmp_path / f"r{suffix}"
    write_image(path, image, bit_depth=bit_depth)
    assert_array_equal(read_image(path), samples.astype(np.float32) / np.float32(levels))
    # The file itself, read by OpenCV (independent of our codec; BGR for colour).
    stored = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert stored.dtype == (np.uint8 if bit_depth == 8 else np.uint16)
    assert_array_equal(stored if stored.ndim == 2 else stored[:, :, ::-1], samples)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"P6\n2 2\n255\n" + bytes(5), r"Netpbm data is truncated \(5 of 12 bytes\)"),
        (b"P5\n2 1\n255", "header but no pixel data"),
        (b"P5\n2 1\n255\n", r"truncated \(0 of 2 bytes\)"),
        (b"P5\n2 1\n9\n\x0a\x01", "sample 10 exceeds maxval 9"),
        (b"P3\n1 1\n255\n1 2\n", r"truncated \(2 of 3 values\)"),
        (b"P1\n1 1\n1\n", "not a PGM/PPM file"),
        (b"P5\n2 x\n255\n\x00\x00", "invalid Netpbm header"),
    ],
)
def test_bad_pnm_files(tmp_path, content, message):
    path = tmp_path / "bad.pgm"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=message):
        read_image(path)


def test_pgm_and_ppm_want_grey_and_colour(tmp_path):
    with pytest.raises(ValueError, match=r"grey \(H, W\) for \.pgm"):
        write_image(tmp_path / "a.pgm", np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match=r"RGB \(H, W, 3\) for \.ppm"):
        write_image(tmp_path / "a.ppm", np.zeros((2, 2)))


# --- Radiance HDR ------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["venice_sunset_1k.hdr", "quarry_01_1k.hdr"])
def test_real_hdr_files_are_linear_with_peaks_in_the_thousands(shared_data, name):
    image = read_image(shared_data / "hdri" / name)
    assert image.shape == (512, 1024, 3) and image.dtype == np.float32
    assert image.min() >= 0.0
    assert image.max() > 1000.0  # real HDR, not tone-mapped to [0, 1] (SOURCES.md)
    assert np.median(image) < image.max() / 100  # a few bright sources, not a rescaled image


def test_hdr_round_trip_within_rgbe_precision(tmp_path):
    image = _ramp_rgb() * np.float32(500.0) + np.float32(0.01)
    path = tmp_path / "r.hdr"
    write_image(path, image)
    out = read_image(path)
    bound = image.max(axis=2, keepdims=True) * RGBE_RELATIVE_ERROR
    assert np.all(np.abs(out - image) <= bound)
    write_image(path, image[:, :, 0])  # grey -> three equal channels
    out = read_image(path)
    assert out.shape == image.shape
    assert_array_equal(out[:, :, 0], out[:, :, 2])


def test_hdr_errors(tmp_path, capfd):
    path = tmp_path / "r.hdr"
    with pytest.raises(ValueError, match="values must be >= 0 for Radiance .hdr; got min -1"):
        write_image(path, np.array([[-1.0, 2.0]]))
    write_image(path, _ramp_rgb(40, 50) * np.float32(7))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    capfd.readouterr()
    with pytest.raises(ValueError, match=r"r\.hdr: Radiance HDR data is corrupt or truncated"):
        read_image(path)
    assert capfd.readouterr().err == ""  # our one error only: OpenCV's own log lines are silenced
    path.write_bytes(b"hello")
    with pytest.raises(ValueError, match="not a Radiance HDR file"):
        read_image(path)


# --- NPY and PFM -------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".npy", ".pfm"])
def test_float_formats_keep_values_exactly(tmp_path, suffix):
    image = _ramp_rgb() * np.float32(37.5) - np.float32(3)
    path = tmp_path / f"f{suffix}"
    write_image(path, image)
    assert_array_equal(read_image(path), image)
    write_image(path, image[:, :, 1])
    assert_array_equal(read_image(path), image[:, :, 1])


def test_float_formats_refuse_nan_and_bit_depth(tmp_path):
    with pytest.raises(ValueError, match="image must be finite .*use write_disparity"):
        write_image(tmp_path / "a.npy", np.array([[np.nan]]))
    with pytest.raises(ValueError, match=r"bit_depth applies to PNG/PGM/PPM only; \.pfm stores float32"):
        write_image(tmp_path / "a.pfm", np.zeros((2, 2)), bit_depth=16)
    path = tmp_path / "inf.pfm"
    path.write_bytes(b"Pf\n1 1\n-1\n" + np.array([np.inf], "<f4").tobytes())
    with pytest.raises(ValueError, match=r"inf\.pfm: image holds NaN or inf \(for disparity maps use read_disp"):
        read_image(path)


@pytest.mark.parametrize(
    ("array", "message"),
    [
        (np.zeros((2, 2, 4), np.float32), r"shape \(H, W\) or \(H, W, 3\); got \(2, 2, 4\)"),
        (np.zeros((2, 2), np.int32), "must be float, uint8 or uint16; got int32"),
        (np.array([[np.nan]], np.float32), "NaN or inf"),
    ],
)
def test_bad_npy_images(tmp_path, array, message):
    path = tmp_path / "a.npy"
    np.save(path, array)
    with pytest.raises(ValueError, match=message):
        read_image(path)


def test_npy_integer_images_are_scaled_and_pickles_refused(tmp_path):
    path = tmp_path / "a.npy"
    np.save(path, np.array([[0, 255]], np.uint8))
    assert_array_equal(read_image(path), [[0.0, 1.0]])
    np.save(path, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match=r"a\.npy: not a valid image \.npy file"):
        read_image(path)
    np.save(path, np.ones((10, 10), np.float32))
    path.write_bytes(path.read_bytes()[:200])  # header kept, data cut
    with pytest.raises(ValueError, match=r"a\.npy: not a valid image \.npy file \(Failed to read all data"):
        read_image(path)


# --- errors common to all formats --------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".ppm", ".hdr", ".pfm", ".npy"])
def test_empty_files_are_refused(tmp_path, suffix):
    path = tmp_path / f"empty{suffix}"
    path.write_bytes(b"")
    with pytest.raises(ValueError, match=rf"empty\{suffix}: the file is empty"):
        read_image(path)


def test_truncated_and_mistyped_png(tmp_path):
    path = tmp_path / "t.png"
    write_image(path, _ramp_rgb(20, 30))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"t\.png: PNG file is truncated \(no IEND chunk\)"):
        read_image(path)
    path.write_bytes(data[:40] + data[-12:])  # IEND kept, image data cut out
    with pytest.raises(ValueError, match=r"t\.png: PNG data is corrupt or truncated"):
        read_image(path)
    jpeg = tmp_path / "j.jpg"
    write_image(jpeg, _ramp_rgb())
    path.write_bytes(jpeg.read_bytes())
    with pytest.raises(ValueError, match=r"t\.png: not a PNG file \(bad signature\)"):
        read_image(path)


def test_paths_extensions_and_exr(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"missing\.png: no such file"):
        read_image(tmp_path / "missing.png")
    with pytest.raises(IsADirectoryError, match="it is a directory"):
        read_image(tmp_path)
    (tmp_path / "a.gif").write_bytes(b"GIF89a")
    with pytest.raises(ValueError, match=r"unknown image extension '\.gif'; expected one of \.hdr, \.jpeg"):
        read_image(tmp_path / "a.gif")
    with pytest.raises(ValueError, match="unknown image extension '.tif'"):
        write_image(tmp_path / "a.tif", np.zeros((2, 2)))
    (tmp_path / "a.exr").write_bytes(b"v/1\x01")
    with pytest.raises(ValueError, match="EXR is not supported"):
        read_image(tmp_path / "a.exr")
    with pytest.raises(ValueError, match="EXR is not supported"):
        write_image(tmp_path / "b.exr", np.zeros((2, 2)))
    with pytest.raises(FileNotFoundError, match="does not exist"):
        write_image(tmp_path / "no" / "a.png", np.zeros((2, 2)))


def test_upper_case_extension_and_overwrite(tmp_path):
    path = tmp_path / "A.PNG"
    write_image(path, np.zeros((2, 2)))
    write_image(path, np.ones((2, 2)))  # outputs may be overwritten (the CLI protects inputs)
    assert_array_equal(read_image(path), np.ones((2, 2)))
    assert [p.name for p in tmp_path.iterdir()] == ["A.PNG"]


def test_input_is_not_modified(tmp_path):
    image = _ramp_rgb()
    before = image.copy()
    write_image(tmp_path / "a.png", image)
    write_image(tmp_path / "a.hdr", image)
    assert_array_equal(image, before)


# --- declared sizes past the limit are refused before decoding -------------------------------


@pytest.mark.parametrize("name", ["big.png", "big.hdr", "big.jpg"])
def test_images_declaring_too_many_pixels_are_refused_before_decoding(tmp_path, huge_image, name):
    from vergence.io.images import MAX_IMAGE_PIXELS

    path = tmp_path / name
    path.write_bytes(huge_image(name))
    with pytest.raises(ValueError, match=rf"declares .* pixels; the limit is {MAX_IMAGE_PIXELS:,}") as info:
        read_image(path)
    assert "\n" not in str(info.value)


# Issue 9: a truncated PNG printed libpng's own line ("libpng error: IDAT: CRC error") before ours.
@pytest.mark.parametrize("where", ["ihdr", "idat", "cut"])
def test_corrupt_png_is_one_error_and_nothing_on_stderr(tmp_path, capfd, where):
    path = tmp_path / "c.png"
    write_image(path, _ramp_rgb(20, 30))
    data = bytearray(path.read_bytes())
    if where == "ihdr":
        data[29] ^= 0xFF  # a byte of the IHDR CRC
    elif where == "idat":
        data[data.index(b"IDAT") + 10] ^= 0xFF
    else:
        data = data[: data.index(b"IDAT") + 60] + data[-12:]  # IDAT cut short, IEND kept
    path.write_bytes(bytes(data))
    capfd.readouterr()
    with pytest.raises(ValueError, match=r"c\.png: PNG data is corrupt or truncated") as info:
        read_image(path)
    assert "libpng" not in str(info.value)
    if where != "cut":
        assert re.search(r"\((IHDR|IDAT): [^()]+\)$", str(info.value))  # libpng's reason, in our one line
    out, err = capfd.readouterr()
    assert (out, err) == ("", "")


def test_codec_refusal_on_write_is_one_line_error(tmp_path, capfd):
    capfd.readouterr()
    with pytest.raises(ValueError, match=r"cannot write .*wide\.png: the \.png encoder refused a 1000001 x 1 image"):
        write_image(tmp_path / "wide.png", np.zeros((1, 1_000_001), np.float32))
    assert capfd.readouterr().err == ""
    assert list(tmp_path.iterdir()) == []
