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


# The heat map's colour stops as docs/workbench.md gives them (t = 0: nearest, 0.5: the screen, 1: farthest),
# written out here, not read from the page: the browser tests of pages 2 and 5 check the page against them.
HEAT_STOPS = [(0.0, (178, 24, 43)), (0.25, (239, 138, 98)), (0.5, (247, 247, 247)), (0.75, (103, 169, 207)),
              (1.0, (33, 102, 172))]
#: A channel the page rounds once: at most one level from the reference.
HEAT_COLOUR_TOL = 1


def heat_colour(value: float, lo: float, hi: float):  # noqa: ANN201 - an (3,) numpy array
    """The heat map's RGB (0-255) of ``value`` on the scale ``lo`` (< 0, nearest) .. ``hi`` (> 0), clamped."""
    import numpy as np

    t = 0.5 * (1 - min(value / lo, 1.0)) if value <= 0 else 0.5 + 0.5 * min(value / hi, 1.0)
    for (t0, c0), (t1, c1) in zip(HEAT_STOPS, HEAT_STOPS[1:]):
        if t <= t1:
            f = (t - t0) / (t1 - t0)
            return np.array([c + f * (d - c) for c, d in zip(c0, c1)])
    return np.array(HEAT_STOPS[-1][1], float)


def match_uploaded_pair(page, left, right, *, max_disparity: int, ready) -> None:  # noqa: ANN001
    """On page 2 (open in ``page``): upload the files ``left`` and ``right`` as a stereo pair and run its
    matching with ``max_disparity``; ``ready(page)`` waits for the page after each step."""
    page.check('[data-testid="st-source-pair"]')
    for field, path in (("left", left), ("right", right)):
        page.set_input_files(f'[data-testid="st-file-{field}"]', str(path))
        ready(page)
    page.fill('[data-testid="st-max-disparity"]', str(max_disparity))
    page.click('[data-testid="st-run"]')
    ready(page)


def run_specular_page(page, server_url: str, size: dict, *, timeout_ms: float) -> str:  # noqa: ANN001
    """Open page 5, set the fields of ``size`` (``spec-<name>``), run a specular job and wait for its
    result to show, no error on the page; returns the shown job's id."""
    page.goto(server_url + "/#specular")
    page.wait_for_function("document.body.dataset.state === 'ready'", timeout=15_000)
    for name, value in size.items():
        page.locator(f'[data-testid="spec-{name}"]').fill(str(value))
    page.click('[data-testid="spec-run"]')
    page.wait_for_function("!document.getElementById('spec-result').hidden "
                           "|| document.body.dataset.state === 'error'", timeout=timeout_ms)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()
    return page.locator("#spec-result").get_attribute("data-job")
