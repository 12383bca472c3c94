"""``vergence stereospace build`` and ``vergence stereospace pair`` on the synthetic collection, and refused input."""

from __future__ import annotations

import json
import re
import shutil
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.cli import main
from vergence.io import read_image
from vergence.stereospace import StereoState, load_space, pair_quality, pan, zoom


@pytest.fixture
def run(capsys):
    """``vergence ARGS`` in-process: (exit code, stdout, stderr)."""

    def _run(*args: object) -> tuple[int, str, str]:
        code = main([str(a) for a in args])
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    return _run


@pytest.fixture(scope="module")
def space_dir(synthetic_space, tmp_path_factory):
    cameras_path, images, _ = synthetic_space
    out = tmp_path_factory.mktemp("cli") / "space"
    assert main(["stereospace", "build", str(cameras_path), "--images", str(images), "--out", str(out)]) == 0
    return out


def test_build_writes_the_space_folder_and_a_summary(synthetic_space, run, tmp_path):
    cameras_path, images, built = synthetic_space
    out = tmp_path / "space"
    code, stdout, err = run("stereospace", "build", cameras_path, "--images", images, "--out", out, "--display", "tv-55")
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["map.png", "points.npz", "space.json"]
    assert read_image(out / "map.png").shape[:2] == (600, 700)
    assert "5 cameras (0 left out without an image, 0 unregistered), 150 points (file)" in stdout
    assert f"{len(built.graph.edges)} edges" in stdout and f"{len(built.space.regions)} regions" in stdout
    assert "vertex quality on tv-55" in stdout and re.search(r"built in \d+\.\d s", stdout)
    assert err.count("leave-one-out view of") == 5  # one progress line per camera, on stderr
    assert load_space(out).display_name == "tv-55"


def test_build_refuses_a_folder_that_is_not_empty_unless_forced(synthetic_space, run, tmp_path):
    cameras_path, images, _ = synthetic_space
    out = tmp_path / "space"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    args = ("stereospace", "build", cameras_path, "--images", images, "--out", out)
    code, _, err = run(*args)
    assert code == 2 and "not empty; give --force" in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
    code, _, err = run(*args, "--force")
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt", "map.png", "points.npz", "space.json"]


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (("--display", "imax"), "--display: unknown display preset 'imax'"),
        (("--images", "/nonexistent"), "--images must be a folder"),
    ],
)
def test_build_refuses_bad_input_and_writes_nothing(synthetic_space, run, tmp_path, extra, words):
    cameras_path, images, _ = synthetic_space
    out = tmp_path / "space"
    code, _, err = run("stereospace", "build", cameras_path, "--images", images, "--out", out, *extra)
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_pair_at_a_state(space_dir, run, tmp_path):
    out = tmp_path / "pair"
    code, stdout, err = run("stereospace", "pair", space_dir, "--at", "0,0.25,1,0.75", "--out", out)
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["anaglyph.png", "left.png", "map.png", "pair.json", "right.png"]
    left, right = read_image(out / "left.png"), read_image(out / "right.png")
    assert left.shape == right.shape == (48, 64, 3) and read_image(out / "anaglyph.png").shape == (48, 64, 3)
    record = json.loads((out / "pair.json").read_text())
    built = load_space(space_dir)
    state = StereoState((0, 1), 0.25, 0.75)
    assert (record["region"], record["li"], record["lj"]) == ([0, 1], 0.25, 0.75)
    assert_allclose(record["stereo_point"], built.space.point(0, 0.25, 1, 0.75))
    eyes = built.space.eyes(state)
    from vergence.camera import Camera

    first = Camera.from_dict(record["cameras"]["first"])
    assert_allclose(first.center, eyes[0], atol=1e-9)
    expected = pair_quality(built.collection, (first, Camera.from_dict(record["cameras"]["second"])), built.display,
                            zone=built.zone, trim=0.01)  # fmt: skip
    assert record["quality"]["range_arcmin"] == pytest.approx(expected["range_arcmin"])
    assert set(record["vertex_quality"]) == {"0,0", "0,1", "1,0", "1,1"}
    assert record["vertex_quality"]["0,0"]["quality"] == built.vertex((0, 1), 0, 0).quality
    assert record["map_quality"] == pytest.approx(built.quality_at(state))
    assert record["move"] == [] and record["swapped"] in (True, False)
    assert "pair at region (0, 1)" in stdout


def test_pair_from_a_state_with_pan_and_zoom(space_dir, run, tmp_path):
    out = tmp_path / "pair"
    code, stdout, err = run("stereospace", "pair", space_dir, "--from", "0,0.25,1,0.75", "--pan", "0.1",
                            "--zoom", "0.05", "--out", out, "--format", "sbs", "--no-map")  # fmt: skip
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["left.png", "pair.json", "right.png", "sbs.png"]
    record = json.loads((out / "pair.json").read_text())
    space = load_space(space_dir).space
    panned = pan(space, StereoState((0, 1), 0.25, 0.75), 0.1)
    zoomed = zoom(space, panned.state, 0.05)  # --pan first, then --zoom
    assert [m["action"] for m in record["move"]] == ["pan", "zoom"]
    assert [m["event"] for m in record["move"]] == [panned.event, zoomed.event]
    assert (record["region"], record["li"], record["lj"]) == (list(zoomed.state.region), zoomed.state.li, zoomed.state.lj)
    assert record["interocular"] == pytest.approx(space.point(0, 0.25, 1, 0.75)[3] + 0.05, abs=0.01)
    assert read_image(out / "sbs.png").shape == (48, 128, 3)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--at", "0,0.5,1"), "--at must be i,li,j,lj"),
        (("--at", "a,0.5,1,0.5"), "--at must be i,li,j,lj"),
        (("--at", "0,1.5,1,0.5"), "--at: li must lie in [0, 1]; got 1.5"),
        (("--at", "0,0.5,1,nan"), "--at: lj must lie in [0, 1]"),
        (("--at", "0,0.5,99,0.5"), "--at region (0, 99) does not exist"),
        (("--at", "1,0.5,0,0.5"), "--at region must have i <= j"),
        (("--at", "0,0.8,0,0.2"), "--at li must be <= lj on the triangle"),
        (("--at", "0,0.5,1,0.5", "--pan", "0.1"), "--pan and --zoom go with --from"),
        (("--from", "0,0.5,1,0.5"), "--from needs --pan V and/or --zoom V"),
        (("--from", "0,0.5,1,0.5", "--zoom", "inf"), "--zoom must be a finite number"),
        ((), "give either --at"),
        (("--at", "0,0.5,1,0.5", "--format", "hologram"), "--format must be one of"),
        (("--at", "0,0.5,1,0.5", "--method", "nerf"), "--method must be one of mls"),
    ],
)
def test_pair_refuses_bad_input_and_writes_nothing(space_dir, run, tmp_path, args, words):
    out = tmp_path / "pair"
    code, _, err = run("stereospace", "pair", space_dir, *args, "--out", out)
    assert code == 2 and words in err, err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_pair_refuses_a_missing_or_corrupt_space(space_dir, run, tmp_path):
    out = tmp_path / "pair"
    code, _, err = run("stereospace", "pair", tmp_path / "nowhere", "--at", "0,0.5,1,0.5", "--out", out)
    assert code == 2 and "does not exist" in err and not out.exists()
    broken = shutil.copytree(space_dir, tmp_path / "broken")
    (broken / "space.json").write_text('{"format": "vergence-stereospace", "version": 1')
    code, _, err = run("stereospace", "pair", broken, "--at", "0,0.5,1,0.5", "--out", out)
    assert code == 2 and "not valid JSON" in err and len(err.strip().splitlines()) == 1 and not out.exists()


# -- the shared collections (timings in docs/stereospace.md) -------------------------------------------
@pytest.mark.slow
def test_build_and_pair_on_kermit(shared_data, run, tmp_path):
    folder = shared_data / "collections" / "kermit"
    space = tmp_path / "kermit"
    start = time.perf_counter()
    code, stdout, err = run("stereospace", "build", folder / "bundle.out", "--images", folder, "--out", space)
    assert code == 0, err
    assert "9 cameras (0 left out without an image, 2 unregistered), 634 points (file)" in stdout
    code, stdout, err = run("stereospace", "pair", space, "--at", "0,0.3,1,0.6", "--out", tmp_path / "pair")
    assert code == 0, err
    left = read_image(tmp_path / "pair" / "left.png")
    assert left.shape == (480, 640, 3) and np.std(left) > 0.1
    assert time.perf_counter() - start < 120
