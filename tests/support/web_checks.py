"""Checks the workbench's API tests share (tests/web): a refusal's shape, a job followed to its end."""

from __future__ import annotations

import time

#: Seconds a test waits for a job: the first job of a process compiles Numba kernels.
JOB_WAIT_S = 300.0

FINAL_STATES = ("done", "failed", "cancelled")


def refused(response, status: int) -> str:  # noqa: ANN001 - an httpx/Starlette response
    """The one-line error of a refusal with ``status``: the body is exactly ``{"error": "<one line>"}``."""
    assert response.status_code == status, response.text
    body = response.json()
    assert list(body) == ["error"] and "\n" not in body["error"] and body["error"]
    return body["error"]


def wait_job(client, job_id: str, *, timeout: float = JOB_WAIT_S, states=FINAL_STATES) -> dict:  # noqa: ANN001
    """The status of a job once its state is one of ``states`` (polled every 50 ms)."""
    deadline = time.monotonic() + timeout
    status: dict = {}
    while time.monotonic() < deadline:
        status = client.get(f"/api/jobs/{job_id}").json()
        if status["state"] in states:
            return status
        time.sleep(0.05)
    raise AssertionError(f"job {job_id} never reached {states}: {status}")
