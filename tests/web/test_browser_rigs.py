"""Page 4 of the workbench (issue 13), "Rig planner", in Chromium: a preset loaded, a field changed, the
plan shown (top view and figures) equal to ``POST /api/rigs/plan``'s answer, a tiny ``rig`` job rendered
from the page: the pair, the truth and the error.

Run with ``VERGENCE_UPDATE_SCREENSHOTS=1`` to write the README's screenshot, docs/images/workbench_rigs.png;
otherwise the screenshot stays in the test's temporary folder.
"""

from __future__ import annotations

import json
import urllib.parse

import httpx
import pytest

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # a few tiny renders; the first run compiles Numba kernels
WIDTH = 128  # render width of the job: about a second, and a screenshot that shows the pictures
READY = "document.body.dataset.state === 'ready'"
SETTLED = "['ready', 'error'].includes(document.body.dataset.state)"


def _open(page, server_url: str) -> None:
    page.goto(server_url + "/#rigs")
    page.wait_for_function(READY, timeout=15_000)


def _shot(page) -> dict:
    return json.loads(page.locator('[data-testid="rig-shot-json"]').text_content())


def _check_plan_shown(page, server_url: str) -> dict:
    """What the page shows equals the API's plan of the shot the page sent (its JSON on the page)."""
    from playwright.sync_api import expect

    shot = _shot(page)
    plan = httpx.post(f"{server_url}/api/rigs/plan", json=shot, timeout=30).json()
    rows = page.locator("#rig-cameras tbody tr")
    expect(rows).to_have_count(len(plan["cameras"]))
    for i, cam in enumerate(plan["cameras"]):
        row = rows.nth(i)
        assert row.get_attribute("data-name") == cam["name"]
        for key in ("fx", "fx_ratio", "baseline"):
            assert float(row.locator(f'[data-key="{key}"]').get_attribute("data-value")) == cam[key]
        centre = row.locator('[data-key="center"]').get_attribute("data-value").split()
        assert [float(v) for v in centre] == cam["camera"]["center"]
    top = page.locator('[data-testid="rig-top"]')
    assert top.get_attribute("data-cameras") == str(len(plan["cameras"]))
    assert [c.get_attribute("data-camera") for c in top.locator("circle[data-camera]").all()] == [
        c["name"] for c in plan["cameras"]]
    assert _value(page, "rig-fig-count") == len(plan["cameras"])
    return plan


def _value(page, testid: str) -> float:
    return float(page.locator(f'[data-testid="{testid}"]').get_attribute("data-value"))


def test_edit_a_shot_see_its_plan_and_render_it(page, server_url, check_screenshot):
    from playwright.sync_api import expect

    _open(page, server_url)
    assert page.locator('[data-testid="rig-preset"]').input_value() == "example:stadium-quadri"
    plan = _check_plan_shown(page, server_url)
    assert _value(page, "rig-fig-setback") == plan["setback"] == 20.0
    href = page.locator('[data-testid="rig-download"]').get_attribute("href")  # the shot file, to save
    assert json.loads(urllib.parse.unquote(href.split(",", 1)[1])) == _shot(page)
    # a field changed: the plan follows (debounced), and still equals the API's
    page.locator('[data-testid="rig-setback"]').fill("30")
    page.wait_for_function(READY, timeout=15_000)
    assert _shot(page)["setback"] == 30
    plan = _check_plan_shown(page, server_url)
    assert _value(page, "rig-fig-setback") == 30.0
    assert _value(page, "rig-fig-ratio-subject") == plan["cameras"][0]["fx_ratio"]
    # the other rig: a preset of the Tri-Rig, a constraint edited
    page.select_option('[data-testid="rig-preset"]', "example:stadium-tri")
    page.wait_for_function(READY, timeout=15_000)
    page.locator('[data-testid="rig-constraint-1-perceived"]').fill("8")
    page.wait_for_function(READY, timeout=15_000)
    assert _shot(page)["constraints"][1] == "z=65,perceived=8"
    plan = _check_plan_shown(page, server_url)
    assert _value(page, "rig-fig-baseline-background") == plan["cameras"][2]["baseline"]
    assert _value(page, "rig-fig-ref-convergence") == plan["reference"]["convergence"]
    # back to the Quadri-Rig, rendered small
    page.select_option('[data-testid="rig-preset"]', "example:stadium-quadri")
    page.wait_for_function(READY, timeout=15_000)
    for testid, value in {"rig-render-width": str(WIDTH), "rig-samples": "2"}.items():
        page.locator(f'[data-testid="{testid}"]').fill(value)
    page.click('[data-testid="rig-run"]')
    page.wait_for_function("!document.getElementById('rig-result').hidden || document.body.dataset.state === 'error'",
                           timeout=JOB_MS)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()
    body = {"shot": _shot(page), "width": WIDTH, "weights": "ulr", "samples": 2, "supersample": 1}
    again = httpx.post(f"{server_url}/api/jobs/rig", json=body, timeout=30).json()
    assert again["cached"] is True and again["id"] == page.locator("#rig-result").get_attribute("data-job")
    result = httpx.get(f"{server_url}/api/jobs/{again['id']}", timeout=30).json()["result"]
    for eye in ("left", "right"):
        row = page.locator(f'#rig-metrics tr[data-method="ulr"][data-eye="{eye}"]')
        for key in ("psnr", "dssim", "psnr_filled", "coverage"):
            shown = float(row.locator(f'[data-key="{key}"]').get_attribute("data-value"))
            assert shown == result["methods"]["ulr"][eye][key]
    for name in ("ulr_left", "ulr_right", "ulr_anaglyph", "truth_left", "truth_right", "ulr_error_left",
                 "ulr_error_right", "camera_subject_left"):
        img = page.locator(f'[data-testid="rig-img-{name}"]')
        expect(img).to_be_visible()
        img.evaluate("el => el.decode()")
        assert img.evaluate("el => el.naturalWidth") == WIDTH
    check_screenshot(page, "workbench_rigs.png")
    # a field edited after the render: the render shown is of the old settings, dimmed and said so
    assert page.locator("#rig-result .stale-note").is_hidden()
    page.locator('[data-testid="rig-setback"]').fill("25")
    page.wait_for_function(READY, timeout=15_000)
    expect(page.locator("#rig-result .stale-note")).to_be_visible()
    opacity = page.locator('[data-testid="rig-img-ulr_left"]').evaluate("el => Number(getComputedStyle(el).opacity)")
    assert opacity < 0.5


def test_a_bad_field_shows_the_api_error(page, server_url):
    _open(page, server_url)
    page.locator('[data-testid="rig-fov"]').fill("0")
    page.wait_for_function(SETTLED, timeout=15_000)
    answer = httpx.post(f"{server_url}/api/rigs/plan", json=_shot(page), timeout=30)
    assert answer.status_code == 422
    assert page.locator("#error").inner_text() == answer.json()["error"]
    assert page.locator('[data-testid="rig-run"]').is_disabled()
    page.locator('[data-testid="rig-fov"]').fill("24")
    page.wait_for_function(READY, timeout=15_000)
    assert page.locator("#error").is_hidden() and page.locator('[data-testid="rig-run"]').is_enabled()
