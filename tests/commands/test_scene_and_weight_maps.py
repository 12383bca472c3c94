"""What the rendering commands and the workbench's specular jobs share in the library: a scene's stereo rig
(``scene_rig``) and the painted weight maps (``weight_maps``), refusing with the parameters named."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vergence.commands import ParameterError
from vergence.commands._scene import scene_rig
from vergence.commands._specular import weight_maps


def _cli(name: str) -> str:
    return "--" + name.replace("_", "-")


@pytest.fixture(scope="module")
def glasses():
    from vergence.render import builtin_scene

    return builtin_scene("glasses")


def test_the_scenes_rig_unless_the_lengths_are_given(glasses):
    left, right, b, h = scene_rig(glasses, None, None, needed_by="x")
    assert (b, h) == (0.065, 3.6)
    assert np.linalg.norm(np.asarray(right.center) - np.asarray(left.center)) == pytest.approx(0.065, rel=1e-12)
    assert scene_rig(glasses, 0.1, 2.0, needed_by="x")[2:] == (0.1, 2.0)


@pytest.mark.parametrize(("baseline", "convergence", "field"), [
    (0.0, None, "baseline must be in [1e-06, 1e+06] m (LENGTH_RANGE); got 0"),
    (None, float("nan"), "convergence must be in [1e-06, 1e+06] m (LENGTH_RANGE); got nan"),
    (1e6, None, "baseline must keep both eyes within"),
])
def test_a_bad_length_names_its_parameter(glasses, baseline, convergence, field):
    with pytest.raises(ParameterError) as caught:
        scene_rig(glasses, baseline, convergence, needed_by="x")
    assert caught.value.spelled(str).startswith(field)
    assert caught.value.spelled(_cli).startswith("--" + field)


def test_a_scene_without_a_rig_names_both_lengths_and_keeps_the_callers_words(glasses):
    with pytest.raises(ParameterError) as caught:
        scene_rig(dataclasses.replace(glasses, stereo=None), None, 2.0, needed_by="scene {a}: a job")
    assert caught.value.spelled(_cli) == ('scene {a}: a job needs --baseline and --convergence (the scene has no '
                                          '"stereo" block)')


def test_weight_maps_refusals_name_the_parameter(tmp_path):
    np.save(tmp_path / "small.npy", np.ones((2, 2), np.float32))
    cases = [
        (["3"], "weight_map must be LAYER=FILE or TERM:LAYER=FILE; got '3'"),
        ([f"colour:2={tmp_path}/small.npy"], f"weight_map colour:2={tmp_path}/small.npy: unknown cost term 'colour'"),
        ([f"9={tmp_path}/small.npy"], f"weight_map 9={tmp_path}/small.npy: LAYER must be a whole number in 1..7 (the "
                                      "layers of depth 2, as report.json numbers them); got '9'"),
        ([f"2={tmp_path}/small.npy"], f"weight_map 2={tmp_path}/small.npy: the map must be 4 x 3 pixels (the "
                                      "render's W x H); got 2 x 2"),
        ([f"2={tmp_path}/no.png"], f"weight_map 2={tmp_path}/no.png: cannot read {tmp_path}/no.png: no such file"),
    ]
    for specs, field in cases:
        with pytest.raises(ParameterError) as caught:
            weight_maps(specs, n_layers=7, width=4, height=3)
        assert caught.value.spelled(str).startswith(field), caught.value
        assert caught.value.spelled(_cli).startswith("--weight-map ")
    with pytest.raises(ParameterError) as caught:
        weight_maps([f"9={tmp_path}/small.npy"], n_layers=7, width=4, height=3)
    assert "(the layers of --depth 2," in caught.value.spelled(_cli)
