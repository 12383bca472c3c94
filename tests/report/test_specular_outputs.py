"""write_specular_outputs: the file list, deterministic figures, an empty scene, refused arguments."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vergence.report.specular_outputs import SPECULAR_OUTPUT_FILES, write_specular_outputs


def _result(objects: bool):
    from vergence import render as vr
    from vergence.rigs import stereo_pair
    from vergence.specular import specular_stereo
    from vergence.viewing import Display

    if objects:
        scene = vr.open_scene("tabletop", width=32, height=24)
    else:  # nothing but sky: no layer has a surface anywhere
        scene = vr.scene_from_dict({"camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0],
                                               "fov_deg": 60, "width": 16, "height": 12},
                                    "environment": {"color": [1, 1, 1]}, "materials": {}, "objects": []})  # fmt: skip
    left, right = stereo_pair(scene.camera.build(), baseline=0.04, convergence=1.2)
    return specular_stereo(scene, left, right, Display.preset("samsung-2233rz"), k=2, samples=1)


@pytest.fixture(scope="module")
def tabletop():
    return _result(objects=True)


def test_files_are_the_documented_list_and_the_figures_repeat_byte_for_byte(tabletop, tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    written = write_specular_outputs(tabletop, first)
    assert [p.name for p in written] == list(SPECULAR_OUTPUT_FILES)
    assert all(p.parent == first and p.is_file() for p in written)
    write_specular_outputs(tabletop, second)
    for name in SPECULAR_OUTPUT_FILES:
        if name.endswith(".png"):  # the .npz zips carry a time stamp; the figures must not
            assert (first / name).read_bytes() == (second / name).read_bytes(), name
    assert json.loads((first / "report.json").read_text()) == tabletop.report()
    with np.load(first / "analysis.npz") as npz:
        np.testing.assert_array_equal(npz["disparity_before"], tabletop.before.disparity)
        np.testing.assert_array_equal(npz["present"], tabletop.before.present)
        assert list(npz["layer_names"]) == ["first hit", "R", "T", "RR", "RT", "TR", "TT"]


def test_one_exposure_for_every_image(tabletop, tmp_path):
    from vergence.io import read_image
    from vergence.render import auto_exposure, tonemap

    write_specular_outputs(tabletop, tmp_path)
    left = read_image(tmp_path / "physical_left.png")
    np.testing.assert_allclose(left, read_image(tmp_path / "physical_left_beauty.png"))
    # the right eye at the left eye's exposure, not its own (8-bit PNG: half a code of rounding)
    k = auto_exposure(tabletop.physical_left.beauty)
    np.testing.assert_allclose(read_image(tmp_path / "physical_right.png"), tonemap(tabletop.right.beauty, exposure=k),
                               atol=0.5 / 255 + 1e-6)  # fmt: skip


def test_a_scene_without_surfaces_still_writes_every_file(tmp_path):
    written = write_specular_outputs(_result(objects=False), tmp_path)
    assert [p.name for p in written] == list(SPECULAR_OUTPUT_FILES)


def test_refused_arguments(tabletop, tmp_path):
    with pytest.raises(TypeError, match="result must be a vergence.specular.SpecularResult; got dict"):
        write_specular_outputs({}, tmp_path)
    with pytest.raises(ValueError, match="anaglyph_method must be one of .*dubois.*; got 'blue'"):
        write_specular_outputs(tabletop, tmp_path, anaglyph_method="blue")
    with pytest.raises(FileNotFoundError, match="output folder does not exist"):
        write_specular_outputs(tabletop, tmp_path / "missing")
    assert list(tmp_path.iterdir()) == []
