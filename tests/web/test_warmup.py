"""The workbench's background warm-up (``vergence.web.warmup``): its state in ``/api/health``, the
page's banner while it runs, and ``vergence serve`` asking for it (issue 29, "first use")."""

from __future__ import annotations

import socket
import threading
import time
import warnings
from types import MappingProxyType

import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    # Starlette >= 1.x asks for httpx2 and warns once, at import, when it finds httpx (the web extra's).
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

import vergence.warm as vw
from vergence.web import create_app
from vergence.web import warmup as web_warmup
from vergence.web.warmup import KERNEL_STATES, PAGE_GROUPS, KernelWarmup

WAIT_S = 10.0  # a fake group finishes in microseconds once released; the thread needs far less


class Gates:
    """Fake warm-up groups ``g1``, ``g2`` (and ``bad``, which raises) that wait until released."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, names: tuple[str, ...] = ("g1", "g2")) -> None:
        self.events = {name: threading.Event() for name in (*names, "bad")}
        self.ran: list[str] = []

        def group(name: str) -> vw.WarmGroup:
            def run(folder: object) -> None:
                assert self.events[name].wait(WAIT_S), f"group {name} never released"
                self.ran.append(name)
                if name == "bad":
                    raise RuntimeError("no\nkernel")

            return vw.WarmGroup(run, (f"page {name}",))

        monkeypatch.setattr(vw, "WARM_GROUPS", MappingProxyType({n: group(n) for n in self.events}))
        monkeypatch.setattr(web_warmup, "PAGE_GROUPS", names)

    def release(self, name: str) -> None:
        self.events[name].set()


def _until(condition, what: str) -> None:  # noqa: ANN001
    deadline = time.monotonic() + WAIT_S
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.01)


def test_the_page_groups_are_warm_up_groups():
    assert set(PAGE_GROUPS) <= set(vw.WARM_GROUPS)
    assert len(set(PAGE_GROUPS)) == len(PAGE_GROUPS)
    assert KERNEL_STATES == ("cold", "warming", "ready", "failed")


def test_the_state_goes_cold_warming_ready_with_the_groups_done(monkeypatch):
    gates = Gates(monkeypatch)
    warm = KernelWarmup()
    assert warm.status() == {"state": "cold", "done": 0, "total": 2}
    warm.start()
    warm.start()  # once only
    assert warm.status() == {"state": "warming", "done": 0, "total": 2}
    gates.release("g1")
    _until(lambda: warm.status()["done"] == 1, "the first group")
    assert warm.status() == {"state": "warming", "done": 1, "total": 2}
    gates.release("g2")
    warm.join(WAIT_S)
    assert warm.status() == {"state": "ready", "done": 2, "total": 2}
    assert gates.ran == ["g1", "g2"]


def test_a_failing_group_is_reported_and_the_others_still_run(monkeypatch, caplog):
    gates = Gates(monkeypatch, ("bad", "g1"))
    warm = KernelWarmup()
    warm.start()
    gates.release("bad")
    gates.release("g1")
    warm.join(WAIT_S)
    assert warm.status() == {"state": "failed", "done": 2, "total": 2,
                             "error": "warm-up group bad: RuntimeError: no kernel"}
    assert gates.ran == ["bad", "g1"]
    assert [r.getMessage() for r in caplog.records] == ["warm-up group bad: RuntimeError: no kernel"]


def test_health_reports_cold_without_the_warm_up():
    with TestClient(create_app(), base_url="http://127.0.0.1") as client:
        body = client.get("/api/health").json()
    assert body["status"] == "ok"
    assert body["kernels"] == {"state": "cold", "done": 0, "total": len(PAGE_GROUPS)}


def test_health_follows_the_warm_up_started_by_the_lifespan(monkeypatch):
    gates = Gates(monkeypatch)
    app = create_app(warm_kernels=True)
    with TestClient(app, base_url="http://127.0.0.1") as client:  # the context runs the lifespan
        assert client.get("/api/health").json()["kernels"] == {"state": "warming", "done": 0, "total": 2}
        gates.release("g1")
        gates.release("g2")
        app.state.kernels.join(WAIT_S)
        assert client.get("/api/health").json()["kernels"] == {"state": "ready", "done": 2, "total": 2}


def test_serve_asks_for_the_warm_up(monkeypatch, capsys):
    import uvicorn

    import vergence.web
    from vergence.cli import main

    made = {}

    def fake_create_app(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        made.update(kwargs)
        return create_app()

    monkeypatch.setattr(vergence.web, "create_app", fake_create_app)
    monkeypatch.setattr(uvicorn.Server, "run", lambda self, sockets=None: None)
    assert main(["serve", "--port", "0"]) == 0
    assert made["warm_kernels"] is True
    capsys.readouterr()


# ---------------------------------------------------------------- the banner, in Chromium


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.browser
def test_the_banner_shows_the_progress_then_goes_away(monkeypatch, _browser):
    import uvicorn

    gates = Gates(monkeypatch)
    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(create_app(warm_kernels=True), host="127.0.0.1", port=port,
                                           log_level="warning", lifespan="on"))
    thread = threading.Thread(target=server.run, name=f"uvicorn-warm-{port}", daemon=True)
    thread.start()
    _until(lambda: server.started, "the server")
    page = _browser.new_page()
    try:
        page.goto(f"http://127.0.0.1:{port}/#budget")
        banner = page.get_by_test_id("kernels")
        banner.wait_for(state="visible", timeout=WAIT_S * 1000)
        assert banner.inner_text() == "preparing kernels (first run only): 0/2"
        gates.release("g1")
        page.wait_for_function("document.getElementById('kernels').textContent.endsWith('1/2')",
                               timeout=WAIT_S * 1000)
        gates.release("g2")
        banner.wait_for(state="hidden", timeout=WAIT_S * 1000)
    finally:
        page.close()
        for name in gates.events:
            gates.release(name)
        server.should_exit = True
        thread.join(timeout=10)
