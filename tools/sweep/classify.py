"""Sort each run's outcome into the classes of issue 9 (a case may fall into several; none means ``ok``).

Web requests (kind ``web``, :mod:`tools.sweep.web_cases`, issue 29) have classes of their own:
``server_error`` (a 5xx, no answer, or an internal error in a job's status), ``accepted_hostile`` (a
guard's case that did not get the guard's refusal, a 2xx on a clearly invalid value, data from outside
the data folder), ``path_leak`` (a server folder or a traceback in the answer), ``hang`` (no answer in
time) and ``not_one_line`` (a refusal that is not exactly ``{"error": "<one line>"}``).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field

from vergence.cli._compile_notice import NOTICE as COMPILE_NOTICE

WEB_CLASSES = ("server_error", "accepted_hostile", "path_leak", "hang", "not_one_line")
CLASSES = ("internal_error", "traceback", "timeout", "killed", "noisy_stderr", "python_name", "suspicious_ok",
           "input_modified", "leftovers", "sigint", *WEB_CLASSES, "ok")

# Text that only a warning machinery or a C library prints (never one of our one-line messages).
NOISE = re.compile(r"RuntimeWarning|UserWarning|DeprecationWarning|encountered in|libpng|Corrupt JPEG|"
                   r"warnings\.warn|Premature end of JPEG|OpenCV\(|\[ WARN")
# Warnings that numpy or a dependency raises, never on purpose (a library's own UserWarning is a message).
NOISY_WARNINGS = ("RuntimeWarning", "DeprecationWarning", "FutureWarning", "ComplexWarning")
# The one exit code of an interrupted command (128 + SIGINT).
SIGINT_EXIT = 130
# A message that starts with a Python identifier followed by one of these words names that identifier.
_LEADING = re.compile(r"^([a-z][a-z0-9_]*)(?=\s+(must|should|is|has|cannot|needs|out of|=|:)|:|=)")
_SNAKE = re.compile(r"(?<![-\w./])([a-z][a-z0-9]*_[a-z0-9_]+)(?![\w./-])")


@dataclass
class Result:
    """What one case did; the runner fills it, :func:`classify` reads it."""

    id: str
    kind: str  # "cli", "sigint", "api" or "web"
    target: str
    command_line: str = ""
    hostile: bool = True
    strict: bool = False
    returncode: int | None = None  # web: the HTTP status (None: no answer)
    timed_out: bool = False
    seconds: float = 0.0
    stdout: str = ""
    stderr: str = ""
    inputs_changed: list[str] = field(default_factory=list)
    leftovers: list[str] = field(default_factory=list)
    degenerate: str | None = None
    sigint_sent: bool = False
    missing_outputs: list[str] = field(default_factory=list)  # of a run that exited 0 after Ctrl-C
    # API calls: "returned", "raised" or "setup_error", and the exception's type name.
    status: str = ""
    exc_type: str | None = None
    expected: bool = True
    warnings: list[str] = field(default_factory=list)
    arguments: tuple[str, ...] = ()  # the command's positional argument names (allowed in messages)
    # Web requests: the statuses of the guard's refusal a case must get (empty: any), the server folder
    # the answer named, and the data from outside the data folder it served.
    expect: tuple[int, ...] = ()
    leaked: str | None = None
    outside: str | None = None
    classes: list[str] = field(default_factory=list)


def error_line(stderr: str) -> str:
    """The message of a one-line ``error: ...`` on stderr ("" when there is none)."""
    for line in stderr.splitlines():
        if line.strip().startswith("error:"):
            return line.strip()[len("error:"):].strip()
    return ""


def python_name_in(message: str, names: frozenset[str], allowed: tuple[str, ...] = ()) -> str | None:
    """The Python parameter name a CLI message speaks of instead of the option, or None."""
    lead = _LEADING.match(message)
    if lead and lead.group(1) in names and lead.group(1) not in allowed:
        return lead.group(1)
    for match in _SNAKE.finditer(message):
        if match.group(1) in names and match.group(1) not in allowed:
            return match.group(1)
    return None


def answer_error(body: str) -> str | None:
    """The ``error`` of a JSON object answer (a refusal, or a job's status), else None."""
    try:
        data = json.loads(body)
    except ValueError:
        return None
    return data.get("error") if isinstance(data, dict) and isinstance(data.get("error"), str) else None


def is_one_line_refusal(body: str) -> bool:
    """Whether ``body`` is exactly ``{"error": "<one line>"}`` (a non-empty line, no line break)."""
    try:
        data = json.loads(body)
    except ValueError:
        return False
    return (isinstance(data, dict) and list(data) == ["error"] and isinstance(data["error"], str)
            and bool(data["error"].strip()) and not any(c in data["error"] for c in "\r\n"))


def classify_web(result: Result) -> list[str]:
    """The classes of a web request's answer (module notes)."""
    found: list[str] = []
    status, body = result.returncode, result.stdout
    error = answer_error(body)
    if result.timed_out:
        found.append("hang")
    elif status is None or status >= 500 or (error is not None and "please report" in error):
        found.append("server_error")
    reached = bool(result.expect) and status is not None and status < 500 and status not in result.expect
    if reached or (status is not None and 200 <= status < 300 and result.strict) or result.outside:
        found.append("accepted_hostile")
    if result.leaked or "Traceback (most recent call last)" in body:
        found.append("path_leak")
    if (status is not None and status >= 400 and not is_one_line_refusal(body)) or (error and "\n" in error):
        found.append("not_one_line")
    return found or ["ok"]


def classify(result: Result, *, names: frozenset[str] = frozenset()) -> list[str]:
    """The classes of ``result`` (``["ok"]`` when nothing is wrong); ``names`` are the Python parameter names."""
    if result.kind == "web":
        return classify_web(result)
    found: list[str] = []
    stderr = result.stderr
    # the console script's line before a first compilation (a cold kernel cache) is no message of the case
    lines = [ln for ln in stderr.splitlines() if ln.strip() and ln.strip() != COMPILE_NOTICE]
    if result.timed_out:
        found.append("timeout")
    if result.kind == "api":
        if result.status == "raised" and not result.expected:
            found.append("internal_error")
        if result.returncode is not None and result.returncode < 0 and not result.timed_out:
            found.append("killed")
        if any(w.startswith(NOISY_WARNINGS) for w in result.warnings) or NOISE.search(stderr):
            found.append("noisy_stderr")
        if result.status == "returned" and result.hostile and (result.strict or result.degenerate):
            found.append("suspicious_ok")
    else:
        rc = result.returncode
        interrupted = result.kind == "sigint" and result.sigint_sent
        if "Traceback (most recent call last)" in stderr:
            found.append("traceback")
        if rc == 1 or "please report" in stderr:
            found.append("internal_error")
        if rc is not None and rc < 0 and not result.timed_out and not (interrupted and rc == -2):
            found.append("killed")
        if NOISE.search(stderr) or (rc not in (0, None) and len(lines) > 1 and "traceback" not in found):
            found.append("noisy_stderr")
        if rc == 2 and python_name_in(error_line(stderr), names, result.arguments):
            found.append("python_name")
        if rc == 0 and result.hostile and not interrupted and (result.strict or result.degenerate):
            found.append("suspicious_ok")
        finished = rc == 0 and not result.missing_outputs and "Traceback" not in stderr  # Ctrl-C came too late
        if interrupted and not result.timed_out and not finished and (rc != SIGINT_EXIT or len(lines) != 1):
            found.append("sigint")
    if result.inputs_changed:
        found.append("input_modified")
    if result.leftovers:
        found.append("leftovers")
    return found or ["ok"]


def discount_degenerate_bases(results: list[Result]) -> None:
    """Forget the ``degenerate`` of a hostile case whose target's valid base call is degenerate too.

    An output that carries no information says nothing about the hostile value when the valid call
    gives the same (our guessed valid arguments may lie past the eyes' divergence, for one).
    """
    degenerate_bases = {r.target for r in results if r.id.endswith("/base") and r.degenerate}
    for r in results:
        if r.hostile and r.degenerate and r.target in degenerate_bases:
            r.degenerate = None
