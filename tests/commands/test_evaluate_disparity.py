"""``vergence evaluate-disparity``'s work called as the library: the bytes ``--json`` prints and
refusals in each face's words."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.cli import main
from vergence.commands import ParameterError, command, to_json
from vergence.io import write_disparity, write_image


@pytest.fixture
def maps(tmp_path):
    """A 40 x 50 disparity (a step), an estimate off by 2 px on a 10 x 10 block, official masks."""
    truth = np.full((40, 50), 8.0, np.float32)
    truth[:, 25:] = 12.0
    estimate = truth.copy()
    estimate[15:25, 5:15] += 2.0
    write_disparity(tmp_path / "truth.pfm", truth)
    write_disparity(tmp_path / "estimate.pfm", estimate)
    (tmp_path / "masks").mkdir()
    nonocc = np.ones((40, 50), np.float32)
    nonocc[:, :10] = 0.0  # the estimate's error lies half in, half out of this region
    write_image(tmp_path / "masks" / "nonocc.png", nonocc)
    write_image(tmp_path / "masks" / "all.png", np.ones((40, 50), np.float32))
    return tmp_path / "estimate.pfm", tmp_path / "truth.pfm", tmp_path / "masks"


def _spelled_cli(exc: ParameterError) -> str:
    names = command("evaluate-disparity").cli_names
    return exc.spelled(lambda name: names[name])


@pytest.mark.parametrize("official", [False, True])
def test_the_work_gives_the_bytes_the_command_prints(capsys, maps, official):
    estimate, truth, masks = maps
    extra = {"masks": masks} if official else {"border": 0}
    report = command("evaluate-disparity").run(estimate=estimate, truth=truth, threshold=1.5, **extra)
    argv = ["--masks", str(masks)] if official else ["--border", "0"]
    assert main(["evaluate-disparity", str(estimate), str(truth), "--threshold", "1.5", *argv, "--json"]) == 0
    assert to_json(report.to_dict()) == capsys.readouterr().out
    if official:  # by hand: 50 of the 100 wrong pixels lie in the 40 x 40 nonocc region, all 100 in all
        assert set(report.scores) == {"nonocc", "all"}
        assert report.scores["nonocc"].bad == pytest.approx(100.0 * 50 / 1600)
        assert report.scores["all"].bad == pytest.approx(100.0 * 100 / 2000)


@pytest.mark.parametrize(("options", "field", "cli"), [
    ({"masks": "masks", "border": 3}, "masks replaces the computed regions; do not combine it with truth_right, image "
     "or border", "--masks replaces the computed regions; do not combine it with --truth-right, --image or --border"),
    ({"threshold": -1.0}, "threshold must be > 0; got -1", "--threshold must be > 0; got -1"),
    ({"estimate_scale": 16.0}, "estimate_scale applies to .png/.pgm disparity maps only",
     "--estimate-scale applies to .png/.pgm disparity maps only"),
    ({"border": -1}, "border must be an integer >= 0; got -1", "--border must be an integer >= 0; got -1"),
])
def test_refusals_name_the_field_and_the_option(capsys, maps, options, field, cli):
    estimate, truth, masks = maps
    values = {k: masks if v == "masks" else v for k, v in options.items()}
    with pytest.raises(ParameterError) as caught:
        command("evaluate-disparity").run(estimate=estimate, truth=truth, **values)
    assert caught.value.spelled(str).startswith(field) and _spelled_cli(caught.value).startswith(cli)
    argv = [f"--{name.replace('_', '-')}={value}" for name, value in values.items()]
    assert main(["evaluate-disparity", str(estimate), str(truth), *argv]) == 2
    assert capsys.readouterr().err == f"error: {_spelled_cli(caught.value)}\n"


def test_an_image_of_another_size_is_refused_by_name(maps, tmp_path):
    estimate, truth, _ = maps
    write_image(tmp_path / "small.png", np.zeros((8, 8, 3), np.float32))
    with pytest.raises(ParameterError) as caught:
        command("evaluate-disparity").run(estimate=estimate, truth=truth, image=tmp_path / "small.png")
    assert caught.value.spelled(str) == "image must have shape (H, W) matching truth (40, 50); got (8, 8)"
    assert _spelled_cli(caught.value) == "--image must have shape (H, W) matching truth (40, 50); got (8, 8)"
