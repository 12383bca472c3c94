"""Page 5 of the workbench (issue 13), "Specular", in Chromium: runs a tiny ``specular`` job from the
page, follows it to the end and shows the job's anaglyphs, analysis sheets and report.

Run with ``VERGENCE_UPDATE_SCREENSHOTS=1`` to write the README's screenshot,
docs/images/workbench_specular.png; otherwise the screenshot stays in the test's temporary folder.
"""

from __future__ import annotations

import httpx
import pytest
from web_checks import run_specular_page

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # k + 3 renders, the table and the figures; the first run compiles Numba kernels
TINY = {"width": 96, "height": 72, "k": 2, "samples": 1}


def _run_tiny(page, server_url: str) -> None:
    run_specular_page(page, server_url, TINY, timeout_ms=JOB_MS)
    assert page.locator('[data-testid="spec-scene"]').input_value() == "scene:glasses"  # the page's default scene


def _value(page, testid: str) -> float | None:
    text = page.locator(f'[data-testid="{testid}"]').get_attribute("data-value")
    return None if text == "" else float(text)


def test_a_tiny_job_from_the_page_shows_the_api_result(page, server_url, check_screenshot):
    _run_tiny(page, server_url)
    body = {"scene": "scene:glasses", **TINY, "display": "samsung-2233rz", "variant": "comfort",
            "weights": [1, 1, 10, 0.1]}
    again = httpx.post(f"{server_url}/api/jobs/specular", json=body, timeout=30).json()
    assert again["cached"] is True and again["id"] == page.locator("#spec-result").get_attribute("data-job")
    report = httpx.get(f"{server_url}/api/jobs/{again['id']}", timeout=30).json()["result"]
    for layer in report["layers"]:
        n = layer["layer"]
        assert _value(page, f"spec-pixels-{n}") == layer["pixels"]
        for key in ("comfort_share_before", "comfort_share_after", "matched_before", "matched_after"):
            testid = f"spec-{key.replace('_share', '').replace('_', '-')}-{n}"
            assert _value(page, testid) == layer[key], (testid, layer)
    for term in report["cost_before"]:
        assert _value(page, f"spec-cost-before-{term}") == pytest.approx(report["cost_before"][term], rel=1e-12)
        assert _value(page, f"spec-cost-after-{term}") == pytest.approx(report["cost_after"][term], rel=1e-12)
    for method in ("physical", "optimised", "on_surface", "near_surface"):
        img = page.locator(f'[data-testid="spec-anaglyph-{method}"]')
        img.evaluate("el => el.decode()")
        assert img.evaluate("el => el.naturalWidth") == TINY["width"]
    for sheet in ("analysis_disparity", "analysis_importance", "analysis_rivalry", "offsets"):
        img = page.locator(f'[data-testid="spec-sheet-{sheet}"]')
        img.evaluate("el => el.decode()")
        assert img.evaluate("el => el.naturalWidth") > 0

    # paint layer 2's absolute weight to 0 over the left half of its picture, then re-optimise
    from playwright.sync_api import expect

    page.select_option('[data-testid="spec-term"]', "absolute")
    page.locator('[data-testid="spec-brush-size"]').fill("30")
    canvas = page.locator('[data-testid="spec-canvas"]')
    expect(canvas).to_be_visible()
    box = canvas.bounding_box()
    page.mouse.move(box["x"] + 2, box["y"] + 2)
    page.mouse.down()
    for t in range(1, 11):
        page.mouse.move(box["x"] + box["width"] * 0.25, box["y"] + box["height"] * t / 10)
    page.mouse.up()
    expect(page.locator('[data-testid="spec-painted"]')).to_have_attribute("data-maps", "1")
    layer = page.locator('[data-testid="spec-layer"]').input_value()
    assert f"layer {layer} · absolute" in page.locator('[data-testid="spec-painted"]').inner_text()
    base = page.locator("#spec-result").get_attribute("data-job")
    page.click('[data-testid="spec-reoptimise"]')
    expect(page.locator("#spec-result")).not_to_have_attribute("data-job", base, timeout=JOB_MS)
    page.wait_for_function("document.body.dataset.state === 'ready'", timeout=JOB_MS)
    reopt = page.locator("#spec-result").get_attribute("data-job")
    status = httpx.get(f"{server_url}/api/jobs/{reopt}", timeout=30).json()
    assert status["kind"] == "specular-reoptimise" and status["state"] == "done"
    assert status["result"]["settings"]["maps"] == ["absolute"]
    assert page.locator("#spec-result").get_attribute("data-base") == base
    for layer in status["result"]["layers"]:
        n = layer["layer"]
        assert _value(page, f"spec-comfort-after-{n}") == layer["comfort_share_after"]
    for term in status["result"]["cost_after"]:
        assert _value(page, f"spec-cost-after-{term}") == pytest.approx(status["result"]["cost_after"][term], rel=1e-12)
    assert "re-optimised with 1 painted map" in page.locator('[data-testid="spec-reopt-message"]').inner_text()
    assert page.locator('[data-testid="spec-anaglyph-optimised"]').get_attribute("src").startswith(
        f"/api/jobs/{reopt}/files/")

    check_screenshot(page, "workbench_specular.png")


def test_bad_parameters_show_the_api_error(page, server_url):
    page.goto(server_url + "/#specular")
    page.wait_for_function("document.body.dataset.state === 'ready'", timeout=15_000)
    page.locator('[data-testid="spec-k"]').fill("1")
    page.click('[data-testid="spec-run"]')
    page.wait_for_function("document.body.dataset.state === 'error'", timeout=15_000)
    assert "k: greater than or equal to 2" in page.locator("#error").inner_text()
    assert page.locator('[data-testid="spec-run"]').is_enabled()


def test_cancel_stops_a_running_job(page, server_url):
    page.goto(server_url + "/#specular")
    page.wait_for_function("document.body.dataset.state === 'ready'", timeout=15_000)
    for name, value in {"width": 320, "height": 240, "k": 32, "samples": 4}.items():
        page.locator(f'[data-testid="spec-{name}"]').fill(str(value))
    page.click('[data-testid="spec-run"]')
    page.wait_for_function("!document.getElementById('spec-cancel').disabled", timeout=15_000)
    page.click('[data-testid="spec-cancel"]')
    page.wait_for_function("document.getElementById('spec-message').textContent === 'cancelled'", timeout=60_000)
    assert page.locator("#spec-result").is_hidden() and page.locator('[data-testid="spec-run"]').is_enabled()
