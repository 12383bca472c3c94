"""The example scenes in the repository load and render: ``examples/scenes/quarry`` (issue 10's
held-out report scene, a non-planar background), ``far_mirror.json`` (a mirror reflecting a far
backdrop, for S3 specular disparity) and the scenes of ``docs/scenes.md``."""

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


FAR_MIRROR = EXAMPLES / "scenes" / "far_mirror.json"


def test_far_mirror_reflects_only_the_far_backdrop():
    scene = vr.open_scene(FAR_MIRROR, width=32, height=24)
    assert (scene.stereo.baseline, scene.stereo.convergence) == (0.065, 2.75)
    result = vr.render(scene, samples=1)
    depth = result.depth[np.isfinite(result.depth)]
    assert 2.3 < depth.min() and depth.max() < 4.8  # the room: first hits 2.4-4.7 m
    first, reflected = result.position[0], result.position[1]
    n = np.array([0.5736, 0.0, 0.8192]) / np.hypot(0.5736, 0.8192)
    on_mirror = np.abs((first - np.array([0.8, 1.25, -2.8])) @ n) < 1e-3
    assert on_mirror.mean() > 0.15  # the mirror covers about a fifth of the frame
    assert np.isfinite(reflected[on_mirror]).all()  # every mirror pixel reflects a surface, no sky
    bounce = np.linalg.norm(reflected[on_mirror] - first[on_mirror], axis=-1)
    assert bounce.min() > 30.0  # ... and that surface is the backdrop, 35 m away, never the room


def test_far_mirror_reflection_lies_outside_the_comfort_zone():
    from vergence.specular import disparity_arcmin, layer_disparity
    from vergence.viewing import Display

    scene = vr.open_scene(FAR_MIRROR, width=64, height=48)
    left, right = vr.render_stereo(scene, baseline=0.065, convergence=2.75, samples=1)
    matches = layer_disparity(left.position, right.position)
    arcmin = disparity_arcmin(matches.disparity_px, Display.preset("desktop-24"))[..., 0]
    room = arcmin[0][matches.matched[0]]
    mirror = np.abs((left.position[0] - np.array([0.8, 1.25, -2.8])) @ np.array([0.5736, 0.0, 0.8192])) < 1e-3
    reflection = arcmin[1][mirror & matches.matched[1]]
    assert matches.matched[1][mirror].mean() > 0.9  # the far reflection stays inside the 81 x 9 window
    assert np.mean(np.abs(room) < 60.0) > 0.95  # the diffuse room: inside the +-60 arcmin zone
    assert np.median(reflection) > 75.0  # the reflection: uncrossed, well behind it (83' at 256 px)
