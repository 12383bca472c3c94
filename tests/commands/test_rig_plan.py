"""``vergence rig plan``'s work called as the library: the bytes ``--json`` prints, refusals in each face's words."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vergence.cli import main
from vergence.commands import ParameterError, command, to_json

REPO = Path(__file__).resolve().parents[2]
SHOTS = sorted((REPO / "examples" / "shots").glob("*.json"))


@pytest.mark.parametrize("shot", SHOTS, ids=[p.stem for p in SHOTS])
def test_the_work_gives_the_bytes_the_command_prints(capsys, shot):
    assert main(["rig", "plan", str(shot), "--json"]) == 0
    printed = capsys.readouterr().out
    report = command("rig plan").run(shot=shot)
    assert to_json(report.to_dict()) == printed
    assert report.to_dict()["shot"] == str(shot) and report.shot.rig == report.to_dict()["rig"]


def test_a_refused_shot_is_the_planners_line_on_both_faces(capsys, tmp_path):
    data = json.loads((REPO / "examples" / "shots" / "stadium-quadri.json").read_text())
    data["setback"] = -5.0  # the real cameras in front of the virtual eyes
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError) as caught:
        command("rig plan").run(shot=path)
    assert main(["rig", "plan", str(path), "--json"]) == 2
    assert capsys.readouterr().err == f"error: {caught.value}\n"
    assert "setback" in str(caught.value)


def test_missing_and_unknown_parameters_name_the_field():
    plan = command("rig plan")
    with pytest.raises(ParameterError) as caught:
        plan.run()
    assert caught.value.spelled(str) == "missing shot"
    assert caught.value.spelled(lambda name: plan.cli_names[name]) == "missing SHOT"
    with pytest.raises(ParameterError, match="unknown parameter 'plot'; valid: shot"):
        plan.run(shot=SHOTS[0], plot="p.png")  # --plot is the command line's: the web has no such field
