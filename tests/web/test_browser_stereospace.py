"""Page 3 of the workbench (issue 13), "StereoSpace browser", in Chromium: prepares a collection from the
page (the built-in tabletop one, 12 views ray-traced by the job, which a fresh clone has; and the shared
kermit collection, Bundler, 9 cameras, when the shared data is there), checks that the state and the map it shows are the
API's answer, moves with the keyboard (arrow key, +) and checks each new state against
``POST /api/stereospace/{job}/move``. The page runs with ``?renderer=server``: the pairs are the server's
PNGs (the pairs the page draws with WebGL2 are tests/web/test_browser_stereospace_gl.py's).

Run with ``VERGENCE_UPDATE_SCREENSHOTS=1`` to write the README's screenshot,
docs/images/workbench_stereospace.png; otherwise the screenshot stays in the test's temporary folder.
"""

from __future__ import annotations

import json

import httpx
import pytest

from vergence.report.demo_stereospace import dino_folder

KERMIT = dino_folder().parent / "kermit"  # the rule of the browser tests' server (conftest.shared_collections)

pytestmark = pytest.mark.browser

JOB_MS = 120_000  # loading and preparing kermit takes well under a second; the first pair compiles nothing
MOVE_MS = 60_000


# (collection id or name prefix, cameras, screenshot): kermit's is the README's
COLLECTIONS = [
    pytest.param(("collection:tabletop", 12, "workbench_stereospace_tabletop.png"), id="builtin-tabletop"),
    pytest.param(("kermit/", 9, "workbench_stereospace.png"), id="kermit", marks=pytest.mark.skipif(
        not KERMIT.is_dir(), reason="the shared kermit collection is missing (set VERGENCE_SHARED_DATA to the "
                                    "folder holding collections/kermit)")),
]


def _collection(server_url: str, wanted: str) -> dict:
    cols = httpx.get(f"{server_url}/api/data", timeout=30).json()["collections"]
    return next(c for c in cols if c["id"] == wanted or c["name"].startswith(wanted))


def _value(page, testid: str):
    return json.loads(page.locator(f'[data-testid="{testid}"]').get_attribute("data-value"))


def _shown_state(page) -> dict:
    return {"region": _value(page, "ss-region"), "li": _value(page, "ss-li"), "lj": _value(page, "ss-lj")}


def _check_view(page, view: dict) -> None:
    assert _shown_state(page) == {k: view[k] for k in ("region", "li", "lj")}
    assert _value(page, "ss-interocular") == view["interocular"]
    for eye in ("left", "right"):
        node = page.locator(f'[data-testid="ss-map-{eye}-eye"]')
        assert [float(node.get_attribute("data-x")), float(node.get_attribute("data-y"))] == view["eyes"][eye]


def _wait_ready(page, timeout: int) -> None:
    page.wait_for_function("document.body.dataset.state === 'ready' || document.body.dataset.state === 'error'",
                           timeout=timeout)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()


@pytest.mark.parametrize("case", COLLECTIONS)
def test_prepare_browse_and_move_with_the_keyboard(page, server_url, check_screenshot, case):
    from playwright.sync_api import expect

    wanted, cameras, screenshot = case
    kermit = _collection(server_url, wanted)
    page.goto(server_url + "/?renderer=server#stereospace")  # the server's pairs (the browser's: *_gl.py)
    page.wait_for_function("document.body.dataset.state === 'ready'", timeout=15_000)
    page.locator('[data-testid="ss-collection"]').select_option(kermit["id"])
    page.click('[data-testid="ss-prepare"]')
    expect(page.locator('[data-testid="ss-browser"]')).to_be_visible(timeout=JOB_MS)
    _wait_ready(page, JOB_MS)
    job = page.locator('[data-testid="ss-browser"]').get_attribute("data-job")
    status = httpx.get(f"{server_url}/api/jobs/{job}", timeout=30).json()
    assert status["kind"] == "stereospace" and status["state"] == "done"
    result = status["result"]
    assert result["cameras"] == cameras and result["collection"] == kermit["id"]
    _check_view(page, result["start"])
    # the map: one dot per camera, the current region drawn
    assert page.locator("#ss-map circle.ss-camera").count() == result["cameras"]
    expect(page.locator('[data-testid="ss-map-region"]')).to_be_visible()
    img = page.locator('[data-testid="ss-pair"]')
    assert img.evaluate("el => el.naturalWidth") == result["default_width"]

    # arrow key: a pan by one step, as POST .../move answers it (the right arrow moves the camera right)
    start = {k: result["start"][k] for k in ("region", "li", "lj")}
    sign = result["start"]["pan_right"]  # the pan towards the view's world right (issue 30)
    page.keyboard.press("ArrowRight")
    page.wait_for_function(f"JSON.parse(document.getElementById('ss-li').dataset.value) !== {start['li']!r} "
                           f"|| document.body.dataset.state === 'error'", timeout=MOVE_MS)  # fmt: skip
    _wait_ready(page, MOVE_MS)
    moved = httpx.post(f"{server_url}/api/stereospace/{job}/move",
                       json={"state": start, "pan": sign * result["pan_step"]}, timeout=30).json()
    _check_view(page, moved["state"])
    assert page.locator('[data-testid="ss-event"]').get_attribute("data-event") == moved["event"]

    # +: the interocular distance grows by one zoom step
    after_pan = {k: moved["state"][k] for k in ("region", "li", "lj")}
    page.keyboard.press("+")
    page.wait_for_function(f"JSON.parse(document.getElementById('ss-interocular').dataset.value) !== "
                           f"{moved['state']['interocular']!r} || document.body.dataset.state === 'error'",
                           timeout=MOVE_MS)  # fmt: skip
    _wait_ready(page, MOVE_MS)
    zoomed = httpx.post(f"{server_url}/api/stereospace/{job}/move",
                        json={"state": after_pan, "zoom": result["zoom_step"]}, timeout=30).json()
    _check_view(page, zoomed["state"])
    assert zoomed["state"]["interocular"] > moved["state"]["interocular"]

    # the mouse: the wheel down over the view is one zoom step down, a drag right by an eighth of the view
    # (and a bit) one pan step right
    box = page.locator('[data-testid="ss-view"]').bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    before = {k: zoomed["state"][k] for k in ("region", "li", "lj")}
    page.mouse.move(cx, cy)
    page.mouse.wheel(0, 100)
    page.wait_for_function(f"JSON.parse(document.getElementById('ss-interocular').dataset.value) !== "
                           f"{zoomed['state']['interocular']!r} || document.body.dataset.state === 'error'",
                           timeout=MOVE_MS)  # fmt: skip
    _wait_ready(page, MOVE_MS)
    wheeled = httpx.post(f"{server_url}/api/stereospace/{job}/move",
                         json={"state": before, "zoom": -result["zoom_step"]}, timeout=30).json()
    _check_view(page, wheeled["state"])
    before = {k: wheeled["state"][k] for k in ("region", "li", "lj")}
    sign = wheeled["state"]["pan_right"]
    page.mouse.move(cx, cy)
    page.mouse.down()
    page.mouse.move(cx + box["width"] / 8 * 1.2, cy, steps=4)
    page.mouse.up()
    page.wait_for_function(f"JSON.parse(document.getElementById('ss-li').dataset.value) !== {before['li']!r} "
                           f"|| document.body.dataset.state === 'error'", timeout=MOVE_MS)  # fmt: skip
    _wait_ready(page, MOVE_MS)
    dragged = httpx.post(f"{server_url}/api/stereospace/{job}/move",
                         json={"state": before, "pan": sign * result["pan_step"]}, timeout=30).json()
    _check_view(page, dragged["state"])

    # another format: side by side is twice as wide
    page.locator('[data-testid="ss-format"]').select_option("sbs")
    page.wait_for_function(f"document.getElementById('ss-pair').naturalWidth === {2 * result['default_width']}",
                           timeout=MOVE_MS)
    _wait_ready(page, MOVE_MS)
    page.locator('[data-testid="ss-format"]').select_option("anaglyph")
    page.wait_for_function(f"document.getElementById('ss-pair').naturalWidth === {result['default_width']}",
                           timeout=MOVE_MS)
    _wait_ready(page, MOVE_MS)
    check_screenshot(page, screenshot)
