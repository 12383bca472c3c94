"""Page 5 (Specular) answering a paint stroke (issue 30): the new anaglyph and the comfort overlay in under a
second after warm-up, the layers no weight can move greyed out (as the API refuses them), the analysis sheets
drawn large. ``SPEC_STROKES_MS`` lists the measured stroke-to-image times (docs/workbench.md reports them).
"""

from __future__ import annotations

import statistics

import httpx
import pytest
from web_checks import run_specular_page

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # k + 3 renders, the table and the figures; the first run compiles Numba kernels
PAGE_SIZE = {"width": 160, "height": 120, "k": 16, "samples": 4}  # the page's defaults
TINY = {"width": 64, "height": 48, "k": 2, "samples": 1}  # glasses: layer 4 (RR) has no matched pixel here
STROKE_GOAL_MS = 1000.0  # issue 30: stroke to new image under a second, after warm-up (the slow run asserts it)
# The default run asserts a bound a busy CI machine keeps (2 cores shared by two test workers and the server):
# before the server answered first, a stroke took 8.1-13.1 s; now 0.8-2 s at loads 4-7.
STROKE_BOUND_MS = 4000.0
STROKES = 5  # answered strokes after the warm-up one; the median is asserted


def _run(page, server_url: str, size: dict) -> str:
    job = run_specular_page(page, server_url, size, timeout_ms=JOB_MS)
    page.wait_for_function("document.body.dataset.state === 'ready'", timeout=JOB_MS)
    return job


def _stroke(page, x0: float, x1: float) -> None:
    box = page.locator('[data-testid="spec-canvas"]').bounding_box()
    page.mouse.move(box["x"] + box["width"] * x0, box["y"] + box["height"] * 0.2)
    page.mouse.down()
    for t in range(1, 9):
        page.mouse.move(box["x"] + box["width"] * (x0 + (x1 - x0) * t / 8), box["y"] + box["height"] * (0.2 + 0.07 * t))
    page.mouse.up()


def _answered(page, count: int) -> list[float]:
    page.wait_for_function(f"(document.getElementById('spec-result').dataset.strokeMs || '').split(',')"
                           f".filter(Boolean).length >= {count} || document.body.dataset.state === 'error'",
                           timeout=JOB_MS)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()
    return [float(v) for v in page.locator("#spec-result").get_attribute("data-stroke-ms").split(",")]


def _stroke_times(page, server_url: str) -> list[float]:
    """Stroke-to-image times (ms) of STROKES strokes after a warm-up one, each checked to show its own job."""
    base = _run(page, server_url, PAGE_SIZE)
    page.locator('[data-testid="spec-brush-size"]').fill("8")
    _stroke(page, 0.05, 0.1)  # warm-up: the first re-optimisation of the process compiles what is left
    _answered(page, 1)
    times, server = [], []
    for i in range(STROKES):
        _stroke(page, 0.15 + 0.15 * i, 0.2 + 0.15 * i)  # new pixels each time: never a cached job
        times = _answered(page, 2 + i)
        shown = page.locator('[data-testid="spec-latest"]').get_attribute("data-job")
        status = httpx.get(f"{server_url}/api/jobs/{shown}", timeout=30).json()
        assert status["kind"] == "specular-reoptimise" and status["state"] == "done" and shown != base
        server.append(1000 * sum(status["result"]["web_seconds"].values()))
        assert page.locator('[data-testid="spec-latest"]').get_attribute("src").startswith(f"/api/jobs/{shown}/files/")
        # the overlay is the shown job's: its count of outside pixels is the file's
        assert page.locator('[data-testid="spec-outside"]').get_attribute("data-job") == shown
    strokes = times[1:]
    print(f"SPEC_STROKES_MS {PAGE_SIZE}: {', '.join(f'{t:.0f}' for t in strokes)}; "
          f"median {statistics.median(strokes):.0f} ms; the server's part (web_seconds) "
          f"{', '.join(f'{t:.0f}' for t in server)} ms")
    assert len(strokes) == STROKES
    return strokes


def test_a_stroke_is_answered_with_the_new_anaglyph_first(page, server_url):
    strokes = _stroke_times(page, server_url)
    assert statistics.median(strokes) < STROKE_BOUND_MS, strokes


@pytest.mark.slow
def test_a_stroke_is_answered_in_under_a_second_on_a_quiet_machine(page, server_url):
    strokes = _stroke_times(page, server_url)
    assert statistics.median(strokes) < STROKE_GOAL_MS, strokes


def test_the_layers_no_weight_can_move_are_greyed_out_as_the_api_refuses_them(page, server_url):
    import io

    import numpy as np

    job = _run(page, server_url, TINY)
    options = page.locator('[data-testid="spec-layer"] option')
    greyed = {int(options.nth(i).get_attribute("value")): options.nth(i).get_attribute("title")
              for i in range(options.count()) if options.nth(i).is_disabled()}
    assert greyed, "glasses at 64 x 48, k 2 has a layer without matches (RR)"
    layers = [int(options.nth(i).get_attribute("value")) for i in range(options.count())]
    buffer = io.BytesIO()
    np.save(buffer, np.zeros((TINY["height"], TINY["width"]), np.float32))
    refused = set()
    for layer in layers:
        upload = httpx.post(f"{server_url}/api/uploads?name=p.npy", content=buffer.getvalue(), timeout=30,
                            headers={"Content-Type": "application/octet-stream"}).json()["id"]
        body = {"job": job, "weight_maps": [{"layer": layer, "upload": upload}]}
        response = httpx.post(f"{server_url}/api/jobs/specular-reoptimise", json=body, timeout=30)
        if response.status_code == 422:
            refused.add(layer)
    assert set(greyed) == refused
    for layer, title in greyed.items():
        assert f"layer {layer} (" in title and "no weight can move its offsets" in title
    assert not page.locator('[data-testid="spec-layer"]').evaluate("el => el.selectedOptions[0].disabled")


def test_the_analysis_sheets_are_drawn_large_with_labels(page, server_url):
    job = _run(page, server_url, TINY)
    view = page.locator('[data-testid="spec-sheet-view"]')
    page.wait_for_function("document.getElementById('spec-sheet-view').dataset.sheet === 'analysis_disparity.png'",
                           timeout=30_000)
    page.click('[data-testid="spec-thumb-offsets"]')
    page.wait_for_function("document.getElementById('spec-sheet-view').dataset.sheet === 'offsets.png'", timeout=30_000)
    assert view.get_attribute("src") == f"/api/jobs/{job}/files/offsets.png"
    natural = view.evaluate("el => el.naturalWidth")
    shown = view.bounding_box()["width"]
    thumb = page.locator('[data-testid="spec-sheet-offsets"]').bounding_box()["width"]
    assert shown >= min(natural, 1000) - 1 and shown > 2.5 * thumb, (shown, natural, thumb)  # at least its own size
    assert "offsets.png: per-layer camera offsets" in page.locator('[data-testid="spec-sheet-caption"]').inner_text()

    # after a re-optimisation the sheets are pending: drawn on request, then shown large
    page.click('[data-testid="spec-reoptimise"]')
    page.wait_for_function("!document.getElementById('spec-draw-sheets').hidden", timeout=JOB_MS)
    shown_job = page.locator("#spec-result").get_attribute("data-job")
    assert shown_job != job
    page.wait_for_timeout(300)  # a sheet of the base job still loading must not come back
    assert view.is_hidden() and job not in (view.get_attribute("src") or "")
    pending = httpx.get(f"{server_url}/api/jobs/{shown_job}", timeout=30).json()["pending"]
    assert "offsets.png" in pending or "offsets.png" in httpx.get(
        f"{server_url}/api/jobs/{shown_job}", timeout=30).json()["files"]
    page.click('[data-testid="spec-draw-sheets"]')
    page.wait_for_function(f"document.getElementById('spec-sheet-view').src.includes('{shown_job}')"
                           " && !document.getElementById('spec-sheet-view').hidden", timeout=JOB_MS)
    assert page.locator('[data-testid="spec-sheet-view"]').evaluate("el => el.naturalWidth") > 0
