"""Page 2 of the workbench (issue 13), "2D + depth to stereo", in Chromium: the built-in example or
uploaded files to a stereo pair, A and B wiped against each other, the comfort figures equal to the
``synthesize`` jobs' results, every layout, the download and the CLI line.

Run with ``VERGENCE_UPDATE_SCREENSHOTS=1`` to write the README's screenshot,
docs/images/workbench_stereo.png; otherwise the screenshot stays in the test's temporary folder.
"""

from __future__ import annotations

import httpx
import numpy as np
import pytest
from web_checks import match_uploaded_pair

pytestmark = pytest.mark.browser

JOB_MS = 300_000  # the first synthesis compiles the warping kernels, the first example the renderer's
SIZE = {"width": 96, "height": 72}


def _ready(page) -> None:
    page.wait_for_function("document.body.dataset.state === 'ready' || document.body.dataset.state === 'error'",
                           timeout=JOB_MS)
    assert page.locator("#error").is_hidden(), page.locator("#error").inner_text()


def _open(page, server_url: str) -> None:
    page.goto(server_url + "/#stereo")
    _ready(page)


def _shown_figures_equal_the_jobs(page, server_url: str) -> dict:
    results = {}
    for set_ in ("a", "b"):
        job_id = page.locator("#st-results").get_attribute(f"data-job-{set_}")
        status = httpx.get(f"{server_url}/api/jobs/{job_id}", timeout=30).json()
        assert status["state"] == "done"
        comfort = status["result"]["comfort"]
        for key in ("min_arcmin", "max_arcmin", "zone_min_arcmin", "zone_max_arcmin", "outside_share",
                    "excess_arcmin", "min_px", "max_px", "divergence_px"):
            shown = page.locator(f'[data-testid="st-{set_}-{key}"]').get_attribute("data-value")
            assert float(shown) == comfort[key], (set_, key)
        for key in ("inside", "diverges"):
            assert page.locator(f'[data-testid="st-{set_}-{key}"]').get_attribute("data-value") == str(comfort[key]).lower()
        results[set_] = status
    return results


def test_the_example_with_an_ab_wipe_every_format_and_the_download(page, server_url, check_screenshot):
    from playwright.sync_api import expect

    _open(page, server_url)
    page.fill('[data-testid="st-example-width"]', str(SIZE["width"]))
    page.fill('[data-testid="st-example-height"]', str(SIZE["height"]))
    page.fill('[data-testid="st-b-budget"]', "90")
    page.click('[data-testid="st-example"]')
    _ready(page)
    expect(page.locator("#st-shown")).to_be_visible()
    jobs = _shown_figures_equal_the_jobs(page, server_url)
    a, b = jobs["a"]["result"], jobs["b"]["result"]
    assert a["inputs"]["scene"] == "tabletop" and a["size"] == [SIZE["width"], SIZE["height"]]
    assert a["budget_arcmin"] == 30 and b["budget_arcmin"] == 90
    assert a["comfort"]["inside"] and b["comfort"]["outside_share"] > 0  # +-90 arcmin leaves the +-60 zone
    expect(page.locator('[data-testid="st-b-outside_share"]')).to_have_text(
        f"{100 * b['comfort']['outside_share']:.1f} %")
    expect(page.locator('[data-testid="st-warnings"]')).to_contain_text("B: ")

    # every layout of vergence.display, each a file of both jobs, shown in the wipe
    options = page.locator('[data-testid="st-format"] option').evaluate_all("els => els.map(e => e.value)")
    assert set(options) == set(a["layouts"]) and len(options) == 15
    widths = {"sbs": 2, "cross-eyed": 2, "tb": 1, "half-sbs": 1, "anaglyph": 1, "rows": 1}
    for layout in options:
        page.select_option('[data-testid="st-format"]', layout)
        for set_ in ("a", "b"):
            img = page.locator(f'[data-testid="st-img-{set_}"]')
            expect(img).to_have_attribute("src", f"/api/jobs/{jobs[set_]['id']}/files/{a['layouts'][layout]}")
            img.evaluate("el => el.decode()")
            if layout in widths:
                assert img.evaluate("el => el.naturalWidth") == widths[layout] * SIZE["width"], layout
    page.select_option('[data-testid="st-format"]', "sbs")
    cli = page.locator('[data-testid="st-cli-a"]').input_value()
    assert cli.startswith("vergence render tabletop --width 96 --height 72 --depth 0 --samples 4 --out example && "
                          "vergence synthesize example/render_beauty.png example/render_depth.pfm --out stereo-a ")
    assert "--display desktop-24 --budget-arcmin 30 --fill background --format sbs" in cli
    assert "--budget-arcmin 90" in page.locator('[data-testid="st-cli-b"]').input_value()

    # the A/B wipe: the slider, then a drag on the image
    page.locator('[data-testid="st-wipe"]').fill("20")
    expect(page.locator('[data-testid="st-wipe-box"]')).to_have_attribute("data-split", "20")
    assert "20%" in page.locator('[data-testid="st-img-b"]').evaluate("el => el.style.clipPath")
    box = page.locator('[data-testid="st-wipe-box"]').bounding_box()
    page.mouse.move(box["x"] + 0.75 * box["width"], box["y"] + box["height"] / 2)
    page.mouse.down()
    page.mouse.move(box["x"] + 0.6 * box["width"], box["y"] + box["height"] / 2)
    page.mouse.up()
    split = float(page.locator('[data-testid="st-wipe-box"]').get_attribute("data-split"))
    assert split == pytest.approx(60, abs=1.5)
    assert page.locator('[data-testid="st-wipe"]').input_value() == str(round(split))

    # the download serves the job's file
    link = page.locator('[data-testid="st-download-a"]')
    href = link.get_attribute("href")
    assert href == f"/api/jobs/{jobs['a']['id']}/files/stereo_sbs.png" and link.get_attribute("download")
    served = httpx.get(server_url + href, timeout=30)
    assert served.status_code == 200 and served.headers["content-type"] == "image/png"
    assert served.content[:8] == b"\x89PNG\r\n\x1a\n"

    page.locator('[data-testid="st-wipe"]').fill("50")
    page.select_option('[data-testid="st-format"]', "anaglyph")
    for set_ in ("a", "b"):
        page.locator(f'[data-testid="st-img-{set_}"]').evaluate("el => el.decode()")
    check_screenshot(page, "workbench_stereo.png")


def _files(tmp_path):
    from vergence.io import write_image

    rng = np.random.default_rng(0)
    image = rng.random((48, 64, 3)).astype(np.float32)
    depth = np.full((48, 64), 4.0, np.float32)
    depth[12:36, 20:44] = 1.5
    write_image(tmp_path / "photo.png", image)
    np.save(tmp_path / "photo_depth.npy", depth)
    return tmp_path / "photo.png", tmp_path / "photo_depth.npy"


def test_uploaded_image_and_depth(page, server_url, tmp_path):
    image, depth = _files(tmp_path)
    _open(page, server_url)
    page.check('[data-testid="st-source-depth"]')
    page.set_input_files('[data-testid="st-file-image"]', str(image))
    _ready(page)
    page.set_input_files('[data-testid="st-file-depth"]', str(depth))
    _ready(page)
    assert "depth: photo_depth.npy (NPY, 64×48, 1 ch)" in page.locator('[data-testid="st-uploads"]').inner_text()
    page.fill('[data-testid="st-a-budget"]', "20")
    page.click('[data-testid="st-run"]')
    _ready(page)
    jobs = _shown_figures_equal_the_jobs(page, server_url)
    assert jobs["a"]["result"]["inputs"] == {"image": "photo.png", "depth": "photo_depth.npy"}
    assert jobs["a"]["result"]["comfort"]["max_arcmin"] == pytest.approx(20.0)
    assert page.locator('[data-testid="st-cli-a"]').input_value().startswith(
        "vergence synthesize photo.png photo_depth.npy --out stereo-a --depth-kind metric --display desktop-24 "
        "--budget-arcmin 20")


def test_a_colour_depth_is_refused_on_the_page(page, server_url, tmp_path):
    image, _ = _files(tmp_path)
    _open(page, server_url)
    page.check('[data-testid="st-source-depth"]')
    page.set_input_files('[data-testid="st-file-image"]', str(image))
    _ready(page)
    page.set_input_files('[data-testid="st-file-depth"]', str(image))
    _ready(page)
    page.click('[data-testid="st-run"]')
    page.wait_for_function("document.body.dataset.state === 'error'", timeout=15_000)
    assert "depth must be a single-channel map" in page.locator("#error").inner_text()
    assert page.locator('[data-testid="st-run"]').is_enabled()


def test_a_stereo_pair_is_matched_from_the_page(page, server_url, tmp_path):
    from vergence.io import write_image

    rng = np.random.default_rng(1)
    wide = rng.random((48, 72)).astype(np.float32)
    write_image(tmp_path / "l.png", wide[:, :64].copy())
    write_image(tmp_path / "r.png", wide[:, 4:68].copy())  # disparity 4 px everywhere
    _open(page, server_url)
    match_uploaded_pair(page, tmp_path / "l.png", tmp_path / "r.png", max_disparity=16, ready=_ready)
    jobs = _shown_figures_equal_the_jobs(page, server_url)
    assert jobs["a"]["result"]["match"]["max_disparity"] == 16
    assert page.locator('[data-testid="st-cli-a"]').input_value().startswith(
        "vergence match l.png r.png --max-disparity 16 --out disparity.pfm && vergence synthesize l.png disparity.pfm "
        "--out stereo-a --depth-kind disparity")


def test_cancel_stops_the_running_job(page, server_url):
    from playwright.sync_api import expect

    _open(page, server_url)
    page.fill('[data-testid="st-example-width"]', "640")
    page.fill('[data-testid="st-example-height"]', "640")
    page.fill('[data-testid="st-a-budget"]', "31")  # not a cached job of another test
    page.click('[data-testid="st-example"]')
    expect(page.locator('[data-testid="st-cancel"]')).to_be_enabled(timeout=15_000)
    page.click('[data-testid="st-cancel"]')
    expect(page.locator('[data-testid="st-message"]')).to_have_text("cancelled", timeout=60_000)
    assert page.locator('[data-testid="st-run"]').is_enabled() and page.locator("#error").is_hidden()
    expect(page.locator('[data-testid="st-cancel"]')).to_be_disabled()


def test_each_set_chooses_its_depth_control(page, server_url):
    """A: a budget in image pixels; B: the shift-sensor rig (focal length, interaxial, convergence); each
    job gets only its control's fields (`vergence synthesize` takes exactly one) and the CLI line says so."""
    _open(page, server_url)
    page.fill('[data-testid="st-example-width"]', str(SIZE["width"]))
    page.fill('[data-testid="st-example-height"]', str(SIZE["height"]))
    page.select_option('[data-testid="st-a-control"]', "px")
    page.fill('[data-testid="st-a-budget-px"]', "3")
    page.select_option('[data-testid="st-b-control"]', "sensor")
    page.fill('[data-testid="st-b-focal"]', "100")
    page.fill('[data-testid="st-b-interaxial"]', "0.02")
    page.fill('[data-testid="st-b-convergence"]', "2")
    page.click('[data-testid="st-example"]')
    _ready(page)
    jobs = _shown_figures_equal_the_jobs(page, server_url)
    a, b = jobs["a"]["result"], jobs["b"]["result"]
    assert a["budget_px"] == 3 and a["budget_arcmin"] is None
    assert b["control"] == "shift-sensor" and b["budget_px"] is None and b["budget_arcmin"] is None
    assert max(abs(a["comfort"]["min_px"]), abs(a["comfort"]["max_px"])) > 0
    cli = page.locator('[data-testid="st-cli-a"]').input_value()
    assert "--budget-px 3" in cli and "--budget-arcmin" not in cli
    cli_b = page.locator('[data-testid="st-cli-b"]').input_value()
    assert "--focal-px 100" in cli_b and "--interaxial 0.02" in cli_b and "--convergence 2" in cli_b
