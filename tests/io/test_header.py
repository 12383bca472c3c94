"""read_header: the format by content and the declared size, from the bytes of a file, nothing decoded."""

from __future__ import annotations

import io
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from vergence.io import HEADER_FORMATS, ImageHeader, read_header, write_image, write_pfm


def _bytes(tmp_path, name, image, **options):  # noqa: ANN001, ANN003, ANN202
    path = tmp_path / name
    (write_pfm if name.endswith(".pfm") else write_image)(path, image, **options)
    return path.read_bytes()


def _npy(array) -> bytes:  # noqa: ANN001
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


@pytest.mark.parametrize("name, image, options, expected", [
    ("rgb.png", np.zeros((5, 7, 3)), {}, ImageHeader("png", 7, 5, 3, "uint8")),
    ("grey16.png", np.zeros((5, 7)), {"bit_depth": 16}, ImageHeader("png", 7, 5, 1, "uint16")),
    ("rgb.jpg", np.zeros((9, 4, 3)), {}, ImageHeader("jpeg", 4, 9, 3, "uint8")),
    ("grey.jpg", np.zeros((9, 4)), {}, ImageHeader("jpeg", 4, 9, 1, "uint8")),
    ("grey.pfm", np.zeros((3, 2), np.float32), {}, ImageHeader("pfm", 2, 3, 1, "float32")),
    ("rgb.pfm", np.zeros((3, 2, 3), np.float32), {}, ImageHeader("pfm", 2, 3, 3, "float32")),
])
def test_files_written_by_vergence(tmp_path, name, image, options, expected):
    header = read_header(_bytes(tmp_path, name, image, **options))
    assert header == expected and header.pixels == expected.width * expected.height
    assert HEADER_FORMATS[header.format] == "." + name.rsplit(".", 1)[1]


def test_an_rgba_png_counts_its_alpha_and_a_jpeg_after_exif_is_found():
    buffer = io.BytesIO()
    Image.new("RGBA", (6, 2)).save(buffer, format="PNG")
    assert read_header(buffer.getvalue()) == ImageHeader("png", 6, 2, 4, "uint8")
    buffer = io.BytesIO()
    exif = Image.Exif()
    exif[0x010E] = "x" * 5000  # an APP1 segment of 5 kB before the start of frame
    Image.new("RGB", (3, 8)).save(buffer, format="JPEG", exif=exif)
    assert read_header(buffer.getvalue()) == ImageHeader("jpeg", 3, 8, 3, "uint8")


@pytest.mark.parametrize("array, expected", [
    (np.zeros((4, 5), np.float32), ImageHeader("npy", 5, 4, 1, "float32")),
    (np.zeros((4, 5, 3), np.uint16), ImageHeader("npy", 5, 4, 3, "uint16")),
    (np.asfortranarray(np.zeros((4, 5))), ImageHeader("npy", 5, 4, 1, "float64")),
])
def test_npy(array, expected):
    assert read_header(_npy(array)) == expected


def test_a_header_alone_is_enough_for_png_pfm_and_npy():
    ihdr = struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    assert read_header(png) == ImageHeader("png", 100_000, 100_000, 3, "uint8")
    assert read_header(b"Pf\n640 480\n-1.0\n").pixels == 307_200
    assert read_header(_npy(np.zeros((7, 3)))[:128]).width == 3


@pytest.mark.parametrize("data, message", [
    (b"GIF89a", "content is not PNG, JPEG, PFM or NPY"),
    (b"", "content is not PNG, JPEG, PFM or NPY"),
    (b"\x89PNG\r\n\x1a\n", "PNG header is truncated"),
    (b"\xff\xd8\xff\xe0\x00\x10", "JPEG header is truncated or malformed"),
    (b"PF\nwide\n", "PFM header is malformed"),
    (b"\x93NUMPY\x01\x00garbage", "not a valid .npy header"),
    (_npy(np.zeros(5)), "shape (H, W) or (H, W, C)"),
    (_npy(np.zeros((2, 2, 2, 2))), "shape (H, W) or (H, W, C)"),
    (_npy(np.array([[None]], dtype=object)), "must be numeric"),
])
def test_unknown_or_broken_content(data, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_header(data)


def test_data_must_be_bytes():
    with pytest.raises(TypeError, match="^data must be bytes; got str$"):
        read_header("\x89PNG")  # type: ignore[arg-type]
