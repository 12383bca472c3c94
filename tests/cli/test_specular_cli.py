"""``vergence specular`` (S3, issue 12): its files, checked with an independent matcher, and refused input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cli_runs import run_main as _main
from vergence.report.specular_outputs import SPECULAR_OUTPUT_FILES

W, H = 48, 36
TINY = ["--width", str(W), "--height", str(H), "--k", "2", "--samples", "1"]
N = 7  # layers of --depth 2
# analysis.npz stores float32 arcmin; the independent matcher's float64 result is rounded the same way.
ARCMIN_TOL = 1e-4


@pytest.fixture(scope="module")
def glasses(tmp_path_factory):
    """One tiny run on glasses, with a painted map of ones (it must change nothing but the settings)."""
    from vergence.io import write_image

    tmp = tmp_path_factory.mktemp("glasses")
    ones = tmp / "ones.png"
    write_image(ones, np.ones((H, W), np.float32))
    out = tmp / "out"
    code, stdout, stderr = _main("specular", "glasses", "--out", str(out), *TINY, "--weight-map", f"absolute:2={ones}")
    assert code == 0, stderr
    return out, stdout, stderr


def test_every_file_is_written_and_loads(glasses):
    out, stdout, stderr = glasses
    # no progress bar off a terminal; at most the one note that the shared HDR sky is missing
    from vergence.render.builtin import shared_hdri

    hdr_missing = not shared_hdri("venice_sunset_1k.hdr").is_file()
    lines = [line for line in stderr.splitlines() if not line.startswith("warning: ")]  # objects outside the zone
    assert lines == [] or (hdr_missing and lines[0].startswith("note: HDR map") and len(lines) == 1), stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(SPECULAR_OUTPUT_FILES)
    for stem in ("physical_left", "right", "optimised_left"):
        with np.load(out / f"{stem}.npz") as npz:
            assert npz["radiance"].shape == npz["position"].shape == npz["normal"].shape == (N, H, W, 3)
            assert npz["beauty"].shape == (H, W, 3) and npz["depth"].shape == (H, W)
            assert list(npz["layer_names"])[:3] == ["first hit", "R", "T"]
            assert json.loads(str(npz["settings"]))["max_depth"] == 2
    with np.load(out / "offsets.npz") as npz:
        y = npz["y"]
    assert y.shape == (N, H, W) and y.dtype == np.float32
    assert ((y >= 0) & (y <= 1)).all() and (y[0] == 1).all()  # the diffuse (first) layer keeps y = 1
    assert (y[1:] < 1).any()  # something specular moved
    with np.load(out / "analysis.npz") as npz:
        for when in ("before", "after"):
            assert npz[f"disparity_{when}"].shape == (N, H, W, 2)
            assert npz[f"importance_{when}"].shape == npz[f"rivalry_{when}"].shape == (N, H, W)
        assert npz["present"].shape == (N, H, W) and npz["present"].dtype == bool
        np.testing.assert_array_equal(npz["y"], y)
        np.testing.assert_array_equal(npz["comfort_zone_arcmin"], [-60.0, 60.0])
    report = json.loads((out / "report.json").read_text())
    assert report["specular"] is True
    terms = {"absolute", "relative", "rivalry", "data", "total"}
    assert set(report["cost_before"]) == set(report["cost_after"]) == terms
    assert report["settings"]["k"] == 2 and report["settings"]["maps"] == ["absolute"]
    assert report["settings"]["variant"] == "comfort"  # DEFAULT_VARIANT
    layer = report["layers"][1]
    assert layer["layer"] == 2 and layer["name"] == "R" and layer["pixels"] > 0
    assert {"comfort_share_before", "comfort_share_after"} <= set(layer)
    assert "layer 2 (R)" in stdout and "importance-weighted" in stdout and "cost (mean per pixel)" in stdout
    assert str(out / "report.json") in stdout


def test_right_images_are_one_eye_and_left_images_differ(glasses):
    from vergence.io import read_image

    out = glasses[0]
    rights = [read_image(out / f"{m}_right.png") for m in ("physical", "optimised", "on_surface", "near_surface")]
    for r in rights[1:]:
        np.testing.assert_array_equal(r, rights[0])
    assert not np.array_equal(read_image(out / "physical_left.png"), read_image(out / "optimised_left.png"))
    assert read_image(out / "anaglyphs.png").shape == (2 * H, 2 * W, 3)


def test_an_independent_matcher_gives_the_analysis_disparities(glasses):
    # issue 12: "we run the command on scenes you do not have and check its outputs with an independent matcher"
    from vergence.specular import disparity_arcmin, layer_disparity
    from vergence.viewing import Display

    out = glasses[0]
    pos = {}
    for stem in ("physical_left", "right", "optimised_left"):
        with np.load(out / f"{stem}.npz") as npz:
            pos[stem] = npz["position"]
    with np.load(out / "analysis.npz") as npz:
        before, after = npz["disparity_before"], npz["disparity_after"]
        epsilon, window = float(npz["match_epsilon_m"]), tuple(int(v) for v in npz["match_window"])
    physical = layer_disparity(pos["physical_left"], pos["right"])  # its epsilon serves every offset
    assert (epsilon, window) == (physical.epsilon, physical.window)
    optimised = layer_disparity(pos["optimised_left"], pos["right"], epsilon=epsilon, window=window)
    display = Display.preset("samsung-2233rz")
    for match, stored in ((physical, before), (optimised, after)):
        mine = disparity_arcmin(match.disparity_px, display)
        np.testing.assert_array_equal(np.isnan(mine), np.isnan(stored))
        np.testing.assert_allclose(stored, mine, rtol=0, atol=ARCMIN_TOL * (1 + np.nanmax(np.abs(mine))))
    assert not np.array_equal(np.isnan(before), np.isnan(after))  # the optimisation changed what matches


def test_a_diffuse_scene_is_the_physical_pair(tmp_path):
    out = tmp_path / "out"
    code, stdout, stderr = _main("specular", "tabletop", "--out", str(out), *TINY)
    assert code == 0, stderr
    assert "no specular surface in view" in stdout
    assert json.loads((out / "report.json").read_text())["specular"] is False
    with np.load(out / "physical_left.npz") as phys, np.load(out / "optimised_left.npz") as opt:
        for name in ("radiance", "position", "normal", "depth", "beauty"):
            np.testing.assert_array_equal(opt[name], phys[name])
    with np.load(out / "offsets.npz") as npz:
        assert (npz["y"] == 1).all()


@pytest.fixture
def files(tmp_path):
    """Weight maps and scenes for the refusals, by name."""
    from vergence.io import write_image

    paths = {"small": tmp_path / "small.png", "neg": tmp_path / "neg.npy", "nan": tmp_path / "nan.npy",
             "huge": tmp_path / "huge.npy", "ok": tmp_path / "ok.png", "corrupt": tmp_path / "corrupt.png",
             "colour": tmp_path / "colour.png", "fish": tmp_path / "fish.json"}  # fmt: skip
    write_image(paths["small"], np.ones((H // 2, W // 2), np.float32))
    np.save(paths["neg"], np.full((H, W), -0.5, np.float32))
    np.save(paths["huge"], np.full((H, W), 1e7, np.float32))
    nan = np.ones((H, W), np.float32)
    nan[3, 4] = np.nan
    np.save(paths["nan"], nan)
    write_image(paths["ok"], np.ones((H, W), np.float32))
    paths["corrupt"].write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    colour = np.zeros((H, W, 3), np.float32)
    colour[..., 0] = 1.0
    write_image(paths["colour"], colour)
    paths["fish"].write_text(json.dumps({
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0], "fov_deg": 180, "width": 8,
                   "height": 6, "lens": "fisheye"},
        "environment": {"color": [1, 1, 1]}, "materials": {}, "objects": [],
        "stereo": {"baseline": 0.065, "convergence": 2.0},
    }))  # fmt: skip
    return paths


@pytest.mark.parametrize("args, message", [
    (["--weight-map", "2={small}"], "must be 48 x 36 pixels (the render's W x H); got 24 x 18"),
    (["--weight-map", "2={neg}"], "negative values (down to -0.5)"),
    (["--weight-map", "rivalry:2={nan}"], "holds NaN or inf"),
    (["--weight-map", "2={tmp}/missing.png"], "missing.png: no such file"),
    (["--weight-map", "2={corrupt}"], "corrupt.png"),
    (["--weight-map", "2={colour}"], "must be a grey image"),
    (["--weight-map", "0={ok}"], "LAYER must be a whole number in 1..7"),
    (["--weight-map", "8={ok}"], "LAYER must be a whole number in 1..7"),
    (["--weight-map", "R={ok}"], "LAYER must be a whole number in 1..7"),
    (["--weight-map", "colour:2={ok}"], "unknown cost term 'colour'; the terms are absolute, relative, rivalry, data"),
    (["--weight-map", "{ok}"], "--weight-map must be LAYER=FILE or TERM:LAYER=FILE"),
    (["--k", "1"], "--k must be a whole number in [2, 256]"),
    (["--display", "no-such-display"], "--display: "),
    (["--weights", "1,1,10"], "--weights must be four numbers in [0, 1e+06]"),
    (["--weights", "1,1,-10,0.1"], "--weights must be four numbers in [0, 1e+06]"),
    (["--weights", "1,1,nan,0.1"], "--weights must be four numbers in [0, 1e+06]"),
    (["--weights", "1e308,1,1,1"], "--weights must be four numbers in [0, 1e+06]"),
    (["--weight-map", "2={huge}"], "the map holds values up to 1e+07"),
    (["--absolute", "flat"], "--absolute must be one of screen, comfort"),
    (["--factor", "0"], "--factor must be a whole number in [1, 64]"),
    (["--depth", "9"], "--depth must be a whole number in [0, 6]"),
    (["--samples", "0"], "--samples must be >= 1"),
    (["--width", "20000", "--height", "20000"], "lower --width/--height, --depth or --samples"),
    (["--width", "1024", "--height", "1024", "--k", "256"], "(MAX_TABLE_BYTES): lower --k, --width/--height or --depth"),
])  # fmt: skip
def test_bad_input_is_one_line_and_writes_nothing(files, tmp_path, args, message):
    out = tmp_path / "out"
    fill = {name: str(p) for name, p in files.items()} | {"tmp": str(tmp_path)}
    code, stdout, stderr = _main("specular", "glasses", "--out", str(out), *TINY, *(a.format(**fill) for a in args))
    assert code == 2, stderr
    assert stderr.startswith("error: ") and stderr.count("\n") == 1 and message in stderr, stderr
    assert not out.exists()


def test_a_fisheye_camera_is_refused(files, tmp_path):
    out = tmp_path / "out"
    code, _, stderr = _main("specular", str(files["fish"]), "--out", str(out), "--k", "2")
    assert code == 2 and stderr.count("\n") == 1
    assert "needs a pinhole scene camera" in stderr and "got lens 'fisheye'" in stderr
    assert not out.exists()


def test_an_output_path_that_is_a_file_is_refused_before_the_renders(tmp_path):
    out = tmp_path / "out"
    out.write_text("keep me")
    code, _, stderr = _main("specular", "glasses", "--out", str(out), *TINY)
    assert code == 2 and stderr.startswith("error: ") and stderr.count("\n") == 1, stderr
    assert out.read_text() == "keep me"


def test_weight_maps_scale_layers_and_multiply(tmp_path):
    from vergence.cli.specular import weight_maps
    from vergence.io import write_image

    half = np.full((3, 4), 0.5, np.float32)
    write_image(tmp_path / "half8.png", half)  # 8-bit: 128 / 255
    write_image(tmp_path / "ramp16.png", np.linspace(0, 1, 12, dtype=np.float32).reshape(3, 4), bit_depth=16)
    np.save(tmp_path / "two.npy", np.full((3, 4), 2.0, np.float32))
    grey_rgb = np.repeat(half[..., None], 3, axis=-1)
    write_image(tmp_path / "grey_rgb.png", grey_rgb)
    maps = weight_maps([f"2={tmp_path / 'two.npy'}"], n_layers=3, width=4, height=3)
    assert sorted(maps) == ["absolute", "data", "relative", "rivalry"]  # LAYER=FILE: every term
    for m in maps.values():
        assert m.shape == (3, 3, 4)
        np.testing.assert_array_equal(m[1], 2.0)
        np.testing.assert_array_equal(m[[0, 2]], 1.0)
    maps = weight_maps([f"rivalry:3={tmp_path / 'half8.png'}", f"rivalry:3={tmp_path / 'two.npy'}",
                        f"rivalry:1={tmp_path / 'ramp16.png'}", f"data:3={tmp_path / 'grey_rgb.png'}"],
                       n_layers=3, width=4, height=3)  # fmt: skip
    assert sorted(maps) == ["data", "rivalry"]
    np.testing.assert_allclose(maps["rivalry"][2], 2.0 * 128 / 255, rtol=1e-6)  # repeated maps multiply
    np.testing.assert_allclose(maps["rivalry"][0].ravel(), np.round(np.linspace(0, 1, 12) * 65535) / 65535, rtol=1e-6)
    np.testing.assert_array_equal(maps["rivalry"][1], 1.0)
    np.testing.assert_allclose(maps["data"][2], 128 / 255, rtol=1e-6)
    assert weight_maps([], n_layers=3, width=4, height=3) == {}


def test_help_states_the_library_defaults():
    from vergence.specular import DEFAULT_VARIANT, PLAN_FACTOR

    code, out, _ = _main("specular", "--help")
    text = " ".join(out.replace("│", " ").split())
    assert code == 0
    assert f"Default: {DEFAULT_VARIANT}." in text and f"default {PLAN_FACTOR})" in text
