"""The workbench's jobs (issue 13): long work off the event loop with progress, cancellation and a cache."""

from __future__ import annotations

import json
import time
import warnings

import pydantic
import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    # Starlette >= 1.x asks for httpx2 and warns once, at import, when it finds httpx (the web extra's).
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.web import create_app
from web_checks import FINAL_STATES, refused as _refused, wait_job
from vergence.web.jobs import JOB_WORKERS, JobKind, JobResult, Prepared

WAIT_S = 120.0  # the first render compiles Numba kernels and Mitsuba's LLVM variant: ~10 s on two cores
RENDER = {"scene": "scene:tabletop", "width": 32, "height": 24, "depth": 1, "samples": 2}


def _wait(client, job_id: str, states=FINAL_STATES) -> dict:
    return wait_job(client, job_id, timeout=WAIT_S, states=states)


class Steps(pydantic.BaseModel):
    model_config = pydantic.ConfigDict(extra="forbid")
    steps: int = 1
    tag: str = ""
    fail: bool = False


def _slow(params, env):  # noqa: ANN001, ANN202 - a test kind: loops calling progress until cancelled
    def run(ctx):  # noqa: ANN001, ANN202
        for i in range(params.steps):
            ctx.progress(i / params.steps, f"step {i}")
            time.sleep(0.01)
        if params.fail:
            raise ValueError("steps must be fewer\nthan that")
        (ctx.folder / "out.json").write_text(json.dumps({"tag": params.tag}))
        return JobResult({"steps": params.steps, "tag": params.tag}, ("out.json",))

    return Prepared((), run)


SLOW = JobKind("slow", "A test kind: sleeps and reports progress.", Steps, _slow)


def _quiet(params, env):  # noqa: ANN001, ANN202 - a test kind: no progress, checks cancelled(); or a bug
    def run(ctx):  # noqa: ANN001, ANN202
        if params.fail:
            raise RuntimeError("kaboom")
        for _ in range(params.steps):
            if ctx.cancelled():
                return JobResult({"stopped": True})
            time.sleep(0.01)
        return JobResult({"stopped": False})

    return Prepared((), run)


QUIET = JobKind("quiet", "A test kind: never reports progress.", Steps, _quiet)


@pytest.fixture
def app():
    application = create_app()
    application.state.jobs.register(SLOW)
    application.state.jobs.register(QUIET)
    return application


@pytest.fixture
def client(app):
    with TestClient(app, base_url="http://127.0.0.1") as c:
        yield c


def test_a_render_job_reports_progress_and_its_png_downloads(client):
    import numpy as np

    from vergence.io import read_image

    first = client.post("/api/jobs/render", json=RENDER)
    assert first.status_code == 202, first.text
    job = first.json()
    # a 32 x 24 render on warm kernels can end before the answer is built: "done" is no cache hit
    assert job["cached"] is False and job["kind"] == "render" and job["state"] in ("queued", "running", "done")
    events = client.get(f"/api/jobs/{job['id']}/events")
    assert events.status_code == 200 and events.headers["content-type"].startswith("text/event-stream")
    blocks = [b for b in events.text.split("\n\n") if b]
    names = [b.split("\n")[0] for b in blocks]
    assert names[-1] == "event: end" and set(names[:-1]) <= {"event: progress"}
    statuses = [json.loads(b.split("\n")[1].removeprefix("data: ")) for b in blocks]
    # the renderer's own reports, coalesced to one look per EVENT_POLL_S: the last one may be all there is
    assert all(s["message"] == "" or s["message"].startswith(("level", "shading", "writing", "done")) for s in statuses)
    progress = [s["progress"] for s in statuses]
    assert progress == sorted(progress) and progress[-1] == 1.0
    final = client.get(f"/api/jobs/{job['id']}").json()
    assert final == statuses[-1]
    assert final["state"] == "done" and final["error"] is None and final["files"] == ["beauty.png"]
    assert final["result"]["layers"] == 3 and (final["result"]["width"], final["result"]["height"]) == (32, 24)
    png = client.get(f"/api/jobs/{job['id']}/files/beauty.png")
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    path = client.app.state.workdir / "downloaded.png"
    path.write_bytes(png.content)
    image = read_image(path)
    assert image.shape == (24, 32, 3) and float(np.ptp(image)) > 0  # a picture, not a blank


def test_the_events_stream_carries_each_progress_report_in_order(client):
    job = client.post("/api/jobs/slow", json={"steps": 40}).json()  # 40 reports 10 ms apart: 0.4 s
    blocks = [b for b in client.get(f"/api/jobs/{job['id']}/events").text.split("\n\n") if b]
    statuses = [json.loads(b.split("\n")[1].removeprefix("data: ")) for b in blocks]
    steps = [int(s["message"].removeprefix("step ")) for s in statuses if s["message"].startswith("step ")]
    assert len(steps) >= 5 and steps == sorted(steps)  # polled every 50 ms: several, never out of order
    assert [s["progress"] for s in statuses if s["message"].startswith("step ")] == [i / 40 for i in steps]
    assert statuses[-1]["state"] == "done" and blocks[-1].startswith("event: end")


def test_the_same_request_twice_is_one_job(client, app):
    a = client.post("/api/jobs/slow", json={"steps": 3, "tag": "x"}).json()
    b = client.post("/api/jobs/slow", json={"tag": "x", "steps": 3})  # the same parameters in another order
    assert b.status_code == 200 and b.json()["cached"] is True and b.json()["id"] == a["id"]
    _wait(client, a["id"])
    c = client.post("/api/jobs/slow", json={"steps": 3, "tag": "x"}).json()
    assert c["id"] == a["id"] and c["state"] == "done" and c["cached"] is True
    other = client.post("/api/jobs/slow", json={"steps": 3, "tag": "y"}).json()
    assert other["id"] != a["id"] and other["cached"] is False
    assert len([j for j in client.get("/api/jobs").json()["jobs"] if j["kind"] == "slow"]) == 2


def test_cancel_a_running_job_frees_the_worker(client):
    assert JOB_WORKERS == 1
    job = client.post("/api/jobs/slow", json={"steps": 100_000}).json()  # ~20 minutes unless cancelled
    _wait(client, job["id"], ("running",))
    deadline = time.monotonic() + WAIT_S
    while client.get(f"/api/jobs/{job['id']}").json()["message"] == "" and time.monotonic() < deadline:
        time.sleep(0.01)  # it has reported progress at least once
    queued = client.post("/api/jobs/slow", json={"steps": 2, "tag": "after"}).json()
    assert queued["state"] == "queued"  # one worker: it waits
    cancelling = client.delete(f"/api/jobs/{job['id']}")
    assert cancelling.status_code == 202
    final = _wait(client, job["id"])
    assert final["state"] == "cancelled" and final["files"] == [] and final["result"] is None
    assert _wait(client, queued["id"])["state"] == "done"
    assert not (client.app.state.workdir / "jobs" / job["id"]).exists()
    assert "already cancelled" in _refused(client.delete(f"/api/jobs/{job['id']}"), 409)
    again = client.post("/api/jobs/slow", json={"steps": 100_000}).json()  # a cancelled job is run again
    assert again["id"] != job["id"] and again["cached"] is False
    client.delete(f"/api/jobs/{again['id']}")
    _wait(client, again["id"])


def test_cancel_a_queued_job_never_runs_it(client):
    running = client.post("/api/jobs/slow", json={"steps": 100_000}).json()
    queued = client.post("/api/jobs/slow", json={"steps": 1, "tag": "never"}).json()
    assert client.delete(f"/api/jobs/{queued['id']}").json()["state"] == "cancelled"
    client.delete(f"/api/jobs/{running['id']}")
    assert _wait(client, running["id"])["state"] == "cancelled"
    assert client.get(f"/api/jobs/{queued['id']}").json()["state"] == "cancelled"
    assert not (client.app.state.workdir / "jobs" / queued["id"]).exists()


def test_a_failing_job_reports_one_line(client):
    job = client.post("/api/jobs/slow", json={"fail": True}).json()
    final = _wait(client, job["id"])
    assert final["state"] == "failed" and final["error"] == "steps must be fewer than that"
    assert "is failed" in _refused(client.get(f"/api/jobs/{job['id']}/files/out.json"), 409)
    retry = client.post("/api/jobs/slow", json={"fail": True}).json()  # a failed job is run again
    assert retry["id"] != job["id"]
    _wait(client, retry["id"])


def test_a_bug_in_a_job_is_an_internal_error_and_cancelled_can_be_polled(client):
    bug = client.post("/api/jobs/quiet", json={"fail": True}).json()
    assert _wait(client, bug["id"])["error"] == "internal error, please report it: RuntimeError: kaboom"
    quiet = client.post("/api/jobs/quiet", json={"steps": 100_000}).json()
    _wait(client, quiet["id"], ("running",))
    client.delete(f"/api/jobs/{quiet['id']}")
    final = _wait(client, quiet["id"])
    assert final["state"] == "done" and final["result"] == {"stopped": True}  # it chose to return early


def test_eviction_deletes_the_files_of_the_least_recently_used(client, app):
    app.state.jobs.max_kept = 2
    ids = []
    for tag in ("a", "b"):
        ids.append(client.post("/api/jobs/slow", json={"tag": tag}).json()["id"])
        _wait(client, ids[-1])
    folders = [app.state.workdir / "jobs" / i for i in ids]
    assert all((f / "out.json").is_file() for f in folders)
    client.get(f"/api/jobs/{ids[0]}")  # "a" is now more recent than "b"
    ids.append(client.post("/api/jobs/slow", json={"tag": "c"}).json()["id"])
    _wait(client, ids[-1])
    assert not folders[1].exists()  # "b", the least recently used, is gone with its file
    _refused(client.get(f"/api/jobs/{ids[1]}"), 404)
    assert (folders[0] / "out.json").is_file()
    assert client.get(f"/api/jobs/{ids[0]}/files/out.json").json() == {"tag": "a"}
    # and a new request for "b" runs it again
    assert client.post("/api/jobs/slow", json={"tag": "b"}).json()["cached"] is False


def test_a_scene_file_is_keyed_by_its_content(tmp_path):
    import shutil
    from pathlib import Path

    source = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "spheres_and_mirror.json"
    if not source.is_file():
        pytest.skip(f"{source} is not in this tree")
    data = tmp_path / "data"
    data.mkdir()
    shutil.copy(source, data / "room.json")
    with TestClient(create_app([data]), base_url="http://127.0.0.1") as c:
        scene_id = next(e["id"] for e in c.get("/api/data").json()["scenes"] if e["name"] == "room.json")
        body = {**RENDER, "scene": scene_id}
        first = c.post("/api/jobs/render", json=body).json()
        assert _wait(c, first["id"])["result"]["scene"] == "room.json"
        assert c.post("/api/jobs/render", json=body).json()["id"] == first["id"]
        scene = json.loads((data / "room.json").read_text())
        scene["environment"]["intensity"] = 0.5
        (data / "room.json").write_text(json.dumps(scene))  # the same id, new content: a new job
        second = c.post("/api/jobs/render", json=body).json()
        assert second["id"] != first["id"] and second["cached"] is False
        assert _wait(c, second["id"])["state"] == "done"
        (data / "room.json").write_text("{not json")
        assert _refused(c.post("/api/jobs/render", json=body), 404) == \
            f"unknown data id {scene_id!r}; GET /api/data lists the ids"  # no longer a scene: not listed


def test_unknown_ids_kinds_and_files_are_404(client):
    for path in ("/api/jobs/nope", "/api/jobs/nope/events", "/api/jobs/nope/files/out.json"):
        assert "unknown job id 'nope'" in _refused(client.get(path), 404)
    assert "unknown job id" in _refused(client.delete("/api/jobs/nope"), 404)
    error = _refused(client.post("/api/jobs/paint", json={}), 404)
    assert error.startswith("no job kind 'paint'; kinds: ") and "quiet, render, " in error and "specular" in error
    job = client.post("/api/jobs/slow", json={"tag": "files"}).json()
    _wait(client, job["id"])
    for name in ("beauty.png", "..%2Fout.json", "%2Fetc%2Fpasswd", "%2E%2E"):
        _refused(client.get(f"/api/jobs/{job['id']}/files/{name}"), 404)
    assert _refused(client.get(f"/api/jobs/{job['id']}/files/other.png"), 404) == \
        f"job {job['id']} has no file 'other.png'; its files: out.json"


@pytest.mark.parametrize("body, status, message", [
    ({**RENDER, "width": 0}, 422, "width: greater than or equal to 1 (got 0)"),
    ({**RENDER, "size": 3}, 422, "unknown field 'size'"),
    ({**RENDER, "depth": 9}, 422, "depth must be at most 6 (2^(D+1)-1 layers); got 9"),
    ({**RENDER, "width": 2048, "height": 2048, "samples": 64}, 422, "MAX_RENDER_JOB_RAYS"),
    ({**RENDER, "scene": "scene:nope"}, 404, "unknown data id 'scene:nope'; GET /api/data lists the ids"),
    ({**RENDER, "scene": "../../etc/passwd"}, 404, "unknown data id"),
])
def test_bad_render_parameters(client, body, status, message):
    assert message in _refused(client.post("/api/jobs/render", json=body), status)


def test_a_body_that_is_not_json_is_422(client):
    bad = client.post("/api/jobs/slow", content=b"{steps", headers={"content-type": "application/json"})
    assert _refused(bad, 422).startswith("the body is not valid JSON")


def test_too_many_active_jobs_is_429(client, app):
    app.state.jobs.max_active = 1
    busy = client.post("/api/jobs/slow", json={"steps": 100_000}).json()
    assert "MAX_ACTIVE_JOBS" in _refused(client.post("/api/jobs/slow", json={"tag": "more"}), 429)
    client.delete(f"/api/jobs/{busy['id']}")
    _wait(client, busy["id"])


def test_the_kinds_are_listed_with_their_parameters(client):
    kinds = {k["name"]: k for k in client.get("/api/jobs").json()["kinds"]}
    assert {"quiet", "render", "slow", "specular", "specular-reoptimise"} <= set(kinds)  # and the pages' own
    assert set(kinds["render"]["parameters"]["properties"]) == {"scene", "width", "height", "depth", "samples"}


def test_shutdown_cancels_running_jobs_and_removes_the_folder():
    app = create_app()
    app.state.jobs.register(SLOW)
    with TestClient(app, base_url="http://127.0.0.1") as c:
        job = c.post("/api/jobs/slow", json={"steps": 100_000}).json()
        _wait(c, job["id"], ("running",))
        workdir = app.state.workdir
        assert workdir.is_dir()
    assert not workdir.exists()
    assert app.state.jobs.status(app.state.jobs.jobs()[0])[0]["state"] == "cancelled"


def test_pending_files_are_written_once_on_the_first_request(app, client):
    """A job done with some files pending: the status lists them; asking for one writes them all once
    (two requests at once: one write), then they are files."""
    import threading

    calls = []

    def later(params, env):  # noqa: ANN001, ANN202
        def run(ctx):  # noqa: ANN001, ANN202
            (ctx.folder / "first.txt").write_text("first")

            def write_pending(folder):  # noqa: ANN001, ANN202
                calls.append(folder)
                time.sleep(0.2)
                (folder / "later.txt").write_text(params.tag)

            return JobResult({"tag": params.tag}, ("first.txt",), pending=("later.txt",), write_pending=write_pending)

        return Prepared((), run)

    app.state.jobs.register(JobKind("later", "A test kind: one file now, one on request.", Steps, later))
    job = _wait(client, client.post("/api/jobs/later", json={"tag": "x"}).json()["id"])
    assert job["state"] == "done" and job["files"] == ["first.txt"] and job["pending"] == ["later.txt"]
    assert calls == []
    answers = []
    threads = [threading.Thread(target=lambda: answers.append(client.get(f"/api/jobs/{job['id']}/files/later.txt")))
               for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert [a.text for a in answers] == ["x", "x"] and len(calls) == 1
    again = client.get(f"/api/jobs/{job['id']}").json()
    assert again["files"] == ["first.txt", "later.txt"] and again["pending"] == []
    with pytest.raises(TypeError, match="needs write_pending"):
        JobResult({}, (), pending=("a.txt",))

    # past MAX_LIVE_JOBS the least recently used job lets its writer go: its pending file is refused
    app.state.jobs.max_live = 1
    one = _wait(client, client.post("/api/jobs/later", json={"tag": "one"}).json()["id"])
    two = _wait(client, client.post("/api/jobs/later", json={"tag": "two"}).json()["id"])
    assert client.get(f"/api/jobs/{one['id']}").json()["pending"] == []
    error = _refused(client.get(f"/api/jobs/{one['id']}/files/later.txt"), 409)
    assert "no longer keeps the work its file later.txt is written from" in error
    assert client.get(f"/api/jobs/{two['id']}/files/later.txt").text == "two"
