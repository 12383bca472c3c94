"""``vergence`` command line: one module per command, listed in :data:`COMMANDS`, loaded on demand.

This module imports only the standard library, so that the console script installs its Ctrl-C
handler before anything heavy loads; Typer and the command modules load inside :func:`main`.
"""

from __future__ import annotations

import _signal  # signal's C core: `import signal` loads enum and collections, 10-60 ms without a handler
import os
import sys
import time
from collections.abc import MutableMapping
from types import FrameType

__all__ = ["COMMANDS", "EXIT_INTERRUPTED", "app", "entry", "main"]

# name -> (module in vergence.cli, one-line summary for ``vergence --help``). A new command is one
# row here and a module that registers it with ``@app.command(name)``; keep the rows sorted.
COMMANDS: dict[str, tuple[str, str]] = {
    "analyze": ("analyze", "Comfort of a stereo or 2D + depth clip on a display: disparity percentiles, comfort, "
                "divergence, stereo window, vertical disparity and a suggested retargeting, per frame and per shot."),
    "budget": ("budget", "Depth budget of a rig on a display: divergence and roundness baselines, z' and "
               "roundness per depth (S0 §2)."),
    "compare": ("compare", "Compare a view with its reference: PSNR, SSIM, DSSIM, registration error (S1 §V.B)."),
    "convert": ("convert", "Retarget a stereo or 2D + depth clip into a display's parallax budget, shot by shot, as "
                "a stereo video (temporal stability, audio copied, --resume per shot)."),
    "demo": ("demo", "Run the main job on built-in data and write OUT/index.html."),
    "evaluate-disparity": ("evaluate_disparity", "Score ESTIMATE against TRUTH: % bad pixels and RMS over "
                           "nonocc / all / disc (/ textureless)."),
    "interpolate": ("interpolate", "Synthesize the view at position T between two rectified references "
                    "(view interpolation)."),
    "mapping": ("mapping", "Build the disparity mapping psi from director constraints and report it "
                "(S0 §6, Eq. 7–9)."),
    "match": ("match", "Compute the disparity map of LEFT (x_left - x_right, px) and write it to --out."),
    "rectify": ("rectify", "Rectify LEFT and RIGHT with their calibrated cameras: row-aligned images, cameras, "
                "homographies."),
    "render": ("render", "Ray-trace SCENE into the S3 ray tree: per-layer radiance, position, normal; depth; "
               "previews."),
    "rig": ("rig", "Plan and render the Quadri-Rig and the Tri-Rig of a shot file (S0 §5–6): plan, render."),
    "serve": ("serve", "Run the workbench: a local page and its JSON API (needs the web extra)."),
    "specular": ("specular", "Make the glass and mirrors of SCENE fusible (S3): per-layer camera offsets, renders, "
                 "per-layer disparity, importance and rivalry before and after, report."),
    "stereospace": ("stereospace", "Browse a calibrated photo collection in stereo (S2): view (a novel view, "
                    "leave-one-out PSNR), build (space, quality, map), pair (the stereo pair at a state)."),
    "synthesize": ("synthesize", "Make the views a display needs from one image and its depth (writes views, "
                   "layout, JSON)."),
    "warm": ("warm", "Compile the kernels of the commands and the workbench ahead of their first use (into "
             "Numba's cache in the user's folder)."),
}

# Exit status after Ctrl-C: 128 + SIGINT (2), as POSIX shells report a process killed by SIGINT.
EXIT_INTERRUPTED = 130

# Seconds between two looks at whether a deferred Ctrl-C can be raised (see _unraisable_at): far
# under the ~100 ms a user notices, and a look (a walk up ~50 frames) takes microseconds, so
# LLVM's seconds of compiling are not slowed.
SIGINT_RETRY_S = 0.01

# Set by the console script's SIGINT handler: whatever happens next (an import that turns the
# KeyboardInterrupt into a SystemError, a library that swallows it), the run ends as interrupted.
# A plain flag, not a threading.Event: this module imports nothing that delays the handler.
_sigint_seen = False
# A Ctrl-C seen but not raised yet: it arrived where an exception would be lost (see _unraisable_at).
_sigint_pending = False


# What the "interrupted" line adds, set by a command that left something to resume (convert's finished shots).
_interrupted_note: str | None = None


def note_if_interrupted(note: str | None) -> None:
    """Have the ``interrupted`` line say ``note`` (``interrupted: NOTE``) should this run end interrupted."""
    global _interrupted_note
    _interrupted_note = note


def sigint_seen() -> bool:
    """Whether the console script's handler saw Ctrl-C (SIGINT) in this process."""
    return _sigint_seen


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if the console script saw Ctrl-C: call it before committing outputs.

    A Ctrl-C that arrived while Numba was inside LLVM waits (up to :data:`SIGINT_RETRY_S`) before it
    is raised; a command whose last step ends in that time must still not commit its outputs.
    """
    if _sigint_seen:
        _forget_pending()
        raise KeyboardInterrupt


def _forget_pending() -> None:
    """Stop the retry timer of a Ctrl-C not raised yet: it is being handled now."""
    global _sigint_pending
    if _sigint_pending:
        _sigint_pending = False
        _retry_in(0.0)


def _retry_in(seconds: float) -> None:
    """Arm (or, with 0, stop) the SIGALRM timer of a deferred Ctrl-C; no-op where there is none (Windows)."""
    if hasattr(_signal, "setitimer"):
        if seconds:
            _signal.signal(_signal.SIGALRM, _on_sigint_retry)
        _signal.setitimer(_signal.ITIMER_REAL, seconds)


def __getattr__(name: str) -> object:
    if name == "app":  # the Typer application; loads Typer, not the commands
        from vergence.cli._app import app

        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code.

    Library errors (``ValueError``, ``TypeError``, ``OSError``) and command-line usage errors become
    one line on stderr naming the option and exit code 2; any other exception is a bug of ours: one
    line and exit code 1 (set ``VERGENCE_DEBUG=1`` for the traceback). Ctrl-C
    (``KeyboardInterrupt``, or any error raised once the console script saw SIGINT) prints
    ``interrupted`` and returns :data:`EXIT_INTERRUPTED`.
    """
    note_if_interrupted(None)  # a note of an earlier run in this process (tests call main again)
    try:
        pause_for_test("START")
        from vergence.cli._run import run

        code = run(argv)
    except KeyboardInterrupt:
        code = EXIT_INTERRUPTED
    except Exception:
        if not _sigint_seen:
            raise
        code = EXIT_INTERRUPTED
    _forget_pending()  # the run is over: a late retry must not raise while we report
    if code == EXIT_INTERRUPTED or _sigint_seen:
        sys.stderr.write("interrupted\n" if not _interrupted_note else f"interrupted: {_interrupted_note}\n")
        sys.stderr.flush()
        return EXIT_INTERRUPTED
    return code


def pause_for_test(point: str) -> None:
    """Sleep at a named point when ``VERGENCE_TEST_SLEEP_<POINT>`` (seconds) is set: a test hook.

    A test sets the variable, waits for the line ``test: sleeping at <point>`` on stderr and sends
    SIGINT, so that Ctrl-C arrives at a known stage: ``START`` (before Typer loads) or ``IMPORT``
    (before a command module loads).
    """
    seconds = os.environ.get(f"VERGENCE_TEST_SLEEP_{point}")
    if seconds:
        sys.stderr.write(f"test: sleeping at {point.lower()}\n")
        sys.stderr.flush()
        time.sleep(float(seconds))


def _on_sigint(signum: int, frame: FrameType | None) -> None:
    """Record Ctrl-C, then raise ``KeyboardInterrupt`` so that ``finally`` blocks clean up.

    Where an exception would be lost (:func:`_unraisable_at`), the raise waits: a timer looks again
    every :data:`SIGINT_RETRY_S` seconds and raises as soon as the interrupted code can take it.
    """
    global _sigint_seen, _sigint_pending
    _sigint_seen = _sigint_pending = True
    _raise_when_safe(frame)


def _on_sigint_retry(signum: int, frame: FrameType | None) -> None:
    """The timer of a deferred Ctrl-C (SIGALRM): raise now if the interrupted code can take it."""
    if _sigint_pending:
        _raise_when_safe(frame)


def _raise_when_safe(frame: FrameType | None) -> None:
    if hasattr(_signal, "setitimer") and _unraisable_at(frame):
        _retry_in(SIGINT_RETRY_S)
        return
    _forget_pending()
    raise KeyboardInterrupt


def _unraisable_at(frame: FrameType | None) -> bool:
    """Whether an exception raised at ``frame`` would be lost, or crash the process.

    True inside llvmlite: LLVM calls back into Python through ctypes while Numba compiles or loads
    its cache (``ExecutionEngine._raw_object_cache_getbuffer``); ctypes prints an exception raised
    there (``Exception ignored on calling ctypes callback function``) and hands LLVM an empty
    object, so a cached kernel is linked without its code and the process dies of SIGSEGV (issue 9,
    sweep case ``sigint/interpolate``). True inside a ``__del__`` too, whose exceptions Python also
    prints and drops.
    """
    llvmlite = sys.modules.get("llvmlite")
    root = os.path.dirname(getattr(llvmlite, "__file__", None) or "")
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or (root and code.co_filename.startswith(root + os.sep)):
            return True
        frame = frame.f_back
    return False


def _prefer_passive_omp_wait(environ: MutableMapping[str, str]) -> None:
    """Let OpenMP threads sleep rather than spin while they wait, unless the user chose a policy.

    Numba reads ``OMP_WAIT_POLICY`` when its threading layer starts (the first parallel kernel), so
    the console script sets it before running a command. Spinning threads steal shared cores
    (measured: ``forward_warp`` 3.3x slower than with passive waiting under a load average of 5 on 2
    cores). The library itself never touches the environment of the program that imports it.
    """
    environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def _use_user_kernel_cache() -> None:
    """Numba's cache in a folder the user owns (:func:`vergence._cache.use_numba_cache_dir`), and one
    line on stderr before the first compilation (:mod:`vergence.cli._compile_notice`).

    Numba reads ``NUMBA_CACHE_DIR`` once, when it is imported: the console script sets it before any
    command loads. Its default (``__pycache__`` beside the kernels' sources) fails or helps no one
    for an installed, read-only or shared package.
    """
    from vergence._cache import use_numba_cache_dir
    from vergence.cli import _compile_notice

    use_numba_cache_dir(os.environ)
    _compile_notice.install()


def entry() -> None:
    """The console script (``vergence``, ``python -m vergence``): SIGINT handler first (before any heavy
    import), then :func:`main`; exits with its code."""
    _signal.signal(_signal.SIGINT, _on_sigint)
    _prefer_passive_omp_wait(os.environ)
    _use_user_kernel_cache()
    code = main()
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)  # a second Ctrl-C cannot turn the exit into a traceback
    _retry_in(0.0)  # nor a deferred one's timer (SIGALRM's default action kills)
    sys.exit(code)
