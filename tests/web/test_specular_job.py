"""The workbench's ``specular`` job (issue 13, page 5): S3's pipeline run from the API."""

from __future__ import annotations

import warnings

import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.web import create_app
from web_checks import refused as _refused, wait_job

WAIT_S = 300.0  # k + 3 renders, the table and the figures; the first compiles Numba kernels
TINY = {"scene": "scene:glasses", "width": 64, "height": 48, "k": 2, "samples": 1}


def _wait(client, job_id: str) -> dict:
    return wait_job(client, job_id, timeout=WAIT_S)


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        yield c


def test_a_tiny_glasses_job_writes_the_outputs_and_its_report(client):
    import cv2
    import numpy as np

    first = client.post("/api/jobs/specular", json=TINY)
    assert first.status_code == 202, first.text
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    for name in ("physical_anaglyph.png", "optimised_anaglyph.png", "on_surface_anaglyph.png",
                 "near_surface_anaglyph.png", "anaglyphs.png", "analysis_disparity.png", "analysis_importance.png",
                 "analysis_rivalry.png", "offsets.png", "report.json"):
        assert name in job["files"]
    report = client.get(f"/api/jobs/{job['id']}/files/report.json").json()
    assert job["result"] == report
    assert report["settings"]["k"] == 2 and report["settings"]["variant"] == "comfort"
    assert set(report["cost_before"]) == set(report["cost_after"]) and report["layers"]
    assert report["display"]["fit"] == "screen" and report["display"]["image_width_px"] == 64  # the default fit
    assert {"inside_share_before", "comfort_share_before"} <= set(report["layers"][1])
    png = client.get(f"/api/jobs/{job['id']}/files/optimised_anaglyph.png")
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    arr = cv2.imdecode(np.frombuffer(png.content, np.uint8), cv2.IMREAD_COLOR)
    assert arr.shape[:2] == (48, 64)

    again = client.post("/api/jobs/specular", json=TINY)
    assert again.status_code == 200 and again.json()["cached"] is True and again.json()["id"] == job["id"]
    other = client.post("/api/jobs/specular", json={**TINY, "variant": "screen"}).json()
    assert other["id"] != job["id"]
    client.delete(f"/api/jobs/{other['id']}")


@pytest.mark.parametrize(("body", "message"), [
    ({**TINY, "width": 641}, "width: less than or equal to 640 (got 641)"),
    ({**TINY, "k": 1}, "k: greater than or equal to 2 (got 1)"),
    ({**TINY, "k": 33}, "k: less than or equal to 32 (got 33)"),
    ({**TINY, "variant": "loose"}, "variant must be one of screen, comfort; got 'loose'"),
    ({**TINY, "weights": [1, 1, -1, 0]}, "weights must be four numbers in [0, 1e+06]"),
    ({**TINY, "weights": [1, 1, 1]}, "weights"),
    ({**TINY, "display": "nope"}, "display: "),
    ({**TINY, "depth": 9}, "depth must be at most 6"),
    ({**TINY, "fit": "wide"}, "fit must be one of screen, native; got 'wide'"),
    ({**TINY, "depth": 0}, "depth 0 traces no specular layer (the first hit only), but scene 'scene:glasses' has"),
])
def test_bad_specular_parameters_are_422(client, body, message):
    assert message in _refused(client.post("/api/jobs/specular", json=body), 422)


def test_an_unknown_scene_is_404(client):
    assert "scene:nope" in _refused(client.post("/api/jobs/specular", json={**TINY, "scene": "scene:nope"}), 404)


def test_a_scene_file_without_a_stereo_block_is_422(tmp_path):
    import json
    from pathlib import Path

    source = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "spheres_and_mirror.json"
    if not source.is_file():
        pytest.skip(f"{source} is not in this tree")
    data = tmp_path / "data"
    data.mkdir()
    scene = json.loads(source.read_text())
    del scene["stereo"]
    (data / "mono.json").write_text(json.dumps(scene))
    with TestClient(create_app([data]), base_url="http://127.0.0.1") as c:
        scene_id = next(e["id"] for e in c.get("/api/data").json()["scenes"] if e["name"] == "mono.json")
        error = _refused(c.post("/api/jobs/specular", json={**TINY, "scene": scene_id}), 422)
        assert error == (f"scene {scene_id!r} has no \"stereo\" block (baseline, convergence): a specular job uses "
                         "the scene's own rig (docs/scenes.md)")


def test_the_specular_kind_is_listed_with_its_parameters(client):
    kinds = {k["name"]: k for k in client.get("/api/jobs").json()["kinds"]}
    assert set(kinds["specular"]["parameters"]["properties"]) == {
        "scene", "width", "height", "k", "depth", "samples", "display", "fit", "variant", "weights"}


def _upload_npy(client, array) -> str:
    import io

    import numpy as np

    buffer = io.BytesIO()
    np.save(buffer, np.asarray(array, dtype=np.float32))
    response = client.post("/api/uploads?name=paint.npy", content=buffer.getvalue(),
                           headers={"Content-Type": "application/octet-stream"})
    assert response.status_code == 201, response.text
    return response.json()["id"]


@pytest.fixture(scope="module")
def done_job(client) -> dict:
    first = client.post("/api/jobs/specular", json=TINY)
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    return job


def test_the_job_writes_a_picture_per_layer_to_paint_on(client, done_job):
    import cv2
    import numpy as np

    layers = [name for name in done_job["files"] if name.startswith("layer_")]
    assert layers == [f"layer_{i}.png" for i in range(1, len(done_job["result"]["layers"]) + 1)]
    png = client.get(f"/api/jobs/{done_job['id']}/files/layer_1.png")
    assert cv2.imdecode(np.frombuffer(png.content, np.uint8), cv2.IMREAD_COLOR).shape[:2] == (48, 64)


def test_reoptimise_with_a_painted_map_equals_the_library(client, done_job):
    """The job re-solves with the kept table: what it reports is SpecularResult.reoptimise's answer
    with the same weights and map, and its files are the specular job's files (no layer pictures)."""
    import numpy as np

    paint = np.ones((48, 64), np.float32)
    paint[:, :32] = 0.0  # the absolute term of layer 2 switched off on the left half
    body = {"job": done_job["id"], "weights": [1, 1, 5, 0.1], "variant": "screen",
            "weight_maps": [{"layer": 2, "term": "absolute", "upload": _upload_npy(client, paint)}]}
    first = client.post("/api/jobs/specular-reoptimise", json=body)
    assert first.status_code == 202, first.text
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    assert "optimised_anaglyph.png" in job["files"] and not any(n.startswith("layer_") for n in job["files"])
    report = job["result"]
    assert report["settings"]["variant"] == "screen" and report["settings"]["alpha"] == [1, 1, 5, 0.1]
    assert report["settings"]["maps"] == ["absolute"]
    base = client.app.state.jobs.live(done_job["id"], "specular")
    maps = {"absolute": np.ones((7, 48, 64))}
    maps["absolute"][1] = paint
    expected = base.reoptimise(alpha=(1, 1, 5, 0.1), variant="screen", maps=maps).report()
    assert report["layers"] == expected["layers"] and report["cost_after"] == expected["cost_after"]
    assert report["cost_before"] == expected["cost_before"]
    again = client.post("/api/jobs/specular-reoptimise", json=body)
    assert again.status_code == 200 and again.json()["cached"] is True


@pytest.mark.parametrize(("change", "status", "message"), [
    ({"job": "0123456789abcdef"}, 404, "unknown job id '0123456789abcdef'"),
    ({"variant": "loose"}, 422, "variant must be one of screen, comfort; got 'loose'"),
    ({"weights": [1, 1, float("nan"), 0]}, 422, "weights"),
    ({"weight_maps": [{"layer": 2, "term": "comfort", "upload": "x"}]}, 422, "unknown cost term 'comfort'"),
    ({"weight_maps": [{"layer": 2, "upload": "nope"}]}, 404, "nope"),
    ({"weight_maps": [{"layer": 0, "upload": "x"}]}, 422, "layer"),
    ({"extra": 1}, 422, "extra"),
])
def test_bad_reoptimise_requests_are_refused(client, done_job, change, status, message):
    body = {"job": done_job["id"], **change}
    response = client.post("/api/jobs/specular-reoptimise", content=__import__("json").dumps(body),
                           headers={"Content-Type": "application/json"})
    assert message in _refused(response, status)


def test_a_map_of_the_wrong_size_or_values_names_the_upload_not_a_path(client, done_job):
    import numpy as np

    for array, says in ((np.ones((10, 10)), "must be 64 x 48 pixels"), (np.full((48, 64), -1.0), "negative")):
        upload = _upload_npy(client, array)
        body = {"job": done_job["id"], "weight_maps": [{"layer": 3, "upload": upload}]}
        error = _refused(client.post("/api/jobs/specular-reoptimise", json=body), 422)
        assert says in error and f"upload {upload}" in error
        assert client.app.state.workdir.as_posix() not in error


def test_reoptimise_needs_a_done_specular_job(client):
    render = client.post("/api/jobs/render", json={"scene": "scene:glasses", "width": 8, "height": 6}).json()
    _wait(client, render["id"])
    error = _refused(client.post("/api/jobs/specular-reoptimise", json={"job": render["id"]}), 404)
    assert "is a render job, not a specular job" in error


def test_only_the_most_recent_jobs_keep_their_table(tmp_path):
    """Past MAX_LIVE_JOBS, the least recently used job drops its live objects: a re-optimise on it is 409."""
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        c.app.state.jobs.max_live = 1
        small = {**TINY, "width": 24, "height": 18}
        a = _wait(c, c.post("/api/jobs/specular", json=small).json()["id"])
        b = _wait(c, c.post("/api/jobs/specular", json={**small, "variant": "screen"}).json()["id"])
        assert a["state"] == b["state"] == "done"
        error = _refused(c.post("/api/jobs/specular-reoptimise", json={"job": a["id"]}), 409)
        assert "no longer keeps its work in memory" in error and "run it again" in error
        assert c.post("/api/jobs/specular-reoptimise", json={"job": b["id"]}).status_code == 202


def _zeros_on_layer(client, done_job, layer: int) -> dict:
    import numpy as np

    return {"job": done_job["id"], "weight_maps": [{"layer": layer, "upload": _upload_npy(client, np.zeros((48, 64)))}]}


def test_a_layer_no_weight_can_move_is_refused_and_the_solve_agrees(client, done_job):
    """The layers refused (422, naming the layer and why) are exactly those whose paint leaves every offset
    where it was in the library's own solve: each layer's four terms painted 0 everywhere, one at a time."""
    import numpy as np

    from vergence.specular import COST_TERMS

    base = client.app.state.jobs.live(done_job["id"], "specular")
    names = {layer["layer"]: layer["name"] for layer in done_job["result"]["layers"]}
    refused, moved = set(), set()
    for layer in names:
        maps = {t: np.ones(base.y.shape) for t in COST_TERMS}
        for m in maps.values():
            m[layer - 1] = 0.0
        if not np.array_equal(base.reoptimise(maps=maps).y, base.y):
            moved.add(layer)
        response = client.post("/api/jobs/specular-reoptimise", json=_zeros_on_layer(client, done_job, layer))
        if response.status_code == 422:
            refused.add(layer)
            error = response.json()["error"]
            assert f"layer {layer} ({names[layer]}) has no matched pixel in the physical pair" in error, error
            assert "no weight can move its offsets" in error
        else:
            assert response.status_code in (200, 202), response.text
            _wait(client, response.json()["id"])
    assert refused, "the tiny glasses run has a layer without matches (RR at 64 x 48); the test needs one"
    assert refused == set(names) - moved


def test_a_map_of_ones_is_refused(client, done_job):
    import numpy as np

    body = {"job": done_job["id"], "weight_maps": [{"layer": 2, "upload": _upload_npy(client, np.ones((48, 64)))}]}
    error = _refused(client.post("/api/jobs/specular-reoptimise", json=body), 422)
    assert "is 1 everywhere: it changes no weight" in error


def test_reoptimise_answers_with_the_left_eye_first_and_writes_the_rest_on_request(client, done_job):
    """The job is done with what the page shows (SHOWN_FIRST); the other files are pending until asked for."""
    import io

    import cv2
    import numpy as np

    from vergence.report.specular_outputs import SPECULAR_OUTPUT_FILES
    from vergence.web.job_kinds import SHOWN_FIRST

    paint = np.ones((48, 64), np.float32)
    paint[:, 32:] = 3.0
    body = {"job": done_job["id"], "weights": [1, 1, 7, 0.1],
            "weight_maps": [{"layer": 3, "term": "relative", "upload": _upload_npy(client, paint)}]}
    job = _wait(client, client.post("/api/jobs/specular-reoptimise", json=body).json()["id"])
    assert job["state"] == "done", job
    assert set(job["files"]) == set(SHOWN_FIRST)
    assert set(job["pending"]) == set(SPECULAR_OUTPUT_FILES) - set(SHOWN_FIRST)
    assert set(job["result"]["web_seconds"]) == {"reoptimise", "report", "write_shown"}
    maps = {"relative": np.ones((7, 48, 64))}
    maps["relative"][2] = paint
    expected = client.app.state.jobs.live(done_job["id"], "specular").reoptimise(alpha=(1, 1, 7, 0.1), maps=maps)
    overlay = np.load(io.BytesIO(client.get(f"/api/jobs/{job['id']}/files/disparity_after.npy").content))
    np.testing.assert_array_equal(overlay, expected.after.disparity[..., 0])
    png = client.get(f"/api/jobs/{job['id']}/files/optimised_anaglyph.png")
    assert cv2.imdecode(np.frombuffer(png.content, np.uint8), cv2.IMREAD_COLOR).shape[:2] == (48, 64)

    sheet = client.get(f"/api/jobs/{job['id']}/files/analysis_disparity.png")  # pending: written now
    assert sheet.status_code == 200 and sheet.headers["content-type"] == "image/png", sheet.text
    after = client.get(f"/api/jobs/{job['id']}").json()
    assert after["pending"] == [] and set(SPECULAR_OUTPUT_FILES) <= set(after["files"])
    analysis = np.load(io.BytesIO(client.get(f"/api/jobs/{job['id']}/files/analysis.npz").content))
    np.testing.assert_array_equal(analysis["disparity_after"][..., 0], overlay)
    assert "no file 'nope.png'" in _refused(client.get(f"/api/jobs/{job['id']}/files/nope.png"), 404)


def test_a_run_with_nothing_specular_refuses_every_paint(client):
    """Tabletop has no mirror or glass: the run has no offsets to solve, so a paint on any layer is 422."""
    import numpy as np

    job = _wait(client, client.post("/api/jobs/specular", json={**TINY, "scene": "scene:tabletop", "width": 32,
                                                                "height": 24}).json()["id"])  # fmt: skip
    assert job["state"] == "done" and job["result"]["specular"] is False
    upload = _upload_npy(client, np.zeros((24, 32)))
    for layer in (1, 2):
        body = {"job": job["id"], "weight_maps": [{"layer": layer, "upload": upload}]}
        error = _refused(client.post("/api/jobs/specular-reoptimise", json=body), 422)
        assert "nothing specular is in view in this run" in error and "the layers a paint can change: none" in error
