"""The CLI entry point: usage errors and library errors are one line on stderr with exit code 2."""

from __future__ import annotations

import pytest

from vergence.cli import main


def test_usage_error_is_one_line(capsys):
    code = main(["budget", "--baseline", "0.1", "--convergence", "3", "--window", "1", "--display", "tv-55",
                 "--screen-pixels", "1.5"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "--screen-pixels" in err


def test_unknown_command_and_no_arguments(capsys):
    assert main(["no-such-command"]) == 2
    assert "No such command" in capsys.readouterr().err
    assert main([]) == 0
    assert "Commands" in capsys.readouterr().out


def test_help_exits_zero(capsys):
    assert main(["budget", "--help"]) == 0
    assert "--baseline" in capsys.readouterr().out
    assert main(["budget", "-h"]) == 0
    assert "--baseline" in capsys.readouterr().out


def test_library_error_is_one_line(capsys):
    code = main(["budget", "--baseline", "-1", "--convergence", "3", "--window", "1", "--display", "tv-55"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == "error: --baseline must be > 0; got -1"  # the option typed (issue 9)


def test_unexpected_exception_is_one_line_with_exit_code_1(capsys, monkeypatch):
    import vergence.commands.budget as budget_cli  # the command's work

    def boom(*args, **kwargs):
        raise RuntimeError("kaboom")

    monkeypatch.setattr(budget_cli, "depth_budget", boom)
    monkeypatch.delenv("VERGENCE_DEBUG", raising=False)
    code = main(["budget", "--baseline", "0.1", "--convergence", "3", "--window", "1", "--display", "tv-55"])
    err = capsys.readouterr().err.strip()
    assert code == 1 and len(err.splitlines()) == 1
    assert "internal error" in err and "RuntimeError: kaboom" in err


def test_console_script_prefers_passive_omp_wait_but_the_user_wins():
    from vergence.cli import _prefer_passive_omp_wait

    environ: dict[str, str] = {}
    _prefer_passive_omp_wait(environ)
    assert environ == {"OMP_WAIT_POLICY": "PASSIVE"}
    environ = {"OMP_WAIT_POLICY": "ACTIVE"}
    _prefer_passive_omp_wait(environ)
    assert environ == {"OMP_WAIT_POLICY": "ACTIVE"}


def test_importing_vergence_leaves_the_environment_alone():
    # vergence.cli is left out: it imports OpenCV, whose own loader prepends to LD_LIBRARY_PATH.
    import os
    import subprocess
    import sys

    code = ("import os; before = dict(os.environ); import vergence, vergence.viewing, vergence.metrics, "
            "vergence.camera; assert dict(os.environ) == before, set(os.environ.items()) ^ set(before.items())")
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    result = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_options_named_rewrites_the_leading_parameter_name_only():
    from vergence.cli._app import options_named

    with pytest.raises(ValueError, match=r"^--viewing-distance must be > 0; got -3$"):
        with options_named(distance="--viewing-distance"):
            raise ValueError("distance must be > 0; got -3")
    # a longer name that merely starts with the parameter is left alone, as are other errors
    with pytest.raises(ValueError, match=r"^distances must be sorted$"):
        with options_named(distance="--viewing-distance"):
            raise ValueError("distances must be sorted")
    with pytest.raises(TypeError, match=r"^--smooth-sigma: expected a number$"):
        with options_named(sigma="--smooth-sigma"):
            raise TypeError("sigma: expected a number")
    with pytest.raises(OSError, match="distance"):
        with options_named(distance="--viewing-distance"):
            raise OSError("distance")


def _run_cli(*args: str, env: dict[str, str] | None = None) -> "subprocess.CompletedProcess[str]":
    """The console script in a fresh interpreter (what a user runs), its output captured."""
    import os
    import subprocess
    import sys

    code = "import sys; from vergence.cli import entry; sys.argv[0] = 'vergence'; entry()"
    full_env = {**os.environ, **(env or {})}
    return subprocess.run([sys.executable, "-c", code, *args], env=full_env, capture_output=True, text=True,
                          timeout=120)


def test_help_lists_the_commands_without_importing_them():
    # issue 9, "Import takes 1.4 s ... `vergence --help` should not pay for Numba and Mitsuba"
    import subprocess
    import sys

    code = ("import sys; from vergence.cli import main, COMMANDS; assert main(['--help']) == 0; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'mitsuba', 'drjit', 'cv2', "
            "'scipy', 'numpy') or m.startswith('vergence.cli.') and m[13:] in {v[0] for v in COMMANDS.values()}),"
            " file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stderr.strip() == "[]"
    from vergence.cli import COMMANDS

    for name in COMMANDS:
        assert name in result.stdout


def test_commands_table_matches_the_command_modules():
    import importlib
    import pathlib

    import vergence.cli
    from vergence.cli import COMMANDS
    from vergence.cli._app import app

    folder = pathlib.Path(vergence.cli.__file__).parent
    modules = {p.stem for p in folder.glob("*.py") if not p.stem.startswith("_")}
    assert {module for module, _ in COMMANDS.values()} == modules
    assert list(COMMANDS) == sorted(COMMANDS)
    for name, (module, summary) in COMMANDS.items():
        importlib.import_module(f"vergence.cli.{module}")
        registered = {i.name for i in app.registered_commands if i.callback.__module__ == f"vergence.cli.{module}"}
        # a command with subcommands (`vergence rig plan`) registers a Typer of its own under its name
        groups = {g.name for g in app.registered_groups
                  if any(c.callback.__module__ == f"vergence.cli.{module}" for c in g.typer_instance.registered_commands)}
        assert registered | groups == {name}, module
        assert summary and "\n" not in summary


def test_command_help_reads_as_a_usage_line(capsys):
    # issue 9: "--help shows --json <bool>", "usage reads {image} {depth}",
    # "the --min-contrast default prints as 0.011764705882352941"
    assert main(["compare", "--help"]) == 0
    out = capsys.readouterr().out
    assert "Usage: vergence compare [OPTIONS] IMAGE REFERENCE" in out
    assert "<bool>" not in out and "{" not in out
    assert "0.0117647]" in out and "0.01176470588" not in out
    assert "[default: 10.0]" in out  # --radius: a round float keeps its point
    assert main(["--help"]) == 0
    assert "<bool>" not in capsys.readouterr().out


def test_an_empty_value_is_refused_naming_the_option(capsys):
    code = main(["budget", "--baseline", "0.1", "--convergence", "3", "--window", "1", "--display", ""])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "--display" in err and "must not be empty" in err
    assert main(["compare", "", "b.png"]) == 2
    assert "IMAGE" in capsys.readouterr().err


@pytest.mark.parametrize("point, args", [("START", ["--help"]), ("IMPORT", ["budget", "--help"])])
def test_ctrl_c_at_start_up_is_one_line_and_exit_code_130(point, args):
    # issue 9: "Ctrl-C in the first half second (imports) prints a 36-line traceback"
    import os
    import signal
    import subprocess
    import sys

    code = "import sys; from vergence.cli import entry; sys.argv[0] = 'vergence'; entry()"
    env = {**os.environ, f"VERGENCE_TEST_SLEEP_{point}": "60"}
    proc = subprocess.Popen([sys.executable, "-c", code, *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr.readline() == f"test: sleeping at {point.lower()}\n"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130
    assert err == "interrupted\n" and out == ""


@pytest.fixture
def sigint_flag(monkeypatch):
    """The console script's Ctrl-C record, cleared after the test."""
    import vergence.cli

    monkeypatch.setattr(vergence.cli, "_sigint_seen", False)


def _budget_raising(monkeypatch, action):
    import vergence.commands.budget as budget_cli  # the command's work

    monkeypatch.setattr(budget_cli, "depth_budget", lambda *a, **k: action())
    return main(["budget", "--baseline", "0.1", "--convergence", "3", "--window", "1", "--display", "tv-55"])


def test_keyboard_interrupt_in_a_command_is_one_line_and_exit_code_130(capsys, monkeypatch):
    def interrupt():
        raise KeyboardInterrupt

    assert _budget_raising(monkeypatch, interrupt) == 130
    captured = capsys.readouterr()
    assert captured.err == "interrupted\n" and captured.out == ""


def test_an_error_raised_after_ctrl_c_still_reads_interrupted(capsys, monkeypatch, sigint_flag):
    # issue 9: Ctrl-C during imports "once became 'internal error ... SystemError'" (an extension
    # module turned the KeyboardInterrupt into a SystemError), and the demo swallowed it and exited 0
    from vergence.cli import _on_sigint

    def systemerror():
        try:
            _on_sigint(2, None)
        except KeyboardInterrupt as exc:
            raise SystemError("<built-in function> returned a result with an exception set") from exc

    assert _budget_raising(monkeypatch, systemerror) == 130
    assert capsys.readouterr().err == "interrupted\n"

    def swallowed():
        try:
            _on_sigint(2, None)
        except KeyboardInterrupt:
            pass
        raise ValueError("baseline must be > 0")  # what the command did next must not show

    assert _budget_raising(monkeypatch, swallowed) == 130
    assert capsys.readouterr().err == "interrupted\n"


@pytest.mark.parametrize("args, message", [
    # issue 9: "--seed -1 says expected non-negative integer without naming --seed"
    (["render", "glasses", "--out", "{tmp}", "--seed", "-1"], "error: --seed: must be >= 0 (got -1)"),
    (["budget", "--baseline", "abc"], "error: --baseline: expected a number (got 'abc')"),
    (["specular", "glasses", "--out", "{tmp}", "--k", "abc"], "error: --k: expected a whole number (got 'abc')"),
    (["budget", "--screen-pixels", "1.5"], "error: --screen-pixels: expected a whole number (got '1.5')"),
    (["budget", "--baseline"], "error: --baseline: needs a value"),
    (["compare"], "error: missing argument IMAGE (usage: vergence compare [OPTIONS] IMAGE REFERENCE)"),
    (["budget", "--baseline", "1"], "error: missing option --convergence"),
    (["mapping", "--nea", "1"], "error: no such option --nea (did you mean --far or --near? vergence mapping --help "
                                "lists the options)"),
    (["compare", "a", "b", "c"], "error: unexpected argument c (usage: vergence compare [OPTIONS] IMAGE REFERENCE)"),
    (["serve", "--port", "http"], "error: --port: expected a whole number (got 'http')"),
    (["serve", "--host", "0.0.0.0"], "error: --host 0.0.0.0 is not a loopback address: anyone who reaches it could "
                                     "use the workbench; add --allow-remote to serve it anyway"),
])
def test_usage_errors_begin_with_the_option_as_typed(capsys, tmp_path, args, message):
    assert main([a.format(tmp=tmp_path / "out") for a in args]) == 2
    assert capsys.readouterr().err == message + "\n"


def test_display_lengths_are_named_as_options(capsys):
    # issue 9: "--viewing-distance -3 says 'distance must be > 0', --screen-width inf 'width must be finite'"
    rig = ["budget", "--baseline", "0.1", "--convergence", "3", "--window", "1", "--eye-separation", "0.065"]
    assert main([*rig, "--viewing-distance", "-3", "--screen-width", "1"]) == 2
    assert capsys.readouterr().err.startswith("error: --viewing-distance must be > 0")
    assert main([*rig, "--viewing-distance", "3", "--screen-width", "inf"]) == 2
    assert capsys.readouterr().err.startswith("error: --screen-width must be finite")


@pytest.mark.parametrize("error, message", [
    # issue 9: 'Read-only file system: .b.tmp-7564498b5275.png', '[Errno 17] File exists'
    (OSError(30, "Read-only file system", "out/.b.tmp-7564498b5275.png"), "cannot write out/b.png: read-only file system"),
    (OSError(28, "No space left on device", "/data/.left.tmp-0123456789ab.png", "/data/left.png"),
     "cannot write /data/left.png: no space left on device"),
    (PermissionError(13, "Permission denied", "scene.json"), "cannot open scene.json: permission denied"),
    (PermissionError(13, "Permission denied", "o/.v.tmp-0123456789ab.png", "o/v.png"), "cannot write o/v.png: permission denied"),
    (IsADirectoryError(21, "Is a directory", "views"), "views is a folder"),
    (FileNotFoundError(2, "No such file or directory", "a/.x.tmp-0123456789ab.pfm", "a/x.pfm"),
     "cannot write a/x.pfm: no such file or directory"),
    (OSError("cannot write a/.x.tmp-0123456789ab.png: OpenCV could not encode .png"),
     "cannot write a/x.png: OpenCV could not encode .png"),
    (OSError("cannot read left.png: truncated file"), "cannot read left.png: truncated file"),
])
def test_filesystem_errors_name_the_users_file_in_words(error, message):
    from vergence.io.atomic import describe_os_error

    assert describe_os_error(error) == message


def test_filesystem_error_in_a_command_is_one_line(capsys, monkeypatch, tmp_path):
    def read_only():
        raise OSError(30, "Read-only file system", str(tmp_path / ".plot.tmp-7564498b5275.png"))

    assert _budget_raising(monkeypatch, read_only) == 2
    assert capsys.readouterr().err == f"error: cannot write {tmp_path / 'plot.png'}: read-only file system\n"
    (tmp_path / "out").write_text("a file")

    def make_folder():
        (tmp_path / "out").mkdir(parents=True, exist_ok=True)

    assert _budget_raising(monkeypatch, make_folder) == 2
    assert capsys.readouterr().err == f"error: cannot create folder {tmp_path / 'out'}: a file of that name exists\n"


def test_a_folder_given_as_a_scene_says_so(capsys, tmp_path):
    # issue 9: "a folder given as a scene says 'not found'"
    assert main(["render", str(tmp_path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: scene {tmp_path} is a folder") and len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_warnings_in_a_command_are_one_line_each(capsys, monkeypatch):
    # issue 9: "budget --baseline 1e308 prints numpy warnings first" (numpy's own format: file, line, source)
    import warnings

    import numpy as np

    def overflow():
        with np.errstate(over="warn"):
            np.float64(1e308) * 10
        warnings.warn("the second\nline", UserWarning)
        raise ValueError("the rig is too large")

    with warnings.catch_warnings():
        warnings.simplefilter("always")  # the project's tests turn warnings into errors; a user sees them
        assert _budget_raising(monkeypatch, overflow) == 2
    assert capsys.readouterr().err.splitlines() == [
        "warning: overflow encountered in scalar multiply", "warning: the second line", "error: the rig is too large"]


def test_log_warnings_in_a_command_are_one_line_each(capsys, monkeypatch):
    # render logs a missing HDR map; Python's last-resort handler printed the bare message
    import logging

    def logs():
        logging.getLogger("vergence.render").warning("glasses scene: %s", "HDR map sky.hdr not found")
        raise ValueError("the rig is too large")

    assert _budget_raising(monkeypatch, logs) == 2
    assert capsys.readouterr().err.splitlines() == [
        "warning: glasses scene: HDR map sky.hdr not found", "error: the rig is too large"]


def test_a_repeatable_option_shows_its_element_type(capsys):
    assert main(["budget", "--help"]) == 0
    out = capsys.readouterr().out
    assert "list[" not in out and "<float>" in out


def test_python_dash_m_vergence_is_the_command():
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-m", "vergence", "budget", "--baseline"], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 2 and result.stderr == "error: --baseline: needs a value\n"


def test_a_folder_given_as_an_image_or_disparity_file_says_so():
    # kin of issue 9 "a folder given as a scene says 'not found'": here it said "unknown extension ''"
    import pathlib
    import tempfile

    from vergence.io import read_disparity, read_image, write_image

    folder = pathlib.Path(tempfile.mkdtemp())
    for call in (lambda: read_image(folder), lambda: read_disparity(folder),
                 lambda: write_image(folder, __import__("numpy").zeros((2, 2), "float32"))):
        with pytest.raises((ValueError, OSError), match=rf"^(cannot read )?{folder}(: it)? is a (folder|directory)"):
            call()


@pytest.mark.skipif(not __import__("os").path.isdir("/sys/kernel"), reason="needs Linux sysfs, where no file can be made")
def test_a_real_failed_atomic_write_names_the_target_not_the_temporary_file():
    from vergence.io.atomic import describe_os_error
    from vergence.io import write_json

    with pytest.raises(OSError) as info:
        write_json("/sys/kernel/vergence-test.json", {"a": 1})
    message = describe_os_error(info.value)
    assert message.startswith("cannot write /sys/kernel/vergence-test.json: ") and ".tmp-" not in message
    assert "Errno" not in message


def test_budget_help_does_not_load_scipy_numba_or_opencv():
    # issue 9 "Import takes 1.4 s before any command runs": budget and mapping are closed formulas
    # (S0 Eq. 1-9); SciPy is for the gradient-domain mapping's solve only
    import subprocess
    import sys

    code = ("import sys; from vergence.cli import main; assert main(['budget', '--help']) == 0; "
            "assert main(['mapping', '--help']) == 0; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'scipy', 'numba', 'cv2', 'mitsuba'}), "
            "file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stderr.strip() == "[]", result.stderr


def test_value_types_read_in_a_users_words(capsys):
    # kin of issue 9 "--help shows --json <bool>": Python's <str> and typer's <int range> [x>=0]
    assert main(["render", "--help"]) == 0
    out = capsys.readouterr().out
    assert "<str>" not in out and "<text>" in out
    assert "range>" not in out and "[x >= 0]" in out
