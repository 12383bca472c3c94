"""The workbench against an attacker on the same machine (issue 29): a foreign Host (DNS rebinding),
a foreign Origin or a body not sent as JSON on every state-changing route, links out of the data
folders and link loops, control characters in names, server paths in answers, and the token of a
server other machines reach. Each test fails when its rule is taken out of :mod:`vergence.web._guard`,
:mod:`vergence.web.data` or the routes."""

from __future__ import annotations

import http.client
import json
import os
import re
import shutil
import socket
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.web import create_app
from vergence.web._guard import TOKEN_COOKIE, host_allowed
from web_checks import refused, wait_job

LOCAL = "http://127.0.0.1"
FOREIGN = "http://rebind.attacker.example"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
BUDGET = {"baseline": 0.12, "convergence": 8, "window": 2.4, "display": "desktop-24", "depth": [4, 8]}
RENDER = {"scene": "scene:tabletop", "width": 8, "height": 6, "depth": 0, "samples": 1}
MOVE = {"state": {"region": [0, 0], "li": 0.0, "lj": 1.0}, "pan": 0.1, "zoom": 0.0}
PAIR = {"state": {"region": [0, 0], "li": 0.0, "lj": 1.0}, "format": "anaglyph", "width": 64}
# Every family of state-changing route, with a body it would accept: a twin, a twin's fallback, a job,
# the rig planner, the StereoSpace follow-ups, and a job's cancellation.
POSTS = [("/api/budget", BUDGET), ("/api/no-such-command", {}), ("/api/jobs/render", RENDER),
         ("/api/rigs/plan", {"rig": "parallel"}), ("/api/stereospace/0123456789abcdef/move", MOVE),
         ("/api/stereospace/0123456789abcdef/pair", PAIR)]
ROUTE_IDS = [path.split("/")[2] + ("/" + path.rsplit("/", 1)[1] if "stereospace" in path else "") for path, _ in POSTS]


def _png() -> bytes:
    import io

    from PIL import Image

    buffer = io.BytesIO()
    Image.new("L", (2, 2), 128).save(buffer, format="PNG")
    return buffer.getvalue()


PNG = _png()


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(), base_url=LOCAL) as c:
        yield c


def _no_jobs(client) -> bool:  # noqa: ANN001
    return client.get("/api/jobs").json()["jobs"] == []


# ------------------------------------------------------------------------------------- Host
@pytest.mark.parametrize("method, path", [("GET", "/"), ("GET", "/static/common.js"), ("GET", "/api/health"),
                                          ("GET", "/api/data"), ("GET", "/api/jobs"), ("GET", "/openapi.json"),
                                          ("POST", "/api/budget"), ("POST", "/api/jobs/render")])
def test_a_foreign_host_is_refused_on_every_path(method, path):
    with TestClient(create_app(), base_url=LOCAL) as c:
        body = {"json": BUDGET if path == "/api/budget" else RENDER} if method == "POST" else {}
        message = refused(c.request(method, path, headers={"host": "rebind.attacker.example"}, **body), 400)
        assert message == ("Host 'rebind.attacker.example' is not served here; this workbench answers to localhost, "
                           "127.0.0.1, [::1] (a foreign name is how DNS rebinding reaches a local server)")
        assert _no_jobs(c)
        assert c.request(method, path, **body).status_code in (200, 202)  # the same request on Host 127.0.0.1


@pytest.mark.parametrize("host", ["localhost", "LOCALHOST", "localhost.", "127.0.0.1", "127.3.2.1", "[::1]"])
def test_the_loopback_names_are_served_with_any_port(client, host):
    for shown in (host, f"{host}:8765"):
        assert client.get("/api/health", headers={"host": shown}).status_code == 200


@pytest.mark.parametrize("host", ["127.0.0.1.attacker.example", "localhost.attacker.example", "0.0.0.0", "10.0.0.1",
                                  "", "attacker.example:80@127.0.0.1"])
def test_names_that_look_local_are_not(client, host):
    refused(client.get("/api/health", headers={"host": host}), 400)


def test_the_bound_host_is_served_and_all_interfaces_admit_ip_addresses_only():
    assert host_allowed("192.168.1.5", ["192.168.1.5"]) and not host_allowed("192.168.1.6", ["192.168.1.5"])
    assert host_allowed("myhost.lan", ["myhost.lan"]) and not host_allowed("myhost.lan", ["192.168.1.5"])
    assert host_allowed("192.168.1.6", ["0.0.0.0"]) and host_allowed("fe80::1", ["::"])
    assert not host_allowed("rebind.attacker.example", ["0.0.0.0", "::"])
    with TestClient(create_app(allowed_hosts=["192.168.1.5", "127.0.0.1"]), base_url="http://192.168.1.5:8765") as c:
        assert c.get("/api/health").status_code == 200
        assert c.get("/api/health", headers={"host": "127.0.0.1"}).status_code == 200
        assert refused(c.get("/api/health", headers={"host": "192.168.1.6"}), 400) == (
            "Host '192.168.1.6' is not served here; this workbench answers to localhost, 127.0.0.1, [::1], "
            "192.168.1.5 (a foreign name is how DNS rebinding reaches a local server)")


def test_the_data_label_replaces_a_data_folder_but_not_the_disk(tmp_path, monkeypatch):
    import vergence.web.data as data

    monkeypatch.setattr(data, "MAX_DATA_FILES", 10)  # --data / walks the disk: a few files suffice here
    assert data.DataIndex([tmp_path]).redact(f"cannot read {tmp_path}/a.png") == "cannot read <data>/a.png"
    assert data.DataIndex(["/"]).redact("cannot read /etc/a.png") == "cannot read /etc/a.png"


# ----------------------------------------------------------------------------------- Origin
@pytest.mark.parametrize("origin", ["http://evil.example", "http://127.0.0.1:9999", "https://127.0.0.1",
                                    "null", "http://127.0.0.1.evil.example"])
@pytest.mark.parametrize("path, body", POSTS, ids=ROUTE_IDS)
def test_a_foreign_origin_is_refused_on_every_post_route(client, path, body, origin):
    response = client.post(path, json=body, headers={"origin": origin})
    assert refused(response, 403) == (f"POST from Origin {origin!r} refused: only the workbench's own page "
                                      "(http://127.0.0.1) may change its state")
    assert _no_jobs(client)
    # the same request from the page itself (its own Origin, or none: not a browser) reaches the route
    for headers in ({"origin": LOCAL}, {}):
        assert client.post(path, json={**body, "width": 0} if "jobs" in path else body,
                           headers=headers).status_code not in (400, 403, 415)


def test_a_foreign_origin_is_refused_on_delete_and_uploads(client):
    for origin in ("http://evil.example", "http://localhost"):  # localhost is another origin than 127.0.0.1
        refused(client.delete("/api/jobs/0123456789abcdef", headers={"origin": origin}), 403)
        refused(client.post("/api/uploads", content=PNG, headers={"origin": origin, "content-type": "image/png"}),
                403)
    assert client.delete("/api/jobs/0123456789abcdef", headers={"origin": LOCAL}).status_code == 404
    assert client.post("/api/uploads", content=PNG, headers={"origin": LOCAL, "content-type": "image/png"}
                       ).status_code == 201


@pytest.mark.parametrize("site, status", [("cross-site", 403), ("same-site", 403), ("same-origin", 200)])
def test_sec_fetch_site_from_another_site_is_refused(client, site, status):
    response = client.post("/api/budget", json=BUDGET, headers={"sec-fetch-site": site})
    assert response.status_code == status, response.text
    if status == 403:
        assert refused(response, 403).startswith(f"POST from another site refused (Sec-Fetch-Site: {site})")


def test_reading_is_not_refused_for_an_origin(client):
    # a GET changes nothing, and without CORS headers the other site cannot read the answer
    assert client.get("/api/health", headers={"origin": "http://evil.example"}).status_code == 200


# ----------------------------------------------------------------------------- Content-Type
@pytest.mark.parametrize("content_type", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data",
                                          None])
@pytest.mark.parametrize("path, body", POSTS, ids=ROUTE_IDS)
def test_a_body_not_sent_as_json_is_415_on_every_post_route(client, path, body, content_type):
    headers = {} if content_type is None else {"content-type": content_type}
    response = client.post(path, content=json.dumps(body), headers=headers)
    shown = "none" if content_type is None else repr(content_type)
    assert refused(response, 415) == f"Content-Type must be application/json on POST {path}; got {shown}"
    assert _no_jobs(client)
    sent = {**body, "width": 0} if "jobs" in path else body  # refused by the route: no job runs
    ok = client.post(path, content=json.dumps(sent), headers={"content-type": "application/json; charset=utf-8"})
    assert ok.status_code not in (400, 403, 415)


def test_an_empty_post_without_content_type_starts_no_job(client):
    # what a no-cors fetch from another page sends: the job's defaults would otherwise run
    for kind in ("render", "stereo", "specular", "stereospace", "rig"):
        refused(client.post(f"/api/jobs/{kind}"), 415)
    assert _no_jobs(client)


def test_an_upload_keeps_its_own_list_of_types(client):
    for content_type in ("text/plain", "application/json", None):
        headers = {} if content_type is None else {"content-type": content_type}
        assert refused(client.post("/api/uploads", content=PNG, headers=headers), 415).startswith(
            "Content-Type must be one of image/png, image/jpeg, image/x-portable-floatmap, application/octet-stream")
    assert client.post("/api/uploads", content=PNG, headers={"content-type": "image/png"}).status_code == 201


def test_the_pages_send_json_on_every_post():
    from vergence.web.app import STATIC_DIR

    scripts = [STATIC_DIR / "common.js", *sorted((STATIC_DIR / "pages").glob("*.js"))]
    for script in scripts:
        text = script.read_text()
        for call in re.finditer(r"fetch\(([^;]*?)\);", text, re.S):
            options = call.group(1)
            if '"POST"' in options or "'POST'" in options:
                assert '"Content-Type"' in options, f"{script.name}: a POST without a Content-Type: {options}"
    common = (STATIC_DIR / "common.js").read_text()
    assert 'method: "POST", headers: { "Content-Type": "application/json" }' in common


# ------------------------------------------------------------------------------ data folders
def _collection(folder: Path, names: tuple[str, ...] = ("v0.png", "v1.png", "v2.png", "v3.png")) -> None:
    """A Bundler collection of small textured views on a line, its points seen by every camera."""
    from vergence.camera import look_at
    from vergence.io import CameraSet, write_bundler, write_image

    folder.mkdir(parents=True)
    cams = tuple(look_at([0.2 * i, 0, 0], [0.3, 0, 4], [0, -1, 0], fov_deg=60, width=64, height=48)
                 for i in range(len(names)))  # fmt: skip
    rng = np.random.default_rng(0)
    points = rng.uniform([-0.5, -0.3, 3.5], [1.1, 0.3, 4.5], (40, 3))
    obs = [(p, c, p) for p in range(len(points)) for c in range(len(cams))]
    pixels = [cams[c].project(points[p:p + 1])[0][0] for p, c, _ in obs]
    write_bundler(folder / "bundle.out", CameraSet(names=names, cameras=cams, points=points,
                                                   colors=np.full((len(points), 3), 128, np.uint8),
                                                   observations=np.array(obs), observation_pixels=np.array(pixels)))
    (folder / "list.txt").write_text("".join(f"{n}\n" for n in names))
    for n in names:
        write_image(folder / n, rng.uniform(0, 1, (48, 64, 3)).astype(np.float32))


@pytest.fixture
def hostile_tree(tmp_path):
    """A data folder with link loops, links to nothing, links out (files and a folder), scenes whose
    texture, .hdr map or mesh leads out, a COLMAP collection whose images.txt leads out, and beside
    them a valid scene and a valid collection whose view v1.png is a link out; the outside folder."""
    root, outside = tmp_path / "data", tmp_path / "outside"
    shutil.copytree(EXAMPLES / "assets", outside / "assets")
    shutil.copy(EXAMPLES / "textured_vase.json", outside / "scene.json")
    _collection(outside / "col")
    (outside / "images.txt").write_text("# Image list\n")
    root.mkdir()
    shutil.copytree(EXAMPLES / "assets", root / "assets")
    vase = json.loads((EXAMPLES / "textured_vase.json").read_text())
    (root / "vase.json").write_text(json.dumps(vase))
    os.symlink("loop-b", root / "loop-a")
    os.symlink("loop-a", root / "loop-b")
    os.symlink("self.json", root / "self.json")
    os.symlink(root / "nothing", root / "broken.json")
    os.symlink(outside / "scene.json", root / "out.json")
    os.symlink(outside, root / "out-folder")
    os.symlink(outside / "assets", root / "assets-out")
    changed = {"tex-absolute.json": ("materials", "tiles", str(outside / "assets" / "tiles.png")),
               "hdr-relative.json": ("environment", None, "../outside/assets/sky.hdr"),
               "mesh-linked.json": ("objects", 2, "assets-out/vase.obj")}
    for name, (section, key, value) in changed.items():
        scene = json.loads(json.dumps(vase))
        target = scene[section] if key is None else scene[section][key]
        target["hdr" if section == "environment" else "path"] = value
        (root / name).write_text(json.dumps(scene))
    (root / "colmap" / "sparse").mkdir(parents=True)
    (root / "colmap" / "sparse" / "cameras.txt").write_text("# Camera list\n")
    os.symlink(outside / "images.txt", root / "colmap" / "sparse" / "images.txt")
    _collection(root / "col")
    (root / "col" / "v1.png").unlink()
    os.symlink(outside / "col" / "v1.png", root / "col" / "v1.png")
    return root, outside


# Left out of the hostile tree, each counted once: loop-a, loop-b, self.json, broken.json (unreadable);
# out.json, colmap/sparse/images.txt, col/v1.png (links out); out-folder, assets-out (linked folders);
# tex-absolute.json, hdr-relative.json, mesh-linked.json (a file of the scene out); colmap/sparse/cameras.txt
# (its images.txt out).
HOSTILE_SKIPPED = 13


def test_a_data_folder_with_loops_and_links_out_lists_what_it_can(hostile_tree):
    root, outside = hostile_tree
    with TestClient(create_app([root]), base_url=LOCAL) as c:
        response = c.get("/api/data")
        assert response.status_code == 200, response.text
        listed = response.json()
        assert [e["name"] for e in listed["scenes"]] == ["glasses", "stadium", "tabletop", "vase.json"]
        assert [e["name"] for e in listed["collections"]][2:] == ["col/bundle.out"]
        assert listed["skipped"] == HOSTILE_SKIPPED
        assert str(root.parent) not in response.text
        for entry in listed["scenes"] + listed["collections"]:
            assert c.get(f"/api/data/{entry['id']}").json() == entry
        # the jobs still start (each looked an id up, which walked the folders on every request before)
        assert c.post("/api/jobs/render", json=RENDER).status_code == 202
        vase = next(e["id"] for e in listed["scenes"] if e["name"] == "vase.json")
        assert c.post("/api/jobs/render", json={**RENDER, "scene": vase}).status_code == 202


def test_a_collection_whose_images_link_outside_leaves_them_out_unread(hostile_tree):
    root, outside = hostile_tree
    with TestClient(create_app([root]), base_url=LOCAL) as c:
        collection = next(e["id"] for e in c.get("/api/data").json()["collections"] if e["name"] == "col/bundle.out")
        started = c.post("/api/jobs/stereospace", json={"collection": collection, "grid_step": 16})
        assert started.status_code == 202, started.text
        job = wait_job(c, started.json()["id"], timeout=120)
        assert job["state"] == "done", job
        assert job["result"]["cameras"] == 3  # v0, v2, v3: v1 leads outside
        assert job["result"]["warnings"] == ["1 of the 4 cameras of bundle.out name an image that leads outside "
                                             "the data folder: left out, unread"]
        names = [cam["name"] for cam in c.get(f"/api/jobs/{job['id']}/files/map.json").json()["cameras"]]
        assert names == ["v0.png", "v2.png", "v3.png"]
        assert str(root.parent) not in json.dumps(job)


def test_a_collection_with_one_image_left_inside_fails_in_one_line_without_a_path(tmp_path):
    root, outside = tmp_path / "data", tmp_path / "outside"
    _collection(root / "col")
    _collection(outside / "col")
    for name in ("v1.png", "v2.png", "v3.png"):
        (root / "col" / name).unlink()
        os.symlink(outside / "col" / name, root / "col" / name)
    with TestClient(create_app([root]), base_url=LOCAL) as c:
        collection = next(e["id"] for e in c.get("/api/data").json()["collections"] if e["name"] == "col/bundle.out")
        job = wait_job(c, c.post("/api/jobs/stereospace", json={"collection": collection}).json()["id"], timeout=120)
        assert job["state"] == "failed"
        assert job["error"] == ("a collection needs at least two cameras with an image; bundle.out has 1 with its "
                                "image in the images folder of col/bundle.out (3 more lead outside the data folder)")


def test_a_link_loop_at_the_top_of_a_listing_does_not_break_the_index(tmp_path, monkeypatch):
    import vergence.web.data as data

    root = tmp_path / "data"
    root.mkdir()
    os.symlink(".", root / "here")  # a folder linked to itself: never followed
    os.symlink("a", root / "a")
    index = data.DataIndex([root])
    assert index.skipped == 2 and [e.kind for e in index.entries()] == ["scene"] * 3 + ["collection"] * 2
    # --data /: whatever sits there (devices, /proc, loops), the walk ends with a list
    monkeypatch.setattr(data, "MAX_DATA_FILES", 3000)
    assert len(data.DataIndex(["/"]).entries()) >= 5


def test_a_file_name_that_is_no_utf8_is_listed_with_a_replacement_character(tmp_path):
    # found by the sweep (tools/sweep web): one such name made GET /api/data answer 500 (JSON has no surrogates)
    root = tmp_path / "data"
    root.mkdir()
    (root / os.fsdecode(b"name-\xff_par.txt")).write_text("2\nl.png 100 0 100 0 100 80 0 0 1 1 0 0 0 1 0 0 0 1 0 0 0\n"
                                                       "r.png 100 0 100 0 100 80 0 0 1 1 0 0 0 1 0 0 0 1 -0.1 0 0\n")
    with TestClient(create_app([root]), base_url=LOCAL) as c:
        response = c.get("/api/data")
        assert response.status_code == 200, response.text
        entry = next(e for e in response.json()["collections"] if e["format"] == "middlebury")
        assert entry["name"] == "name-\ufffd_par.txt"
        assert c.get(f"/api/data/{entry['id']}").json() == entry


def test_the_index_is_walked_once_and_again_on_demand(tmp_path, monkeypatch):
    import vergence.web.data as data

    root = tmp_path / "data"
    root.mkdir()
    walks = []
    real = data.DataIndex._search
    monkeypatch.setattr(data.DataIndex, "_search", lambda self, r: walks.append(r) or real(self, r))
    index = data.DataIndex([root])
    assert len(walks) == 1
    for _ in range(3):
        index.get("scene:tabletop")
    assert len(walks) == 1  # an id it knows: no walk
    (root / "room.json").write_text((EXAMPLES / "spheres_and_mirror.json").read_text())
    new = data._id("scene", (root / "room.json").resolve())
    assert index.get(new).name == "room.json" and len(walks) == 2  # an unknown id: one walk
    (root / "room.json").write_text("{not json")
    with pytest.raises(KeyError):
        index.get(new)  # its file changed: walked again, no longer a scene
    assert len(walks) == 3
    index.refresh()
    assert len(walks) == 4


# ------------------------------------------------------------------------------ server paths
@pytest.mark.parametrize("name", ["a\x00b.png", "line\nbreak.png", "tab\there.png", "bell\x07.png", "del\x7f.png"])
def test_a_control_character_in_an_upload_name_is_422(client, name):
    response = client.post("/api/uploads", content=PNG, headers={"content-type": "image/png"},
                           params={"name": name})
    bad = next(ch for ch in name if ord(ch) < 32 or ord(ch) == 127)
    assert refused(response, 422) == (f"name must be printable text (a file name); got a control character "
                                      f"U+{ord(bad):04X} at position {name.index(bad)}")
    ok = client.post("/api/uploads", content=PNG, headers={"content-type": "image/png"},
                     params={"name": "a b é.png"})
    assert ok.status_code == 201 and ok.json()["name"] == "a b é.png"


def test_a_bug_names_no_server_path(tmp_path, monkeypatch):
    from vergence.web.data import DataIndex

    root = tmp_path / "data"
    root.mkdir()
    app = create_app([root])
    workdir = app.state.workdir

    def loop(self):  # noqa: ANN001, ANN202
        raise RuntimeError(f"Symlink loop from '{root}/a' seen in {workdir}/jobs")

    monkeypatch.setattr(DataIndex, "refresh", loop)
    with TestClient(app, base_url=LOCAL, raise_server_exceptions=False) as c:
        assert refused(c.get("/api/data"), 500) == ("internal error, please report it: RuntimeError: Symlink loop "
                                                    "from '<data>/a' seen in <workdir>/jobs")


def test_a_job_refusal_names_no_server_path(tmp_path):
    root = tmp_path / "data"
    shutil.copytree(EXAMPLES / "assets", root / "assets")
    (root / "assets" / "tiles.png").unlink()  # the scene is listed (its files stay inside) but cannot be opened
    shutil.copy(EXAMPLES / "textured_vase.json", root / "vase.json")
    with TestClient(create_app([root]), base_url=LOCAL, raise_server_exceptions=False) as c:
        vase = next(e["id"] for e in c.get("/api/data").json()["scenes"] if e["name"] == "vase.json")
        response = c.post("/api/jobs/render", json={**RENDER, "scene": vase})
        assert response.status_code in (422, 500)
        assert str(tmp_path) not in response.text and "<data>/assets/tiles.png" in response.text


# ------------------------------------------------------------------------------------ token
def test_a_token_is_required_on_every_request_when_set():
    app = create_app(token="s3cret-token")
    with TestClient(app, base_url=LOCAL) as c:
        for path in ("/", "/static/common.js", "/api/health", "/api/data"):
            assert refused(c.get(path), 401).startswith("this workbench needs its token")
        refused(c.post("/api/budget", json=BUDGET), 401)
        refused(c.get("/api/health", headers={"authorization": "Bearer wrong"}), 401)
        refused(c.get("/api/health?token=wrong"), 401)
        refused(c.get("/api/health", headers={"cookie": f"{TOKEN_COOKIE}=wrong"}), 401)
        assert c.get("/api/health", headers={"authorization": "Bearer s3cret-token"}).status_code == 200
        first = c.get("/?token=s3cret-token")  # the URL vergence serve prints
        assert first.status_code == 200
        assert first.headers["set-cookie"] == f"{TOKEN_COOKIE}=s3cret-token; Path=/; HttpOnly; SameSite=Strict"
        assert c.get("/api/health").status_code == 200  # the cookie carries it now
        assert c.post("/api/budget", json=BUDGET).status_code == 200
    with TestClient(app, base_url=FOREIGN) as evil:  # the Host is judged first
        refused(evil.get("/api/health?token=s3cret-token"), 400)
    with TestClient(create_app(), base_url=LOCAL) as c:  # loopback serving: no token
        assert c.get("/api/health").status_code == 200


def test_serve_on_all_interfaces_prints_a_token_the_server_requires(capsys, monkeypatch):
    import uvicorn

    from vergence.cli import main

    served = []
    monkeypatch.setattr(uvicorn.Server, "run", lambda self, sockets=None: served.append(self.config.app))
    assert main(["serve", "--host", "0.0.0.0", "--port", "0", "--allow-remote"]) == 0
    m = re.fullmatch(r"Vergence workbench at http://0\.0\.0\.0:(\d+)/\?token=([\w-]{43}) \(Ctrl-C stops it\)\n",
                     capsys.readouterr().out)
    assert m is not None
    with TestClient(served[0], base_url="http://192.168.1.5") as c:
        refused(c.get("/api/health"), 401)
        assert c.get(f"/api/health?token={m[2]}").status_code == 200
        refused(c.get("/api/health", headers={"host": "rebind.attacker.example"}), 400)


# ------------------------------------------------------------------------------- real server
def test_uvicorn_on_a_real_port_refuses_a_foreign_host_and_origin():
    import uvicorn

    sock = socket.create_server(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(create_app(), log_level="warning", ws="none", lifespan="off"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()

    def ask(method: str, path: str, headers: dict[str, str], body: bytes | None = None) -> tuple[int, str]:
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        try:
            conn.putrequest(method, path, skip_host=True)
            for key, value in headers.items():
                conn.putheader(key, value)
            conn.putheader("Content-Length", str(len(body or b"")))
            conn.endheaders(body)
            response = conn.getresponse()
            return response.status, response.read().decode()
        finally:
            conn.close()

    try:
        deadline = time.monotonic() + 60
        while not server.started and thread.is_alive() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert server.started
        ours = {"Host": f"127.0.0.1:{port}"}
        for path in ("/", "/api/data"):
            status, text = ask("GET", path, {"Host": f"rebind.attacker.example:{port}"})
            assert status == 400 and json.loads(text)["error"].startswith("Host 'rebind.attacker.example:")
            assert ask("GET", path, ours)[0] == 200
        job = json.dumps(RENDER).encode()
        status, text = ask("POST", "/api/jobs/render", {**ours, "Origin": f"http://127.0.0.1:{port + 1}",
                                                        "Content-Type": "application/json"}, job)
        assert status == 403, text
        status, text = ask("POST", "/api/jobs/render", {**ours, "Content-Type": "text/plain"}, job)
        assert status == 415, text
        assert json.loads(ask("GET", "/api/jobs", ours)[1])["jobs"] == []
    finally:
        server.should_exit = True
        thread.join(30)
        sock.close()
    assert not thread.is_alive()
