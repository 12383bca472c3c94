"""Long work off the event loop: jobs with progress, cancellation and a result cache (``/api/jobs``).

A job is one call of a kind's function (rendering, later StereoSpace preparation, S3 tabulation,
synthesis of large images) on a worker thread. The function receives a :class:`JobContext`: its
``progress(fraction, message)`` records how far it is and raises :class:`JobCancelled` once the
job was cancelled, so a function that reports progress often (the library's long functions take a
``progress`` callback: :func:`vergence.render.render`, :func:`vergence.specular.specular_stereo`,
``tabulate_offsets``) stops at its next report; ``cancelled()`` lets any other loop check.

Workers: :data:`JOB_WORKERS` (1) by default. The library's Numba kernels already run in parallel
on every core, so a second job at once would only halve the speed of each (and Numba's threading
layer is not meant for two parallel regions at once).

Cache: a job is keyed by its kind, the canonical JSON of its parameters and the ids or content
hashes of its inputs (:attr:`Prepared.inputs`). Submitting the same key again returns the job
already there, queued, running or done; a failed or cancelled one is run again. The last
:data:`MAX_KEPT_JOBS` finished jobs are kept, least recently used evicted first, and an evicted
job's files are deleted. Files live in the job's folder under the app's temporary folder.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import hashlib
import json
import secrets
import shutil
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pydantic

__all__ = [
    "FINAL_STATES",
    "JOB_STATES",
    "JOB_WORKERS",
    "MAX_ACTIVE_JOBS",
    "MAX_KEPT_JOBS",
    "MAX_LIVE_JOBS",
    "SHUTDOWN_WAIT_S",
    "Job",
    "JobCancelled",
    "JobContext",
    "JobKind",
    "JobManager",
    "JobRefused",
    "JobResult",
    "Prepared",
]

#: Worker threads: one, as the library's Numba kernels already use every core (module notes).
JOB_WORKERS = 1

#: Finished jobs (done, failed, cancelled) kept with their results; the least recently used go first.
MAX_KEPT_JOBS = 32

#: Done jobs whose ``live`` objects (:attr:`JobResult.live`) are kept in memory: the most recently
#: used; an older job keeps its files and result, and a follow-up request on it is told to run it again.
MAX_LIVE_JOBS = 4

#: Jobs queued or running at once; one more is refused (429) until some finish.
MAX_ACTIVE_JOBS = 16

#: Seconds the shutdown waits for running jobs to reach their next progress report and stop.
SHUTDOWN_WAIT_S = 10.0

JOB_STATES = ("queued", "running", "done", "failed", "cancelled")
FINAL_STATES = frozenset({"done", "failed", "cancelled"})


class JobCancelled(Exception):
    """Raised by :meth:`JobContext.progress` in a job that was cancelled: the job stops there."""


class JobRefused(Exception):
    """A request the job manager refuses: the HTTP status and one line saying why."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


@dataclass(frozen=True, slots=True)
class JobResult:
    """What a finished job returns: a JSON summary, the names of the files it wrote in its folder, and
    ``live``: objects a follow-up request of the page reuses without running the job again (the
    specular job's planner, a prepared collection); kept in memory while the job is, never sent.

    ``pending`` names files the job is done without: ``write_pending(folder)`` writes them (and may
    write the ready ones again, atomically) when one is first asked for (:meth:`JobManager.file`), so a
    job answers with what the page shows first and draws the rest on request. Only the
    :data:`MAX_LIVE_JOBS` most recently used jobs keep their writer (it holds the work in memory); an
    older job's pending names become ``released``: asking for one is refused (409)."""

    summary: dict[str, Any]
    files: tuple[str, ...] = ()
    live: Any = field(default=None, compare=False, repr=False)
    pending: tuple[str, ...] = ()
    write_pending: Callable[[Path], object] | None = field(default=None, compare=False, repr=False)
    released: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.pending and self.write_pending is None:
            raise TypeError("a JobResult with pending files needs write_pending, the function that writes them")


@dataclass(frozen=True, slots=True)
class JobContext:
    """What a job function is given: its folder for result files, progress and the cancel check."""

    folder: Path
    _job: Job
    _manager: JobManager

    def progress(self, fraction: float, message: str = "") -> None:
        """Record progress in [0, 1] and a message; raise :class:`JobCancelled` if the job was cancelled."""
        if self._job.cancel_requested.is_set():
            raise JobCancelled(f"job {self._job.id} was cancelled")
        self._manager._update(self._job, fraction=float(fraction), message=str(message))  # noqa: SLF001

    def cancelled(self) -> bool:
        """Whether the job was cancelled (a loop that reports no progress checks this)."""
        return self._job.cancel_requested.is_set()


@dataclass(frozen=True, slots=True)
class Prepared:
    """A checked request, ready to run: the ids or hashes of its inputs (part of the cache key) and the work."""

    inputs: tuple[str, ...]
    run: Callable[[JobContext], JobResult]


@dataclass(frozen=True, slots=True)
class JobKind:
    """One kind of job (``POST /api/jobs/{name}``).

    Attributes
    ----------
    name : str
        The kind, as in the URL.
    summary : str
        One line for people (``GET /api/jobs`` lists it).
    model : type[pydantic.BaseModel]
        The parameters, a JSON object (unknown fields refused).
    prepare : callable(params, env) -> Prepared
        Checks the parameters against the server's data (``env``: the app's data index and
        uploads) on the request's thread; raises ``KeyError`` for an unknown id (404) and
        ``ValueError``/``TypeError`` for a bad parameter (422), in one line.
    """

    name: str
    summary: str
    model: type[pydantic.BaseModel]
    prepare: Callable[[pydantic.BaseModel, Any], Prepared]


@dataclass(eq=False)
class Job:
    """One job's state (read it through :meth:`JobManager.status`; the manager's lock guards it)."""

    id: str
    kind: str
    key: str
    folder: Path
    state: str = "queued"
    fraction: float = 0.0
    message: str = ""
    error: str | None = None
    result: JobResult | None = None
    version: int = 0
    cancel_requested: threading.Event = field(default_factory=threading.Event)
    future: concurrent.futures.Future[None] | None = None
    writing: threading.Lock = field(default_factory=threading.Lock)  # held while its pending files are written


def _one_line(text: str) -> str:
    return " ".join(text.split())


class JobManager:
    """The jobs of one app: a bounded worker pool, the job table and the result cache.

    Parameters
    ----------
    folder : Path
        Where jobs write their files (a folder per job, removed when the job is evicted).
    env : object
        Handed to each kind's ``prepare`` (the app's data index and uploads).
    kinds : mapping of str to JobKind
        The kinds it runs; :meth:`register` adds one.
    workers, max_kept, max_active, max_live : int
        :data:`JOB_WORKERS`, :data:`MAX_KEPT_JOBS`, :data:`MAX_ACTIVE_JOBS`, :data:`MAX_LIVE_JOBS` by default.
    redact : callable(str) -> str, optional
        Applied to every refusal and error message of a job: the app replaces its server paths
        (temporary folder, data folders) by labels. None: messages as raised.
    """

    def __init__(self, folder: Path, env: object, kinds: Mapping[str, JobKind] | None = None, *,
                 workers: int = JOB_WORKERS, max_kept: int = MAX_KEPT_JOBS, max_active: int = MAX_ACTIVE_JOBS,
                 max_live: int = MAX_LIVE_JOBS, redact: Callable[[str], str] | None = None) -> None:  # fmt: skip
        self.folder, self.env = Path(folder), env
        self.redact: Callable[[str], str] = redact if redact is not None else (lambda text: text)
        self.kinds: dict[str, JobKind] = dict(kinds or {})
        self.max_kept, self.max_active, self.max_live = max_kept, max_active, max_live
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers, thread_name_prefix="vergence-job")
        self._lock = threading.Lock()
        self._jobs: OrderedDict[str, Job] = OrderedDict()  # least recently used first
        self._by_key: dict[str, str] = {}
        self._closed = False

    def register(self, kind: JobKind) -> None:
        """Add (or replace) a kind."""
        self.kinds[kind.name] = kind

    # -- requests ---------------------------------------------------------------------------------

    def submit(self, kind_name: str, params: pydantic.BaseModel) -> tuple[Job, bool]:
        """Start a job, or find the same one in the cache; returns the job and whether it was cached.

        Raises
        ------
        JobRefused
            404 unknown kind or input id, 422 bad parameter, 429 too many jobs, 409 shutting down.
        """
        kind = self._kind(kind_name)
        try:
            prepared = kind.prepare(params, self.env)
        except KeyError as exc:
            raise JobRefused(404, self.redact(str(exc.args[0])) if exc.args else "unknown id") from None
        except (ValueError, TypeError) as exc:
            raise JobRefused(422, self.redact(str(exc))) from None
        canonical = json.dumps(params.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
        key = hashlib.sha256(json.dumps([kind.name, canonical, list(prepared.inputs)]).encode()).hexdigest()
        with self._lock:
            if self._closed:
                raise JobRefused(409, "the server is shutting down; no new jobs")
            old = self._jobs.get(self._by_key.get(key, ""))
            if old is not None and old.state not in ("failed", "cancelled") and not old.cancel_requested.is_set():
                self._jobs.move_to_end(old.id)
                return old, True
            active = sum(j.state in ("queued", "running") for j in self._jobs.values())
            if active >= self.max_active:
                raise JobRefused(429, f"{active} jobs are queued or running; the limit is {self.max_active} "
                                      "(MAX_ACTIVE_JOBS): wait for one to finish or cancel one")  # fmt: skip
            job_id = secrets.token_hex(8)
            job = Job(id=job_id, kind=kind.name, key=key, folder=self.folder / job_id)
            self._jobs[job_id] = job
            self._by_key[key] = job_id
            job.future = self._pool.submit(self._run, job, prepared)
        return job, False

    def jobs(self) -> list[Job]:
        """Every job kept, least recently used first."""
        with self._lock:
            return list(self._jobs.values())

    def get(self, job_id: str) -> Job:
        """The job of an id (and mark it recently used). Raises ``KeyError`` naming the id."""
        with self._lock:
            job = self._jobs.get(job_id)
            if job is None:
                raise KeyError(f"unknown job id {job_id!r} (never submitted, or evicted from the cache)")
            self._jobs.move_to_end(job_id)
            return job

    def status(self, job: Job) -> tuple[dict[str, Any], int]:
        """The job as the API shows it, and its version (it grows with each change)."""
        with self._lock:
            return {"id": job.id, "kind": job.kind, "state": job.state, "progress": job.fraction,
                    "message": job.message, "error": job.error,
                    "result": None if job.result is None else job.result.summary,
                    "files": [] if job.result is None else list(job.result.files),
                    "pending": [] if job.result is None else list(job.result.pending)}, job.version  # fmt: skip

    def cancel(self, job_id: str) -> Job:
        """Cancel a queued or running job (a running one stops at its next progress report).

        A running job that returns without reporting progress again (it polled ``cancelled()`` and
        chose to stop early, or was at its end) is done, with the result it returned.

        Raises ``KeyError`` for an unknown id, :class:`JobRefused` (409) for a finished job.
        """
        job = self.get(job_id)
        with self._lock:
            if job.state in FINAL_STATES:
                raise JobRefused(409, f"job {job_id} is already {job.state}; "
                                      "only a queued or running job can be cancelled")
            job.cancel_requested.set()
            if job.future is not None and job.future.cancel():
                self._finish(job, "cancelled")
            else:
                job.message = "cancelling"
                job.version += 1
        return job

    def file(self, job_id: str, name: str) -> Path:
        """The path of a result file the job lists by name (never a client's path).

        A name of the job's ``pending`` files is written first, on the caller's thread, with the other
        pending ones (:attr:`JobResult.write_pending`; a second request for them waits for the first);
        then they are listed in ``files``.

        Raises ``KeyError`` for an unknown id or a name the job does not list, :class:`JobRefused`
        (409) while the job is not done.
        """
        job = self.get(job_id)
        with self._lock:
            if job.state != "done" or job.result is None:
                raise JobRefused(409, f"job {job_id} is {job.state}: its files exist once it is done")
            result = job.result
            if name in result.files:
                return job.folder / name
            if name in result.released:
                raise JobRefused(409, f"job {job_id} no longer keeps the work its file {name} is written from (only "
                                      f"the {self.max_live} most recently used jobs do, MAX_LIVE_JOBS): run it again")
            if name not in result.pending:
                names = ", ".join((*result.files, *result.pending)) or "none"
                raise KeyError(f"job {job_id} has no file {name!r}; its files: {names}")
        with job.writing:
            with self._lock:
                result = job.result
                if result is None or not job.folder.is_dir():
                    raise KeyError(f"job {job_id} was evicted from the cache with its files")
                if name in result.files:  # written by the request that held the lock before
                    return job.folder / name
                if result.write_pending is None:  # let go meanwhile (MAX_LIVE_JOBS)
                    raise JobRefused(409, f"job {job_id} no longer keeps the work its file {name} is written "
                                          f"from (only the {self.max_live} most recently used jobs do): run it again")
            result.write_pending(job.folder)
            missing = [n for n in result.pending if not (job.folder / n).is_file()]
            if missing:
                raise RuntimeError(f"the job's pending writer did not write: {', '.join(missing)}")
            with self._lock:
                if job.result is not None:
                    job.result = dataclasses.replace(job.result, files=(*job.result.files, *job.result.pending),
                                                     pending=())  # fmt: skip
                    job.version += 1
        return job.folder / name

    def live(self, job_id: str, kind: str) -> Any:
        """The in-memory ``live`` objects of a done job of ``kind`` (:attr:`JobResult.live`).

        Raises ``KeyError`` for an unknown id or a job of another kind, :class:`JobRefused` (409)
        while the job is not done or if it kept nothing.
        """
        job = self.get(job_id)
        with self._lock:
            if job.kind != kind:
                raise KeyError(f"job {job_id} is a {job.kind} job, not a {kind} job")
            if job.state != "done" or job.result is None:
                raise JobRefused(409, f"job {job_id} is {job.state}: it can be used once it is done")
            if job.result.live is None:
                raise JobRefused(409, f"job {job_id} no longer keeps its work in memory (only the {self.max_live} "
                                      "most recently used jobs do, MAX_LIVE_JOBS): run it again")  # fmt: skip
            return job.result.live

    def shutdown(self) -> None:
        """Cancel every job, stop the workers, wait up to :data:`SHUTDOWN_WAIT_S` for running ones."""
        with self._lock:
            self._closed = True
            running = []
            for job in self._jobs.values():
                if job.state in FINAL_STATES:
                    continue
                job.cancel_requested.set()
                if job.future is not None and job.future.cancel():
                    self._finish(job, "cancelled")
                elif job.future is not None:
                    running.append(job.future)
        self._pool.shutdown(wait=False, cancel_futures=True)
        concurrent.futures.wait(running, timeout=SHUTDOWN_WAIT_S)

    # -- the worker -------------------------------------------------------------------------------

    def _kind(self, name: str) -> JobKind:
        if name not in self.kinds:
            raise JobRefused(404, f"no job kind {name!r}; kinds: {', '.join(sorted(self.kinds)) or 'none'}")
        return self.kinds[name]

    def _update(self, job: Job, **changes: Any) -> None:
        with self._lock:
            for name, value in changes.items():
                setattr(job, name, value)
            job.version += 1

    def _finish(self, job: Job, state: str, *, error: str | None = None, result: JobResult | None = None) -> None:
        """Under the lock: the final state; a job without a result loses its folder; evict past the bound."""
        job.state, job.error, job.result = state, error, result
        if state == "done":
            job.fraction, job.message = 1.0, "done"
        elif state == "cancelled":
            job.message = "cancelled"
        job.version += 1
        if state != "done":
            shutil.rmtree(job.folder, ignore_errors=True)
        live = [j for j in self._jobs.values() if j.result is not None and j.result.live is not None]
        for old in live[: max(0, len(live) - self.max_live)]:  # least recently used first
            old.result = dataclasses.replace(old.result, live=None)
        writers = [j for j in self._jobs.values() if j.result is not None and j.result.write_pending is not None]
        for old in writers[: max(0, len(writers) - self.max_live)]:  # what they are written from is let go
            old.result = dataclasses.replace(old.result, pending=(), write_pending=None,
                                             released=(*old.result.released, *old.result.pending))  # fmt: skip
        finished = [j for j in self._jobs.values() if j.state in FINAL_STATES]
        for old in finished[: max(0, len(finished) - self.max_kept)]:
            del self._jobs[old.id]
            if self._by_key.get(old.key) == old.id:
                del self._by_key[old.key]
            shutil.rmtree(old.folder, ignore_errors=True)

    def _run(self, job: Job, prepared: Prepared) -> None:
        with self._lock:
            if job.state != "queued" or job.cancel_requested.is_set():
                if job.state not in FINAL_STATES:
                    self._finish(job, "cancelled")
                return
            job.state = "running"
            job.version += 1
        try:
            job.folder.mkdir(parents=True)
            result = prepared.run(JobContext(job.folder, job, self))
            missing = [n for n in result.files if not (job.folder / n).is_file() or Path(n).name != n]
            if missing:
                raise RuntimeError(f"the job listed files it did not write in its folder: {', '.join(missing)}")
        except JobCancelled:
            outcome: dict[str, Any] = {"state": "cancelled"}
        except (ValueError, TypeError) as exc:
            outcome = {"state": "failed", "error": _one_line(self.redact(str(exc)))}
        except Exception as exc:  # noqa: BLE001 - a bug of ours: reported as the CLI reports one
            error = f"internal error, please report it: {type(exc).__name__}: {exc}"
            outcome = {"state": "failed", "error": _one_line(self.redact(error))}
        else:
            outcome = {"state": "done", "result": result}
        with self._lock:
            self._finish(job, outcome.pop("state"), **outcome)
