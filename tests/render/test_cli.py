"""``vergence render`` through ``vergence.cli.main``: files written, stereo output, one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from vergence.camera import Camera
from vergence.cli import main
from vergence.io import read_image

SMALL = ["--width", "16", "--height", "12", "--samples", "2"]


def test_render_single_view(tmp_path, capsys):
    assert main(["render", "tabletop", "--out", str(tmp_path / "out"), *SMALL, "--depth", "1"]) == 0
    out = tmp_path / "out"
    with np.load(out / "render.npz") as npz:
        assert npz["radiance"].shape == (3, 12, 16, 3) and npz["radiance"].dtype == np.float32
        assert npz["position"].shape == npz["normal"].shape == (3, 12, 16, 3)
        assert npz["depth"].shape == (12, 16) and npz["beauty"].shape == (12, 16, 3)
        assert_allclose(npz["beauty"], npz["radiance"].sum(axis=0))
        assert list(npz["layer_names"]) == ["first hit", "R", "T"]
        assert json.loads(str(npz["settings"]))["max_depth"] == 1
    cam = Camera.from_dict(json.loads((out / "render_camera.json").read_text()))
    assert (cam.width, cam.height) == (16, 12)
    assert read_image(out / "render_beauty.png").shape == (12, 16, 3)
    for name in ("render_depth.png", "render_layers.png"):
        assert read_image(out / name).shape[2] == 3
    assert "rendered tabletop" in capsys.readouterr().out


def test_render_both_eyes_uses_the_scene_rig(tmp_path):
    assert main(["render", "glasses", "--eye", "both", "--out", str(tmp_path), *SMALL]) == 0
    left = Camera.from_dict(json.loads((tmp_path / "left_camera.json").read_text()))
    right = Camera.from_dict(json.loads((tmp_path / "right_camera.json").read_text()))
    # The glasses scene's rig: b = 0.065 m along the camera's right axis.
    assert_allclose(right.center - left.center, 0.065 * left.R[0], atol=1e-12)
    assert left.principal_point[0] < right.principal_point[0]  # sensor shift towards each other
    for eye in ("left", "right"):
        assert (tmp_path / f"{eye}.npz").is_file() and (tmp_path / f"{eye}_beauty.png").is_file()
    assert not (tmp_path / "render.npz").exists()


def test_render_one_eye_with_explicit_rig(tmp_path):
    code = main(["render", "stadium", "--eye", "right", "--baseline", "0.2", "--convergence", "25", "--out",
                 str(tmp_path), *SMALL, "--depth", "0"])  # fmt: skip
    assert code == 0
    assert (tmp_path / "right.npz").is_file() and not (tmp_path / "left.npz").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["moon"], "scene must be a scene file or one of glasses, stadium, tabletop; got 'moon'"),
        (["tabletop", "--baseline", "0.1"], "--baseline and --convergence need --eye left, right or both"),
        (["tabletop", "--eye", "up"], "--eye must be one of left, right, both; got 'up'"),
        (["tabletop", "--depth", "9"], r"--depth must be an integer in [0, 6]; got 9"),
        (["tabletop", "--samples", "0"], "--samples must be >= 1; got 0"),
        (["tabletop", "--supersample", "0"], "--supersample must be >= 1; got 0"),
        # issue 9: "expected non-negative integer" without naming the option
        (["tabletop", "--seed", "-1"], "--seed: must be >= 0 (got -1)"),
        (["tabletop", "--preview", "sbs"], "--preview needs --eye both (a stereo pair)"),
        (["glasses", "--eye", "both", "--preview", "mosaic"], "--preview must be one of anaglyph, "),
        # the sweep: "baseline must be > 0" named the Python parameter; 1e308 printed a numpy overflow warning
        (["glasses", "--eye", "both", "--baseline", "-1"], "--baseline must be in [1e-06, 1e+06] m (LENGTH_RANGE); got -1"),
        (["glasses", "--eye", "left", "--baseline", "1e308", "--convergence", "1e-308"],
         "--baseline must be in [1e-06, 1e+06] m (LENGTH_RANGE); got 1e+308"),
        (["glasses", "--eye", "right", "--convergence", "nan"], "--convergence must be in [1e-06, 1e+06] m"),
        # issue 9 sweep kin: a baseline inside LENGTH_RANGE put the eyes 5e5 m out, past the scene's extent
        (["glasses", "--eye", "left", "--baseline", "1e6", "--convergence", "2"],
         "--baseline must keep both eyes within 100000 m of the origin (MAX_SCENE_EXTENT); they reach 4998"),
    ],
)
def test_render_errors_are_one_line(tmp_path, capsys, args, message):
    assert main(["render", *args, "--out", str(tmp_path / "o"), "--width", "8", "--height", "6"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err
    assert not (tmp_path / "o").exists()


def test_bad_scene_file_is_one_line_exit_2(tmp_path, capsys):
    scene = tmp_path / "scene.json"
    scene.write_text('{"camera": 1, "environment": {}, "materials": {}, "objects": []}')
    assert main(["render", str(scene), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "scene.json: camera must be a JSON object; got int" in err
    no_rig = tmp_path / "plain.json"
    no_rig.write_text(json.dumps({
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0], "fov_deg": 40, "width": 8, "height": 6},
        "environment": {"color": [1, 1, 1]}, "materials": {}, "objects": [],
    }))  # fmt: skip
    assert main(["render", str(no_rig), "--eye", "both", "--out", str(tmp_path / "o")]) == 2
    assert 'the scene has no "stereo" block' in capsys.readouterr().err


def test_import_vergence_does_not_import_mitsuba():
    import subprocess
    import sys

    code = "import sys, vergence, vergence.cli, vergence.rigs; print('mitsuba' in sys.modules, 'drjit' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def test_stderr_is_empty_on_success_and_one_line_on_error(tmp_path, capsys):
    # The progress bar is drawn only on a terminal: captured stderr holds nothing but errors.
    assert main(["render", "tabletop", "--out", str(tmp_path), *SMALL, "--depth", "0"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["render", "tabletop", "--out", str(tmp_path), *SMALL, "--depth", "-1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1


def test_eye_needs_a_pinhole_camera(tmp_path, capsys):
    scene = tmp_path / "fish.json"
    scene.write_text(json.dumps({
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0], "fov_deg": 180, "width": 8,
                   "height": 6, "lens": "fisheye"},
        "environment": {"color": [1, 1, 1]}, "materials": {}, "objects": [],
    }))  # fmt: skip
    assert main(["render", str(scene), "--eye", "left", "--baseline", "0.1", "--convergence", "2", "--out",
                 str(tmp_path / "o")]) == 2  # fmt: skip
    assert "--eye needs a pinhole scene camera (the rig shifts the sensor); got lens 'fisheye'" in capsys.readouterr().err


def test_render_supersampled(tmp_path, capsys):
    assert main(["render", "tabletop", "--out", str(tmp_path), *SMALL, "--depth", "0", "--supersample", "2"]) == 0
    with np.load(tmp_path / "render.npz") as npz:
        assert json.loads(str(npz["settings"]))["supersample"] == 2
    assert main(["render", "tabletop", "--out", str(tmp_path / "x"), *SMALL, "--supersample", "0"]) == 2
    assert "supersample must be >= 1; got 0" in capsys.readouterr().err


# Issue 9: a 100,000-level scene JSON was "internal error ... RecursionError" (exit 1); a folder "not found".
def test_deep_scene_and_folder_scene_are_one_line_exit_2(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    assert main(["render", str(deep), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nests arrays/objects more than 64 levels deep (MAX_JSON_DEPTH)" in err
    assert main(["render", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "is a folder; give a scene file (.json)" in err and "not found" not in err
    assert not (tmp_path / "o").exists()


# Issue 9: `--samples 100000000` ran for hours; `--width 1000000 --height 24` grew to 24 GB; `--width 1e20`
# (as an integer) was a Numba TypingError. Refused from the estimate, before any folder or allocation.
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--samples", "100000000"], "--samples 100000000, --supersample 1 may cast up to 3.07e+13 rays; "
                                     "the limit is 1e+09 (MAX_RENDER_RAYS)"),
        (["--width", "1000000", "--height", "24"], "--width must be <= 32768 pixels (MAX_RENDER_SIDE); got 1000000"),
        (["--width", "100000000000000000000"], "--width must be <= 32768 pixels (MAX_RENDER_SIDE)"),
        (["--width", "30000", "--height", "30000"], "needs an estimated 1.05e+03 GiB of memory; the limit is 8 GiB "
                                                    "(MAX_RENDER_BYTES)"),
        (["--width", "8000", "--height", "8000", "--eye", "both"], "x 2 view(s)"),
    ],
)
def test_render_past_the_limits_is_refused_before_starting(tmp_path, capsys, args, message):
    import time

    start = time.perf_counter()
    assert main(["render", "glasses", "--out", str(tmp_path / "o"), *args]) == 2
    assert time.perf_counter() - start < 5.0  # refused from the estimate, not after tracing
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err, err
    assert list(tmp_path.iterdir()) == []  # no output folder, no temporary folder


def test_render_output_is_all_or_nothing(tmp_path, monkeypatch):
    import vergence.report.preview as preview

    real = preview.save_render

    def interrupted(result, folder, **kw):  # a Ctrl-C after the first view's files
        real(result, folder, **kw)
        raise KeyboardInterrupt

    monkeypatch.setattr(preview, "save_render", interrupted)
    assert main(["render", "glasses", "--eye", "both", "--out", str(tmp_path / "o"), *SMALL, "--depth", "0"]) == 130
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "kept").mkdir()
    (tmp_path / "kept" / "notes.txt").write_text("mine")
    assert main(["render", "glasses", "--out", str(tmp_path / "kept"), *SMALL, "--depth", "0"]) == 130
    assert [p.name for p in tmp_path.iterdir()] == ["kept"]
    assert [p.name for p in (tmp_path / "kept").iterdir()] == ["notes.txt"]


# Issue 9: render wrote depth only inside .npz, which synthesize refused: the chain needed Python.
def test_render_depth_pfm_feeds_synthesize(tmp_path, capsys):
    from vergence.io import read_pfm

    assert main(["render", "tabletop", "--out", str(tmp_path / "r"), *SMALL, "--depth", "0"]) == 0
    with np.load(tmp_path / "r" / "render.npz") as npz:
        np.testing.assert_array_equal(read_pfm(tmp_path / "r" / "render_depth.pfm"), npz["depth"])
    code = main(["synthesize", str(tmp_path / "r" / "render_beauty.png"), str(tmp_path / "r" / "render_depth.pfm"),
                 "--out", str(tmp_path / "s"), "--budget-px", "2"])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    assert read_image(tmp_path / "s" / "left.png").shape == (12, 16, 3)


# Issue 9: no anaglyph/SBS preview for --eye both.
def test_render_both_eyes_preview_layout(tmp_path):
    assert main(["render", "glasses", "--eye", "both", "--preview", "sbs", "--out", str(tmp_path), *SMALL,
                 "--depth", "0"]) == 0  # fmt: skip
    left, right = read_image(tmp_path / "left_beauty.png"), read_image(tmp_path / "right_beauty.png")
    np.testing.assert_array_equal(read_image(tmp_path / "stereo_sbs.png"), np.concatenate([left, right], axis=1))
    assert main(["render", "glasses", "--eye", "both", "--preview", "anaglyph", "--out", str(tmp_path), *SMALL,
                 "--depth", "0"]) == 0  # fmt: skip
    assert read_image(tmp_path / "stereo_anaglyph.png").shape == (12, 16, 3)
