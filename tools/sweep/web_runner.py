"""Serve the workbench on 127.0.0.1 and send it the web cases (:mod:`tools.sweep.web_cases`), each bounded in time.

The app is made in this process (``vergence.web.create_app``, or a factory a test passes) over the data
folder of :mod:`tools.sweep.web_data`, and served by uvicorn in a thread on a socket bound to
127.0.0.1 on a free port (never another address). Requests go over real sockets (``http.client``),
so that a Host header, a missing Content-Type or a chunked body arrive as a browser or an attacker
sends them; each has a wall-clock limit, past which the case is a hang. After a hang the server is
asked for ``/api/health``; when it no longer answers, the cases left are recorded as hangs unrun.

Each answer is judged here for what only the running server knows: a server path in it (the sweep's
folder, the data folder, the app's temporary folder, the repository) that the request did not
contain, and data from outside the data folder (:data:`tools.sweep.web_data.OUTSIDE_MARKER`, or an
entry that ``GET /api/data`` must not list). A job started by a hostile request is cancelled at once;
one started by a valid base is followed to its end (its final status judged as an answer), then
cancelled if it is still running.
"""

from __future__ import annotations

import http.client
import json
import logging
import os
import random
import re
import shlex
import shutil
import socket
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from urllib.parse import quote, unquote

from tools.sweep.classify import Result
from tools.sweep.runner import OUTPUT_TAIL, REPO
from tools.sweep.web_cases import WebCase, WebContext, route_table, web_cases
from tools.sweep.web_data import OUTSIDE_MARKER, listed_forbidden, write_data_folder

__all__ = ["JOB_WAIT_S", "run_web"]

#: Seconds the jobs of the valid bases may take, all together (tiny sizes: a few seconds each).
JOB_WAIT_S = 60.0
# Seconds to wait for the server to start and stop, and for /api/health after a hang.
START_S, STOP_S, PROBE_S = 30.0, 30.0, 5.0
MAX_READ = 4 * 2**20  # bytes of an answer read at most (the OpenAPI schema is ~100 kB)
# Characters of an answer kept in the report: a refusal whole (judged for its one line), else the start.
BODY_KEPT, REFUSAL_KEPT = 4000, 65536
FINAL = ("done", "failed", "cancelled")
# The fixtures uploaded for the twins (tools.sweep.runner.prepare writes them), by file name.
UPLOADS = ("image.png", "image_right.png", "image_noisy.png", "left.png", "right.png", "depth.npy", "disp_left.pfm",
           "disp_right.pfm", "disp_left_noisy.pfm")
_TYPES = {".png": "image/png", ".npy": "application/octet-stream", ".pfm": "image/x-portable-floatmap"}


@dataclass
class _Answer:
    status: int | None
    head: str  # the status line's reason and the headers, as text
    body: bytes
    timed_out: bool
    seconds: float
    error: str = ""  # why no answer came


class _Log(logging.Handler):
    """The server's log lines (uvicorn's errors: a traceback of an unhandled exception) for the current case."""

    def __init__(self) -> None:
        super().__init__()
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(self.format(record))


class _Served:
    """``app`` served by uvicorn in a daemon thread on 127.0.0.1 and a free port, its log captured."""

    def __init__(self, app) -> None:  # noqa: ANN001 - an ASGI app
        import uvicorn

        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        config = uvicorn.Config(app, log_config=None, log_level="warning", access_log=False, ws="none",
                                lifespan="on", timeout_graceful_shutdown=5)
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True,
                                       name=f"sweep-web-{self.port}")
        self.log = _Log()
        self._logger = logging.getLogger("uvicorn.error")

    def __enter__(self) -> _Served:
        self._propagate = self._logger.propagate
        self._logger.addHandler(self.log)
        self._logger.propagate = False
        self.thread.start()
        deadline = time.monotonic() + START_S
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                self.__exit__()
                raise RuntimeError(f"the workbench did not start on 127.0.0.1:{self.port}: {self.log.lines[-3:]}")
            time.sleep(0.02)
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(STOP_S)
        self.sock.close()
        self._logger.removeHandler(self.log)
        self._logger.propagate = self._propagate


def send(port: int, case: WebCase, limit_s: float) -> _Answer:
    """Send ``case`` to 127.0.0.1:``port`` and read the answer, all within ``limit_s`` seconds."""
    start = time.monotonic()
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=limit_s)
    status, head, chunks = None, "", []
    try:
        conn.putrequest(case.method, case.url, skip_host=True, skip_accept_encoding=True)
        if not any(k.lower() == "host" for k, _ in case.headers):
            conn.putheader("Host", f"127.0.0.1:{port}")
        for key, value in case.headers:
            conn.putheader(key, value)
        body = case.body
        try:
            if case.chunked:
                conn.putheader("Transfer-Encoding", "chunked")
                conn.endheaders([body[i:i + 65536] for i in range(0, len(body or b""), 65536)], encode_chunked=True)
            elif body is not None or case.method in ("POST", "PUT"):
                length = case.declared_length if case.declared_length is not None else len(body or b"")
                conn.putheader("Content-Length", str(length))
                conn.endheaders(body or b"")
            else:
                conn.endheaders()
        except (BrokenPipeError, ConnectionResetError):
            pass  # the server answered (413) and closed before the whole body was sent: read its answer
        response = conn.getresponse()
        status = response.status
        head = f"{response.reason}\n" + "".join(f"{k}: {v}\n" for k, v in response.getheaders())
        size = 0
        while size < MAX_READ:
            if time.monotonic() - start > limit_s:
                raise TimeoutError
            chunk = response.read1(65536)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except TimeoutError:
        return _Answer(status, head, b"".join(chunks), True, time.monotonic() - start, "no answer in time")
    except (OSError, http.client.HTTPException) as exc:
        if status is None:
            return _Answer(None, "", b"", False, time.monotonic() - start, f"no answer: {type(exc).__name__}: {exc}")
    finally:
        conn.close()
    return _Answer(status, head, b"".join(chunks), False, time.monotonic() - start)


def _curl(case: WebCase, port: int) -> str:
    """The case as a curl command line (a long or binary body described, not shown)."""
    parts = ["curl", "-sS", "-X", case.method, f"http://127.0.0.1:{port}{case.url}"]
    for key, value in case.headers:
        parts += ["-H", f"{key}: {value}"]
    if not any(k.lower() == "content-type" for k, _ in case.headers) and case.body is not None:
        parts += ["-H", "Content-Type:"]
    if case.chunked:
        parts += ["-H", "Transfer-Encoding: chunked"]
    if case.declared_length is not None:
        parts += ["-H", f"Content-Length: {case.declared_length}"]
    line = shlex.join(parts)
    body = case.body
    if body is not None:
        try:
            text = body.decode("utf-8")
            printable = text.isprintable()
        except UnicodeDecodeError:
            printable = False
        shown = shlex.quote(text) if printable and len(body) <= 300 else f"<{len(body)} bytes: {body[:40]!r}...>"
        line += f" --data-binary {shown}"
    return line


class _Judge:
    """What only the running server's folders tell: leaked paths and data from outside."""

    def __init__(self, out: Path, data_root: Path, outside: Path, workdir: Path) -> None:
        named = [("the sweep's folder", out), ("the data folder", data_root), ("the outside folder", outside),
                 ("the app's temporary folder", workdir), ("the repository", REPO)]
        forms = {(label, form) for label, p in named for form in (os.fspath(p), os.path.realpath(p))}
        self.secrets = sorted(forms, key=lambda lf: -len(lf[1]))  # the most specific folder first

    def __call__(self, case: WebCase, answer: _Answer) -> tuple[str | None, str | None]:
        text = answer.head + answer.body.decode("utf-8", "replace")
        sent = unquote(case.url) + (case.body or b"")[:MAX_READ].decode("utf-8", "replace")
        leaked = next((f"{label} ({path})" for label, path in self.secrets if path in text and path not in sent), None)
        outside = "an outside file's content" if OUTSIDE_MARKER in text and OUTSIDE_MARKER not in sent else None
        if case.method == "GET" and case.target.endswith("/api/data") and answer.status == 200:
            try:
                listing = json.loads(answer.body)
                names = [e["name"] for key in ("collections", "scenes") for e in listing[key]]
            except (ValueError, KeyError, TypeError):
                names = []
            bad = listed_forbidden(names)
            outside = outside or (f"listed {bad!r}" if bad else None)
        return leaked, outside


class _Session:
    """The running server, its judge and the results so far: :meth:`run` sends a case and records it."""

    def __init__(self, served: _Served, judge: _Judge, time_limit_s: float) -> None:
        self.served, self.judge, self.time_limit_s = served, judge, time_limit_s
        self.results: list[Result] = []

    def send(self, method: str, url: str, limit_s: float = PROBE_S) -> _Answer:
        """A request of the harness itself (a poll, a cancel), not recorded."""
        return send(self.served.port, WebCase("", "", method, url, headers=()), limit_s)

    def run(self, case: WebCase) -> _Answer:
        self.served.log.lines.clear()
        answer = send(self.served.port, case, self.time_limit_s)
        self.record(case, answer)
        return answer

    def record(self, case: WebCase, answer: _Answer) -> None:
        leaked, outside = self.judge(case, answer)
        stderr = "\n".join([*self.served.log.lines, answer.error]).strip()
        self.results.append(Result(
            id=case.id, kind="web", target=case.target, command_line=_curl(case, self.served.port),
            hostile=case.hostile, strict=case.strict, returncode=answer.status, timed_out=answer.timed_out,
            seconds=round(answer.seconds, 3),
            stdout=answer.body.decode("utf-8", "replace")[:REFUSAL_KEPT if (answer.status or 0) >= 400 else BODY_KEPT],
            stderr=stderr[-OUTPUT_TAIL:], expect=case.expect, leaked=leaked, outside=outside))


def _json(answer: _Answer) -> dict:
    try:
        data = json.loads(answer.body)
    except ValueError:
        return {}
    return data if isinstance(data, dict) else {}


def _context(app, session: _Session, data, fixtures: Path) -> WebContext:  # noqa: ANN001
    """Upload the fixtures, look the data entries up, run one tiny render job: the ids cases use."""
    import hashlib

    ctx = WebContext(ids={}, port=session.served.port, fixtures={n: (fixtures / n).read_bytes() for n in UPLOADS})
    for name in UPLOADS:
        case = WebCase(f"web/setup/upload={name}", "POST /api/uploads", "POST", f"/api/uploads?name={name}",
                       (("Content-Type", _TYPES[Path(name).suffix]),), ctx.fixtures[name], hostile=False)
        ctx.ids[Path(name).stem] = _json(session.run(case)).get("id", "0123456789abcdef")
    by_name = {e.name: e for e in app.state.data_index.entries()}
    roles = {"cameras": data.cameras, "shot": data.shot, "collection_out": data.collection_out,
             "truncated": data.truncated, "unreadable": "unreadable_par.txt"}
    ctx.ids.update({role: by_name[name].id for role, name in roles.items() if name in by_name})
    ctx.data_path = os.fspath(data.root / data.cameras)
    # the id rule of vergence.web.data (the kind and a hash of the resolved path), for a file outside
    secret = os.path.realpath(data.outside / "secret_par.txt")
    ctx.outside_id = f"collection-{hashlib.sha256(os.fsencode(secret)).hexdigest()[:16]}"
    job = WebCase("web/setup/render", "POST /api/jobs/render", "POST", "/api/jobs/render",
                  body=b'{"scene": "scene:tabletop", "width": 1, "height": 1, "depth": 0, "samples": 1}', hostile=False)
    job_id = _json(session.run(job)).get("id")
    deadline = time.monotonic() + JOB_WAIT_S
    while isinstance(job_id, str) and time.monotonic() < deadline:
        status = _json(session.send("GET", f"/api/jobs/{job_id}"))
        if status.get("state") in FINAL:
            ctx.job, ctx.job_file = job_id, (status.get("files") or ["beauty.png"])[0]
            break
        time.sleep(0.05)
    return ctx


def _follow_cases(ctx: WebContext) -> list[WebCase]:
    """StereoSpace jobs on the hostile collections (a truncated camera file, an unreadable one): each
    fails in one line naming no path, or runs on what lies inside."""
    return [WebCase(f"web/POST /api/jobs/stereospace/collection={role}", "POST /api/jobs/stereospace", "POST",
                    "/api/jobs/stereospace", body=json.dumps({"collection": ctx.ids[role], "grid_step": 16}).encode(),
                    follow=True) for role in ("truncated", "unreadable") if role in ctx.ids]


def _wanted(target: str, templates: set[str]) -> bool:
    """Whether a case's route (``POST /api/jobs/render`` or a template) is one of ``templates``."""
    path = target.split(" ", 1)[-1]
    return path in templates or any(re.fullmatch(re.sub(r"\{\w+\}", "[^/]+", t), path) for t in templates if "{" in t)


def run_web(out: Path, *, quick: bool = False, rng: random.Random | None = None, time_limit_s: float = 20.0,
            names: tuple[str, ...] = (), limit: int | None = None, per_field: int | None = None,
            app_factory=None) -> list[Result]:  # noqa: ANN001
    """Run the web cases against a fresh app served on 127.0.0.1; returns the results.

    ``names`` (command or route names: ``budget``, ``health``, ``jobs``) keep the routes with such a path
    segment; ``app_factory(data_dirs)`` makes the app (``vergence.web.create_app`` by default);
    ``per_field``: hostile values per body field in a quick sweep. ``out/fixtures`` must hold the
    sweep's fixtures (:func:`tools.sweep.runner.prepare`).
    """
    if app_factory is None:
        from vergence.web import create_app as app_factory
    rng = rng or random.Random(9)
    scratch = Path(out) / "scratch" / "web"
    shutil.rmtree(scratch, ignore_errors=True)
    data = write_data_folder(scratch, cameras_par=Path(out) / "fixtures" / "cameras_par.txt")
    try:
        app = app_factory([data.root])
        wanted = {t for _, t in route_table(app) if not names or any(n in t.split("/") for n in names)}
        if not wanted:
            return []
        with _Served(app) as served:
            session = _Session(served, _Judge(Path(out), data.root, data.outside, app.state.workdir), time_limit_s)
            ctx = _context(app, session, data, Path(out) / "fixtures")
            cases = web_cases(app, ctx, quick=quick, rng=rng, **({} if per_field is None else {"per_field": per_field}))
            cases = [c for c in cases if _wanted(c.target, wanted)]
            cases += [c for c in _follow_cases(ctx) if _wanted(c.target, wanted)]
            _run_cases(session, cases[:limit])
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return session.results


def _run_cases(session: _Session, cases: list[WebCase]) -> None:
    followed: dict[str, WebCase] = {}  # job id -> the valid base that started it
    dead = None
    for case in cases:
        if dead is not None:
            session.results.append(Result(
                id=case.id, kind="web", target=case.target, command_line=_curl(case, session.served.port),
                hostile=case.hostile, strict=case.strict, timed_out=True, expect=case.expect,
                stderr=f"not run: the server stopped answering after {dead}"))
            continue
        answer = session.run(case)
        if answer.timed_out and session.send("GET", "/api/health").status != 200:
            dead = case.id
            continue
        job_id = _json(answer).get("id") if case.method == "POST" and case.url.startswith("/api/jobs/") else None
        if answer.status is not None and 200 <= answer.status < 300 and isinstance(job_id, str):
            if case.follow and job_id not in followed:
                followed[job_id] = case
            elif job_id not in followed:  # a hostile request's job: cancelled at once
                session.send("DELETE", f"/api/jobs/{job_id}")
    if dead is None:
        _follow(session, followed)
    for job in _json(session.send("GET", "/api/jobs")).get("jobs") or []:
        if job.get("state") not in FINAL:
            session.send("DELETE", f"/api/jobs/{job['id']}")


def _follow(session: _Session, followed: dict[str, WebCase]) -> None:
    """Each valid base's job to its end: its final status judged as an answer (one line, no path, nothing
    from outside, no internal error), and its JSON files read; still running at the deadline: a hang."""
    deadline = time.monotonic() + JOB_WAIT_S
    for job_id, started in followed.items():
        poll = replace(started, id=started.id.removesuffix("/base") + "/end", target="GET /api/jobs/{job_id}",
                       method="GET", url=f"/api/jobs/{job_id}", headers=(), body=None, strict=False, follow=False)
        while True:
            answer = send(session.served.port, poll, session.time_limit_s)
            state = _json(answer).get("state")
            if state in FINAL or answer.status != 200 or time.monotonic() > deadline:
                break
            time.sleep(0.1)
        if answer.status == 200 and state not in FINAL:
            answer.timed_out, answer.error = True, f"the job is still {state} after {JOB_WAIT_S:.0f} s"
            session.send("DELETE", f"/api/jobs/{job_id}")
        session.record(poll, answer)
        files = _json(answer).get("files") if state == "done" else None
        for name in files or []:
            if isinstance(name, str) and name.endswith(".json"):
                session.run(replace(poll, id=f"{poll.id.removesuffix('/end')}/file={name}",
                                    target="GET /api/jobs/{job_id}/files/{name}",
                                    url=f"/api/jobs/{job_id}/files/{quote(name, safe='')}"))
