"""Ctrl-C while Numba is inside LLVM: one line ``interrupted``, exit code 130, no output.

Issue 9 sweep round 2, case ``sigint/interpolate`` (exit -11): SIGINT delivered while LLVM called
back into Python through ctypes (``ExecutionEngine._raw_object_cache_getbuffer``, as Numba loads a
cached kernel) raised ``KeyboardInterrupt`` inside the callback; ctypes printed "Exception ignored
on calling ctypes callback function", LLVM linked the kernel without its code and the process died
of SIGSEGV. Each test below raises SIGINT at exactly that point (``signal.raise_signal`` inside
Numba's getbuffer hook, so the handler runs inside the callback) in a fresh interpreter.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from vergence.io import write_disparity, write_image

# Runs the console script with SIGINT raised inside LLVM's first getbuffer callback: of any module
# (HOOK=first, a compile) or of a module loaded from Numba's cache (HOOK=cached); HOOK unset: none.
_DRIVER = textwrap.dedent(
    """
    import os, signal, sys
    from numba.core import codegen

    mode = os.environ.get("HOOK")
    real = codegen.JITCodeLibrary._object_getbuffer_hook.__func__
    fired = []

    def getbuffer(cls, ll_module):
        library = getattr(ll_module, "_CPUCodeLibrary__library", None)
        cached = library is not None and getattr(library, "_compiled_object", None) is not None
        if mode and not fired and (mode == "first" or cached):
            fired.append(True)
            signal.raise_signal(signal.SIGINT)  # the handler runs here, inside the ctypes callback
        return real(cls, ll_module)

    codegen.JITCodeLibrary._object_getbuffer_hook = classmethod(getbuffer)
    if os.environ.get("KERNEL_DIR"):  # the command: a fresh cached kernel, its result staged to OUT
        sys.path.insert(0, os.environ["KERNEL_DIR"])
        import vergence.cli._run
        from pathlib import Path

        def run(argv):
            from fresh_kernel import twice
            from vergence.cli import raise_if_interrupted
            from vergence.commands._outputs import staged_outputs

            value = twice(21.0)
            with staged_outputs([Path(os.environ["OUT"])], before_commit=raise_if_interrupted) as (temp,):
                temp.write_text(str(value))
            return 0

        vergence.cli._run.run = run
    from vergence.cli import entry

    sys.argv[0] = "vergence"
    entry()
    """
)

_KERNEL = textwrap.dedent(
    """
    import numba

    @numba.njit(cache=True)
    def twice(x):
        return 2.0 * x
    """
)


def _driver(args: list[str], env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    src = str(Path(__file__).resolve().parents[2] / "src")
    full = {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]), **env}
    full.pop("VERGENCE_DEBUG", None)
    return subprocess.run([sys.executable, "-c", _DRIVER, *args], env=full, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize("hook", ["cached", "first"])
def test_ctrl_c_inside_an_llvm_callback_waits_for_safe_code(tmp_path, hook):
    (tmp_path / "fresh_kernel.py").write_text(_KERNEL)
    out = tmp_path / "out.txt"
    env = {"KERNEL_DIR": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "OUT": str(out)}
    if hook == "cached":  # a first run compiles the kernel into the cache; the second loads it
        warm = _driver([], env)
        assert warm.returncode == 0 and out.read_text() == "42.0", warm.stderr
        out.unlink()
    result = _driver([], {**env, "HOOK": hook})
    assert result.returncode == 130, result.stderr[-2000:]  # was -11 (cached) or a printed traceback
    assert result.stderr == "interrupted\n" and result.stdout == ""
    assert not out.exists()  # the command did not run on after Ctrl-C
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_ctrl_c_inside_an_llvm_callback_of_interpolate_leaves_nothing(tmp_path):
    # The sweep's command: Ctrl-C as interpolate's first kernel is compiled or loaded.
    rng = np.random.default_rng(0)
    for name in ("left", "right"):
        write_image(tmp_path / f"{name}.png", rng.random((12, 40)).astype(np.float32))
        write_disparity(tmp_path / f"{name}_disp.pfm", np.full((12, 40), 2.0, np.float32))
    args = ["interpolate", "--left", str(tmp_path / "left.png"), "--left-disparity", str(tmp_path / "left_disp.pfm"),
            "--right", str(tmp_path / "right.png"), "--right-disparity", str(tmp_path / "right_disp.pfm"),
            "--position", "0.5", "--out", str(tmp_path / "mid.png")]
    result = _driver(args, {"HOOK": "first"})
    assert result.returncode == 130, result.stderr[-2000:]
    assert result.stderr == "interrupted\n" and result.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["left.png", "left_disp.pfm", "right.png", "right_disp.pfm"]


def test_a_deferred_ctrl_c_is_raised_once_the_stack_is_safe(monkeypatch):
    # The handler itself: inside a frame of llvmlite it arms the retry timer instead of raising;
    # the timer's handler raises once no such frame is left.
    import llvmlite

    import vergence.cli as cli

    monkeypatch.setattr(cli, "_sigint_seen", False)
    monkeypatch.setattr(cli, "_sigint_pending", False)
    namespace: dict[str, object] = {}
    fake = os.path.join(os.path.dirname(llvmlite.__file__), "binding", "fake_callback.py")
    exec(compile("def callback(handler):\n    handler(2, sys._getframe())\n", fake, "exec"),
         {"sys": sys}, namespace)
    old_alarm = signal.getsignal(signal.SIGALRM)
    try:
        try:
            namespace["callback"](cli._on_sigint)
        except KeyboardInterrupt:
            pytest.fail("Ctrl-C raised inside llvmlite (inside a ctypes callback it would be lost)")
        assert cli.sigint_seen()
        assert 0.0 < signal.getitimer(signal.ITIMER_REAL)[0] <= cli.SIGINT_RETRY_S
        assert signal.getsignal(signal.SIGALRM) is cli._on_sigint_retry
        with pytest.raises(KeyboardInterrupt):
            signal.pause()  # the timer fires; here no llvmlite frame is left
        assert signal.getitimer(signal.ITIMER_REAL)[0] == 0.0
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old_alarm)


def test_staged_outputs_do_not_appear_after_a_ctrl_c_not_yet_raised(tmp_path, monkeypatch):
    # A Ctrl-C deferred inside LLVM may still be waiting when the command finishes its last kernel:
    # the outputs must not appear (all or nothing), the interrupt is raised instead.
    import vergence.cli as cli
    from vergence.commands._outputs import staged_outputs

    monkeypatch.setattr(cli, "_sigint_seen", True)
    folder = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), staged_outputs([folder / "a.png"], folder=folder,
                                                          before_commit=cli.raise_if_interrupted) as temps:
        temps[0].write_bytes(b"view")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["match", "rectify", "render", "specular"])
def test_commands_writing_through_atomic_io_commit_nothing_after_a_ctrl_c_not_yet_raised(tmp_path, monkeypatch,
                                                                                         command):
    # The same for the commands that write through vergence.io.atomic_write / atomic_folder: the
    # interrupt is seen inside the commit block, so no output appears and main() says "interrupted".
    import numpy as np

    import vergence.cli as cli
    from vergence.camera import look_at
    from vergence.io import CameraSet, write_image, write_middlebury_par

    rng = np.random.default_rng(0)
    texture = rng.random((48, 67, 3)).astype(np.float32)
    write_image(tmp_path / "left.png", texture[:, 3:])
    write_image(tmp_path / "right.png", texture[:, :64])
    cams = tuple(look_at((x, 0.0, 0.0), (0.0, 0.0, 3.0), (0.0, -1.0, 0.0), fov_deg=50.0, width=64, height=48)
                 for x in (-0.05, 0.05))
    write_middlebury_par(tmp_path / "cameras_par.txt", CameraSet(names=("left.png", "right.png"), cameras=cams))
    out = tmp_path / "out"
    argv = {
        "match": ["match", str(tmp_path / "left.png"), str(tmp_path / "right.png"), "--max-disparity", "16",
                  "--out", str(out) + ".pfm", "--preview", str(out) + "_preview.png"],
        "rectify": ["rectify", str(tmp_path / "left.png"), str(tmp_path / "right.png"), "--cameras",
                    str(tmp_path / "cameras_par.txt"), "--out", str(out)],
        "render": ["render", "tabletop", "--out", str(out), "--width", "16", "--height", "12", "--samples", "2",
                   "--depth", "1"],
        "specular": ["specular", "glasses", "--out", str(out), "--width", "16", "--height", "12", "--k", "2",
                     "--samples", "1"],
    }[command]
    before = sorted(p.name for p in tmp_path.iterdir())
    monkeypatch.setattr(cli, "_sigint_seen", True)
    assert cli.main(argv) == cli.EXIT_INTERRUPTED
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no output, no temporary file
