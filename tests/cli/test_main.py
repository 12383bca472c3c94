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


def test_library_error_is_one_line(capsys):
    code = main(["budget", "--baseline", "-1", "--convergence", "3", "--window", "1", "--display", "tv-55"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == "error: --baseline must be > 0; got -1"  # the option typed (issue 9)


def test_unexpected_exception_is_one_line_with_exit_code_1(capsys, monkeypatch):
    import vergence.cli.budget as budget_cli

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
