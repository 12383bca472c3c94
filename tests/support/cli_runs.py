"""Running ``vergence`` in the test process (tests/cli): exit code and both streams, usable from
module-scoped fixtures (where pytest's ``capsys`` is not available)."""

from __future__ import annotations

import contextlib
import io


def run_main(*args: str) -> tuple[int, str, str]:
    """``vergence ARGS`` in-process: (exit code, stdout, stderr)."""
    from vergence.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return code, out.getvalue(), err.getvalue()
