"""``vergence analyze``'s work called as the library: the bytes ``--json`` prints, the report, refusals in
each face's words."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("av", reason="the video extra is not installed: pip install 'vergence[video]'")

from vergence.cli import main  # noqa: E402
from vergence.commands import ParameterError, command, to_json  # noqa: E402


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    from vergence.video import make_test_clips

    # 8 frames per shot: the smallest clip whose shots pass MIN_SHOT_FRAMES (6)
    return make_test_clips(tmp_path_factory.mktemp("clips"), frames_per_shot=8)


def _printed(capsys, args: list[str]) -> str:
    assert main(["analyze", *args, "--json"]) == 0
    return capsys.readouterr().out


def test_the_work_gives_the_bytes_the_command_prints(clips, capsys):
    printed = _printed(capsys, [str(clips.stereo), "--display", "tv-55", "--every", "4", "--no-vertical"])
    done = command("analyze").run(input_path=clips.stereo, display="tv-55", every=4, no_vertical=True)
    assert to_json(done.to_dict()) == printed
    data = json.loads(printed)
    assert data["input"] == str(clips.stereo) and data["layout"] == "sbs" and data["frames"] == 16
    assert data["display"]["preset"] == "tv-55" and done.display.resolution == data["display"]["resolution"]


def test_a_2d_plus_depth_clip_and_its_report(clips, capsys, tmp_path):
    printed = _printed(capsys, [str(clips.rgbd), "--display", "desktop-24", "--every", "4", "--budget-arcmin", "20"])
    report, seen = tmp_path / "report", []
    done = command("analyze").run(input_path=clips.rgbd, display="desktop-24", every=4, budget_arcmin=20.0,
                                  report=report, before_commit=lambda: seen.append(sorted(report.glob("*"))))
    assert to_json(done.to_dict()) == printed
    assert "layout" not in done.to_dict() and done.to_dict()["budget_arcmin"] == 20.0
    assert seen == [[]]  # the files were not there yet when the hook ran: all or none
    assert json.loads((report / "analysis.json").read_text()) == json.loads(printed)


def test_progress_reaches_one_after_every_analysed_frame(clips):
    calls = []
    command("analyze").run(input_path=clips.stereo, display="tv-55", every=8, no_vertical=True,
                           progress=lambda f, m: calls.append((f, m)))
    assert calls[0] == (0.0, "analysing 16 frames") and calls[-1] == (1.0, "analysed 16 frames")
    assert [m for _, m in calls[1:-1]] == ["analysing frame 1 of 2", "analysing frame 2 of 2"]
    fractions = [f for f, _ in calls]
    assert fractions == sorted(fractions) and all(f < 1 for f in fractions[:-1])


@pytest.mark.parametrize(("values", "field", "option"), [
    ({"every": 0}, "every must be an integer >= 1; got 0", "--every must be an integer >= 1; got 0"),
    ({"display": "tv-99"}, "display: unknown display preset 'tv-99'", "--display: unknown display preset 'tv-99'"),
    ({"input_kind": "mono"}, "input_kind must be one of stereo, 2d+depth; got 'mono'",
     "--input-kind must be one of stereo, 2d+depth; got 'mono'"),
    # the budget applies to a stereo clip too (its suggestion says how convert would map it there)
    ({"budget_arcmin": 0.0}, "budget_arcmin must be a number in (0, 600]; got 0.0",
     "--budget-arcmin must be a number in (0, 600]; got 0.0"),
    ({"layout": "lr"}, "layout must be one of sbs, half-sbs, tb, half-tb; got 'lr'",
     "--layout must be one of sbs, half-sbs, tb, half-tb; got 'lr'"),
    ({"comfort_arcmin": -1.0}, "comfort_arcmin must lie in", "--comfort-arcmin must lie in"),
])
def test_a_refusal_names_the_field_and_the_command_line_the_option(clips, capsys, values, field, option):
    analyze = command("analyze")
    with pytest.raises(ParameterError) as caught:
        analyze.run(**{"input_path": clips.stereo, "display": "tv-55", **values})
    assert caught.value.spelled(str).startswith(field)
    assert caught.value.spelled(lambda name: analyze.cli_names[name]).startswith(option)
    args = [f"--{k.replace('_', '-')}={v}" for k, v in values.items()]
    assert main(["analyze", str(clips.stereo), *(args if "display" in values else ["--display", "tv-55", *args])]) == 2
    assert capsys.readouterr().err.startswith(f"error: {option}")


def test_options_of_a_stereo_input_are_refused_for_2d_plus_depth(clips):
    with pytest.raises(ParameterError) as caught:
        command("analyze").run(input_path=clips.rgbd, display="tv-55", method="bm", no_vertical=True)
    assert caught.value.spelled(str) == ("method, no_vertical apply to a stereo input_path; clips_RGBD.mp4 is read as "
                                         "2d+depth (input_kind)")


def test_a_missing_input_names_the_argument(tmp_path):
    analyze = command("analyze")
    with pytest.raises(ParameterError) as caught:
        analyze.run(input_path=tmp_path / "none_LR.mp4", display="tv-55")
    assert caught.value.spelled(lambda name: analyze.cli_names[name]) == f"INPUT {tmp_path / 'none_LR.mp4'} does not exist"


def test_the_default_budget_is_synthesizes():
    from vergence.commands.analyze import DEFAULT_BUDGET_ARCMIN
    from vergence.commands.synthesize import SYNTHESIS_BUDGET_ARCMIN

    assert DEFAULT_BUDGET_ARCMIN == SYNTHESIS_BUDGET_ARCMIN
    assert f"default {SYNTHESIS_BUDGET_ARCMIN:g}." in command("analyze").parameter("budget_arcmin").help
