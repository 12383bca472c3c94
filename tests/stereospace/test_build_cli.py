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
from vergence.camera import Camera
from vergence.stereospace import StereoState, load_space, pair_quality, pan, zoom
from vergence.viewing import arcmin_from_pixels


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
        ((), "give exactly one of --at"),
        (("--at", "0,0.5,1,0.5", "--best"), "give exactly one of --at"),
        (("--near", "v9"), "--near: no camera 'v9' in the collection"),
        (("--best", "--size", "64"), "--size must be WxH"),
        (("--best", "--size", "0x10"), "--size must be (width, height), whole numbers of pixels in [1, 4096]"),
        (("--best", "--framing", "zoom"), "--framing must be one of fit, crop"),
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


def test_pair_refuses_a_damaged_points_file_in_one_line(space_dir, run, tmp_path):
    broken = shutil.copytree(space_dir, tmp_path / "broken")
    for damage in (b"", b"PK\x03\x04 cut here", (space_dir / "points.npz").read_bytes()[:200]):
        (broken / "points.npz").write_bytes(damage)
        for args in (("pair", broken, "--best", "--out", tmp_path / "pair"), ("info", broken)):
            code, _, err = run("stereospace", *args)
            assert code == 2 and "points.npz is damaged" in err and len(err.strip().splitlines()) == 1, err
            assert "internal error" not in err and not (tmp_path / "pair").exists()


def test_pair_refuses_a_used_folder_unless_forced(space_dir, run, tmp_path):
    out = tmp_path / "pair"
    assert run("stereospace", "pair", space_dir, "--at", "0,0.25,1,0.75", "--out", out)[0] == 0
    first = (out / "pair.json").read_bytes()
    code, _, err = run("stereospace", "pair", space_dir, "--at", "0,0.5,1,0.5", "--out", out)
    assert code == 2 and "exists and is not empty; give --force" in err and len(err.strip().splitlines()) == 1
    assert (out / "pair.json").read_bytes() == first  # untouched: no mix of two states' files
    code, _, err = run("stereospace", "pair", space_dir, "--at", "0,0.5,1,0.5", "--out", out, "--force")
    assert code == 0, err
    assert json.loads((out / "pair.json").read_text())["li"] == 0.5


def test_pair_best_puts_the_eyes_at_the_best_vertex_cameras(space_dir, run, tmp_path):
    built = load_space(space_dir)
    stereo = [q for q in built.vertex_qualities.values() if q.cameras[0] != q.cameras[1]]
    best = max(stereo, key=lambda q: q.quality)
    code, _, err = run("stereospace", "pair", space_dir, "--best", "--out", tmp_path / "pair", "--no-map")
    assert code == 0, err
    record = json.loads((tmp_path / "pair" / "pair.json").read_text())
    centres = {tuple(np.round(Camera.from_dict(record["cameras"][e]).center, 9)) for e in ("first", "second")}
    assert centres == {tuple(np.round(built.collection.centers[c], 9)) for c in best.cameras}  # world positions
    assert record["chosen"] == {"by": "best", "cameras": [built.collection.names[c] for c in best.cameras],
                                "quality": best.quality}  # fmt: skip


def test_pair_near_a_camera_stands_at_its_centre(space_dir, run, tmp_path):
    built = load_space(space_dir)
    k = built.collection.names.index("v2.png")  # the middle of the row: neighbours on both sides
    code, _, err = run("stereospace", "pair", space_dir, "--near", "v2", "--out", tmp_path / "pair", "--no-map")
    assert code == 0, err
    record = json.loads((tmp_path / "pair" / "pair.json").read_text())
    assert_allclose(record["stereo_point"][:3], built.collection.centers[k], atol=1e-9)
    assert record["interocular"] > 0 and record["chosen"] == {"by": "near", "camera": "v2.png"}


def _disparity_range_arcmin(record, built):
    """The 1st-99th percentile range of the points' disparities in the written views, arcmin: from the
    rectified cameras of pair.json and the world points, not from the code's shift."""
    left, right = (Camera.from_dict(record["rectified"][e]) for e in ("left", "right"))
    xl, zl = left.project(built.collection.points)
    xr, zr = right.project(built.collection.points)
    seen = (zl > 0) & (zr > 0)
    for xy, cam in ((xl, left), (xr, right)):
        seen &= (np.abs(xy[:, 0] - (cam.width - 1) / 2) <= cam.width / 2) & (np.abs(xy[:, 1] - (cam.height - 1) / 2) <= cam.height / 2)
    d = xr[seen, 0] - xl[seen, 0]
    low, high = np.quantile(d, [0.01, 0.99])
    d = d[(d >= low) & (d <= high)]
    scale = built.display.resolution / left.width
    return arcmin_from_pixels(d.min() * scale, built.display), arcmin_from_pixels(d.max() * scale, built.display)


def test_the_convergence_shift_centres_the_disparities_in_the_zone(space_dir, run, tmp_path):
    built = load_space(space_dir)
    for flag in ("--shift", "--no-shift"):
        out = tmp_path / flag
        code, stdout, err = run("stereospace", "pair", space_dir, "--at", "0,0.5,1,0.5", "--out", out, flag)
        assert code == 0, err
        record = json.loads((out / "pair.json").read_text())
        low, high = _disparity_range_arcmin(record, built)
        shift = record["shift"]
        assert_allclose((low, high), shift["after_arcmin"], atol=0.05)
        zone = (built.zone.min_arcmin, built.zone.max_arcmin)
        if flag == "--shift":
            assert shift["applied"] and shift["fits"] and zone[0] < low < high < zone[1]
            assert (low + high) / 2 == pytest.approx(sum(zone) / 2, abs=0.5)  # centred
            assert "convergence shift" in stdout
        else:
            assert not shift["applied"] and shift["shift_px"] == 0 and shift["before_arcmin"] == shift["after_arcmin"]
    # the shift moved the right view against the left by shift_px: the cameras' principal points
    a = json.loads((tmp_path / "--shift" / "pair.json").read_text())
    b = json.loads((tmp_path / "--no-shift" / "pair.json").read_text())
    gap = lambda r: r["rectified"]["right"]["K"][0][2] - r["rectified"]["left"]["K"][0][2]  # noqa: E731
    assert gap(a) - gap(b) == pytest.approx(a["shift"]["shift_px"])


def test_a_range_wider_than_the_zone_is_warned(space_dir, run, tmp_path):
    # A wide pair of the synthetic row (measured 338 arcmin, the zone 120) and a narrow one (55).
    for state, wide in (("0,0,3,1", True), ("0,0.5,1,0.5", False)):
        code, _, err = run("stereospace", "pair", space_dir, "--at", state, "--out", tmp_path / state, "--no-map")
        assert code == 0, err
        record = json.loads((tmp_path / state / "pair.json").read_text())
        low, high = _disparity_range_arcmin(record, load_space(space_dir))
        assert (high - low > 120.0) == wide
        assert ("wider than the comfort zone" in err) == wide and record["shift"]["fits"] == (not wide)


def test_pair_size_and_framing(space_dir, run, tmp_path):
    code, _, err = run("stereospace", "pair", space_dir, "--best", "--size", "80x40", "--out", tmp_path / "p",
                       "--format", "sbs", "--no-map")  # fmt: skip
    assert code == 0, err
    assert read_image(tmp_path / "p" / "left.png").shape == (40, 80, 3)
    assert read_image(tmp_path / "p" / "sbs.png").shape == (40, 160, 3)
    record = json.loads((tmp_path / "p" / "pair.json").read_text())
    assert record["size"] == [80, 40] and record["framing"] == "fit"


def test_info_lists_the_best_states_and_the_cameras(space_dir, run):
    code, stdout, err = run("stereospace", "info", space_dir)
    assert code == 0, err
    lines = stdout.splitlines()
    assert lines[0].startswith(f"{space_dir}: ")  # the folder as given, however long the test's tmp path
    assert max(len(line) for line in lines[1:]) <= 80
    assert "v0 v1 v2 v3 v4" in stdout
    code, stdout, err = run("stereospace", "info", space_dir, "--json", "--top", "3")
    assert code == 0, err
    record = json.loads(stdout)
    built = load_space(space_dir)
    qualities = sorted((q.quality for q in built.vertex_qualities.values() if q.cameras[0] != q.cameras[1]), reverse=True)
    assert [b["quality"] for b in record["best"]] == qualities[:3]
    assert [c["name"] for c in record["cameras"]] == list(built.collection.names)
    first = record["best"][0]
    state = StereoState(tuple(first["region"]), first["li"], first["lj"])
    eyes = built.space.eyes(state)  # the state's eyes are the listed cameras, in the world
    names = [built.collection.names.index(n) for n in first["cameras"]]
    assert_allclose(sorted(map(tuple, eyes)), sorted(map(tuple, built.collection.centers[names])), atol=1e-12)
    assert run("stereospace", "info", space_dir, "--top", "0")[0] == 2


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
