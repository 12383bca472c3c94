"""The example scenes in the repository load and render: ``examples/scenes/quarry`` (issue 10's
held-out report scene, a non-planar background) and the scenes of ``docs/scenes.md``."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import vergence.render as vr
from vergence.io import read_image

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
QUARRY = EXAMPLES / "scenes" / "quarry"
MAX_ASSET_BYTES = 2_000_000  # the quarry's files stay small enough for the repository


def _make_module():
    spec = importlib.util.spec_from_file_location("quarry_make", QUARRY / "make.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def quarry_depth() -> np.ndarray:
    scene = vr.open_scene(QUARRY / "scene.json", width=32, height=18)
    return vr.render(scene, samples=1).depth


def test_quarry_loads_as_documented():
    scene = vr.load_scene(QUARRY / "scene.json")
    assert scene.name == "quarry"
    assert (scene.camera.width, scene.camera.height, scene.camera.fov_deg) == (480, 270, 12.0)
    assert scene.stereo.convergence == 30.0
    kinds = {type(o).__name__ for o in scene.objects}
    assert kinds == {"Mesh", "Rectangle", "Sphere"}
    # Everything is textured except the checkered ball: no flat-colour material.
    assert {type(m).__name__ for m in scene.materials.values()} == {"Texture", "Checker"}
    assert sum(p.stat().st_size for p in QUARRY.iterdir()) < MAX_ASSET_BYTES


def test_quarry_subject_is_nearer_than_its_non_planar_background(quarry_depth):
    depth = quarry_depth
    assert np.isfinite(depth).all()  # the hillside fills the frame: no sky behind the subject
    person = depth[9:12, 15:17]  # the person's torso, 30 m away (radius 0.25 m)
    np.testing.assert_allclose(person, 30.0, atol=0.6)
    assert depth.min() > 25.0  # the nearest thing in view: the ground at the bottom edge, 26 m
    top = depth[:3]  # conifers 45-60 m and the hillside behind them, up to about 80 m
    assert 40.0 < top.min() and top.max() < 90.0
    hill = top[top > 58.0]
    assert hill.size > 20 and np.ptp(hill) > 15.0  # the hillside's own depth spans > 15 m: not a plane
    assert np.median(person) < np.median(top) - 20.0


def test_quarry_hillside_runs_in_and_out():
    make = _make_module()
    front = make.hill_front(np.linspace(-10.0, 10.0, 201))
    assert 48.0 < front.min() < 55.0 and 72.0 < front.max() < 80.0  # its foot between ~50 and ~76 m


def test_quarry_files_match_make_py(tmp_path, monkeypatch):
    make = _make_module()
    monkeypatch.setattr(make, "HERE", tmp_path)
    make.main()
    committed = sorted(p.name for p in QUARRY.iterdir() if p.name != "make.py")
    assert sorted(p.name for p in tmp_path.iterdir()) == committed
    for name in committed:
        if name.endswith((".json", ".obj")):
            assert (tmp_path / name).read_text() == (QUARRY / name).read_text(), name
        else:
            np.testing.assert_array_equal(read_image(tmp_path / name), read_image(QUARRY / name), err_msg=name)
