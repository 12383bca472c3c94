"""``vergence rectify``'s work called as the library: the bytes ``--json`` prints and rectification.json
holds, the five files or none, the hooks, and refusals in each face's words."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.cli import main
from vergence.commands import ParameterError, command, to_json
from vergence.commands.rectify import OUTPUTS
from vergence.io import CameraSet, read_image, write_image, write_middlebury_par

W, H = 64, 48  # px: the calibrated image size


@pytest.fixture
def calibrated(tmp_path):
    """A textured pair beside its Middlebury camera file (two cameras 0.1 apart on x, looking at z = 3),
    the pair at half size in a folder of its own, and a grey right view there too."""
    rng = np.random.default_rng(0)
    texture = rng.random((H, W + 3, 3)).astype(np.float32)
    write_image(tmp_path / "left.png", texture[:, 3:])
    write_image(tmp_path / "right.png", texture[:, :W])
    cams = tuple(look_at((x, 0.0, 0.0), (0.0, 0.0, 3.0), (0.0, -1.0, 0.0), fov_deg=50.0, width=W, height=H)
                 for x in (-0.05, 0.05))
    write_middlebury_par(tmp_path / "cameras_par.txt", CameraSet(names=("left.png", "right.png"), cameras=cams))
    (tmp_path / "other").mkdir()
    write_image(tmp_path / "other" / "left.png", texture[::2, 3::2])
    write_image(tmp_path / "other" / "right.png", texture[:, :W].mean(axis=2))
    return tmp_path / "left.png", tmp_path / "right.png", tmp_path / "cameras_par.txt"


def _cli(exc: ParameterError) -> str:
    names = command("rectify").cli_names
    return exc.spelled(lambda name: names[name])


def test_the_work_gives_the_bytes_the_command_prints_and_writes(capsys, calibrated, tmp_path):
    left, right, cameras = calibrated
    out = tmp_path / "rect"
    report = command("rectify").run(left=left, right=right, cameras=cameras, out=out)
    assert sorted(p.name for p in out.iterdir()) == sorted(OUTPUTS)
    assert json.loads((out / "rectification.json").read_text()) == report.to_dict()
    images = [read_image(out / name) for name in OUTPUTS[:4]]
    assert main(["rectify", str(left), str(right), "--cameras", str(cameras), "--out", str(out), "--json"]) == 0
    assert to_json(report.to_dict()) == capsys.readouterr().out
    for name, image in zip(OUTPUTS, images):
        np.testing.assert_array_equal(read_image(out / name), image)
    data = report.to_dict()
    assert data["left"] == "left.png" and data["right"] == "right.png" and "row_alignment" not in data
    assert data["baseline"] == pytest.approx(0.1)  # the cameras' centres, 0.1 apart


def test_hooks_hear_the_stages_and_the_commit(calibrated, tmp_path):
    left, right, cameras = calibrated
    heard = []
    out = tmp_path / "rect"
    command("rectify").run(left=left, right=right, cameras=cameras, out=out,
                           progress=lambda f, m: heard.append((f, m)), note=heard.append,
                           before_commit=lambda: heard.append(("commit", out.exists())))
    assert heard == [(0.0, "rectifying"), (1.0, "rectified"), ("commit", False)]  # a Middlebury file: no note


def test_an_interrupted_commit_writes_nothing(calibrated, tmp_path):
    left, right, cameras = calibrated
    before = sorted(p.name for p in tmp_path.iterdir())

    def interrupted() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        command("rectify").run(left=left, right=right, cameras=cameras, out=tmp_path / "rect",
                               before_commit=interrupted)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize(("options", "field", "cli"), [
    ({"left": "other/left.png"},
     "left left.png is 32x24 px, but its camera in cameras_par.txt belongs to the 64x48 image {tmp}/left.png: "
     "rectify the images at the size they were calibrated at",
     "LEFT left.png is 32x24 px, but its camera in cameras_par.txt belongs to the 64x48 image {tmp}/left.png: "
     "rectify the images at the size they were calibrated at"),
    ({"image_list": "cameras_par.txt"},
     "image_list applies to Bundler cameras (*.out) only; cameras_par.txt is a middlebury camera file",
     "--image-list applies to Bundler cameras (*.out) only; cameras_par.txt is a middlebury camera file"),
    ({"right": "other/right.png"}, "left and right must both be grey or both colour",
     "LEFT and RIGHT must both be grey or both colour"),
])
def test_refusals_name_the_field_and_the_option(capsys, calibrated, tmp_path, options, field, cli):
    left, right, cameras = calibrated
    values = {"left": left, "right": right, "cameras": cameras, "out": tmp_path / "rect"}
    values.update({k: tmp_path / v for k, v in options.items()})
    field, cli = (text.replace("{tmp}", str(tmp_path)) for text in (field, cli))
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(ParameterError) as caught:
        command("rectify").run(**values)
    assert caught.value.spelled(str).startswith(field) and _cli(caught.value).startswith(cli)
    argv = [str(values.pop("left")), str(values.pop("right"))]
    argv += [f"--{name.replace('_', '-')}={value}" for name, value in values.items()]
    assert main(["rectify", *argv]) == 2
    assert capsys.readouterr().err.startswith(f"error: {cli}")
    assert sorted(p.name for p in tmp_path.iterdir()) == before
