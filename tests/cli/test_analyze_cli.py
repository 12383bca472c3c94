"""``vergence analyze`` end to end on the rendered clips: JSON keys, the report, one-line refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("av", reason="the video extra is not installed: pip install 'vergence[video]'")

from vergence.cli import main  # noqa: E402

PERCENTILE_KEYS = ["p1", "p5", "p50", "p95", "p99"]


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    from vergence.video import make_test_clips

    # 8 frames per shot: the smallest clip whose shots pass MIN_SHOT_FRAMES (6)
    return make_test_clips(tmp_path_factory.mktemp("cli_clips"), frames_per_shot=8)


def _run(capsys, args):
    code = main(args)
    out, err = capsys.readouterr()
    return code, out, err


def test_json_has_the_keys_of_the_issue(clips, capsys):
    code, out, err = _run(capsys, ["analyze", str(clips.stereo), "--display", "tv-55", "--json", "--every", "2"])
    assert code == 0, err
    data = json.loads(out)
    assert data["frames"] == 16 and data["fps"] == 24.0 and data["layout"] == "sbs" and data["every"] == 2
    assert data["display"] == {"preset": "tv-55", "eye_separation": 0.065, "distance": 3.0, "width": 1.2176,
                               "resolution": 1920}
    assert [(s["start"], s["end"]) for s in data["shots"]] == [(0, 8), (8, 16)]
    for shot in data["shots"]:
        assert {"start", "end", "disparity_px", "disparity_arcmin", "outside_comfort", "window_violations",
                "suggestion"} <= set(shot)
        assert list(shot["disparity_px"]) == PERCENTILE_KEYS == list(shot["disparity_arcmin"])
        assert 0 <= shot["outside_comfort"] <= 1
    assert [f["frame"] for f in data["per_frame"]] == list(range(0, 16, 2))
    with np.load(clips.truth) as truth:
        assert data["shots"][1]["disparity_px"]["p50"] == pytest.approx(np.nanmedian(truth["disparity"][8:]), abs=0.75)


def test_report_and_rgbd_input(clips, tmp_path, capsys):
    report = tmp_path / "report"
    code, out, err = _run(capsys, ["analyze", str(clips.rgbd), "--display", "desktop-24", "--report", str(report)])
    assert code == 0, err
    assert sorted(p.name for p in report.iterdir()) == ["analysis.json", "disparity.png", "index.html",
                                                        "shot_00.png", "shot_01.png"]
    data = json.loads((report / "analysis.json").read_text())
    assert data["kind"] == "2d+depth" and data["depth_kind"] == "inverse" and data["budget_arcmin"] == 30.0
    page = (report / "index.html").read_text()
    assert 'src="disparity.png"' in page and 'src="shot_01.png"' in page
    assert "shot 0: frames 0-7" in out and f"report: {report / 'index.html'}" in out


def test_colour_and_depth_clips_and_a_folder(clips, tmp_path, capsys):
    from vergence.io import write_image
    from vergence.video import open_depth_clip

    colour, depth = tmp_path / "colour", tmp_path / "depth"
    colour.mkdir(), depth.mkdir()
    for k, (image, d) in enumerate(open_depth_clip(clips.rgbd).pairs(0, 3)):
        write_image(colour / f"c_{k:03d}.png", image)
        write_image(depth / f"d_{k:03d}.png", d)
    code, out, err = _run(capsys, ["analyze", str(colour), "--depth", str(depth), "--display", "tv-55", "--json"])
    assert code == 0, err
    data = json.loads(out)
    assert data["frames"] == 3 and data["fps"] == 24.0 and data["kind"] == "2d+depth"


@pytest.mark.parametrize("args, message", [
    (["{plain}", "--display", "tv-55"], "error: cannot guess the stereo layout of plain.mp4"),
    (["{stereo}", "--display", "tv-99"], "error: --display: unknown display preset 'tv-99'"),
    (["{stereo}", "--display", "tv-55", "--every", "0"], "error: --every must be an integer >= 1; got 0"),
    (["{stereo}", "--display", "tv-55", "--layout", "lr"], "error: --layout must be one of sbs, half-sbs, tb, "
                                                           "half-tb; got 'lr'"),
    (["{junk}", "--display", "tv-55"], "error: cannot read video"),
    (["{rgbd}", "--display", "tv-55", "--depth", "{short}"], "error: depth clip short.mp4 has 2 frames; the "
                                                              "colour clip clips_RGBD.mp4 has 16"),
    (["{missing}", "--display", "tv-55"], "error: INPUT"),
    (["{stereo}", "--display", "tv-55", "--report", "{stereo}"], "error: output"),
])
def test_bad_input_is_one_line_and_exit_code_2(clips, tmp_path, capsys, args, message):
    from vergence.video import VideoWriter

    plain = tmp_path / "plain.mp4"
    plain.write_bytes(clips.stereo.read_bytes())
    (tmp_path / "junk_LR.mp4").write_bytes(b"junk")
    with VideoWriter(tmp_path / "short.mp4", fps=24, width=320, height=90) as video:
        for _ in range(2):
            video.write(np.zeros((90, 320, 3), np.float32))
    names = {"plain": plain, "stereo": clips.stereo, "rgbd": clips.rgbd, "junk": tmp_path / "junk_LR.mp4",
             "short": tmp_path / "short.mp4", "missing": tmp_path / "missing_LR.mp4"}
    code, out, err = _run(capsys, ["analyze", *(a.format(**names) for a in args)])
    assert code == 2
    assert out == "" and err.count("\n") == 1 and err.startswith(message), err


def test_single_images_stereo_and_2d_plus_depth(clips, tmp_path, capsys):
    from vergence.io import write_image
    from vergence.video import open_stereo

    with np.load(clips.truth) as truth:
        depth, disparity = truth["depth"][0], truth["disparity"][0]
    frame = next(open_stereo(clips.stereo).reader.frames())
    write_image(tmp_path / "pair-lr.png", frame)  # Bino's tag
    code, out, err = _run(capsys, ["analyze", str(tmp_path / "pair-lr.png"), "--display", "tv-55", "--json"])
    assert code == 0, err
    data = json.loads(out)
    assert data["frames"] == 1 and data["layout"] == "sbs"
    assert data["shots"][0]["disparity_px"]["p50"] == pytest.approx(np.nanmedian(disparity), abs=0.75)
    write_image(tmp_path / "image.png", frame[:, : clips.width])
    np.save(tmp_path / "depth.npy", depth)
    code, out, err = _run(capsys, ["analyze", str(tmp_path / "image.png"), "--depth", str(tmp_path / "depth.npy"),
                                   "--depth-kind", "metric", "--display", "tv-55", "--budget-arcmin", "20", "--json"])
    assert code == 0, err
    shot = json.loads(out)["shots"][0]
    # one image is one shot: its nearness range fills the +-20 arcmin budget, as vergence synthesize does
    assert -20.0 - 1e-6 <= shot["disparity_arcmin"]["p1"] < shot["disparity_arcmin"]["p99"] <= 20.0 + 1e-6
    assert max(-shot["disparity_arcmin"]["p1"], shot["disparity_arcmin"]["p99"]) > 19.0


def test_options_of_the_other_kind_of_input_are_refused(clips, capsys):
    code, out, err = _run(capsys, ["analyze", str(clips.rgbd), "--display", "tv-55", "--method", "bm",
                                   "--no-vertical"])
    assert code == 2 and err.startswith("error: --method, --no-vertical apply to a stereo INPUT; clips_RGBD.mp4 is "
                                        "read as 2d+depth")
    # --budget-arcmin applies to a stereo clip too (issue 28: each shot's suggestion says what convert would do there)
    code, out, err = _run(capsys, ["analyze", str(clips.stereo), "--display", "tv-55", "--budget-arcmin", "0"])
    assert code == 2 and err.startswith("error: --budget-arcmin must be a number in (0, 600]; got 0.0")
    code, out, err = _run(capsys, ["analyze", str(clips.stereo), "--display", "tv-55", "--method", "nope"])
    assert code == 2 and err.startswith("error: --method must be one of bm, ncc, patchmatch, sad, sgbm, ssd; got 'nope'")


def test_an_unnamed_input_and_an_untagged_one_name_the_path_and_layout(clips, tmp_path, capsys, monkeypatch):
    """Issue 28: `analyze .` said "cannot guess the stereo layout of : ..." (an empty name); the refusal names the
    folder, and the option that answers it (--layout), as for a file without a tag."""
    import shutil

    shutil.copy(clips.stereo, tmp_path / "plain.mp4")
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(capsys, ["analyze", ".", "--display", "tv-55"])
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"error: cannot guess the stereo layout of {tmp_path.resolve()}: its name carries no tag")
    assert err.rstrip().endswith("give --layout (sbs, half-sbs, tb, half-tb)"), err
    code, out, err = _run(capsys, ["analyze", "plain.mp4", "--display", "tv-55"])
    assert code == 2 and err.startswith("error: cannot guess the stereo layout of plain.mp4") and "--layout" in err
