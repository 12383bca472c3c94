"""Page 5's overlays (issue 30) in Chromium: the chosen layer's disparity heat map over its picture and the
histogram of every layer's matched pixels against the comfort zone and the divergence limit.

Every figure is checked against the job's own array (``GET /api/jobs/{id}/files/disparity_after.npy``) with
arithmetic done here: the colours from docs/workbench.md's stops, the counts with numpy, the divergence limit
from the display's eye separation and distance by hand.
"""

from __future__ import annotations

import io
import math

import httpx
import numpy as np
import pytest
from web_checks import HEAT_COLOUR_TOL, heat_colour, run_specular_page

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # k + 3 renders and the table; the first run compiles Numba kernels
TINY = {"width": 64, "height": 48, "k": 2, "samples": 1}


def _run(page, server_url: str) -> str:
    job = run_specular_page(page, server_url, TINY, timeout_ms=JOB_MS)
    page.wait_for_function(f"document.getElementById('spec-ov').dataset.state === 'ready' && "
                           f"document.getElementById('spec-ov').dataset.job === '{job}'", timeout=60_000)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()
    return job


def _float(page, testid: str, attr: str = "data-value") -> float:
    return float(page.locator(f'[data-testid="{testid}"]').get_attribute(attr))


def test_the_heat_map_and_histogram_are_the_jobs_disparity(page, server_url):
    from playwright.sync_api import expect

    job = _run(page, server_url)
    data = httpx.get(f"{server_url}/api/jobs/{job}/files/disparity_after.npy", timeout=30).content
    disparity = np.load(io.BytesIO(data)).astype(np.float64)  # (N, H, W) arcmin, NaN unmatched
    report = httpx.get(f"{server_url}/api/jobs/{job}", timeout=30).json()["result"]
    assert disparity.shape[1:] == (TINY["height"], TINY["width"])
    zone = report["comfort_zone_arcmin"]
    block = report["display"]
    # the eyes turn parallel at a screen parallax of one eye separation: 2 atan(e / 2D) of vergence
    divergence = 60 * math.degrees(2 * math.atan(block["eye_separation_m"] / (2 * block["viewing_distance_m"])))

    # the chosen layer: the first specular layer with a match (glasses: the reflection or the refraction)
    layer = int(page.locator('[data-testid="spec-ov-layer"]').input_value())
    plane = disparity[layer - 1]
    assert layer > 1 and np.isfinite(plane).any()
    heat = page.locator('[data-testid="spec-heat-canvas"]')
    expect(heat).to_be_visible()
    assert heat.evaluate("c => [c.width, c.height]") == [TINY["width"], TINY["height"]]
    rgba = heat.evaluate("c => Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data)")
    pixels = np.array(rgba, float).reshape(TINY["height"], TINY["width"], 4)
    known = np.isfinite(plane)
    assert (pixels[~known, 3] == 0).all() and (pixels[known, 3] == 255).all()  # unmatched: transparent
    ys, xs = np.nonzero(known)
    for y, x in list(zip(ys, xs))[:: max(1, len(ys) // 40)]:
        np.testing.assert_allclose(pixels[y, x, :3], heat_colour(plane[y, x], -120.0, 120.0), atol=HEAT_COLOUR_TOL)
    labels = page.locator('[data-testid="spec-heat-bar"] text[data-arcmin]').evaluate_all(
        "els => els.map(e => e.textContent)")
    assert labels == ["-120′", "-90′", "-60′", "-30′", "0′", "30′", "60′", "90′", "120′"]

    # the histogram: every layer's matched pixels pooled, each bar's share counted here
    values = disparity[np.isfinite(disparity)]
    bars = page.locator('[data-testid="spec-hist"] rect.bar').evaluate_all(
        "els => els.map(e => [Number(e.dataset.lo), Number(e.dataset.hi), Number(e.dataset.value)])")
    assert len(bars) > 3 and sum(v for *_, v in bars) == pytest.approx(100.0)
    for lo, hi, percent in bars:
        assert percent == pytest.approx(100 * np.count_nonzero((values >= lo) & (values < hi)) / values.size, abs=1e-9)
    inside = np.count_nonzero((values >= zone[0]) & (values <= zone[1]))
    assert _float(page, "spec-share-inside") == pytest.approx(inside / values.size, abs=1e-12)
    assert int(_float(page, "spec-share-inside", "data-count")) == inside
    diverging = np.count_nonzero(values > divergence) / values.size
    assert _float(page, "spec-share-div") == pytest.approx(diverging, abs=1e-12)
    expect(page.locator('[data-testid="spec-share-div"]')).to_contain_text(f"{divergence:.4g}′")
    # the chosen layer's plain share inside, as the library's report counts it (inside / matched, after)
    mine = plane[known]
    count = np.count_nonzero((mine >= zone[0]) & (mine <= zone[1]))
    assert int(_float(page, "spec-share-layer", "data-count")) == count
    entry = report["layers"][layer - 1]
    assert (count, mine.size) == (entry["inside_pixels_after"], entry["matched_pixels_after"])

    # another layer: its own plane, the pooled histogram unchanged
    other = next(n for n in range(1, disparity.shape[0] + 1) if n != layer)
    page.select_option('[data-testid="spec-ov-layer"]', str(other))
    page.wait_for_function(f"document.getElementById('spec-ov').dataset.layer === '{other}'")
    plane = disparity[other - 1]
    mine = plane[np.isfinite(plane)]
    count = np.count_nonzero((mine >= zone[0]) & (mine <= zone[1]))
    assert int(_float(page, "spec-share-layer", "data-count")) == count
    assert _float(page, "spec-share-inside") == pytest.approx(inside / values.size, abs=1e-12)


def test_the_overlay_endpoint_refuses_what_it_cannot_answer(server_url):
    assert httpx.get(f"{server_url}/api/specular/nope/overlay", timeout=30).status_code == 404
    bad = httpx.get(f"{server_url}/api/specular/nope/overlay?scale_arcmin=0", timeout=30)
    assert bad.status_code == 422 and "scale_arcmin" in bad.json()["error"]
