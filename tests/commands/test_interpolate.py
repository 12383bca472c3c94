"""``vergence interpolate``'s work called as the library: the bytes ``--json`` prints, the view and its
report written together or not at all, the hooks, and refusals in each face's words."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vergence.cli import main
from vergence.commands import ParameterError, command, to_json
from vergence.io import read_image, write_disparity, write_image

# 16-bit PNG views: the synthesized view is exact to a 16-bit step where both references agree.
PNG16_ATOL = 1e-4


@pytest.fixture
def references(tmp_path):
    """Left and right views of a two-layer scene (background d = 2, a square d = 8), their PNG
    disparities (scale 4), the true middle view, and a narrower image."""
    h, w = 12, 40
    xs = np.arange(w)[None, :].repeat(h, axis=0)

    def view(t):
        u_bg, u_fg = xs + 2.0 * t, xs + 8.0 * t
        inside = (u_fg >= 16) & (u_fg < 26) & (np.arange(h)[:, None] >= 3) & (np.arange(h)[:, None] < 9)
        return np.where(inside, 0.9, 0.3 + 0.2 * np.sin(u_bg / 4.0)).astype(np.float32), np.where(inside, 8.0, 2.0)

    for name, t in (("left", 0.0), ("right", 1.0), ("middle", 0.5)):
        img, disp = view(t)
        write_image(tmp_path / f"{name}.png", img, bit_depth=16)
        write_disparity(tmp_path / f"{name}_disp.png", disp, scale=4.0)
    write_image(tmp_path / "small.png", np.zeros((12, 30), np.float32), bit_depth=16)
    return {"left": tmp_path / "left.png", "left_disparity": tmp_path / "left_disp.png",
            "right": tmp_path / "right.png", "right_disparity": tmp_path / "right_disp.png", "disparity_scale": 4.0}


def _argv(values: dict) -> list[str]:
    return ["interpolate", *(f"--{k.replace('_', '-')}={v}" for k, v in values.items())]


def _cli(exc: ParameterError) -> str:
    names = command("interpolate").cli_names
    return exc.spelled(lambda name: names[name])


def test_the_work_gives_the_bytes_the_command_prints_and_writes(capsys, references, tmp_path):
    out, report_file = tmp_path / "mid.png", tmp_path / "mid.json"
    report = command("interpolate").run(**references, position=0.5, out=out, json_out=report_file)
    view = read_image(out)
    assert json.loads(report_file.read_text()) == report.to_dict()
    assert main([*_argv({**references, "position": 0.5, "out": out, "json_out": report_file}), "--json"]) == 0
    assert to_json(report.to_dict()) == capsys.readouterr().out
    np.testing.assert_array_equal(read_image(out), view)
    # integer shifts (1 and 4 px): away from the square's 1-px contour bands the view is the true one
    np.testing.assert_allclose(view[:, 2:10], read_image(tmp_path / "middle.png")[:, 2:10], atol=PNG16_ATOL)
    assert report.to_dict()["output"] == str(out) and report.to_dict()["holes_percent"] == 0.0


def test_the_progress_hook_hears_each_stage(references, tmp_path):
    heard = []
    command("interpolate").run(**references, position=0.25, out=tmp_path / "v.png",
                               progress=lambda f, m: heard.append((f, m)))
    assert heard == [(0.0, "reading inputs"), (0.5, "interpolating T = 0.25"), (1.0, "interpolated T = 0.25")]


def test_an_interrupted_commit_writes_neither_file(references, tmp_path):
    before = sorted(p.name for p in tmp_path.iterdir())

    def interrupted() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        command("interpolate").run(**references, position=0.5, out=tmp_path / "v.png", json_out=tmp_path / "v.json",
                                   before_commit=interrupted)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize(("options", "field", "cli"), [
    ({"bit_depth": 12}, "bit_depth must be 8 or 16; got 12", "--bit-depth must be 8 or 16; got 12"),
    ({"disparity_scale": 0.0}, "disparity_scale must be > 0; got 0", "--disparity-scale must be > 0; got 0"),
    ({"disparity_scale": 1e308}, "disparity_scale must lie in [1e-30, 1e+30] (it divides float32 values); got 1e+308",
     "--disparity-scale must lie in [1e-30, 1e+30] (it divides float32 values); got 1e+308"),
    ({"position": 1.5}, "position must lie in [0, 1]; got 1.5", "--position must lie in [0, 1]; got 1.5"),
    ({"edge_dilation": 10**20}, "edge_dilation must lie in [0, 64] pixels",
     "--edge-dilation must lie in [0, 64] pixels"),
    ({"right": "small.png"}, "right must have shape (12, 40) like left; got (12, 30)",
     "--right must have shape (12, 40) like left; got (12, 30)"),
    ({"json_out": "v.png"}, "json_out must differ from out; got {tmp}/v.png for both",
     "--json-out must differ from --out; got {tmp}/v.png for both"),
])
def test_refusals_name_the_field_and_the_option(capsys, references, tmp_path, options, field, cli):
    values = {**references, "position": 0.5, "out": tmp_path / "v.png"}
    values.update({k: tmp_path / v if k in ("right", "json_out") else v for k, v in options.items()})
    field, cli = (text.replace("{tmp}", str(tmp_path)) for text in (field, cli))
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(ParameterError) as caught:
        command("interpolate").run(**values)
    assert caught.value.spelled(str).startswith(field) and _cli(caught.value).startswith(cli)
    assert main(_argv(values)) == 2
    assert capsys.readouterr().err.startswith(f"error: {cli}")
    assert sorted(p.name for p in tmp_path.iterdir()) == before
