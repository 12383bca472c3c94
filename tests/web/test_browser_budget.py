"""End to end in Chromium: page 1 of the workbench (Display and budget) shows what /api/budget and
/api/mapping answer for the same inputs, draws them, reports the API's errors and is not blank.

Run with ``VERGENCE_UPDATE_SCREENSHOTS=1`` to write the README's screenshot,
docs/images/workbench_budget.png; otherwise the screenshot stays in the test's temporary folder.
"""

from __future__ import annotations

import json

import httpx
import pytest

pytestmark = pytest.mark.browser

SETTLE_MS = 15_000  # debounce (200 ms) + two API calls; generous for two busy shared cores
# The page prints 4 significant digits: its text matches the API to half a unit in the 4th digit.
TEXT_RTOL = 5e-4

# A rig that diverges inside the scene on a 24" desktop monitor (b > b_div = 0.2447 m), so that the
# divergence limit shows in the plots and the screenshot.
RIG = {"baseline": 0.3, "convergence": 2.5, "window": 1.5}
PROBE = 1.8


def settle(page) -> str:
    """Wait until the page shows the API's answer to its current inputs; returns "ready" or "error"."""
    page.wait_for_function("['ready', 'error'].includes(document.body.dataset.state)", timeout=SETTLE_MS)
    return page.evaluate("document.body.dataset.state")


def shown(page, testid: str) -> tuple[float | None, str]:
    """The exact value (data-value) and the text of a figure of the page."""
    node = page.locator(f'[data-testid="{testid}"]')
    value = node.get_attribute("data-value")
    return (None if value is None else float(value)), node.inner_text()


def leading_number(text: str) -> float:
    return float(text.split()[0])


def enter_rig(page) -> None:
    page.select_option('[data-testid="display-preset"]', "desktop-24")
    for field, value in RIG.items():
        page.fill(f"#{field}", str(value))
    page.fill("#probe", str(PROBE))
    assert settle(page) == "ready", page.locator('[data-testid="error"]').inner_text()


@pytest.fixture
def workbench(page, server_url):
    page.goto(server_url + "/")
    settle(page)
    return page


def post(server_url: str, command: str, body: dict) -> httpx.Response:
    return httpx.post(f"{server_url}/api/{command}", json=body, timeout=30)


def test_budget_figures_equal_the_api(workbench, server_url):
    page = workbench
    enter_rig(page)
    answer = post(server_url, "budget", {**RIG, "display": "desktop-24", "depth": [RIG["convergence"], PROBE]})
    assert answer.status_code == 200
    api = answer.json()
    at_h, at_probe = api["depths"]
    expected = {
        "divergence-baseline": api["divergence_baseline"],
        "roundness-baseline": api["roundness_baseline"],
        "focal-ratio": api["focal_ratio"],
        "roundness-at-convergence": at_h["roundness"],
        "perceived-at-probe": at_probe["perceived_depth"],
        "roundness-at-probe": at_probe["roundness"],
    }
    for testid, want in expected.items():
        value, text = shown(page, testid)
        assert value == want, testid
        assert leading_number(text) == pytest.approx(want, rel=TEXT_RTOL), (testid, text)
    assert page.locator('[data-testid="warnings"] li').all_inner_texts() == api["warnings"]
    # this rig diverges in the scene: the limit is shaded, and the first diverging depth is shown
    assert page.locator("#plot-perceived rect.shade").count() == 1
    z_div, _ = shown(page, "divergence-depth")
    assert z_div is not None and PROBE < z_div <= 50
    assert int(page.get_attribute("#plot-perceived", "data-points")) > 50


def test_preset_fills_the_display_lengths(workbench, server_url):
    page = workbench
    displays = httpx.get(f"{server_url}/api/displays", timeout=30).json()
    listed = displays if isinstance(displays, list) else displays.get("displays", displays)
    cinema = next(d for d in listed if d.get("name") == "cinema") if isinstance(listed, list) else listed["cinema"]
    page.select_option('[data-testid="display-preset"]', "cinema")
    assert settle(page) == "ready"
    assert float(page.input_value("#eye-separation")) == cinema["eye_separation"]
    assert float(page.input_value("#viewing-distance")) == cinema["distance"]
    assert float(page.input_value("#screen-width")) == cinema["width"]
    assert "--display cinema" in page.input_value('[data-testid="cli-budget"]')
    # typing a length leaves the preset: the display is then sent as the three lengths
    page.fill("#viewing-distance", "12")
    assert settle(page) == "ready"
    assert page.input_value('[data-testid="display-preset"]') == ""
    assert "--viewing-distance 12" in page.input_value('[data-testid="cli-budget"]')


def test_cli_command_prints_what_the_page_shows(workbench, server_url, capsys):
    from vergence.cli import main

    page = workbench
    enter_rig(page)
    line = page.input_value('[data-testid="cli-budget"]')
    words = line.split()
    assert words[:2] == ["vergence", "budget"]
    capsys.readouterr()
    assert main([*words[1:], "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["divergence_baseline"] == shown(page, "divergence-baseline")[0]
    assert printed["depths"][1]["perceived_depth"] == shown(page, "perceived-at-probe")[0]
    page.context.grant_permissions(["clipboard-read", "clipboard-write"], origin=server_url)
    page.click('[data-testid="copy-cli"]')
    page.wait_for_function("document.getElementById('copy-note').textContent !== ''", timeout=SETTLE_MS)
    assert page.evaluate("navigator.clipboard.readText()") == line


def test_psi_constraint_updates_the_plots(workbench, server_url):
    page = workbench
    enter_rig(page)
    assert page.get_attribute('[data-testid="plot-psi"]', "data-points") == "0"
    assert page.locator('#plot-perceived path[data-series="psi"]').count() == 0
    page.click('[data-testid="add-constraint"]')
    row = page.locator('[data-testid="constraints"] tr').first
    row.locator('input[data-field="perceived"]').fill("0.6")
    assert settle(page) == "ready", page.locator('[data-testid="error"]').inner_text()
    body = {"reference_baseline": RIG["baseline"], "convergence": RIG["convergence"], "window": RIG["window"],
            "display": "desktop-24", "constraint": ["z=2.5,perceived=0.6,roundness=1"], "near": 1, "far": 50}
    answer = post(server_url, "mapping", body)
    assert answer.status_code == 200, answer.text
    mapping = answer.json()
    psi = page.locator('[data-testid="plot-psi"]')
    assert psi.get_attribute("data-constraints") == "1"
    assert int(psi.get_attribute("data-points")) == 2 + len(mapping["samples"])  # identity + psi
    assert psi.locator("circle.dot").count() == len(mapping["control_points"])
    assert page.locator('#plot-perceived path[data-series="psi"]').count() == 1
    assert "--constraint z=2.5,perceived=0.6,roundness=1" in page.input_value('[data-testid="cli-mapping"]')
    # a second constraint changes psi; removing both empties its plot
    before = psi.locator("path.psi").get_attribute("d")
    page.click('[data-testid="add-constraint"]')
    second = page.locator('[data-testid="constraints"] tr').nth(1)
    second.locator('input[data-field="z"]').fill("20")
    second.locator('input[data-field="perceived"]').fill("0.7")
    second.locator('input[data-field="roundness"]').fill("")
    assert settle(page) == "ready", page.locator('[data-testid="error"]').inner_text()
    assert psi.get_attribute("data-constraints") == "2"
    assert psi.locator("path.psi").get_attribute("d") != before
    for _ in range(2):
        page.locator('[data-testid="remove-constraint"]').first.click()
    assert settle(page) == "ready"
    assert psi.get_attribute("data-points") == "0"


def test_invalid_input_shows_the_api_error(workbench, server_url):
    page = workbench
    enter_rig(page)
    error = page.locator('[data-testid="error"]')
    assert error.is_hidden()
    page.fill("#baseline", "-1")
    assert settle(page) == "error"
    answer = post(server_url, "budget", {**RIG, "baseline": -1, "display": "desktop-24",
                                          "depth": [RIG["convergence"], PROBE]})
    assert answer.status_code == 422
    message = answer.json()["error"]
    assert message.startswith("baseline ") and "--" not in message  # the field the page sent
    assert error.is_visible()
    assert error.inner_text() == "baseline b" + message.removeprefix("baseline")  # the page's label
    page.fill("#baseline", str(RIG["baseline"]))  # fixed: the message goes away
    assert settle(page) == "ready"
    assert error.is_hidden()


def test_every_page_is_live(workbench):
    """Every system has landed: each link opens its page (its markup loaded, no placeholder)."""
    from playwright.sync_api import expect  # waits for the page to switch (a bare is_visible() raced it)

    page = workbench
    for link in ("stereo", "stereospace", "rigs", "specular"):
        page.click(f'[data-page-link="{link}"]')
        section = page.locator(f"#page-{link}")
        expect(section).to_be_visible()
        expect(section).not_to_have_class("page placeholder")
        assert "coming as the systems land" not in section.inner_text().lower()
        expect(page.locator("#page-budget")).to_be_hidden()
    assert page.locator("nav a.soon").count() == 0
    page.click('[data-page-link="budget"]')
    expect(page.locator("#page-budget")).to_be_visible()


def test_screenshot_is_not_blank(workbench, check_screenshot):
    page = workbench
    enter_rig(page)
    page.click('[data-testid="add-constraint"]')
    page.locator('[data-testid="constraints"] tr input[data-field="perceived"]').fill("0.6")
    assert settle(page) == "ready"
    check_screenshot(page, "workbench_budget.png")


def test_focal_length_and_sensor_instead_of_the_window(workbench, server_url):
    page = workbench
    enter_rig(page)
    page.check('input[name="window-mode"][value="focal"]')
    assert page.locator("#window").is_hidden()
    page.fill("#focal-mm", "50")
    page.fill("#sensor-mm", "24")
    page.fill("#screen-pixels", "2560")  # overrides the preset's resolution: sent as --screen-pixels
    assert settle(page) == "ready", page.locator('[data-testid="error"]').inner_text()
    line = page.input_value('[data-testid="cli-budget"]')
    assert "--focal-mm 50 --sensor-mm 24" in line and "--window" not in line
    assert "--display desktop-24 --screen-pixels 2560" in line
    body = {"baseline": RIG["baseline"], "convergence": RIG["convergence"], "focal_mm": 50, "sensor_mm": 24,
            "display": "desktop-24", "screen_pixels": 2560, "depth": [RIG["convergence"], PROBE]}
    api = post(server_url, "budget", body).json()
    assert shown(page, "focal-ratio")[0] == api["focal_ratio"]
    assert shown(page, "perceived-at-probe")[0] == api["depths"][1]["perceived_depth"]
    # a focal length alone is refused by the API; the page says it with its own labels
    page.fill("#sensor-mm", "")
    assert settle(page) == "error"
    message = post(server_url, "budget", {**body, "sensor_mm": None}).json()
    assert message.get("error") == "sensor_mm (sensor width in mm) is required with focal_mm"
    assert page.locator('[data-testid="error"]').inner_text() == "sensor S (sensor width in mm) is required with focal length F"


def test_the_page_asks_only_its_own_server(page, server_url):
    """No CDN, no font service: every request of the page goes to the workbench (it works offline)."""
    requests: list[str] = []
    page.on("request", lambda request: requests.append(request.url))
    page.goto(server_url + "/")
    assert settle(page) == "ready"
    page.click('[data-testid="add-constraint"]')
    assert settle(page) == "ready"
    assert requests, "the page made no request"
    outside = [u for u in requests if not (u.startswith(server_url + "/") or u.startswith("data:"))]
    assert outside == []
    assert {server_url + "/static/common.js", server_url + "/static/pages/budget.html",
            server_url + "/static/style.css"} <= set(requests)


PLOT = {"width": 560, "height": 260, "left": 56, "right": 14, "top": 12, "bottom": 38}  # common.js's PLOT


def _path_points(d: str) -> list[tuple[float, float]]:
    import re

    return [(float(x), float(y)) for x, y in re.findall(r"[ML](-?[\d.]+),(-?[\d.]+)", d)]


def _x_of(z: float, lo: float, hi: float) -> float:
    import math

    span = PLOT["width"] - PLOT["left"] - PLOT["right"]
    return PLOT["left"] + (math.log(z) - math.log(lo)) / (math.log(hi) - math.log(lo)) * span


def test_divergence_is_shaded_from_its_exact_depth_and_roundness_stops_there(workbench, server_url):
    page = workbench
    enter_rig(page)
    api = post(server_url, "budget", {**RIG, "display": "desktop-24", "depth": [RIG["convergence"]]}).json()
    z_div = api["divergence_depth"]
    assert 1 < z_div < 50  # inside the scene's depths (1-50 m)
    assert shown(page, "divergence-depth")[0] == z_div  # not the first sampled depth past it
    shade_x = float(page.locator("#plot-perceived rect.shade").get_attribute("x"))
    assert shade_x == pytest.approx(_x_of(z_div, 1, 50), abs=0.01)
    roundness = _path_points(page.locator('#plot-roundness path[data-series="budget"]').get_attribute("d"))
    assert len(roundness) > 20 and max(x for x, _ in roundness) <= shade_x + 0.01
    # a probe past the limit: no roundness to show
    page.fill("#probe", "40")
    assert settle(page) == "ready"
    value, text = shown(page, "roundness-at-probe")
    assert value is None and "diverge" in text


def test_psi_stays_inside_the_perceived_depth_plot_and_far_may_be_infinite(workbench, server_url):
    page = workbench
    enter_rig(page)
    page.click('[data-testid="add-constraint"]')
    page.locator('[data-testid="constraints"] tr').first.locator('input[data-field="perceived"]').fill("0.6")
    page.fill("#far", "inf")
    assert settle(page) == "ready", page.locator('[data-testid="error"]').inner_text()
    assert "--far inf" in page.input_value('[data-testid="cli-mapping"]')
    psi = _path_points(page.locator('#plot-perceived path[data-series="psi"]').get_attribute("d"))
    assert len(psi) > 10
    top, bottom = PLOT["top"], PLOT["height"] - PLOT["bottom"]
    assert all(top - 0.01 <= y <= bottom + 0.01 for _, y in psi)  # psi's whole curve is in the frame
    assert int(page.get_attribute("#plot-perceived", "data-points")) > 50


def test_a_mapping_error_names_the_pages_field(workbench):
    page = workbench
    enter_rig(page)
    page.click('[data-testid="add-constraint"]')
    page.locator('[data-testid="constraints"] tr').first.locator('input[data-field="perceived"]').fill("0.6")
    assert settle(page) == "ready"
    page.fill("#baseline", "0")
    assert settle(page) == "error"
    text = page.locator('[data-testid="error"]').inner_text()
    assert text.startswith("baseline b ") and "reference" not in text and "--" not in text
