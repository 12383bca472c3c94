"""Progress of long work when stderr is not a terminal (issue 31: `stereospace build` printed 146 lines
into a log): a line each tenth of the work and the last, whatever the number of steps."""

from __future__ import annotations

import pytest

from vergence.cli._spinner import ProgressLines


@pytest.mark.parametrize("steps", [1, 7, 48, 146, 1000])
def test_a_handful_of_lines_however_many_steps(capsys, steps):
    with ProgressLines() as progress:
        for k in range(steps + 1):
            progress(k / steps, f"view {k}/{steps}")
    lines = capsys.readouterr().err.splitlines()
    assert 2 <= len(lines) <= 11 and lines[0] == f"  0 % view 0/{steps}" and lines[-1] == f"100 % view {steps}/{steps}"
    shown = [int(line.split("%")[0]) for line in lines]
    assert all(a < b for a, b in zip(shown, shown[1:]))  # each line past the next tenth, none repeated


def test_a_new_stage_starts_its_lines_again(capsys):
    with ProgressLines() as progress:
        for stage in ("points", "views"):
            for k in range(21):
                progress(k / 20, stage)
    lines = capsys.readouterr().err.splitlines()
    assert [line for line in lines if line.startswith("100 %")] == ["100 % points", "100 % views"]
    assert len(lines) == 22


@pytest.mark.parametrize("lines", [False, True])
def test_the_bar_of_a_command_off_a_terminal(capsys, lines):
    """`render`, `specular` and `rig render` share one bar: off a terminal it prints nothing, or with
    ``lines`` (the minutes-long rig render) ProgressLines' handful."""
    from vergence.cli._spinner import progress_bar

    with progress_bar("rendering", lines=lines) as report:
        for k in range(101):
            report(k / 100, f"step {k}")
    err = capsys.readouterr().err.splitlines()
    if lines:
        assert err[0] == "  0 % step 0" and err[-1] == "100 % step 100" and len(err) == 11
    else:
        assert err == []
