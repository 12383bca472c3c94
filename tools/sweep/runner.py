"""Run the cases: each command line in its own subprocess, API calls in batches, all under limits.

A subprocess gets a wall-clock limit (``time_limit_s``) and an address-space limit
(``resource.RLIMIT_AS``, ``memory_gb``); it runs in its own session so that a timeout kills the whole
process group and Ctrl-C goes to the group, as a terminal sends it. Each command line works in a
fresh case folder holding copies of its inputs: the inputs are hashed before and after, and whatever
the command leaves in the folder is checked (all or nothing).
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import select
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tools.sweep.classify import Result

REPO = Path(__file__).resolve().parents[2]
ENTRY = "import sys; sys.argv[0] = 'vergence'; from vergence.cli import entry; entry()"
# Share of pixels exactly black above which an output image counts as empty (a valid view of a
# textured fixture has none; issue 9 saw 84 % holes and all-black views).
BLACK_SHARE = 0.5
MASK_WORDS = ("hole", "error", "mask", "confidence", "invalid", "valid")
OUTPUT_TAIL = 4000  # characters of stdout/stderr kept per case


@dataclass(frozen=True)
class Limits:
    """Per-process limits: wall clock (s) and address space (GiB)."""

    time_limit_s: float = 60.0
    memory_gb: float = 8.0


def environment() -> dict[str, str]:
    """The subprocess environment: this checkout's ``src`` first, one thread per process."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO / "src"), str(REPO)])
    env.setdefault("HOME", str(Path.home()))
    env.update(OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
    env.pop("VERGENCE_DEBUG", None)
    return env


def _limit_memory(memory_gb: float):
    limit = int(memory_gb * 2**30)

    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    return apply


def prepare(folder: Path) -> None:
    """Write the fixtures (``folder/fixtures``) and the hostile files (``folder/hostile``)."""
    from tools.sweep.cli_cases import write_fixtures
    from tools.sweep.hostile import write_hostile_files

    write_fixtures(folder / "fixtures")
    write_hostile_files(folder / "hostile")
    from vergence.io import read_middlebury_par, write_cameras_json

    fixtures = folder / "fixtures"
    write_cameras_json(fixtures / "cameras.json", read_middlebury_par(fixtures / "cameras_par.txt"))


def _hashes(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _listing(folder: Path, skip: tuple[str, ...]) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")
            if p.relative_to(folder).parts[0] not in skip}


def _degenerate_file(path: Path) -> str | None:
    """Why an output file is empty of content (constant, mostly black, all NaN), or None.

    Masks and error images (holes, errors, confidence) are black where all is well: only their
    readability and finiteness are judged.
    """
    suffix = path.suffix.lower()
    try:
        if suffix in (".png", ".jpg", ".jpeg", ".tif", ".tiff"):
            from PIL import Image

            with Image.open(path) as im:
                a = np.asarray(im)
        elif suffix == ".npy":
            a = np.load(path)
        elif suffix == ".pfm":
            sys.path.insert(0, str(REPO / "src"))
            from vergence.io import read_pfm

            a = read_pfm(path)
        else:
            return None
    except Exception as exc:  # noqa: BLE001 - an unreadable output is a finding of its own
        return f"{path.name}: unreadable ({type(exc).__name__})"
    if a.size == 0:
        return f"{path.name}: empty"
    a = a.astype(np.float64)
    if not np.isfinite(a).any():
        return f"{path.name}: no finite value"
    if any(word in path.stem.lower() for word in MASK_WORDS):
        return None
    if np.nanmax(a) == np.nanmin(a):
        return f"{path.name}: constant {np.nanmax(a):g}"
    black = (a == 0).all(axis=-1) if a.ndim == 3 else a == 0
    if suffix != ".pfm" and suffix != ".npy" and black.mean() > BLACK_SHARE:
        return f"{path.name}: {100 * black.mean():.0f} % black"
    return None


def inconsistent_json(stdout: str) -> str | None:
    """Why a command's JSON contradicts itself (a perceived depth of 0 m, a divergence flag that
    disagrees with the missing perceived depth), or None; stdout that is not JSON is not judged.

    A perceived depth is finite and > 0 exactly when the eyes do not diverge (S0 Eq. (1b):
    ``z' = b'H' / (b' - W' d)``, finite and positive for ``W' d < b'``).
    """
    try:
        data = json.loads(stdout)
    except ValueError:
        return None
    stack = [data]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            if "perceived_depth" in item and "diverges" in item:
                z, diverges = item["perceived_depth"], item["diverges"]
                if z is not None and not z > 0:
                    return f"perceived_depth {z} at depth {item.get('depth')}"
                if (z is None) != bool(diverges):
                    return f"diverges {diverges} but perceived_depth {z} at depth {item.get('depth')}"
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)
    return None


def substitute(argv: tuple[str, ...], mapping: dict[str, str]) -> list[str]:
    out = []
    for token in argv:
        for key, value in mapping.items():
            token = token.replace("{" + key + "}", value)
        out.append(token)
    return out


def run_cli(case, folder: Path, index: int, limits: Limits, arguments: tuple[str, ...] = ()) -> Result:
    """Run one command-line case (kind "cli" or "sigint") in its own case folder."""
    case_dir = folder / "cases" / f"{index:05d}"
    shutil.rmtree(case_dir, ignore_errors=True)
    case_dir.mkdir(parents=True)
    shutil.copytree(folder / "fixtures", case_dir / "in")
    shutil.copytree(folder / "hostile", case_dir / "hostile")
    (case_dir / "existing_dir").mkdir()
    inputs = [t for t in case.argv if "{fx}/" in t]
    first_input = inputs[0] if inputs else "{fx}/image.png"
    argv = [t.replace("{input}", first_input) for t in case.argv]
    real = substitute(argv, {"fx": str(case_dir / "in"), "hostile": str(case_dir / "hostile"), "case": str(case_dir)})
    shown = substitute(argv, {"fx": str(folder / "fixtures"), "hostile": str(folder / "hostile"),
                              "case": str(folder / "scratch")})
    before_hashes = _hashes(case_dir / "in") | {"hostile/" + k: v for k, v in _hashes(case_dir / "hostile").items()}
    skip = ("in", "hostile")
    before = _listing(case_dir, skip)
    result = Result(id=case.id, kind=case.kind, target=case.target, hostile=case.hostile, strict=case.strict,
                    command_line="vergence " + shlex.join(shown), arguments=arguments)
    start = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-c", ENTRY, *real], cwd=case_dir, env=environment(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                            start_new_session=True, preexec_fn=_limit_memory(limits.memory_gb))
    if case.sigint_after is not None:
        while time.monotonic() - start < case.sigint_after and proc.poll() is None:
            time.sleep(0.01)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            result.sigint_sent = True
    try:
        out, err = proc.communicate(timeout=max(1.0, limits.time_limit_s - (time.monotonic() - start)))
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        result.timed_out = True
    result.seconds = round(time.monotonic() - start, 2)
    result.returncode = proc.returncode
    result.stdout = out.decode("utf-8", "replace")[-OUTPUT_TAIL:]
    result.stderr = err.decode("utf-8", "replace")[-OUTPUT_TAIL:]
    after_hashes = _hashes(case_dir / "in") | {"hostile/" + k: v for k, v in _hashes(case_dir / "hostile").items()}
    result.inputs_changed = sorted(k for k in before_hashes if after_hashes.get(k) != before_hashes[k])
    if result.sigint_sent and result.returncode == 0:
        result.missing_outputs = [o for o in case.outputs if not (case_dir / o).exists()]
    new = sorted(_listing(case_dir, skip) - before)
    if result.returncode != 0 and not result.timed_out and not (result.returncode or 0) < 0:
        result.leftovers = new
    elif result.returncode == 0:
        result.leftovers = [n for n in new if Path(n).name.startswith(".")
                            or ((case_dir / n).is_dir() and not any((case_dir / n).iterdir()))]
        files = [case_dir / n for n in new if (case_dir / n).is_file()]
        reasons = [r for r in [*map(_degenerate_file, files), inconsistent_json(result.stdout)] if r]
        result.degenerate = "; ".join(reasons) or None
    shutil.rmtree(case_dir, ignore_errors=True)
    return result


def run_api_batch(specs: list[dict], folder: Path, batch: int, limits: Limits) -> tuple[list[Result], int]:
    """Run API cases in driver subprocesses (a new one after a hang or crash); return results and runs."""
    cases_path = folder / f"api_batch_{batch:03d}.json"
    cases_path.write_text(json.dumps(specs))
    work = folder / f"api_work_{batch:03d}"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    (work / "fixtures").symlink_to(folder / "fixtures")
    shutil.copytree(folder / "hostile", work / "hostile")
    results: dict[int, Result] = {}
    start_index, runs = 0, 0
    while start_index < len(specs):
        runs += 1
        log = (work / "driver_stderr.txt").open("wb")
        proc = subprocess.Popen([sys.executable, "-m", "tools.sweep.api_driver", str(cases_path), str(work),
                                 str(start_index)], cwd=work, env=environment(), stdout=subprocess.PIPE,
                                stderr=log, stdin=subprocess.DEVNULL, start_new_session=True,
                                preexec_fn=_limit_memory(limits.memory_gb))
        current, buffer, deadline = None, b"", time.monotonic() + limits.time_limit_s + 30  # imports first
        timed_out = False
        while True:
            ready, _, _ = select.select([proc.stdout], [], [], 0.5)
            if ready:
                chunk = os.read(proc.stdout.fileno(), 65536)
                if not chunk:
                    break
                buffer += chunk
                while b"\n" in buffer:
                    line, buffer = buffer.split(b"\n", 1)
                    event = json.loads(line)
                    if "start" in event:
                        current, deadline = event["start"], time.monotonic() + limits.time_limit_s
                    else:
                        results[event["index"]] = _api_result(specs[event["index"]], event)
                        current = None
            if time.monotonic() > deadline:
                os.killpg(proc.pid, signal.SIGKILL)
                timed_out = True
                break
        proc.wait()
        log.close()
        if current is None:
            break
        spec = specs[current]
        result = _api_result(spec, {"status": "crashed", "seconds": limits.time_limit_s if timed_out else 0.0})
        result.timed_out = timed_out
        result.returncode = proc.returncode
        result.stderr = (work / "driver_stderr.txt").read_text("utf-8", "replace")[-OUTPUT_TAIL:]
        if not timed_out and proc.returncode is not None and proc.returncode >= 0:
            result.expected = False  # the process exited in the middle of a call: a bug of ours
            result.status = "raised"
            result.exc_type = f"exit {proc.returncode}"
        results[current] = result
        start_index = current + 1
    shutil.rmtree(work, ignore_errors=True)
    return [results[i] for i in sorted(results)], runs


def _api_result(spec: dict, event: dict) -> Result:
    from tools.sweep.api_cases import CONTENTLESS_ARRAYS

    token = spec.get("token") or ""
    degenerate = event.get("degenerate")
    if spec.get("kind") == "array" and token.rstrip("!") not in CONTENTLESS_ARRAYS:
        degenerate = None
    call = f"{spec['module']}.{spec['name']}" + (f"({spec['param']}=<{token.rstrip('!')}>)" if spec["param"] else "()")
    return Result(id=spec["id"], kind="api", target=f"{spec['module']}.{spec['name']}", command_line=call,
                  hostile=spec["param"] is not None, strict=token.endswith("!"), status=event.get("status", ""),
                  exc_type=event.get("exc_type"), expected=event.get("expected", True),
                  stderr=(event.get("stderr") or "") if event.get("status") != "setup_error" else "",
                  stdout=event.get("message", ""), warnings=event.get("warnings", []),
                  inputs_changed=event.get("inputs_changed", []), leftovers=event.get("leftovers", []),
                  degenerate=degenerate, seconds=event.get("seconds", 0.0))
