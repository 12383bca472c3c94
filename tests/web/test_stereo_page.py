"""The workbench's ``synthesize`` job (issue 13, page 2): 2D + depth, a matched pair or the example to stereo."""

from __future__ import annotations

import io
import json
import time
import warnings

import numpy as np
import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.display import LAYOUTS, pack
from vergence.io import write_image
from vergence.synthesis import plan_comfort, synthesize_stereo
from vergence.viewing import Display
from vergence.web import create_app
from web_checks import refused as _refused, wait_job
from vergence.web.stereo_page import MAX_EXAMPLE_SIDE

WAIT_S = 300.0  # the first job compiles the warping kernels (and, for the example, the renderer's)
W, H = 64, 48


def _wait(client, job_id: str) -> dict:
    return wait_job(client, job_id, timeout=WAIT_S)


def _png(image: np.ndarray, tmp_path, name: str = "x.png") -> bytes:
    path = tmp_path / name
    write_image(path, image)
    return path.read_bytes()


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def _upload(client, data: bytes, name: str, content_type: str = "image/png") -> str:
    response = client.post("/api/uploads", content=data, headers={"content-type": content_type},
                           params={"name": name})
    assert response.status_code == 201 or response.status_code == 200, response.text
    return response.json()["id"]


def _image() -> np.ndarray:
    return np.random.default_rng(0).random((H, W, 3)).astype(np.float32)


def _depth() -> np.ndarray:
    depth = np.full((H, W), 4.0, np.float32)
    depth[12:36, 20:44] = 1.5  # a near square in front of a far wall
    return depth


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        yield c


@pytest.fixture(scope="module")
def ids(client, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("uploads")
    rgb = _png(_image(), tmp, "image.png")
    grey_depth = np.clip(_depth() / 5.0, 0, 1)
    return {
        "image": _upload(client, rgb, "image.png"),
        "depth": _upload(client, _npy(_depth()), "depth.npy", "application/octet-stream"),
        "small": _upload(client, _npy(_depth()[:-1]), "small.npy", "application/octet-stream"),
        "colour": _upload(client, rgb, "colour_depth.png"),
        "jpeg": _upload(client, _jpeg(grey_depth, tmp), "depth.jpg", "image/jpeg"),
    }


def _jpeg(image: np.ndarray, tmp) -> bytes:
    path = tmp / "depth.jpg"
    write_image(path, image)
    return path.read_bytes()


def test_image_and_depth_give_every_layout_and_the_comfort_figures(client, ids):
    body = {"image": ids["image"], "depth": ids["depth"], "display": "desktop-24", "budget_px": 3.0}
    first = client.post("/api/jobs/synthesize", json=body)
    assert first.status_code == 202, first.text
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    result = job["result"]
    assert set(result["layouts"]) == set(LAYOUTS)
    assert set(job["files"]) == {"left.png", "right.png", "parallax.npy", "synthesis.json", *result["layouts"].values()}
    assert client.get(f"/api/jobs/{job['id']}/files/synthesis.json").json() == result
    # the library's own answer for the same input
    expected = synthesize_stereo(_image(), _depth(), display=Display.preset("desktop-24"), budget_px=3.0)
    report, outside = plan_comfort(expected.plan, Display.preset("desktop-24"))
    assert result["parallax_range_px"] == list(expected.plan.range_px)
    assert result["comfort"]["min_arcmin"] == report.min_arcmin and result["comfort"]["max_arcmin"] == report.max_arcmin
    assert result["comfort"]["outside_share"] == outside
    assert (result["comfort"]["zone_min_arcmin"], result["comfort"]["zone_max_arcmin"]) == (-60.0, 60.0)
    assert result["inputs"] == {"image": "image.png", "depth": "depth.npy"} and result["control"] == "budget"
    views = {}
    for name in ("left.png", "right.png"):
        response = client.get(f"/api/jobs/{job['id']}/files/{name}")
        assert response.status_code == 200 and response.headers["content-type"] == "image/png"
        views[name] = _decode(response.content)
    for layout, name in result["layouts"].items():
        response = client.get(f"/api/jobs/{job['id']}/files/{name}")
        assert response.status_code == 200 and response.headers["content-type"] == "image/png", name
        packed = _decode(response.content)
        assert packed.shape == pack(views["left.png"], views["right.png"], layout=layout).shape, layout
    sbs = _decode(client.get(f"/api/jobs/{job['id']}/files/stereo_sbs.png").content)
    assert np.array_equal(sbs[:, :W], views["left.png"]) and np.array_equal(sbs[:, W:], views["right.png"])
    again = client.post("/api/jobs/synthesize", json=body)
    assert again.status_code == 200 and again.json()["cached"] is True and again.json()["id"] == job["id"]


def _decode(data: bytes) -> np.ndarray:
    import cv2

    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)


def test_no_control_takes_the_cli_default_budget(client, ids):
    job = _wait(client, client.post("/api/jobs/synthesize", json={"image": ids["image"], "depth": ids["depth"]})
                .json()["id"])  # fmt: skip
    assert job["state"] == "done", job
    assert job["result"]["budget_arcmin"] == 30.0 and job["result"]["display"]["preset"] == "desktop-24"
    assert job["result"]["parallax_range_arcmin"][1] == pytest.approx(30.0)


def test_a_stereo_pair_is_matched_then_synthesized(client, tmp_path):
    rng = np.random.default_rng(1)
    left = rng.random((H, W + 8)).astype(np.float32)
    right = left[:, 4:4 + W].copy()  # x_right = x_left - 4: disparity 4 everywhere
    left = left[:, :W].copy()
    ids = {"left": _upload(client, _png(left, tmp_path, "l.png"), "left.png"),
           "right": _upload(client, _png(right, tmp_path, "r.png"), "right.png")}
    job = _wait(client, client.post("/api/jobs/synthesize", json={**ids, "max_disparity": 16, "budget_px": 2.0})
                .json()["id"])  # fmt: skip
    assert job["state"] == "done", job
    match = job["result"]["match"]
    assert match["method"] == "sgbm" and match["max_disparity"] == 16
    assert 3.0 <= match["disparity_min"] <= match["disparity_max"] <= 5.0
    assert job["result"]["source"] == "pair" and job["result"]["depth_kind"] == "disparity"


def test_the_example_renders_once_for_two_parameter_sets(client):
    body = {"example": "scene:tabletop", "example_width": 48, "example_height": 36}
    a = _wait(client, client.post("/api/jobs/synthesize", json={**body, "budget_arcmin": 20}).json()["id"])
    start = time.monotonic()
    b = _wait(client, client.post("/api/jobs/synthesize", json={**body, "budget_arcmin": 80}).json()["id"])
    assert a["state"] == b["state"] == "done", (a, b)
    assert time.monotonic() - start < 30.0  # no second render (a render compiles nothing now, but takes time)
    assert a["result"]["inputs"]["scene"] == "tabletop" and a["result"]["size"] == [48, 36]
    assert a["result"]["comfort"]["max_arcmin"] == pytest.approx(20.0)
    assert b["result"]["comfort"]["excess_arcmin"] > 0 and b["result"]["comfort"]["outside_share"] > 0
    assert any("comfort zone" in w for w in b["result"]["warnings"])


@pytest.mark.parametrize(("change", "message"), [
    ({"image": None, "depth": None}, "give image and depth (upload ids), or left and right (a stereo pair), or "
                                     "example (a scene id); got none"),
    ({"depth": None}, "got image"),
    ({"example": "scene:tabletop"}, "got depth, example, image"),
    ({"depth": "@small"}, "depth must have the size of image (64x48); got 64x47"),
    ({"depth": "@colour"}, "depth must be a single-channel map (grey PNG, 'Pf' PFM, (H, W) NPY); 'colour_depth.png' "
                           "has 3 channels (a colour image)"),
    ({"depth": "@jpeg"}, "depth must be a PNG, PFM or NPY file (a lossy JPEG would invent depth); got 'depth.jpg'"),
    ({"depth_kind": "height"}, "depth_kind must be one of disparity, inverse, metric; got 'height'"),
    ({"display": "nope"}, "display: "),
    ({"fill": "paint"}, "fill must be one of "),
    ({"method": "sgbm"}, "method does not apply to an image and its depth"),
    ({"origin": "right"}, "origin must be one of center, left; got 'right'"),
    ({"max_disparity": 32}, "max_disparity does not apply to an image and its depth"),
    ({"budget_arcmin": -5.0}, "budget_arcmin"),
    ({"budget_arcmin": 10.0, "budget_px": 2.0}, "budget"),
    ({"depth_scale": 0.0}, "depth_scale"),
    ({"example_width": MAX_EXAMPLE_SIDE + 1}, f"example_width: less than or equal to {MAX_EXAMPLE_SIDE}"),
    ({"size": 3}, "unknown field 'size'"),
])
def test_bad_requests_are_422_in_one_line(client, ids, change, message):
    body = {"image": ids["image"], "depth": ids["depth"]}
    for key, value in change.items():
        if value is None:
            body.pop(key)
        else:
            body[key] = ids[value[1:]] if isinstance(value, str) and value.startswith("@") else value
    assert message in _refused(client.post("/api/jobs/synthesize", json=body), 422)


def test_pair_and_example_refusals(client, ids):
    pair = {"left": ids["image"], "right": ids["image"]}
    assert "max_disparity must be > min_disparity >= 0 and below the width 64" in _refused(
        client.post("/api/jobs/synthesize", json={**pair, "max_disparity": 64}), 422)
    assert "method must be one of " in _refused(
        client.post("/api/jobs/synthesize", json={**pair, "method": "magic"}), 422)
    assert "depth_kind does not apply to a stereo pair" in _refused(
        client.post("/api/jobs/synthesize", json={**pair, "depth_kind": "metric"}), 422)
    assert "right must have the size of left" in _refused(
        client.post("/api/jobs/synthesize", json={"left": ids["image"], "right": ids["small"]}), 422)
    assert "depth_scale does not apply to the example" in _refused(
        client.post("/api/jobs/synthesize", json={"example": "scene:tabletop", "depth_scale": 2.0}), 422)
    assert "budget_px" in _refused(
        client.post("/api/jobs/synthesize", json={"example": "scene:tabletop", "budget_px": -1.0}), 422)
    # the sweep (tools/sweep web) found a NaN sigma accepted (202) and the job failing later
    for sigma in ('"nan"', "NaN", '"inf"'):
        assert _refused(client.post("/api/jobs/synthesize", content=f'{{"example": "scene:tabletop", "smooth_sigma": '
                                    f'{sigma}}}', headers={"content-type": "application/json"}), 422).startswith(
            "smooth_sigma: ")


def test_unknown_ids_are_404(client, ids):
    assert "unknown upload id 'nope'" in _refused(
        client.post("/api/jobs/synthesize", json={"image": "nope", "depth": ids["depth"]}), 404)
    assert "unknown upload id 'gone'" in _refused(
        client.post("/api/jobs/synthesize", json={"left": ids["image"], "right": "gone"}), 404)
    assert "scene:nope" in _refused(client.post("/api/jobs/synthesize", json={"example": "scene:nope"}), 404)


def test_the_kind_is_listed_with_its_parameters(client):
    kinds = {k["name"]: k for k in client.get("/api/jobs").json()["kinds"]}
    assert {"image", "depth", "left", "right", "example", "display", "budget_arcmin", "fill"} <= set(
        kinds["synthesize"]["parameters"]["properties"])


def test_the_cli_line_of_the_example_makes_the_same_pair(client, tmp_path, capsys):
    """What the page's "copy the CLI command" gives (vergence render, then vergence synthesize) writes the
    job's own pair and figures: the job calls the library as the commands do."""
    from vergence.cli import main

    body = {"example": "scene:tabletop", "example_width": 48, "example_height": 36, "budget_arcmin": 20.0}
    job = _wait(client, client.post("/api/jobs/synthesize", json=body).json()["id"])
    assert job["state"] == "done", job
    example, out = tmp_path / "example", tmp_path / "stereo-a"
    assert main(["render", "tabletop", "--width", "48", "--height", "36", "--depth", "0", "--samples", "4",
                 "--out", str(example)]) == 0
    capsys.readouterr()
    assert main(["synthesize", str(example / "render_beauty.png"), str(example / "render_depth.pfm"), "--out", str(out),
                 "--display", "desktop-24", "--budget-arcmin", "20", "--fill", "background", "--format", "sbs",
                 "--json"]) == 0  # fmt: skip
    printed = json.loads(capsys.readouterr().out)
    for key in ("parallax_range_px", "parallax_range_arcmin", "holes_percent", "warnings", "size", "budget_arcmin"):
        assert printed[key] == job["result"][key], key
    served = _decode(client.get(f"/api/jobs/{job['id']}/files/stereo_sbs.png").content)
    assert np.array_equal(served, _decode((out / "stereo_sbs.png").read_bytes()))


def _overlay_job(client, ids) -> dict:
    job = _wait(client, client.post("/api/jobs/synthesize", json={"image": ids["image"], "depth": ids["depth"],
                                                                  "budget_arcmin": 45.0}).json()["id"])  # fmt: skip
    assert job["state"] == "done", job
    return job


def _zone_px_by_hand(display: Display, width: int, theta_arcmin: float) -> float:
    """The parallax (px of a ``width``-px pair filling the screen) whose vergence differs from the screen's by
    ``theta_arcmin`` (positive behind): ``s = e - 2 D tan(gamma_0 / 2 - theta / 2)``, ``gamma_0 = 2 atan(e / 2D)``."""
    import math

    e, d = display.eye_separation, display.distance
    half = math.atan(e / (2 * d)) - math.radians(theta_arcmin / 60.0) / 2
    metres = e - 2 * d * math.tan(half)
    return metres / (display.width / display.resolution) / (display.resolution / width)


def test_the_parallax_map_and_the_overlay_geometry(client, ids):
    """parallax.npy is the plan's P = x_r - x_l of the same input (the library's own answer), and the overlay's
    comfort zone, divergence limit and colour scale are those of the display worked by hand."""
    job = _overlay_job(client, ids)
    served = np.load(io.BytesIO(client.get(f"/api/jobs/{job['id']}/files/parallax.npy").content))
    expected = synthesize_stereo(_image(), _depth(), display=Display.preset("desktop-24"), budget_arcmin=45.0)
    assert served.dtype == np.float32 and served.shape == (H, W)
    np.testing.assert_array_equal(served, expected.plan.parallax_px)
    geo = client.get(f"/api/stereo/{job['id']}/overlay").json()
    display = Display.preset("desktop-24")
    assert (geo["width"], geo["height"], geo["display"]) == (W, H, "desktop-24")
    assert geo["display_px_per_px"] == display.resolution / W
    np.testing.assert_allclose(geo["zone_px"], [_zone_px_by_hand(display, W, -60), _zone_px_by_hand(display, W, 60)],
                               rtol=1e-9)  # fmt: skip
    assert geo["divergence_px"] == pytest.approx(display.eye_separation / display.width * W, rel=1e-12)
    assert geo["scale"]["arcmin"] == [-120.0, 120.0]
    np.testing.assert_allclose(geo["scale"]["px"], [_zone_px_by_hand(display, W, a) for a in (-120, 120)], rtol=1e-9)
    assert [t["arcmin"] for t in geo["scale"]["ticks"]] == [-120, -90, -60, -30, 0, 30, 60, 90, 120]
    # vergence analyze's band: round(0.02 * 64) = 1 column, at least 2
    assert geo["window"] == {"band_px": 2, "min_px": 0.5, "share": 0.1, "mask_percentile": 95}
    assert geo["parallax"] == "parallax.npy" and geo["row_alignment"] is None  # measured for a stereo pair only
    wide = client.get(f"/api/stereo/{job['id']}/overlay", params={"scale_arcmin": 240}).json()
    assert wide["scale"]["arcmin"] == [-240.0, 240.0] and wide["zone_px"] == geo["zone_px"]


@pytest.mark.parametrize("value", ["0", "-1", "601", "nan", "inf", "wide"])
def test_the_overlay_refuses_a_bad_scale_422(client, ids, value):
    job = _overlay_job(client, ids)
    message = _refused(client.get(f"/api/stereo/{job['id']}/overlay", params={"scale_arcmin": value}), 422)
    assert "scale_arcmin" in message


def test_the_overlay_of_an_unknown_job_is_404(client):
    assert "unknown job id 'nope'" in _refused(client.get("/api/stereo/nope/overlay"), 404)
    assert "no such page or endpoint" in _refused(client.get("/api/stereo/nope/overlays"), 404)


def test_the_overlay_of_another_kind_of_job_is_404_and_of_a_running_one_409(client, ids):
    render = _wait(client, client.post("/api/jobs/render", json={"scene": "scene:tabletop", "width": 8, "height": 6,
                                                                 "depth": 0, "samples": 1}).json()["id"])  # fmt: skip
    assert render["state"] == "done", render
    assert "is a render job, not a synthesize job" in _refused(client.get(f"/api/stereo/{render['id']}/overlay"), 404)
    # a large example takes seconds to render: asked at once, the job is still queued or running
    running = client.post("/api/jobs/synthesize", json={"example": "scene:tabletop", "example_width": 640,
                                                        "example_height": 639}).json()  # fmt: skip
    try:
        assert running["state"] in ("queued", "running"), running
        message = _refused(client.get(f"/api/stereo/{running['id']}/overlay"), 409)
        assert "its overlays exist once it is done" in message
    finally:
        client.delete(f"/api/jobs/{running['id']}")
