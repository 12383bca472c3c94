"""Page 2's overlays (issue 30) in Chromium: the disparity heat map, the histogram against the comfort zone
and the divergence limit, the stereo-window check with its floating window, the live horizontal image
translation (HIT) and a stereo pair's vertical disparity.

Every figure is checked against the job's own parallax map (``GET /api/jobs/{id}/files/parallax.npy``) with
arithmetic done here: the comfort zone from the display's lengths by hand, the histogram's counts with numpy,
the window's band and percentile as docs/workbench.md states them.
"""

from __future__ import annotations

import io
import math

import httpx
import numpy as np
import pytest
from web_checks import HEAT_COLOUR_TOL, heat_colour, match_uploaded_pair

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # the first synthesis compiles the warping kernels
W, H = 160, 120
NEAR_ROWS, NEAR_COLS = slice(30, 90), slice(0, 36)  # a near box touching the left edge: a window violation


def _ready(page) -> None:
    page.wait_for_function("document.body.dataset.state === 'ready' || document.body.dataset.state === 'error'",
                           timeout=JOB_MS)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()


def _overlays_ready(page) -> None:
    page.wait_for_function("document.getElementById('st-overlays').dataset.state === 'ready'", timeout=60_000)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()


def _inputs(tmp_path):
    """A bright textured image and its metric depth: a floor receding from 2 m (bottom) to 6 m (top) and a box
    at 1.2 m touching the left edge."""
    from vergence.io import write_image

    rng = np.random.default_rng(3)
    image = (0.4 + 0.6 * rng.random((H, W, 3))).astype(np.float32)
    depth = np.repeat(np.linspace(6.0, 2.0, H, dtype=np.float32)[:, None], W, axis=1)
    depth[NEAR_ROWS, NEAR_COLS] = 1.2
    write_image(tmp_path / "scene.png", image)
    np.save(tmp_path / "scene_depth.npy", depth)
    return tmp_path / "scene.png", tmp_path / "scene_depth.npy"


def _synthesize(page, server_url, tmp_path, *, budget_a: str = "60", budget_b: str = "90") -> None:
    image, depth = _inputs(tmp_path)
    page.goto(server_url + "/#stereo")
    _ready(page)
    page.check('[data-testid="st-source-depth"]')
    page.set_input_files('[data-testid="st-file-image"]', str(image))
    _ready(page)
    page.set_input_files('[data-testid="st-file-depth"]', str(depth))
    _ready(page)
    page.fill('[data-testid="st-a-budget"]', budget_a)
    page.fill('[data-testid="st-b-budget"]', budget_b)
    page.click('[data-testid="st-run"]')
    _ready(page)
    _overlays_ready(page)


def _job_of_overlays(page, server_url) -> tuple[str, np.ndarray, dict]:
    job_id = page.locator('[data-testid="st-overlays"]').get_attribute("data-job")
    data = httpx.get(f"{server_url}/api/jobs/{job_id}/files/parallax.npy", timeout=30).content
    geo = httpx.get(f"{server_url}/api/stereo/{job_id}/overlay", timeout=30).json()
    return job_id, np.load(io.BytesIO(data)), geo


def _set_hit(page, shift: int) -> None:
    page.locator('[data-testid="st-hit"]').fill(str(shift))
    page.wait_for_function(f"document.getElementById('st-overlays').dataset.shift === '{shift}'")


def _heat_pixels(page, points) -> np.ndarray:
    return np.array(page.evaluate("""(points) => {
        const c = document.getElementById('st-heat-canvas').getContext('2d');
        return points.map(([x, y]) => Array.from(c.getImageData(x, y, 1, 1).data));
    }""", points), float)


def _zone_px(display: dict, theta_arcmin: float) -> float:
    """Parallax (px of the W-px pair filling the screen) whose vergence differs from the screen's by theta
    (positive behind): s = e - 2 D tan(atan(e / 2D) - theta / 2), in metres, over the pixel pitch."""
    e, d = display["eye_separation"], display["distance"]
    metres = e - 2 * d * math.tan(math.atan(e / (2 * d)) - math.radians(theta_arcmin / 60) / 2)
    return metres / (display["width"] / display["resolution"]) / (display["resolution"] / W)


def test_the_heat_map_toggles_and_its_colours_are_the_parallax(page, server_url, tmp_path):
    from playwright.sync_api import expect

    _synthesize(page, server_url, tmp_path)
    job_id, parallax, geo = _job_of_overlays(page, server_url)
    assert job_id == page.locator("#st-results").get_attribute("data-job-a")
    heat = page.locator('[data-testid="st-heat-canvas"]')
    expect(heat).to_be_visible()
    assert heat.evaluate("c => [c.width, c.height]") == [W, H]
    page.locator('[data-testid="st-heat-opacity"]').fill("35")
    assert heat.evaluate("c => c.style.opacity") == "0.35"
    page.uncheck('[data-testid="st-heat"]')
    expect(heat).to_be_hidden()
    page.check('[data-testid="st-heat"]')
    expect(heat).to_be_visible()

    lo, hi = geo["scale"]["px"]
    points = [[2, 60], [20, 40], [100, 5], [100, 115], [150, 60], [80, 70]]
    values = [float(parallax[y, x]) for x, y in points]
    assert min(values) < 0 < max(values)  # near and far pixels, different colours
    for shift in (0, 3):
        if shift:
            _set_hit(page, shift)
        shown = _heat_pixels(page, points)
        expected = np.array([heat_colour(v + shift, lo, hi) for v in values])
        np.testing.assert_allclose(shown[:, :3], expected, atol=HEAT_COLOUR_TOL)
        assert (shown[:, 3] == 255).all()
    # the colour bar is labelled in arcmin of the chosen display, the zone's limits among its ticks
    labels = page.locator('[data-testid="st-heat-bar"] text[data-arcmin]').evaluate_all(
        "els => els.map(e => e.textContent)")
    assert labels == ["-120′", "-90′", "-60′", "-30′", "0′", "30′", "60′", "90′", "120′"]
    assert "desktop-24" in page.locator('[data-testid="st-heat-bar"]').text_content()


def test_the_histogram_and_its_shares_follow_the_hit_slider(page, server_url, tmp_path):
    _synthesize(page, server_url, tmp_path)
    page.select_option('[data-testid="st-ov-set"]', "b")
    _overlays_ready(page)
    job_id, parallax, _ = _job_of_overlays(page, server_url)
    assert job_id == page.locator("#st-results").get_attribute("data-job-b")
    status = httpx.get(f"{server_url}/api/jobs/{job_id}", timeout=30).json()["result"]
    zone = (_zone_px(status["display"], -60), _zone_px(status["display"], 60))
    divergence = status["display"]["eye_separation"] / status["display"]["width"] * W
    known = parallax[np.isfinite(parallax)].astype(np.float64)

    def bars() -> list[tuple[float, float, float]]:
        return page.locator('[data-testid="st-hist"] rect.bar').evaluate_all(
            "els => els.map(e => [Number(e.dataset.lo), Number(e.dataset.hi), Number(e.dataset.value)])")

    before = bars()
    mean_before = float(page.locator('[data-testid="st-hist"]').get_attribute("data-mean"))
    for shift in (0, -2, 5):
        _set_hit(page, shift)
        values = known + shift
        outside = np.count_nonzero((values < zone[0]) | (values > zone[1])) / values.size
        diverging = np.count_nonzero(values > divergence) / values.size
        assert float(page.locator('[data-testid="st-share-zone"]').get_attribute("data-value")) == pytest.approx(
            outside, abs=1e-12)
        assert float(page.locator('[data-testid="st-share-div"]').get_attribute("data-value")) == pytest.approx(
            diverging, abs=1e-12)
        if shift == 0:
            assert outside > 0.1  # budget +-90 arcmin leaves the +-60 zone
            assert outside == pytest.approx(status["comfort"]["outside_share"], abs=1e-12)  # the library's figure
        shown = bars()
        assert sum(v for *_, v in shown) == pytest.approx(100.0)
        for lo, hi, percent in shown:
            count = np.count_nonzero((values >= lo) & (values < hi))
            assert percent == pytest.approx(100 * count / values.size, abs=1e-9), (shift, lo, hi)
        mean = float(page.locator('[data-testid="st-hist"]').get_attribute("data-mean"))
        assert mean == pytest.approx(mean_before + shift, abs=1e-6)
        if shift == 5:  # the same bars, each moved by s (the bin width divides 1 px here)
            width = float(page.locator('[data-testid="st-hist"]').get_attribute("data-bin-width"))
            assert (1 / width) == round(1 / width)
            np.testing.assert_allclose([(lo + shift, hi + shift, v) for lo, hi, v in before], shown, atol=1e-9)
    # the shown pair is the job's views moved apart by s: the left view -s/2, the right +s/2 (the canvas is 2x)
    canvas = _canvas_rgb(page)
    views = {name: _view(server_url, job_id, name) for name in ("left.png", "right.png")}
    cols = np.arange(2 * W)
    for channel, name, dx in ((0, "left.png", 5), (1, "right.png", -5), (2, "right.png", -5)):
        src = (cols + dx) // 2  # the view's column drawn at canvas column c
        inside = (src >= 0) & (src < W)
        expected = np.zeros((2 * H, 2 * W))
        expected[:, inside] = np.repeat(views[name][:, src[inside], channel], 2, axis=0)
        np.testing.assert_allclose(canvas[:, :, channel], expected, atol=1, err_msg=name)
    assert "HIT +5 px" in page.locator('[data-testid="st-cli-b"]').input_value()
    assert "HIT" not in page.locator('[data-testid="st-cli-a"]').input_value()
    assert "hit+5px" in page.locator('[data-testid="st-save-shown"]').get_attribute("download")
    with page.expect_download() as info:
        page.click('[data-testid="st-save-shown"]')
    saved = tmp_path / "saved.png"
    info.value.save_as(saved)
    assert info.value.suggested_filename == "b_anaglyph_hit+5px.png"
    from vergence.io import read_image

    np.testing.assert_allclose(255 * read_image(saved)[..., :3], canvas, atol=1)  # the pair as shown


def _canvas_rgb(page) -> np.ndarray:
    """The shown pair's canvas as (2H, 2W, 3) values 0-255."""
    data = page.evaluate("""() => {
        const c = document.getElementById('st-pair-canvas');
        return [c.width, c.height, Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data)];
    }""")
    width, height, values = data
    return np.array(values, float).reshape(height, width, 4)[:, :, :3]


def _view(server_url: str, job_id: str, name: str) -> np.ndarray:
    import cv2

    data = httpx.get(f"{server_url}/api/jobs/{job_id}/files/{name}", timeout=30).content
    return cv2.cvtColor(cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB).astype(float)


def _red_columns(page, x0: int, x1: int) -> np.ndarray:
    """The red channel (the left view's) of the shown pair's canvas columns [x0, x1), every row."""
    data = page.evaluate("""([x0, x1]) => {
        const c = document.getElementById('st-pair-canvas');
        const d = c.getContext('2d').getImageData(x0, 0, x1 - x0, c.height).data;
        const out = [];
        for (let i = 0; i < d.length; i += 4) out.push(d[i]);
        return out;
    }""", [x0, x1])
    return np.array(data).reshape(-1, x1 - x0)


def test_a_window_violation_is_flagged_and_the_floating_window_masks_it(page, server_url, tmp_path):
    from playwright.sync_api import expect

    _synthesize(page, server_url, tmp_path)
    _, parallax, geo = _job_of_overlays(page, server_url)
    band = max(2, round(0.02 * W))  # vergence analyze's band: 2 % of the width, at least 2 columns
    near = -parallax[:, :band]
    assert np.isnan(near).sum() == 0 and (near[NEAR_ROWS] > 0.5).all()  # the box is in front of the screen there
    width = math.ceil(np.percentile(near, 95))
    assert width >= 2
    left = page.locator('[data-testid="st-window-left"]')
    right = page.locator('[data-testid="st-window-right"]')
    assert left.get_attribute("data-violation") == "true" and right.get_attribute("data-violation") == "false"
    assert float(left.get_attribute("data-share")) == pytest.approx(np.mean(near > 0.5), abs=1e-12)
    assert int(left.get_attribute("data-width")) == width
    rows = np.flatnonzero((near > 0.5).any(axis=1))
    expect(left).to_contain_text(f"rows {rows[0]}–{rows[-1]}")
    expect(left).to_contain_text(f"floating window of {width} px")
    assert _red_columns(page, 0, 2 * width).max() > 0  # not masked yet: the left view's bright texture

    page.check('[data-testid="st-float"]')
    note = page.locator('[data-testid="st-float-note"]')
    expect(note).to_contain_text(f"left edge of the left view: {width} px black")
    assert page.locator('[data-testid="st-overlays"]').get_attribute("data-mask-left") == str(width)
    assert page.locator('[data-testid="st-overlays"]').get_attribute("data-mask-right") == "0"
    assert _red_columns(page, 0, 2 * width).max() == 0  # the canvas is the pair at 2x: 2 columns per px
    assert _red_columns(page, 2 * width, 2 * width + 2).max() > 0
    assert f"floating window: left {width} px, right 0 px" in page.locator('[data-testid="st-cli-a"]').input_value()

    # pushed behind the screen by the HIT, the box no longer breaks the window: nothing is masked
    shift = math.ceil(float(np.nanmax(near))) + 1
    _set_hit(page, shift)
    assert left.get_attribute("data-violation") == "false"
    assert page.locator('[data-testid="st-overlays"]').get_attribute("data-mask-left") == "0"
    expect(page.locator('[data-testid="st-float-note"]')).to_contain_text("no edge needs it")


def test_the_vertical_disparity_of_a_matched_pair(page, server_url, tmp_path):
    """A textured pair whose right view sits 2 px higher than its left (and 4 px left): the page shows the
    measure of `vergence rectify --check` within half a pixel, above its 1-px threshold."""
    import cv2
    from playwright.sync_api import expect

    from vergence.io import write_image

    rng = np.random.default_rng(5)
    texture = cv2.GaussianBlur(rng.random((H + 20, W + 20)).astype(np.float32), (0, 0), 1.5)
    texture = (texture - texture.min()) / (texture.max() - texture.min())
    write_image(tmp_path / "l.png", texture[10:10 + H, 10:10 + W])
    write_image(tmp_path / "r.png", texture[12:12 + H, 14:14 + W])  # y_r = y_l - 2, x_r = x_l - 4
    page.goto(server_url + "/#stereo")
    _ready(page)
    match_uploaded_pair(page, tmp_path / "l.png", tmp_path / "r.png", max_disparity=16, ready=_ready)
    _overlays_ready(page)
    vertical = page.locator('[data-testid="st-vertical"]')
    expect(vertical).to_be_visible()
    assert float(vertical.get_attribute("data-value")) == pytest.approx(2.0, abs=0.5)
    expect(vertical).to_contain_text("above 1 px")
    assert "st-warn" in vertical.get_attribute("class")
    expect(vertical).to_contain_text("px of the pair")
