"""``vergence synthesize``'s work called as the library: the bytes ``--json`` prints and the files it
writes, its hooks, and refusals in each face's words."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vergence.cli import main
from vergence.commands import ParameterError, command, to_json
from vergence.commands.synthesize import SYNTHESIS_BUDGET_ARCMIN, SYNTHESIS_DISPLAY, layout_file_name
from vergence.io import write_image


@pytest.fixture
def scene(tmp_path):
    """A 16 x 48 textured image and its metric depth (NPY): a near square before a far wall."""
    rng = np.random.default_rng(1)
    write_image(tmp_path / "image.png", rng.random((16, 48, 3)).astype(np.float32))
    depth = np.full((16, 48), 4.0, np.float32)
    depth[5:11, 20:28] = 1.0
    np.save(tmp_path / "depth.npy", depth)
    return tmp_path / "image.png", tmp_path / "depth.npy"


def _spelled_cli(exc: ParameterError) -> str:
    names = command("synthesize").cli_names
    return exc.spelled(lambda name: names[name])


@pytest.mark.parametrize("options", [
    {},  # no depth control: the default budget on the default display
    {"budget_px": 2.0, "views": 3, "format": "views", "bit_depth": 16},
    {"focal_px": 500.0, "interaxial": 0.065, "convergence": 2.0, "display": "laptop-15", "format": "anaglyph"},
])
def test_the_work_gives_the_bytes_the_command_prints_and_the_files_it_writes(capsys, scene, tmp_path, options):
    image, depth = scene
    out = tmp_path / "out"
    report = command("synthesize").run(image=image, depth=depth, out=out, **options)
    written = {p.name: p.read_bytes() for p in out.iterdir()}
    argv = [f"--{name.replace('_', '-')}={value}" for name, value in options.items()]
    assert main(["synthesize", str(image), str(depth), "--out", str(out), *argv, "--json"]) == 0
    printed = capsys.readouterr().out
    assert to_json(report.to_dict()) == printed
    assert {p.name: p.read_bytes() for p in out.iterdir()} == written  # the same views, layout and JSON
    assert json.loads(written["synthesis.json"]) == report.to_dict()
    assert [str(p) for p in report.outputs] == report.to_dict()["outputs"]
    views = options.get("views", 2)
    assert len(report.result.views) == views and report.outputs[views].name == layout_file_name(
        options.get("format", "sbs"))


def test_without_a_depth_control_the_default_budget_on_the_default_display(scene, tmp_path):
    image, depth = scene
    data = command("synthesize").run(image=image, depth=depth, out=tmp_path / "out").to_dict()
    assert data["control"] == "budget" and data["budget_arcmin"] == SYNTHESIS_BUDGET_ARCMIN == 30.0
    assert data["display"]["preset"] == SYNTHESIS_DISPLAY == "desktop-24"
    # the pair's parallax spans the budget: +-30 arcmin between the nearest and farthest depth
    assert max(abs(v) for v in data["parallax_range_arcmin"]) == pytest.approx(30.0, rel=1e-6)


def test_layout_file_names():
    assert layout_file_name("anaglyph") == "anaglyph.png"
    assert layout_file_name("views") == "views_tiled.png"
    assert layout_file_name("sbs") == "stereo_sbs.png"


def test_hooks_hear_the_stages_and_a_refusal_before_commit_leaves_nothing(scene, tmp_path):
    image, depth = scene
    heard = []
    out = tmp_path / "new" / "out"
    command("synthesize").run(image=image, depth=depth, out=out, progress=lambda f, m: heard.append((f, m)))
    assert [m for _, m in heard] == ["reading inputs", "synthesizing views", "writing outputs", "written"]
    assert [f for f, _ in heard] == sorted(f for f, _ in heard) and heard[-1][0] == 1.0

    def interrupted() -> None:
        raise KeyboardInterrupt

    other = tmp_path / "other" / "out"
    with pytest.raises(KeyboardInterrupt):
        command("synthesize").run(image=image, depth=depth, out=other, before_commit=interrupted)
    assert not (tmp_path / "other").exists()  # the folders the call created are removed again


@pytest.mark.parametrize(("options", "field", "cli"), [
    ({"views": 3}, "format sbs shows a stereo pair: use views 2 or format views; got views 3",
     "--format sbs shows a stereo pair: use --views 2 or --format views; got --views 3"),
    ({"bit_depth": 12}, "bit_depth must be 8 or 16; got 12", "--bit-depth must be 8 or 16; got 12"),
    ({"depth_scale": -1.0}, "depth_scale must be > 0; got -1", "--depth-scale must be > 0; got -1"),
    ({"display": "nope"}, "display: unknown display preset 'nope'", "--display: unknown display preset 'nope'"),
    ({"depth_kind": "inverse"}, "depth must lie in [0, 1] for inverse depth", "DEPTH must lie in [0, 1] for inverse"),
    ({"smooth_sigma": -1.0}, "smooth_sigma must lie in (0, ", "--smooth-sigma must lie in (0, "),
    ({"format": "{x}"}, "format must be one of anaglyph, ", "--format must be one of anaglyph, "),
])
def test_refusals_name_the_field_and_the_option(capsys, scene, tmp_path, options, field, cli):
    image, depth = scene
    out = tmp_path / "out"
    with pytest.raises(ParameterError) as caught:
        command("synthesize").run(image=image, depth=depth, out=out, **options)
    assert caught.value.spelled(str).startswith(field) and str(caught.value) == caught.value.spelled(str)
    assert _spelled_cli(caught.value).startswith(cli)
    argv = [f"--{name.replace('_', '-')}={value}" for name, value in options.items()]
    assert main(["synthesize", str(image), str(depth), "--out", str(out), *argv]) == 2
    assert capsys.readouterr().err == f"error: {_spelled_cli(caught.value)}\n"
    assert not out.exists()


def test_an_output_folder_that_is_a_file_is_refused(scene, tmp_path):
    image, depth = scene
    (tmp_path / "f{1}").write_text("mine")
    with pytest.raises(ParameterError) as caught:
        command("synthesize").run(image=image, depth=depth, out=tmp_path / "f{1}")
    assert caught.value.spelled(str) == f"out {tmp_path / 'f{1}'} is a file; give a folder"
    assert (tmp_path / "f{1}").read_text() == "mine"
