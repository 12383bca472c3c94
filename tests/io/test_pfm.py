"""PFM reader/writer: byte order by the sign of the scale, bottom-to-top rows, strict sizes."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from vergence.io import read_pfm, write_pfm


def _pfm_bytes(kind: bytes, rows_top_to_bottom: np.ndarray, scale: bytes, dtype: str) -> bytes:
    """A PFM file built by hand: header, then the rows bottom to top in the given byte order."""
    h, w = rows_top_to_bottom.shape[:2]
    header = kind + b"\n%d %d\n" % (w, h) + scale + b"\n"
    return header + np.ascontiguousarray(rows_top_to_bottom[::-1], dtype=dtype).tobytes()


@pytest.mark.parametrize(("scale", "dtype"), [(b"-1.0", "<f4"), (b"1.0", ">f4"), (b"-0.5", "<f4"), (b"4", ">f4")])
def test_byte_order_follows_scale_sign_and_rows_are_flipped(tmp_path, scale, dtype):
    image = np.array([[1.0, 2.0, 3.0], [4.0, -5.5, np.inf]], np.float32)  # row 0 is the top
    path = tmp_path / "hand.pfm"
    path.write_bytes(_pfm_bytes(b"Pf", image, scale, dtype))
    out = read_pfm(path)
    assert out.dtype == np.float32 and out.dtype.isnative
    assert_array_equal(out, image)


def test_colour_file_hand_made(tmp_path):
    image = np.arange(2 * 2 * 3, dtype=np.float32).reshape(2, 2, 3)
    path = tmp_path / "c.pfm"
    path.write_bytes(_pfm_bytes(b"PF", image, b"-1.0", "<f4"))
    assert_array_equal(read_pfm(path), image)


def test_header_on_one_line_is_accepted(tmp_path):
    path = tmp_path / "one.pfm"
    path.write_bytes(b"Pf 2 1 -1\n" + np.array([7.0, 8.0], "<f4").tobytes())
    assert_array_equal(read_pfm(path), [[7.0, 8.0]])


def test_written_header_and_layout(tmp_path):
    path = tmp_path / "w.pfm"
    image = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    write_pfm(path, image)
    data = path.read_bytes()
    assert data.startswith(b"Pf\n3 2\n-1.0\n")
    # first stored row is the bottom row, little endian
    assert_array_equal(np.frombuffer(data[12:], "<f4"), [4, 5, 6, 1, 2, 3])
    write_pfm(path, np.zeros((2, 3, 3)))
    assert path.read_bytes().startswith(b"PF\n3 2\n-1.0\n")


@pytest.mark.parametrize("shape", [(4, 5), (4, 5, 3), (1, 1)])
def test_round_trip_is_exact_with_nan_and_inf(tmp_path, shape):
    rng = np.random.default_rng(1)
    image = (rng.standard_normal(shape) * 100).astype(np.float32)
    image.flat[0] = np.inf
    image.flat[-1] = np.nan
    path = tmp_path / "r.pfm"
    write_pfm(path, image)
    assert_array_equal(read_pfm(path), image)


def test_single_channel_3d_is_written_grey(tmp_path):
    path = tmp_path / "g.pfm"
    write_pfm(path, np.ones((2, 2, 1)))
    assert read_pfm(path).shape == (2, 2)


def test_truncated_and_padded_files_are_refused(tmp_path):
    path = tmp_path / "t.pfm"
    write_pfm(path, np.ones((3, 4)))
    data = path.read_bytes()
    path.write_bytes(data[:-5])
    with pytest.raises(ValueError, match=r"t\.pfm: PFM data is truncated \(43 bytes for 4 x 3 x 1 float32 = 48"):
        read_pfm(path)
    path.write_bytes(data + b"\x00")
    with pytest.raises(ValueError, match="longer than its header says"):
        read_pfm(path)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "the file is empty"),
        (b"P6\n2 2\n255\n" + bytes(12), "not a PFM file"),
        (b"Pf\n2 2\n0\n" + bytes(16), "scale must be non-zero"),
        (b"Pf\n0 2\n-1\n", r"size must be at least 1 x 1"),
        (b"Pf\n2 2\n", "not a PFM file"),
    ],
)
def test_bad_files(tmp_path, content, message):
    path = tmp_path / "bad.pfm"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=message):
        read_pfm(path)


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nope\.pfm: no such file"):
        read_pfm(tmp_path / "nope.pfm")
    with pytest.raises(IsADirectoryError, match="it is a directory"):
        read_pfm(tmp_path)
    with pytest.raises(TypeError, match="path must be a str or os.PathLike; got int"):
        read_pfm(3)


@pytest.mark.parametrize(
    ("image", "error", "message"),
    [
        (np.zeros((2, 2, 2)), ValueError, r"shape \(H, W\), \(H, W, 1\) or \(H, W, 3\) for PFM; got \(2, 2, 2\)"),
        (np.zeros((0, 3)), ValueError, "must not be empty"),
        (np.zeros(5), ValueError, "for PFM; got"),
        (np.zeros((2, 2), bool), TypeError, "real-valued array; got dtype bool"),
        (np.array([["a"]]), TypeError, "real-valued array"),
    ],
)
def test_write_bad_input(tmp_path, image, error, message):
    with pytest.raises(error, match=message):
        write_pfm(tmp_path / "x.pfm", image)
    assert list(tmp_path.iterdir()) == []
