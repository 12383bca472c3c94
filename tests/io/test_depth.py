"""read_depth: depth maps of a kind and scale."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.io import DEPTH_KINDS, read_depth, write_disparity, write_image


def test_metric_png_is_value_over_scale_with_zero_unknown(tmp_path):
    path = tmp_path / "depth.png"
    write_disparity(path, np.array([[1.5, np.nan, 2.0]]), scale=1000)
    assert_allclose(read_depth(path, kind="metric", scale=1000), [[1.5, np.nan, 2.0]])
    assert_allclose(read_depth(path, kind="disparity"), [[1500.0, np.nan, 2000.0]])  # default scale 1


def test_inverse_png_is_an_image_in_unit_range_with_zero_the_far_plane(tmp_path):
    path = tmp_path / "inverse.png"
    write_image(path, np.array([[0.0, 1.0]], np.float32))
    assert_array_equal(read_depth(path, kind="inverse"), [[0.0, 1.0]])  # 0 is a real value (far plane)
    assert_array_equal(read_depth(path, kind="inverse", scale=2.0), [[0.0, 0.5]])


def test_float_files_are_read_as_stored(tmp_path):
    path = tmp_path / "depth.npy"
    np.save(path, np.array([[1.0, np.inf]], np.float32))
    assert_array_equal(read_depth(path), [[1.0, np.nan]])
    with pytest.raises(ValueError, match="scale"):
        read_depth(path, scale=2.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "height"}, "kind must be one of " + ", ".join(DEPTH_KINDS) + "; got 'height'"),
        ({"scale": 0.0}, "scale must be > 0"),
    ],
)
def test_read_depth_bad_arguments(tmp_path, kwargs, match):
    path = tmp_path / "d.npy"
    np.save(path, np.ones((2, 2), np.float32))
    with pytest.raises(ValueError, match=match):
        read_depth(path, **kwargs)


def test_inverse_depth_must_be_single_channel(tmp_path):
    path = tmp_path / "rgb.png"
    write_image(path, np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ValueError, match="must be a single-channel image"):
        read_depth(path, kind="inverse")


# Issue 9: synthesize refused a render's .npz as "unknown disparity extension" (calling depth a disparity).
def test_unknown_depth_extension_speaks_of_depth(tmp_path):
    p = tmp_path / "left.npz"
    p.write_bytes(b"PK")
    with pytest.raises(ValueError, match=r"cannot read depth .*left.npz: unknown depth-map extension '.npz'; expected "
                                         r"one of .pfm, .npy, .png, .pgm \(a vergence render writes its depth as "
                                         r"\*_depth.pfm beside the .npz\)"):  # fmt: skip
        read_depth(p)
    (tmp_path / "d.tif").write_bytes(b"II")
    with pytest.raises(ValueError, match=r"unknown depth-map extension '.tif'; expected one of .pfm, .npy, .png, .pgm$"):
        read_depth(tmp_path / "d.tif")
