"""The workbench's StereoSpace page (issue 13, page 3): the ``stereospace`` job and its follow-ups
(``/api/stereospace/{job}/move``, ``/pair``, ``/views/{name}``), each answer checked against the library
and each refusal with its one line. The collections are the shared kermit (Bundler, 9 cameras: fast) and
dino (Middlebury, 48 views: slow enough to be caught running); tests that need them skip without them."""

from __future__ import annotations

import warnings

from pathlib import Path

import numpy as np
from numpy.testing import assert_allclose
import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.web import create_app
from web_checks import refused as _refused, wait_job
from vergence.web.stereospace_page import MAX_MAP_POINTS, MAX_PAIR_FILES

WAIT_S = 120.0  # kermit prepares in well under a second, dino in a few seconds


def _wait(client, job_id: str) -> dict:
    return wait_job(client, job_id, timeout=WAIT_S)


# ../shared/data/collections beside the checkout (the rule of the shared_data fixture, which skips instead)
SHARED_COLLECTIONS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "collections"


@pytest.fixture(scope="module")
def client():
    """The app with the shared collections when they are there (kermit, dino), else the built-in ones only."""
    folders = [SHARED_COLLECTIONS] if SHARED_COLLECTIONS.is_dir() else []
    with TestClient(create_app(folders), base_url="http://127.0.0.1") as c:
        yield c


@pytest.fixture(scope="module")
def bare():
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        yield c


def _collection(client, name: str) -> str:
    cols = client.get("/api/data").json()["collections"]
    found = [c["id"] for c in cols if c["name"].startswith(f"{name}/")]
    if not found:
        pytest.skip(f"the shared {name} collection is missing")
    return found[0]


@pytest.fixture(scope="module")
def kermit(client, shared_data):
    """``(job status, the library's PreparedCollection of the same collection)``."""
    from vergence.stereospace import PreparedCollection, load_collection

    first = client.post("/api/jobs/stereospace", json={"collection": _collection(client, "kermit")})
    assert first.status_code in (200, 202), first.text
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    folder = shared_data / "collections" / "kermit"
    return job, PreparedCollection(load_collection(folder / "bundle.out", images=folder))


@pytest.fixture(scope="module")
def browsed(client) -> dict:
    """A done job on the built-in tabletop collection (12 views ray-traced by the job: no shared data needed)."""
    first = client.post("/api/jobs/stereospace", json={"collection": "collection:tabletop", "grid_step": 16})
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    return job


def _state(view: dict) -> dict:
    return {k: view[k] for k in ("region", "li", "lj")}


def _lib_state(view: dict):
    from vergence.stereospace import StereoState

    return StereoState(tuple(view["region"]), view["li"], view["lj"])


def _map_xy(prepared, points):
    from vergence.stereospace import map_frame

    frame = map_frame(prepared.collection)
    return (np.asarray(points) - prepared.centers.mean(axis=0)) @ frame[:2].T


# ---------------------------------------------------------------- the job
def test_the_job_prepares_kermit_and_its_map(client, kermit):
    from vergence.stereospace import start_state
    from vergence.viewing import Display

    job, prepared = kermit
    r = job["result"]
    assert (r["cameras"], r["points"], r["segments"], r["regions"]) == (
        9, prepared.collection.point_count, len(prepared.space.segments), len(prepared.space.regions))
    assert r["image_width"] == 640 and r["default_width"] == 320 and "anaglyph" in r["formats"]
    assert job["files"] == ["map.json"]
    start, _, _ = start_state(prepared, Display.preset("desktop-24"))
    assert r["start"]["region"] == list(start.region) and (r["start"]["li"], r["start"]["lj"]) == (start.li, start.lj)
    eyes = _map_xy(prepared, prepared.space.eyes(start))
    shown = np.array([r["start"]["eyes"]["left"], r["start"]["eyes"]["right"]])
    np.testing.assert_allclose(np.sort(shown, axis=0), np.sort(eyes, axis=0), atol=1e-12)
    np.testing.assert_allclose(r["start"]["stereo_camera"], eyes.mean(axis=0), atol=1e-12)
    baseline = np.diff(prepared.space.eyes(start), axis=0)
    assert r["start"]["interocular"] == pytest.approx(float(np.linalg.norm(baseline)))
    m = client.get(f"/api/jobs/{job['id']}/files/map.json").json()
    assert [c["name"] for c in m["cameras"]] == list(prepared.collection.names)
    centers = [[c["x"], c["y"]] for c in m["cameras"]]
    np.testing.assert_allclose(centers, _map_xy(prepared, prepared.centers), atol=1e-12)
    assert m["segments"] == prepared.segment_cameras.tolist() and len(m["paths"]) == r["paths"]
    assert 0 < len(m["points"]) <= MAX_MAP_POINTS
    # the same request again is the cached job
    again = client.post("/api/jobs/stereospace", json={"collection": r["collection"]})
    assert again.status_code == 200 and again.json()["cached"] is True and again.json()["id"] == job["id"]


def test_the_job_refuses_what_is_not_a_collection(bare):
    assert "is a scene, not a collection" in _refused(
        bare.post("/api/jobs/stereospace", json={"collection": "scene:tabletop"}), 422)
    assert "unknown data id" in _refused(bare.post("/api/jobs/stereospace", json={"collection": "collection-00"}), 404)
    assert "missing field collection" in _refused(bare.post("/api/jobs/stereospace", json={}), 422)
    assert "grid_step: greater than or equal to 2" in _refused(
        bare.post("/api/jobs/stereospace", json={"collection": "scene:tabletop", "grid_step": 1}), 422)
    assert "unknown field 'path'" in _refused(
        bare.post("/api/jobs/stereospace", json={"collection": "x", "path": "/etc"}), 422)


def test_the_job_refuses_a_display_without_resolution_or_unknown(client, kermit):
    cid = kermit[0]["result"]["collection"]
    assert "display: unknown display preset 'nope'" in _refused(
        client.post("/api/jobs/stereospace", json={"collection": cid, "display": "nope"}), 422)


# ---------------------------------------------------------------- move
def test_a_move_is_the_library_pan_then_zoom(client, kermit):
    from vergence.stereospace import pan, zoom

    job, prepared = kermit
    r = job["result"]
    start = _lib_state(r["start"])
    answer = client.post(f"/api/stereospace/{job['id']}/move",
                         json={"state": _state(r["start"]), "pan": r["pan_step"], "zoom": r["zoom_step"]})
    assert answer.status_code == 200, answer.text
    a = answer.json()
    panned = pan(prepared.space, start, r["pan_step"])
    zoomed = zoom(prepared.space, panned.state, r["zoom_step"])
    assert [s["action"] for s in a["steps"]] == ["pan", "zoom"]
    assert [s["event"] for s in a["steps"]] == [panned.event, zoomed.event]
    assert _state(a["state"]) == {"region": list(zoomed.state.region), "li": zoomed.state.li, "lj": zoomed.state.lj}
    assert a["steps"][0]["to"] == _state({"region": list(panned.state.region), "li": panned.state.li,
                                          "lj": panned.state.lj})  # fmt: skip


def test_a_long_pan_jumps_at_the_region_border(client, kermit):
    from vergence.stereospace import pan

    job, prepared = kermit
    r = job["result"]
    v = 10 * r["pan_step"]
    a = client.post(f"/api/stereospace/{job['id']}/move", json={"state": _state(r["start"]), "pan": v}).json()
    expected = pan(prepared.space, _lib_state(r["start"]), v)
    assert expected.event == "jumped" and a["event"] == "jumped"
    assert a["state"]["region"] != r["start"]["region"] and a["state"]["region"] == list(expected.state.region)
    # a pan of zero moves nothing; both zero is no step at all
    still = client.post(f"/api/stereospace/{job['id']}/move", json={"state": _state(r["start"])}).json()
    assert still["event"] == "moved" and still["steps"] == [] and _state(still["state"]) == _state(r["start"])


def test_right_presses_keep_moving_kermit_right_in_the_world(client, kermit):
    """Issue 30: the page pans by ``pan_right * pan_step`` for the right arrow. Successive presses move
    the eyes' midpoint (world positions from the library, not the server's map) along the start view's
    world right every time (the eyes' order, ``swapped``, flips on the way in region (13, 15))."""
    from vergence.stereospace import pair_cameras

    job, prepared = kermit
    r = job["result"]
    space = prepared.space
    first, second = pair_cameras(space, prepared.collection, _lib_state(r["start"]))
    right = np.cross(first.R[2] + second.R[2], prepared.up)
    view, xs, flags = r["start"], [], set()
    for _ in range(8):
        xs.append(float(space.eyes(_lib_state(view)).mean(axis=0) @ right))
        assert_allclose(view["centre_world"], space.eyes(_lib_state(view)).mean(axis=0), atol=1e-12)
        flags.add(view["swapped"])
        a = client.post(f"/api/stereospace/{job['id']}/move",
                        json={"state": _state(view), "pan": view["pan_right"] * r["pan_step"]}).json()
        if a["event"] == "stopped":
            break
        view = a["state"]
    assert len(xs) >= 6 and (np.diff(xs) > 0).all(), xs
    assert flags == {False, True}  # the walk passes where the eyes' order flips


@pytest.mark.parametrize(("body", "message"), [
    ({"state": {"region": [10, 21], "li": 1.5, "lj": 0.5}}, "state[li]: less than or equal to 1"),
    ({"state": {"region": [10, 21], "li": 0.5, "lj": -0.1}}, "state[lj]: greater than or equal to 0"),
    ({"state": {"region": [0, 999], "li": 0.5, "lj": 0.5}}, "state: region (0, 999) does not exist"),
    ({"state": {"region": [3, 3], "li": 0.9, "lj": 0.1}}, "state: "),
    ({"state": {"region": [10.5, 21], "li": 0.5, "lj": 0.5}}, "state[region][0]: expected a whole number"),
    ({"state": {"region": [10, 21], "li": 0.5}}, "missing field state[lj]"),
    ({"pan": 0.1}, "missing field state"),
    ({"state": {"region": [10, 21], "li": 0.5, "lj": 0.5}, "pan": 1e9}, "pan must be at most"),
    ({"state": {"region": [10, 21], "li": 0.5, "lj": 0.5}, "zoom": -1e9}, "zoom must be at most"),
    ({"state": {"region": [10, 21], "li": 0.5, "lj": 0.5}, "tilt": 1}, "unknown field 'tilt'"),
])  # fmt: skip
def test_a_move_refuses_bad_states_and_steps(client, browsed, body, message):
    job = browsed
    assert message in _refused(client.post(f"/api/stereospace/{job['id']}/move", json=body), 422)


@pytest.mark.parametrize("raw", [
    b'{"state": {"region": [10, 21], "li": NaN, "lj": 0.5}}',
    b'{"state": {"region": [10, 21], "li": 0.5, "lj": 0.5}, "pan": Infinity}',
    b'{"state": {"region": [10, 21], "li": 0.5, "lj": 0.5}, "zoom": NaN}',
    b'[1, 2]',
    b'{"state": ',
])  # fmt: skip
def test_a_move_refuses_nan_infinity_and_bad_json(client, browsed, raw):
    job = browsed
    response = client.post(f"/api/stereospace/{job['id']}/move", content=raw,
                           headers={"Content-Type": "application/json"})
    _refused(response, 422)


def test_follow_ups_refuse_unknown_jobs_and_jobs_of_another_kind(client, bare):
    body = {"state": {"region": [0, 0], "li": 0.0, "lj": 1.0}}
    for route in ("move", "pair"):
        assert "unknown job id 'nope'" in _refused(client.post(f"/api/stereospace/nope/{route}", json=body), 404)
    render = bare.post("/api/jobs/render", json={"scene": "scene:tabletop", "width": 8, "height": 6, "samples": 1})
    rid = render.json()["id"]
    _wait(bare, rid)
    for route in ("move", "pair"):
        assert "is a render job, not a stereospace job" in _refused(
            bare.post(f"/api/stereospace/{rid}/{route}", json=body), 404)
    assert "is a render job" in _refused(bare.get(f"/api/stereospace/{rid}/views/x.png"), 404)


def test_follow_ups_refuse_a_job_not_done_and_cancel_stops_it(client):
    dino = _collection(client, "dino")
    # a grid step of its own: a new job, not a cached one (loading dino triangulates for seconds)
    first = client.post("/api/jobs/stereospace", json={"collection": dino, "grid_step": 13})
    assert first.status_code in (200, 202), first.text
    job = first.json()
    if job["state"] != "done":
        body = {"state": {"region": [0, 0], "li": 0.0, "lj": 1.0}}
        message = _refused(client.post(f"/api/stereospace/{job['id']}/move", json=body), 409)
        assert "it can be used once it is done" in message
        _refused(client.post(f"/api/stereospace/{job['id']}/pair", json=body), 409)
        client.delete(f"/api/jobs/{job['id']}")
        assert _wait(client, job["id"])["state"] in ("cancelled", "done")


# ---------------------------------------------------------------- pair
def test_a_pair_is_the_library_pair_as_png(client, kermit):
    from vergence.display import pack
    from vergence.io import read_image
    from vergence.stereospace import stereo_pair

    job, prepared = kermit
    r = job["result"]
    state = _lib_state(r["start"])
    body = {"state": _state(r["start"]), "format": "sbs", "width": 160}
    first = client.post(f"/api/stereospace/{job['id']}/pair", json=body)
    assert first.status_code == 200, first.text
    a = first.json()
    assert (a["width"], a["height"], a["format"]) == (160, 120, "sbs")
    assert set(a["images"]) == {"packed", "left", "right"}
    expected = stereo_pair(prepared, state, width=160)
    assert a["swapped"] == expected.swapped and _state(a["state"]) == _state(r["start"])
    assert a["quality"]["points_seen"] > 0 and a["quality"]["range_arcmin"] > 0
    images = {}
    for role, url in a["images"].items():
        got = client.get(url)
        assert got.status_code == 200 and got.headers["content-type"] == "image/png"
        path = client.app.state.workdir / f"{role}.png"
        path.write_bytes(got.content)
        images[role] = read_image(path)
    for role, view in (("left", expected.left), ("right", expected.right),
                       ("packed", pack(expected.left, expected.right, layout="sbs"))):  # fmt: skip
        assert images[role].shape == view.shape
        assert np.abs(images[role] - np.clip(view, 0, 1)).max() <= 0.5 / 255 + 1e-6  # 8-bit rounding only
    again = client.post(f"/api/stereospace/{job['id']}/pair", json={**body, "format": "anaglyph"}).json()
    assert again["cached"] is True and again["images"]["left"] == a["images"]["left"]
    assert again["images"]["packed"] != a["images"]["packed"]


@pytest.mark.parametrize(("body", "status", "message"), [
    ({"format": "hologram"}, 422, "format must be one of anaglyph"),
    ({"width": 16}, 422, "width: greater than or equal to 32"),
    ({"width": 10_000}, 422, "width: less than or equal to 4096"),
    ({"width": 1000}, 422, "width must be at most 320 (the collection's image width)"),
    ({"state": {"region": [10, 21], "li": 2.0, "lj": 0.5}}, 422, "state[li]: less than or equal to 1"),
    ({"state": {"region": [99, 99], "li": 0.0, "lj": 1.0}}, 422, "state: region (99, 99) does not exist"),
])  # fmt: skip
def test_a_pair_refuses_bad_formats_widths_and_states(client, browsed, body, status, message):
    job = browsed
    full = {"state": _state(job["result"]["start"]), **body}
    assert message in _refused(client.post(f"/api/stereospace/{job['id']}/pair", json=full), status)


def test_views_serve_only_the_names_the_server_made(client, browsed):
    job = browsed
    for name in ("map.json", "0123456789abcdef-left.png", "x" * 300):
        assert "has no pair image" in _refused(client.get(f"/api/stereospace/{job['id']}/views/{name}"), 404)
    for name in ("..%2Fmap.json", "../map.json", "%2Fetc%2Fpasswd"):  # never a path
        _refused(client.get(f"/api/stereospace/{job['id']}/views/{name}"), 404)
    assert MAX_PAIR_FILES >= 3  # a pair's three images fit


def test_the_scene_is_the_library_collection(client, kermit):
    """``GET .../scene`` (what the browser draws from, issue 30): the cameras, segments, up, points and S2's
    render parameters of the job's PreparedCollection; each ``source-{k}.png`` is camera k's decoded image."""
    from PIL import Image
    import io

    from vergence.stereospace import S2_HANDLE_CELL_PX, S2_MAX_SOURCES, UP_MIN_COSINE

    job, prepared = kermit
    scene = client.get(f"/api/stereospace/{job['id']}/scene").json()
    col = prepared.collection
    assert len(scene["cameras"]) == len(col) == len(scene["images"])
    for got, cam in zip(scene["cameras"], col.cameras):
        assert_allclose(np.reshape(got["K"], (3, 3)), cam.K, rtol=0, atol=0)
        assert_allclose(np.reshape(got["R"], (3, 3)), cam.R, rtol=0, atol=0)
        assert (got["width"], got["height"]) == (cam.width, cam.height)
    assert scene["segment_cameras"] == prepared.segment_cameras.tolist()
    assert_allclose(scene["up"], prepared.up, rtol=0, atol=0)
    assert_allclose(np.reshape(scene["points"], (-1, 3)), col.points, rtol=0, atol=0)
    r = scene["render"]
    assert (r["grid_step"], r["k"], r["handle_cell_px"], r["up_min_cosine"]) == (
        job["result"]["grid_step"], S2_MAX_SOURCES, S2_HANDLE_CELL_PX, UP_MIN_COSINE)
    got = client.get(scene["images"][3])
    assert got.status_code == 200 and got.headers["content-type"] == "image/png"
    image = np.asarray(Image.open(io.BytesIO(got.content)).convert("RGB"), dtype=np.float64) / 255.0
    assert_allclose(image, prepared.image(3), atol=0.5 / 255.0)  # 8-bit photos: the stored values
    assert str(col.image_paths[0].parent.parent) not in str(scene)  # no server path


def test_the_scene_serves_only_its_images(client, browsed):
    job = browsed
    for name in ("source-12.png", "source-01.png", "source--1.png", "map.json", "x" * 300, "..%2Fmap.json"):
        _refused(client.get(f"/api/stereospace/{job['id']}/scene/{name}"), 404)
    assert "has no scene image" in _refused(client.get(f"/api/stereospace/{job['id']}/scene/source-99.png"), 404)
    assert "unknown job id" in _refused(client.get("/api/stereospace/0123456789abcdef/scene"), 404)


def test_the_follow_ups_are_documented_in_openapi(bare):
    paths = bare.get("/openapi.json").json()["paths"]
    move = paths["/api/stereospace/{job_id}/move"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert set(move["properties"]) == {"state", "pan", "zoom"}
    assert set(move["properties"]["state"]["properties"]) == {"region", "li", "lj"}  # inlined, no dangling $ref
    pair = paths["/api/stereospace/{job_id}/pair"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert set(pair["properties"]) == {"state", "format", "width"}
    assert "/api/stereospace/{job_id}/views/{name}" in paths
    assert {"/api/stereospace/{job_id}/scene", "/api/stereospace/{job_id}/scene/{name}"} <= set(paths)
    kinds = {k["name"]: k for k in bare.get("/api/jobs").json()["kinds"]}
    assert set(kinds["stereospace"]["parameters"]["properties"]) == {"collection", "grid_step", "display"}


def test_a_built_in_collection_is_ray_traced_by_the_job(bare):
    """A fresh clone has no photo collection: the built-in ones are rendered by the job
    (vergence.stereospace.render_collection), then prepared and browsed as any other."""
    cols = bare.get("/api/data").json()["collections"]
    assert [c["id"] for c in cols] == ["collection:tabletop", "collection:stadium"]
    first = bare.post("/api/jobs/stereospace", json={"collection": "collection:tabletop", "grid_step": 16})
    assert first.status_code == 202, first.text
    job = _wait(bare, first.json()["id"])
    assert job["state"] == "done", job
    result = job["result"]
    assert result["cameras"] == 12 and result["points"] > 500 and result["points_source"] == "triangulated"
    assert (result["image_width"], result["image_height"]) == (320, 240)
    state = {k: result["start"][k] for k in ("region", "li", "lj")}
    pair = bare.post(f"/api/stereospace/{job['id']}/pair", json={"state": state, "format": "anaglyph", "width": 160})
    assert pair.status_code == 200, pair.text
    moved = bare.post(f"/api/stereospace/{job['id']}/move", json={"state": state, "pan": result["pan_step"]})
    assert moved.status_code == 200 and moved.json()["event"] in ("moved", "jumped", "stopped")
    again = bare.post("/api/jobs/stereospace", json={"collection": "collection:tabletop", "grid_step": 16})
    assert again.status_code == 200 and again.json()["cached"] is True
