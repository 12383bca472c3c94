"""``vergence convert`` end to end on the rendered clips: outputs, flicker line, resume, one-line refusals."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("av", reason="the video extra is not installed: pip install 'vergence[video]'")

from vergence.cli import main  # noqa: E402


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    from vergence.video import make_test_clips

    # 8 frames per shot: the smallest clip whose shots pass MIN_SHOT_FRAMES (6)
    return make_test_clips(tmp_path_factory.mktemp("convert_clips"), frames_per_shot=8)


def _run(capsys, args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_rgbd_to_sbs_names_the_output_and_prints_shots_and_flicker(clips, tmp_path, capsys):
    from vergence.video import open_stereo

    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path, "--display", "tv-55",
                                   "--budget-arcmin", "20"])  # fmt: skip
    assert code == 0, err
    target = tmp_path / "clips_LRF_Full_SBS.mp4"
    assert target.is_file() and open_stereo(target).frames == 16
    assert "shot 0: frames 0-7" in out and "shot 1: frames 8-15" in out
    assert "flicker on static content:" in out and f"wrote 16 frames" in out


def test_stereo_to_anaglyph_and_to_frames(clips, tmp_path, capsys):
    code, out, err = _run(capsys, ["convert", clips.stereo, "--out", tmp_path / "ana.mp4", "--display", "tv-55",
                                   "--format", "anaglyph", "--origin", "center", "--no-stabilize"])  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "ana_Anaglyph.mp4").is_file()
    assert "0.0000 px before" not in out  # flicker is still measured without the filter
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path / "frames", "--images", "--display",
                                   "tv-55", "--format", "tb"])  # fmt: skip
    assert code == 0, err
    assert len(list((tmp_path / "frames_Full_TB").glob("frame_*.png"))) == 16


def test_truncated_input_keeps_the_frames_before_and_exits_2(clips, tmp_path, capsys):
    data = clips.rgbd.read_bytes()
    cut = tmp_path / "cut_RGBD.mp4"
    cut.write_bytes(data[: int(len(data) * 0.75)])
    code, out, err = _run(capsys, ["convert", cut, "--out", tmp_path, "--display", "tv-55"])
    assert code == 2
    lines = [line for line in err.splitlines() if not line.startswith("warning: ")]  # the tabletop's stereo window
    assert len(lines) == 1 and lines[0].startswith("error: INPUT cut_RGBD.mp4 stopped after frame "), err
    assert (tmp_path / "cut_LRF_Full_SBS.mp4").is_file()


@pytest.mark.parametrize(("args", "message"), [
    (["{stereo}", "--out", "{stereo}", "--display", "tv-55"], "error: output"),
    (["{missing}", "--out", "{tmp}/o.mp4", "--display", "tv-55"], "error: INPUT"),
    (["{junk}", "--out", "{tmp}/o.mp4", "--display", "tv-55"], "error: cannot read video"),
    (["{plain}", "--out", "{tmp}/o.mp4", "--display", "tv-55"], "error: cannot guess the stereo layout"),
    (["{stereo}", "--out", "{tmp}/o.mp4", "--display", "tv-55", "--format", "rgbd"], "error: --format must be"),
    (["{stereo}", "--out", "{tmp}/o_Half_SBS.mp4", "--display", "tv-55"], "error: --out o_Half_SBS.mp4 is tagged"),
    (["{stereo}", "--out", "{tmp}/o.mp4", "--display", "tv-55", "--depth-kind", "metric"],
     "error: --depth-kind apply to a 2d+depth INPUT"),
    # the input's --layout, not the output's --format
    (["{stereo}", "--out", "{tmp}/o.mp4", "--display", "tv-55", "--layout", "lr"],
     "error: --layout must be one of sbs, half-sbs, tb, half-tb; got 'lr'"),
    (["{stereo}", "--out", "{tmp}/o.mp4", "--display", "tv-55", "--budget-arcmin", "0"],
     "error: --budget-arcmin must be in (0, 600]"),
    (["{stereo}", "--out", "{tmp}/o.avi", "--display", "tv-55"], "error: --out must be a .mp4, .mkv, .mov file or a "
     "folder"),
])  # fmt: skip
def test_bad_input_is_one_line_and_exit_code_2(clips, tmp_path, capsys, args, message):
    plain = tmp_path / "plain.mp4"
    plain.write_bytes(clips.stereo.read_bytes())
    (tmp_path / "junk_LR.mp4").write_bytes(b"junk")
    names = {"plain": plain, "stereo": clips.stereo, "junk": tmp_path / "junk_LR.mp4", "tmp": tmp_path,
             "missing": tmp_path / "missing_LR.mp4"}
    code, out, err = _run(capsys, ["convert", *(a.format(**names) for a in args)])
    assert code == 2
    assert out == "" and err.count("\n") == 1 and err.startswith(message), err
    assert not list(tmp_path.glob("o*"))


def test_nothing_is_lost_without_force(clips, tmp_path, capsys):
    """Issue 28: converting x_RGBD.mp4 into a folder holding x_LRF_Full_SBS.mp4 (another clip: both map to one
    name) leaves that file as it was; --force replaces it; a missing --out folder is created."""
    import shutil

    folder = tmp_path / "clips"
    folder.mkdir()
    shutil.copy(clips.rgbd, folder / "x_RGBD.mp4")
    shutil.copy(clips.stereo, folder / "x_LRF_Full_SBS.mp4")
    before = (folder / "x_LRF_Full_SBS.mp4").read_bytes()
    args = ["convert", folder / "x_RGBD.mp4", "--display", "tv-55", "--preset", "ultrafast"]
    code, out, err = _run(capsys, [*args, "--out", folder])
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith(f"error: --out {folder / 'x_LRF_Full_SBS.mp4'} exists: give --force to replace it"), err
    assert (folder / "x_LRF_Full_SBS.mp4").read_bytes() == before
    assert sorted(p.name for p in folder.iterdir()) == ["x_LRF_Full_SBS.mp4", "x_RGBD.mp4"]  # no work folder left
    # the batch refuses two inputs of one output name, --force or not, before any work
    code, out, err = _run(capsys, ["convert", folder, "--batch", "--out", folder, "--display", "tv-55", "--force"])
    assert code == 2 and "another input of the batch" in err and (folder / "x_LRF_Full_SBS.mp4").read_bytes() == before
    # a missing folder is created (parents too), a second run is refused, --force replaces
    code, out, err = _run(capsys, [*args, "--out", tmp_path / "new" / "deeper"])
    assert code == 0, err
    made = tmp_path / "new" / "deeper" / "x_LRF_Full_SBS.mp4"
    assert made.is_file()
    made.write_bytes(b"kept")
    assert _run(capsys, [*args, "--out", tmp_path / "new" / "deeper"])[0] == 2 and made.read_bytes() == b"kept"
    assert _run(capsys, [*args, "--out", tmp_path / "new" / "deeper", "--force"])[0] == 0
    assert made.read_bytes() != b"kept"
    # an image folder holding files is an existing output too; --force replaces it whole (no stale frames)
    frames = tmp_path / "frames_LRF_Full_SBS"
    frames.mkdir()
    (frames / "frame_999999.png").write_bytes(b"old")
    code, out, err = _run(capsys, [*args, "--images", "--out", tmp_path / "frames"])
    assert code == 2 and "exists and holds files: give --force" in err, err
    assert _run(capsys, [*args, "--images", "--out", tmp_path / "frames", "--force"])[0] == 0
    assert len(list(frames.iterdir())) == 16 and not (frames / "frame_999999.png").exists()


def test_resume_after_an_interrupted_run(clips, tmp_path, capsys, monkeypatch):
    import vergence.video.convert as conversion

    real = conversion.convert_clip

    def interrupted(*args, progress, **kwargs):
        def stop(phase, done, total):
            progress(phase, done, total)
            if phase == "converting" and done == 10:
                raise KeyboardInterrupt

        return real(*args, progress=stop, **kwargs)

    monkeypatch.setattr(conversion, "convert_clip", interrupted)
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path, "--display", "tv-55"])
    assert code == 130 and not (tmp_path / "clips_LRF_Full_SBS.mp4").exists()
    work = tmp_path / ".clips_LRF_Full_SBS.mp4.parts"
    assert err.splitlines()[-1] == f"interrupted: run the same command with --resume to reuse the finished shots in {work}"
    monkeypatch.setattr(conversion, "convert_clip", real)
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path, "--display", "tv-55", "--resume"])
    assert code == 0, err
    assert "shot 0: frames 0-7" in out and "(reused)" in out.splitlines()[0] and "(reused)" not in out.splitlines()[1]
    assert not np.isnan(float(out.split("flicker on static content: ")[1].split(" px")[0]))
    assert "nan" not in out  # a reused shot's planned range too (issue 28: "+nan .. +nan px (reused)")
    assert "wrote 16 frames (" in out and ", 8 reused) to " in out  # the rate counts the frames rendered now
    # an interruption before any shot is finished leaves nothing to resume: the line says only "interrupted"
    def early(*args, progress, **kwargs):
        def stop(phase, done, total):
            progress(phase, done, total)
            if phase == "converting" and done == 2:
                raise KeyboardInterrupt

        return real(*args, progress=stop, **kwargs)

    monkeypatch.setattr(conversion, "convert_clip", early)
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path / "other", "--display", "tv-55"])
    assert code == 130 and err.splitlines()[-1] == "interrupted"


def test_interrupted_while_measuring_says_the_output_is_complete(clips, tmp_path, capsys, monkeypatch):
    import vergence.video.convert as conversion

    def cut_short(*args, **kwargs):
        raise KeyboardInterrupt  # Ctrl-C after the output was joined, while it is matched again

    monkeypatch.setattr(conversion, "measure_output", cut_short)
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path, "--display", "tv-55"])
    target = tmp_path / "clips_LRF_Full_SBS.mp4"
    assert code == 130 and target.is_file()
    assert err.splitlines()[-1] == f"interrupted: {target} was written in full; only its measurement was cut short"
    # with --force over an existing output, the same note
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path, "--display", "tv-55", "--force"])
    assert code == 130 and err.splitlines()[-1].endswith("was written in full; only its measurement was cut short")


def test_workers_on_dask_write_the_serial_frames(clips, tmp_path, capsys):
    pytest.importorskip("distributed", reason="dask.distributed is not installed: pip install 'vergence[dask]'")
    args = ["convert", clips.rgbd, "--display", "tv-55", "--images"]
    assert _run(capsys, [*args, "--out", tmp_path / "serial"])[0] == 0
    code, out, err = _run(capsys, [*args, "--out", tmp_path / "dask", "--workers", "2"])
    assert code == 0, err
    assert "wrote 16 frames" in out
    serial, dask = (sorted(tmp_path.glob(f"{n}_LRF_Full_SBS/*.png")) for n in ("serial", "dask"))
    assert len(serial) == 16 and [p.read_bytes() for p in serial] == [p.read_bytes() for p in dask]


def test_bad_scheduler_address_is_one_line_exit_2(clips, tmp_path, capsys, monkeypatch):
    pytest.importorskip("distributed", reason="dask.distributed is not installed: pip install 'vergence[dask]'")
    from vergence.video import _shots

    monkeypatch.setattr(_shots, "CONNECT_TIMEOUT_S", 1)
    code, out, err = _run(capsys, ["convert", clips.rgbd, "--out", tmp_path / "x", "--images", "--display", "tv-55",
                                   "--scheduler", "tcp://127.0.0.1:9"])  # fmt: skip
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "cannot reach the Dask scheduler" in err, err
    assert not any(tmp_path.iterdir())


def test_batch_converts_each_video_and_skip_errors_reports_the_broken_one(clips, tmp_path, capsys):
    import shutil

    src, dst = tmp_path / "in", tmp_path / "out"
    src.mkdir(), dst.mkdir()
    shutil.copy(clips.rgbd, src / "a_RGBD.mp4")
    shutil.copy(clips.stereo, src / "b_LRF_Full_SBS.mp4")
    (src / "c_LRF_Full_SBS.mp4").write_bytes(b"not a video")
    args = ["convert", src, "--batch", "--out", dst, "--display", "tv-55", "--images"]
    code, out, err = _run(capsys, args)
    assert code == 2 and err.strip().splitlines()[-1].startswith("error: c_LRF_Full_SBS.mp4: cannot read video"), err
    code, out, err = _run(capsys, [*args, "--skip-errors", "--resume"])
    assert code == 2, err
    lines = err.strip().splitlines()
    assert lines[0].startswith("skipped c_LRF_Full_SBS.mp4:") and "1 of 3 files skipped" in lines[-1], err
    assert "converted 2 of 3 files (2 kept from an earlier run)" in out
    assert sorted(p.name for p in dst.iterdir()) == ["a_LRF_Full_SBS", "b_LRF_Full_SBS"]
    assert all(len(list((dst / n).glob("*.png"))) == 16 for n in ("a_LRF_Full_SBS", "b_LRF_Full_SBS"))


def test_batch_on_dask_writes_the_serial_frames(clips, tmp_path, capsys):
    pytest.importorskip("distributed", reason="dask.distributed is not installed: pip install 'vergence[dask]'")
    import shutil

    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(clips.rgbd, src / "a_RGBD.mp4")
    shutil.copy(clips.stereo, src / "b_LRF_Full_SBS.mp4")
    for name, extra in (("serial", []), ("dask", ["--workers", "2"])):
        (tmp_path / name).mkdir()
        code, out, err = _run(capsys, ["convert", src, "--batch", "--out", tmp_path / name, "--display", "tv-55",
                                       "--images", *extra])  # fmt: skip
        assert code == 0, err
    for n in ("a_LRF_Full_SBS", "b_LRF_Full_SBS"):
        a, b = (sorted((tmp_path / d / n).glob("*.png")) for d in ("serial", "dask"))
        assert len(a) == 16 and [p.read_bytes() for p in a] == [p.read_bytes() for p in b]


def test_option_defaults_are_the_library_defaults():
    # The command keeps literal defaults (importing vergence.video would slow every command's start); they must
    # stay those of convert_clip.
    import inspect

    import typer

    from vergence.cli.convert import _OPTIONS, convert
    from vergence.video import convert_clip

    library = inspect.signature(convert_clip).parameters
    cli = {p.default.param_decls[0]: p.default.default for p in inspect.signature(convert).parameters.values()
           if isinstance(p.default, typer.models.OptionInfo)}  # fmt: skip
    names = {"--static-threshold": "threshold", "--stabilize-alpha": "alpha", **{v: k for k, v in _OPTIONS.items()}}
    checked = [flag for flag in cli if names.get(flag) in library and library[names[flag]].default is not
               inspect.Parameter.empty and cli[flag] is not None]  # fmt: skip
    assert {"--split-frames", "--crf", "--preset", "--static-threshold", "--stabilize-alpha", "--transition"} <= set(checked)
    for flag in checked:
        assert cli[flag] == library[names[flag]].default, flag


def test_split_frames_cuts_a_shot_into_pieces_with_the_same_frames(clips, tmp_path, capsys):
    args = ["convert", clips.rgbd, "--display", "tv-55", "--images"]
    assert _run(capsys, [*args, "--out", tmp_path / "whole", "--split-frames", "0"])[0] == 0
    assert _run(capsys, [*args, "--out", tmp_path / "split", "--split-frames", "3"])[0] == 0
    whole, split = (sorted(tmp_path.glob(f"{n}_LRF_Full_SBS/*.png")) for n in ("whole", "split"))
    assert len(whole) == 16 and [p.read_bytes() for p in whole] == [p.read_bytes() for p in split]
    code, _, err = _run(capsys, [*args, "--out", tmp_path / "bad", "--split-frames", "-2"])
    assert code == 2 and "--split-frames must be an integer >= 0" in err and len(err.strip().splitlines()) == 1


def test_floating_window_is_reported_in_the_terminal_and_the_json(clips, tmp_path, capsys):
    """The tabletop's table crosses the frame's edges in front of the screen: without --floating-window a warning per
    edge-breaking shot; with it, each such shot says the columns it masked, and --json lists them per edge."""
    import json

    args = ["convert", clips.rgbd, "--display", "tv-55", "--preset", "ultrafast"]
    code, out, err = _run(capsys, [*args, "--out", tmp_path / "plain"])
    assert code == 0 and "breaks the stereo window: a floating window (--floating-window) masks it" in err, err
    code, out, err = _run(capsys, [*args, "--out", tmp_path / "masked", "--floating-window"])
    assert code == 0 and "stereo window" not in err, err
    table = out.splitlines()[0]
    assert table.startswith("shot 0: frames 0-7, nearness ") and "; floating window: left " in table, out
    code, out, err = _run(capsys, [*args, "--out", tmp_path / "json", "--floating-window", "--json"])
    shot = json.loads(out)["shots"][0]
    widths = {w["edge"]: w["width_px"] for w in shot["window"]["floating_window"]}
    assert widths and all(w >= 1 for w in widths.values()) and shot["window"]["violations"] == []
    lo, hi = shot["disparity_out_px"]
    assert lo < 0 < hi and all(w <= hi + 1 for w in widths.values())  # never wider than the nearest content
