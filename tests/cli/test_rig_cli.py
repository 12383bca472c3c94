"""``vergence rig plan|render``: the shot files of examples/shots, tiny renders, and refused input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from vergence.cli import main

REPO = Path(__file__).resolve().parents[2]
SHOTS = sorted((REPO / "examples" / "shots").glob("*.json"))


@pytest.fixture
def run(capsys):
    """``vergence ARGS`` in-process: (exit code, stdout, stderr)."""

    def _run(*args: str) -> tuple[int, str, str]:
        code = main(list(args))
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    return _run


def _tiny(kind: str, tmp_path: Path, **extra: object) -> Path:
    """A stadium shot of 64x36 pixels (seconds to render)."""
    camera = {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "up": [0, 1, 0], "fov_deg": 8.0,
              "width": 64, "height": 36}  # fmt: skip
    if kind == "quadri":
        data = {"rig": "quadri", "scene": "stadium", "display": "tv-55", "camera": {**camera, "position": [0.0, 1.8, -20.0], "look_at": [0.0, 1.8, -30.0]},
                "baseline": 0.3, "convergence": 10.0, "setback": 20.0,
                "elements": [{"name": "subject", "point": [0.0, 1.0, -30.0]},
                             {"name": "background", "point": [0.0, 2.5, -64.0]}]}  # fmt: skip
    else:
        data = {"rig": "tri", "scene": "stadium", "display": "tv-55", "camera": camera,
                "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=20"], "reference": "round"}  # fmt: skip
    data.update(extra)
    path = tmp_path / f"{kind}.json"
    path.write_text(json.dumps(data))
    return path


def test_example_shots_exist():
    names = {p.name for p in SHOTS}
    assert {"stadium-quadri.json", "stadium-tri.json"} <= names


@pytest.mark.parametrize("shot", SHOTS, ids=[p.stem for p in SHOTS])
def test_plan_every_example_shot(run, shot):
    code, out, err = run("rig", "plan", str(shot), "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["rig"] in ("quadri", "tri")
    for cam in doc["cameras"]:
        assert {"name", "element", "eye", "camera"} <= set(cam)
        assert cam["eye"] in ("left", "right")
    if doc["rig"] == "quadri":
        assert len(doc["cameras"]) == 2 * len(doc["elements"])
        assert set(doc["virtual"]) >= {"left", "right"}
    else:
        assert [c["element"] for c in doc["cameras"]] == ["director", "subject", "background"]
        assert [c["eye"] for c in doc["cameras"]] == ["left", "right", "right"]
        assert set(doc["reference"]) == {"baseline", "convergence", "window"}
        assert len(doc["control_points"]) >= 2


def test_plan_quadri_focal_ratios_follow_eq_10(run, tmp_path):
    """f_e / f_v = (distance of the real camera to the element) / (distance of the virtual eye to it)."""
    code, out, err = run("rig", "plan", str(_tiny("quadri", tmp_path)), "--json")
    assert code == 0, err
    doc = json.loads(out)
    ratios = {c["name"]: c["fx_ratio"] for c in doc["cameras"]}
    # virtual centre at z = -20; real plane 20 m behind (z = 0): subject at 10 m from the eyes, 30 from the plane
    assert ratios["subject_left"] == pytest.approx(30.0 / 10.0, rel=1e-9)
    assert ratios["background_right"] == pytest.approx(64.0 / 44.0, rel=1e-9)
    base = {c["name"]: c["baseline"] for c in doc["cameras"]}
    assert base["subject_left"] == pytest.approx(0.3 * 3.0, rel=1e-9)  # b_e = b_v z_e / H_e


def test_plan_prints_a_table_and_plots(run, tmp_path):
    plot = tmp_path / "rig.png"
    code, out, err = run("rig", "plan", str(_tiny("tri", tmp_path)), "--plot", str(plot))
    assert code == 0, err
    assert "subject" in out and "background" in out and "director" in out
    assert plot.stat().st_size > 1000


@pytest.mark.parametrize("width", [80, 200])
def test_plan_fits_the_terminal_and_drops_no_column(run, width):
    """At 80 columns the table would squeeze "centre (m)" to nothing: one camera to two lines instead."""
    from vergence.cli._app import console

    saved = console._width
    console.width = width
    try:
        code, out, err = run("rig", "plan", str(Path(__file__).resolve().parents[2] / "examples" / "shots" / "stadium-quadri.json"))
    finally:
        console._width = saved
    assert code == 0, err
    assert max(len(line) for line in out.splitlines()) <= width
    assert "-0.30 2.80 -0.04" in out  # subject_left's centre, whichever the layout
    assert ("centre (m)" in out) == (width == 200)


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        ({"colour": 3}, "colour"),
        ({"rig": "penta"}, "rig"),
        ({"setback": -5.0}, "setback"),  # the real camera plane in front of the virtual eyes
        ({"elements": [{"name": "subject", "point": [0.0, 1.0, -15.0]}]}, "subject"),  # behind the virtual eyes
    ],
)
def test_plan_refuses_bad_quadri_shots_in_one_line(run, tmp_path, extra, needle):
    code, out, err = run("rig", "plan", str(_tiny("quadri", tmp_path, **extra)))
    assert code == 2, err
    line = err.strip()
    assert "\n" not in line and "Traceback" not in line and needle in line


def test_plan_refuses_constraints_psi_cannot_satisfy(run, tmp_path):
    # the background perceived nearer than the subject
    code, out, err = run("rig", "plan", str(_tiny("tri", tmp_path, constraints=["z=30,perceived=3,roundness=1", "z=65,perceived=2"])))
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_plan_refuses_a_missing_field(run, tmp_path):
    path = _tiny("tri", tmp_path)
    data = json.loads(path.read_text())
    del data["camera"]
    path.write_text(json.dumps(data))
    code, out, err = run("rig", "plan", str(path))
    assert code == 2 and "camera" in err


@pytest.mark.parametrize("kind", ["quadri", "tri"])
def test_render_writes_every_file_and_a_report(run, tmp_path, kind):
    out = tmp_path / "out"
    code, stdout, err = run("rig", "render", str(_tiny(kind, tmp_path)), "--out", str(out), "--samples", "1", "--supersample", "1")
    assert code == 0, err
    report = json.loads((out / "report.json").read_text())
    assert report["rig"] == kind
    for method in ("ulr", "bayesian"):
        for eye in ("left", "right"):
            assert (out / method / f"{eye}.png").is_file()
            assert (out / method / f"coverage_{eye}.png").is_file()
        right = report["methods"][method]["right"]
        assert 0.3 < right["coverage"] <= 1.0
        assert right["psnr"] > 20.0  # a real synthesis, not noise
        assert 0.0 <= right["dssim"] < 0.2
        # windows wholly inside the covered area: fewer pixels, none comparing a hole's black
        assert 0.0 < right["inside"] <= right["coverage"] and 0.0 <= right["dssim_inside"] < 0.2
        # the whole image, holes filled: never above the covered pixels' figure by more than noise
        assert 10.0 < right["psnr_filled"] <= right["psnr"] + 1.0 and 0.0 <= right["dssim_filled"] < 0.5
    assert (out / "truth" / "left.png").is_file() and (out / "truth" / "right.png").is_file()
    cams = sorted(p.name for p in (out / "cameras").glob("*.png"))
    assert len(cams) == (4 if kind == "quadri" else 3)
    assert (out / "mapped_disparity.pfm").is_file() == (kind == "tri")
    if kind == "tri":
        from vergence.io import read_pfm

        d = read_pfm(out / "mapped_disparity.pfm")
        assert d.shape == (36, 64) and np.isfinite(d).mean() > 0.9


def test_render_writes_nothing_when_a_source_is_refused(run, tmp_path):
    out = tmp_path / "out"
    code, stdout, err = run("rig", "render", str(_tiny("quadri", tmp_path, setback=-5.0)), "--out", str(out))
    assert code == 2, err
    assert not out.exists()


def test_render_refuses_unknown_weights(run, tmp_path):
    code, out, err = run("rig", "render", str(_tiny("tri", tmp_path)), "--out", str(tmp_path / "o"), "--weights", "mean")
    assert code == 2 and "--weights" in err


def test_render_defaults_match_the_library():
    import inspect

    from vergence.cli.rig import render
    from vergence.rigs.shoot import SHOT_SUPERSAMPLE

    assert inspect.signature(render).parameters["supersample"].default.default == SHOT_SUPERSAMPLE


def test_rig_help_reads_as_the_other_commands(run):
    code, out, _ = run("rig", "--help")
    assert code == 0 and "plan" in out and "render" in out
    assert "<bool>" not in out  # a flag shows no value type


def test_plan_refuses_an_element_just_in_front_of_the_virtual_cameras(run, tmp_path):
    """2 mm in front of the virtual plane (z = -20) with a 20 m setback: k = 1 + 20 / 0.002 = 10001x the
    virtual focal length, past QUADRI_MAX_FOCAL_RATIO (1000): refused, naming the element and the fix."""
    elements = [{"name": "ball", "point": [0.0, 1.8, -20.002]}, {"name": "background", "point": [0.0, 2.5, -64.0]}]
    code, out, err = run("rig", "plan", str(_tiny("quadri", tmp_path, elements=elements)))
    assert code == 2, err
    line = err.strip()
    assert "\n" not in line and "Traceback" not in line
    assert "'ball'" in line and "1e+04x" in line and "0.02 m in front" in line


def test_plan_warns_on_an_element_near_the_virtual_cameras(run, tmp_path):
    """0.5 m in front: k = 41, buildable but past QUADRI_WARN_FOCAL_RATIO (20): planned, one warning line."""
    elements = [{"name": "ball", "point": [0.0, 1.8, -20.5]}]
    code, out, err = run("rig", "plan", str(_tiny("quadri", tmp_path, elements=elements)), "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert len(doc["warnings"]) == 1 and "'ball'" in doc["warnings"][0] and "41x" in doc["warnings"][0]
    assert [ln for ln in err.splitlines() if ln.startswith("warning:")] == [f"warning: {doc['warnings'][0]}"]


def test_plan_warns_on_a_baseline_of_a_thousand_kilometres(run, tmp_path):
    """b_v = 1e6 m against elements 10 and 44 m away: the eyes would converge by ~180 degrees: warned per element."""
    code, out, err = run("rig", "plan", str(_tiny("quadri", tmp_path, baseline=1e6)))
    assert code == 0, err
    warnings = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert len(warnings) == 2 and all("baseline 1e+06 m" in w for w in warnings)
    code, out, err = run("rig", "plan", str(_tiny("quadri", tmp_path)))  # 0.3 m: no warning
    assert code == 0 and "warning" not in err


def test_render_refuses_real_cameras_that_see_no_scene(run, tmp_path):
    """The rig 50 m under the stadium's ground, looking down: every real camera sees sky (or nothing),
    0 % coverage: refused in one line before the virtual eyes are traced, nothing written."""
    camera = {"position": [0.0, -50.0, -20.0], "look_at": [0.0, -60.0, -30.0], "up": [0, 1, 0], "fov_deg": 8.0,
              "width": 32, "height": 18}  # fmt: skip
    elements = [{"name": "subject", "point": [0.0, -60.0, -30.0]}]
    out = tmp_path / "out"
    code, stdout, err = run("rig", "render", str(_tiny("quadri", tmp_path, camera=camera, elements=elements)), "--out",
                            str(out), "--samples", "1", "--supersample", "1")  # fmt: skip
    assert code == 2, err
    line = err.strip().splitlines()[-1]
    assert "Traceback" not in err and "0 % coverage" in line
    assert not out.exists()


def test_plan_passes_on_the_mappings_comfort_warning(run, tmp_path):
    """The tiny Tri-Rig's background perceived 20 m away leaves the +-60' zone: `vergence mapping` warns,
    and so does `rig plan` (one line on stderr, and in the JSON)."""
    code, out, err = run("rig", "plan", str(_tiny("tri", tmp_path)), "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert len(doc["warnings"]) == 1 and "comfort zone" in doc["warnings"][0]
    assert [ln for ln in err.splitlines() if ln.startswith("warning:")] == [f"warning: {doc['warnings'][0]}"]


def test_render_with_each_eyes_own_cameras_as_s0(run, tmp_path):
    """--sources eye: each virtual eye from its own 2 real cameras (S0 §5), said in report.json; the
    default blends all 4. A Tri-Rig has no per-eye cameras: refused, naming the option."""
    from vergence.rigs import load_shot
    from vergence.rigs.shoot import render_shot

    shot = load_shot(_tiny("quadri", tmp_path))
    own = render_shot(shot, weights=("ulr",), samples=1, supersample=1, sources="eye")
    every = render_shot(shot, weights=("ulr",), samples=1, supersample=1)
    assert own.report["sources"] == "eye" and every.report["sources"] == "all"
    for eye in ("left", "right"):
        assert own.results["ulr"][eye].weights.shape[0] == 2 and every.results["ulr"][eye].weights.shape[0] == 4
    code, out, err = run("rig", "render", str(_tiny("tri", tmp_path)), "--out", str(tmp_path / "o"), "--sources", "eye")
    assert code == 2 and "--sources" in err and "Tri-Rig" in err
    code, out, err = run("rig", "render", str(_tiny("quadri", tmp_path)), "--out", str(tmp_path / "o"), "--sources", "one")
    assert code == 2 and "--sources must be one of all, eye" in err


@pytest.mark.parametrize(("option", "value", "says"), [("--ulr-k", "0", "--ulr-k must be >= 1"),
                                                       ("--visibility-tolerance", "0", "--visibility-tolerance must be > 0"),
                                                       ("--visibility-tolerance", "nan", "--visibility-tolerance must be finite"),
                                                       ("--deformation-cap", "0.5", "--deformation-cap must be >= 1")])
def test_render_refuses_bad_ibr_settings_before_rendering(run, tmp_path, option, value, says):
    code, _out, err = run("rig", "render", str(_tiny("quadri", tmp_path)), "--out", str(tmp_path / "o"), option, value)
    assert code == 2 and says in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_render_uses_and_reports_the_ibr_settings(run, tmp_path):
    out = tmp_path / "out"
    code, _stdout, err = run("rig", "render", str(_tiny("quadri", tmp_path)), "--out", str(out), "--samples", "1",
                             "--supersample", "1", "--weights", "ulr", "--ulr-k", "1", "--visibility-tolerance", "0.02")
    assert code == 0, err
    report = json.loads((out / "report.json").read_text())
    assert report["ibr"] == {"k": 1, "occlusion_tolerance": 0.02, "deformation_cap": 20.0}
    from vergence.io import read_image

    # k = 1 reaches the synthesis: one source per pixel gives another image than the default k = 4's blend.
    out4 = tmp_path / "out4"
    code, _stdout, err = run("rig", "render", str(_tiny("quadri", tmp_path)), "--out", str(out4), "--samples", "1",
                             "--supersample", "1", "--weights", "ulr")
    assert code == 0, err
    assert np.abs(read_image(out / "ulr" / "left.png") - read_image(out4 / "ulr" / "left.png")).max() > 0.01
