"""The twins call the library, not the CLI (issue 29): side by side on worker threads, a slow call never
blocks a fast one, a burst past MAX_CALLS (shared with the page's other computations) is 429, a list past MAX_LIST_ITEMS is 422, and the
refusals name the JSON field."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
import warnings

import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.commands import MAX_LIST_ITEMS
from vergence.web import create_app
from vergence.web._slots import MAX_CALLS
from web_checks import refused

BUDGET = {"baseline": 0.12, "convergence": 8, "window": 2.4, "display": "tv-55", "depth": [4, 8]}
MAPPING = {"reference_baseline": 0.65, "convergence": 30, "window": 3, "display": "tv-55",
           "constraint": ["z=30,perceived=3,roundness=1"], "near": 12, "far": "inf"}

# Seconds a fast call may take while slow ones hold their threads: a budget answers in milliseconds;
# under the old server-wide lock it waited for the slow call (20 s in the issue), here forever.
FAST_CALL_S = 10.0


@pytest.fixture()
def blocked_mapping(monkeypatch):
    """``vergence mapping``'s work waits for the returned event (the library call, not the CLI)."""
    import vergence.commands.mapping as work

    release, entered = threading.Event(), threading.Semaphore(0)
    real = work.psi_from_constraints

    def slow(*args, **kwargs):
        entered.release()
        assert release.wait(60), "the test never released the slow call"
        return real(*args, **kwargs)

    monkeypatch.setattr(work, "psi_from_constraints", slow)
    yield release, entered
    release.set()


def _post_in_thread(client, path, body, answers):
    thread = threading.Thread(target=lambda: answers.append(client.post(path, json=body)), daemon=True)
    thread.start()
    return thread


def test_a_slow_call_does_not_block_a_fast_one(blocked_mapping):
    release, entered = blocked_mapping
    with TestClient(create_app(), base_url="http://127.0.0.1") as client:
        slow_answers: list = []
        slow = _post_in_thread(client, "/api/mapping", MAPPING, slow_answers)
        assert entered.acquire(timeout=30), "the slow call never started"
        start = time.monotonic()
        fast = client.post("/api/budget", json=BUDGET)
        waited = time.monotonic() - start
        assert fast.status_code == 200, fast.text
        assert waited < FAST_CALL_S and slow.is_alive() and not slow_answers  # answered while the slow one runs
        release.set()
        slow.join(30)
        assert slow_answers[0].status_code == 200, slow_answers[0].text


def test_calls_past_the_bound_are_429_at_once(blocked_mapping):
    release, entered = blocked_mapping
    with TestClient(create_app(), base_url="http://127.0.0.1") as client:
        answers: list = []
        threads = [_post_in_thread(client, "/api/mapping", MAPPING, answers) for _ in range(MAX_CALLS)]
        for _ in threads:
            assert entered.acquire(timeout=30), "a slow call never started"
        start = time.monotonic()
        message = refused(client.post("/api/budget", json=BUDGET), 429)
        assert time.monotonic() - start < FAST_CALL_S
        assert message == (f"the server is busy: {MAX_CALLS} calls are running (MAX_CALLS); "
                           "try again in a moment")
        # the page's other computations share the slots: a rig plan is refused too
        from vergence.rigs import EXAMPLE_SHOTS

        assert refused(client.post("/api/rigs/plan", json=EXAMPLE_SHOTS["stadium-tri"]), 429) == message
        release.set()
        for t in threads:
            t.join(30)
        assert [a.status_code for a in answers] == [200] * MAX_CALLS
        assert client.post("/api/budget", json=BUDGET).status_code == 200  # the slots are free again
        assert client.post("/api/rigs/plan", json=EXAMPLE_SHOTS["stadium-tri"]).status_code == 200


def test_a_list_past_the_bound_is_422_before_any_work(monkeypatch):
    import vergence.commands.budget as work

    monkeypatch.setattr(work, "depth_budget", lambda *a, **k: pytest.fail("the work ran on a refused list"))
    with TestClient(create_app(), base_url="http://127.0.0.1") as client:
        body = {**BUDGET, "depth": [1.0] * (MAX_LIST_ITEMS + 1)}
        assert refused(client.post("/api/budget", json=body), 422) == \
            f"depth: at most {MAX_LIST_ITEMS} values (MAX_LIST_ITEMS); got {MAX_LIST_ITEMS + 1}"


@pytest.mark.parametrize(("path", "body", "message"), [
    ("/api/budget", {**BUDGET, "baseline": -1}, "baseline must be > 0; got -1"),
    ("/api/budget", {**BUDGET, "screen_width": 1.0},
     "give either display or the display lengths, not both (got display and screen_width)"),
    ("/api/budget", {**BUDGET, "display": ""}, "display: must not be empty"),
    ("/api/budget", {**BUDGET, "window": None}, "the convergence window is missing: give window, or focal_mm with sensor_mm"),
    ("/api/mapping", {**MAPPING, "near": 90, "far": 80}, "far must be > near 90; got 80"),
])
def test_refusals_name_the_json_field(path, body, message):
    with TestClient(create_app(), base_url="http://127.0.0.1") as client:
        assert refused(client.post(path, json=body), 422) == message


def test_the_server_loads_no_cli_module():
    code = ("import sys; from vergence.web import create_app; create_app(); "
            "print(sorted(m for m in sys.modules if m.startswith('vergence.cli')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_a_refusal_names_no_server_path(monkeypatch, tmp_path):
    """What the work says about a file of a data folder, or of the app's own folder, reaches the client
    with the folder as a label (vergence.web.data.DATA_LABEL, <workdir>)."""
    import vergence.commands.budget as work
    from vergence.web.data import DATA_LABEL

    data = tmp_path / "data"
    data.mkdir()
    said = []
    monkeypatch.setattr(work, "depth_budget", lambda *a: (_ for _ in ()).throw(ValueError(said[0])))
    with TestClient(create_app([data]), base_url="http://127.0.0.1") as client:
        workdir = client.app.state.workdir
        said.append(f"cannot read {data}/secret.png (nor {workdir}/twins/x)")
        message = refused(client.post("/api/budget", json=BUDGET), 422)
    assert str(data) not in message and str(workdir) not in message and str(tmp_path) not in message
    assert message.startswith(f"cannot read {DATA_LABEL}/secret.png")
