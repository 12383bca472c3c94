"""The matching result's overlays (issue 30) in Chromium: a stereo pair uploaded on page 2 is matched as
``vergence match`` does; "the stereo pair as matched" draws its own parallax (``-d``) as a heat map over the pair
and as a histogram against the comfort zone and the divergence limit.

The pair is a texture and its copy moved 4 px left, so every matched parallax is -4 px (in front of the screen):
the map is checked against that, and the page's colours and counts against numpy on the job's own array.
"""

from __future__ import annotations

import io

import httpx
import numpy as np
import pytest
from web_checks import HEAT_COLOUR_TOL, heat_colour, match_uploaded_pair

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # the first synthesis compiles the warping kernels
W, H = 160, 120
SHIFT_PX = 4  # x_r = x_l - 4: d = 4, P = x_r - x_l = -4
MATCH_TOL_PX = 0.5  # SGBM's subpixel estimate on a blurred random texture


def _ready(page, condition: str = "document.body.dataset.state === 'ready' || document.body.dataset.state === 'error'"):
    page.wait_for_function(condition, timeout=JOB_MS)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()


def test_the_matched_pair_is_drawn_with_its_own_parallax(page, server_url, tmp_path):
    import cv2
    from playwright.sync_api import expect

    from vergence.io import write_image

    rng = np.random.default_rng(11)
    texture = cv2.GaussianBlur(rng.random((H, W + 20)).astype(np.float32), (0, 0), 1.5)
    texture = (texture - texture.min()) / (texture.max() - texture.min())
    left, right = texture[:, 10:10 + W], texture[:, 10 + SHIFT_PX:10 + SHIFT_PX + W]
    write_image(tmp_path / "l.png", left)
    write_image(tmp_path / "r.png", right)
    page.goto(server_url + "/#stereo")
    _ready(page)
    match_uploaded_pair(page, tmp_path / "l.png", tmp_path / "r.png", max_disparity=16, ready=_ready)
    _ready(page, "document.getElementById('st-overlays').dataset.state === 'ready'")
    page.select_option('[data-testid="st-ov-set"]', "input")
    _ready(page, "document.getElementById('st-overlays').dataset.set === 'input' && "
                 "document.getElementById('st-overlays').dataset.state === 'ready'")
    job = page.locator('[data-testid="st-overlays"]').get_attribute("data-job")
    assert job == page.locator("#st-results").get_attribute("data-job-a")
    geo = httpx.get(f"{server_url}/api/stereo/{job}/overlay?of=input", timeout=30).json()
    assert geo["parallax"] == "matched_parallax.npy" and geo["views"] == ["input_left.png", "input_right.png"]
    data = httpx.get(f"{server_url}/api/jobs/{job}/files/matched_parallax.npy", timeout=30).content
    parallax = np.load(io.BytesIO(data)).astype(np.float64)
    known = parallax[np.isfinite(parallax)]
    assert known.size > 0.8 * W * H
    assert np.mean(np.abs(known + SHIFT_PX) <= MATCH_TOL_PX) > 0.9  # the world's shift, in front of the screen

    # the heat map's colours are the matched parallax
    heat = page.locator('[data-testid="st-heat-canvas"]')
    expect(heat).to_be_visible()
    lo, hi = geo["scale"]["px"]
    rgba = heat.evaluate("c => Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data)")
    pixels = np.array(rgba, float).reshape(H, W, 4)
    ys, xs = np.nonzero(np.isfinite(parallax))
    for y, x in list(zip(ys, xs))[::97]:
        np.testing.assert_allclose(pixels[y, x, :3], heat_colour(parallax[y, x], lo, hi), atol=HEAT_COLOUR_TOL)
    assert (pixels[~np.isfinite(parallax), 3] == 0).all()

    # the histogram and its shares, counted here
    bars = page.locator('[data-testid="st-hist"] rect.bar').evaluate_all(
        "els => els.map(e => [Number(e.dataset.lo), Number(e.dataset.hi), Number(e.dataset.value)])")
    assert sum(v for *_, v in bars) == pytest.approx(100.0)
    for b_lo, b_hi, percent in bars:
        assert percent == pytest.approx(100 * np.count_nonzero((known >= b_lo) & (known < b_hi)) / known.size, abs=1e-9)
    outside = np.count_nonzero((known < geo["zone_px"][0]) | (known > geo["zone_px"][1])) / known.size
    share = float(page.locator('[data-testid="st-share-zone"]').get_attribute("data-value"))
    assert share == pytest.approx(outside, abs=1e-12)

    # the pair drawn is the uploaded pair itself: the left view in red (the canvas is 2x), at HIT 0
    canvas = page.evaluate("""() => {
        const c = document.getElementById('st-pair-canvas');
        return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data);
    }""")
    red = np.array(canvas, float).reshape(2 * H, 2 * W, 4)[::2, ::2, 0]
    np.testing.assert_allclose(red, np.round(255 * left), atol=1)
    assert "the stereo pair as matched" in page.locator('[data-testid="st-save-shown"]').inner_text()
    bad = httpx.get(f"{server_url}/api/stereo/{job}/overlay?of=depth", timeout=30)
    assert bad.status_code == 422 and "of must be one of result, input" in bad.json()["error"]
