"""The workbench's JSON API (issue 13): the twins answer exactly what the commands print, and every
refusal is one JSON line with its status (422 bad parameter, 404 unknown id or endpoint, 413 too large)."""

from __future__ import annotations

import json
import os
import socket
import threading
import time
import urllib.request
import warnings

import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    # Starlette >= 1.x asks for httpx2 and warns once, at import, when it finds httpx (the web extra's).
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.cli import main
from vergence.web import MAX_JSON_BODY, create_app
from web_checks import refused as _refused
from vergence.web.app import STATIC_DIR
from vergence.web.data import DataIndex

BUDGET = {"baseline": 0.12, "convergence": 8, "window": 2.4, "eye_separation": 0.063, "viewing_distance": 2.2,
          "screen_width": 1.1, "screen_pixels": 1280, "depth": [4, 8, 16, "inf"]}
BUDGET_ARGS = ["budget", "--baseline", "0.12", "--convergence", "8", "--window", "2.4", "--eye-separation", "0.063",
               "--viewing-distance", "2.2", "--screen-width", "1.1", "--screen-pixels", "1280",
               "--depth", "4", "--depth", "8", "--depth", "16", "--depth", "inf", "--json"]
MAPPING = {"reference_baseline": 0.65, "convergence": 30, "window": 3, "display": "tv-55",
           "constraint": ["z=30,perceived=3,roundness=1", "z=inf,perceived=inf"], "near": 12, "far": "inf",
           "depth": [15, 30, 80]}
MAPPING_ARGS = ["mapping", "--reference-baseline", "0.65", "--convergence", "30", "--window", "3", "--display", "tv-55",
                "--constraint", "z=30,perceived=3,roundness=1", "--constraint", "z=inf,perceived=inf",
                "--near", "12", "--far", "inf", "--depth", "15", "--depth", "30", "--depth", "80", "--json"]


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        yield c


@pytest.mark.parametrize("path, body, argv", [("/api/budget", BUDGET, BUDGET_ARGS),
                                              ("/api/mapping", MAPPING, MAPPING_ARGS)])
def test_a_twin_answers_exactly_what_the_command_prints(client, capsys, path, body, argv):
    assert main(argv) == 0
    printed = capsys.readouterr().out
    response = client.post(path, json=body)
    assert response.status_code == 200, response.text
    assert response.headers["content-type"] == "application/json"
    assert response.text == printed  # byte for byte, not only the same values
    assert response.json() == json.loads(printed)


def test_a_twin_with_defaults_and_a_preset_matches_too(client, capsys):
    assert main(["budget", "--baseline", "0.1", "--convergence", "3", "--window", "1", "--display", "tv-55",
                 "--json"]) == 0
    printed = capsys.readouterr().out
    response = client.post("/api/budget", json={"baseline": 0.1, "convergence": 3, "window": 1, "display": "tv-55"})
    assert response.text == printed


def test_a_request_reaches_the_work_as_the_command_line_does(monkeypatch):
    # the twin calls the library's work with the same values the command line passes it
    import vergence.commands.budget as work
    from vergence.web.twins import build_twins

    seen = []
    real = work.depth_budget
    monkeypatch.setattr(work, "depth_budget", lambda *a: seen.append(a) or real(*a))
    twin = build_twins(["budget"])["budget"]
    twin.run(twin.model(baseline=0.1, convergence=3.0, window=1.0, display="tv-55", depth=[1.0, "inf"]))
    assert main(["budget", "--baseline=0.1", "--convergence=3.0", "--window=1.0", "--display=tv-55", "--depth=1.0",
                 "--depth=inf", "--json"]) == 0
    assert len(seen) == 2 and seen[0] == seen[1]
    assert seen[0][2] == [1.0, float("inf")]


def test_a_twin_has_a_field_per_option_and_never_an_output_file():
    from vergence.web.twins import build_twins

    twins = build_twins(["budget", "mapping"])
    assert sorted(twins) == ["budget", "mapping"]
    assert list(twins["budget"].model.model_fields) == [
        "baseline", "convergence", "window", "focal_mm", "sensor_mm", "eye_separation", "viewing_distance",
        "screen_width", "screen_pixels", "display", "depth"]
    assert "plot" not in twins["mapping"].model.model_fields and "json" not in twins["mapping"].model.model_fields


@pytest.mark.parametrize("body, message", [
    ({**BUDGET, "baseline": "abc"}, "baseline: expected a number (got 'abc')"),
    ({**BUDGET, "baseline": True}, "baseline: expected a number (got True)"),
    ({**BUDGET, "screen_pixels": 1.5}, "screen_pixels: expected a whole number (got 1.5)"),
    ({**BUDGET, "depth": [1, "x"]}, "depth[1]: expected a number (got 'x')"),
    ({**BUDGET, "depth": 3}, "depth: expected a list (got 3)"),
    ({**BUDGET, "display": 55}, "display: expected text (got 55)"),
    ({k: v for k, v in BUDGET.items() if k != "baseline"}, "missing field baseline"),
    ({**BUDGET, "plot": "/tmp/x.png"}, "unknown field 'plot'; valid fields: baseline, convergence, window, "
     "focal_mm, sensor_mm, eye_separation, viewing_distance, screen_width, screen_pixels, display, depth"),
    ([1, 2], "the body must be a JSON object of options; got list"),
    # the work's own checks, naming the JSON fields (the command line names its options)
    ({**BUDGET, "baseline": -1}, "baseline must be > 0; got -1"),
    ({**BUDGET, "display": "tv-55"}, "give either display or the display lengths, not both (got display and "
     "eye_separation, viewing_distance, screen_width)"),
    ({**BUDGET, "display": ""}, "display: must not be empty"),
])
def test_bad_parameters_are_422_with_one_line(client, body, message):
    assert _refused(client.post("/api/budget", json=body), 422) == message


def test_mapping_refusals_name_the_field_or_option(client):
    missing = {k: v for k, v in MAPPING.items() if k != "constraint"}
    assert _refused(client.post("/api/mapping", json=missing), 422) == "missing field constraint"
    assert _refused(client.post("/api/mapping", json={**MAPPING, "near": 90, "far": 80}), 422) == \
        "far must be > near 90; got 80"


def test_a_body_that_is_not_json_is_422_and_one_not_sent_as_json_415(client):
    bad = client.post("/api/budget", content=b"{baseline", headers={"content-type": "application/json"})
    assert _refused(bad, 422).startswith("the body is not valid JSON")
    empty = client.post("/api/budget", headers={"content-type": "application/json"})
    assert _refused(empty, 422) == "the body is missing: send the options as a JSON object"
    # another site's page can send these without asking first (tests/web/test_security.py)
    assert _refused(client.post("/api/budget"), 415) == \
        "Content-Type must be application/json on POST /api/budget; got none"
    plain = client.post("/api/budget", content=json.dumps(BUDGET), headers={"content-type": "text/plain"})
    assert _refused(plain, 415) == "Content-Type must be application/json on POST /api/budget; got 'text/plain'"


def test_a_body_over_the_limit_is_413_declared_or_streamed(client):
    big = json.dumps({**BUDGET, "depth": [1.0] * (MAX_JSON_BODY // 4)}).encode()
    assert len(big) > MAX_JSON_BODY
    message = _refused(client.post("/api/budget", content=big, headers={"content-type": "application/json"}), 413)
    assert message == f"request body too large: {len(big)} bytes; the limit is {MAX_JSON_BODY} bytes (MAX_JSON_BODY)"

    def chunks():  # no Content-Length: counted as it arrives
        for i in range(0, len(big), 65536):
            yield big[i:i + 65536]

    streamed = client.post("/api/budget", content=chunks(), headers={"content-type": "application/json"})
    assert _refused(streamed, 413).startswith(f"request body too large: more than {MAX_JSON_BODY} bytes")
    # just under the limit is read and judged on its content
    fits = json.dumps({**BUDGET, "depth": [1.0] * 1000}).encode()
    assert client.post("/api/budget", content=fits, headers={"content-type": "application/json"}).status_code == 200


def test_unknown_commands_and_endpoints_are_404(client):
    assert _refused(client.post("/api/no-such-command", json={}), 404).startswith(
        "no command 'no-such-command' has a JSON twin; twins: analyze, budget, compare, ")
    assert _refused(client.get("/no/such/page"), 404) == "no such page or endpoint: GET /no/such/page"
    assert _refused(client.get("/api/budget"), 405) == \
        "GET is not allowed on /api/budget: POST its options as a JSON object"
    assert _refused(client.get("/api/no-such-thing"), 404) == "no such page or endpoint: GET /api/no-such-thing"
    assert _refused(client.put("/api/budget", json=BUDGET), 405) == "PUT is not allowed on /api/budget"


def test_twins_called_at_once_each_get_their_own_answer(capsys):
    # the twins call the library side by side (no lock): each answer is its own request's
    from concurrent.futures import ThreadPoolExecutor

    from vergence.web.twins import build_twins

    twin = build_twins(["budget"])["budget"]
    baselines = [0.05 + 0.01 * i for i in range(8)]
    expected = []
    for b in baselines:
        assert main([*BUDGET_ARGS[:2], repr(b), *BUDGET_ARGS[3:]]) == 0
        expected.append(capsys.readouterr().out)
    with ThreadPoolExecutor(4) as pool:
        answers = list(pool.map(lambda b: twin.run(twin.model(**{**BUDGET, "baseline": b})), baselines))
    assert answers == expected


def test_a_bug_is_a_one_line_500(monkeypatch):
    import vergence.commands.budget as budget_work
    from vergence.web.data import DataIndex as Index

    def boom(*args, **kwargs):
        raise RuntimeError("kaboom")

    monkeypatch.delenv("VERGENCE_DEBUG", raising=False)
    monkeypatch.setattr(budget_work, "depth_budget", boom)  # inside the command's work
    app = create_app()
    monkeypatch.setattr(Index, "refresh", boom)  # in the server itself (GET /api/data walks the folders again)
    with TestClient(app, raise_server_exceptions=False, base_url="http://127.0.0.1") as c:
        assert _refused(c.post("/api/budget", json=BUDGET), 500) == \
            "internal error, please report it: RuntimeError: kaboom"
        assert _refused(c.get("/api/data"), 500) == "internal error, please report it: RuntimeError: kaboom"


def test_health_and_displays(client):
    from vergence import __version__
    from vergence.viewing import DISPLAY_PRESETS

    health = client.get("/api/health").json()
    assert {k: health[k] for k in ("status", "version")} == {"status": "ok", "version": __version__}
    assert health["kernels"]["state"] == "cold"  # the test app warms nothing (create_app(warm_kernels=False))
    shown = client.get("/api/displays").json()["displays"]
    assert [d["name"] for d in shown] == sorted(DISPLAY_PRESETS)
    for d in shown:
        preset = DISPLAY_PRESETS[d["name"]]
        assert d == {"name": d["name"], "eye_separation": preset.eye_separation, "distance": preset.distance,
                     "width": preset.width, "resolution": preset.resolution}


def test_no_cors_headers(client):
    response = client.get("/api/health", headers={"origin": "http://example.com"})
    assert not any(h.lower().startswith("access-control-") for h in response.headers)


def test_the_page_is_served_at_the_root(client):
    if not (STATIC_DIR / "index.html").is_file():
        pytest.skip("src/vergence/web/static/index.html is not in this tree")
    response = client.get("/")
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/html")
    assert response.content == (STATIC_DIR / "index.html").read_bytes()


def test_the_page_folder_is_served_and_nothing_beside_it(monkeypatch, tmp_path):
    import vergence.web.app as web_app

    static = tmp_path / "static"
    static.mkdir()
    (static / "index.html").write_text("<!doctype html><title>workbench</title>")
    (static / "app.js").write_text("// the page")
    (tmp_path / "secret.txt").write_text("not for the client")
    os.symlink(tmp_path / "secret.txt", static / "link.txt")
    monkeypatch.setattr(web_app, "STATIC_DIR", static)
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        assert c.get("/").text == "<!doctype html><title>workbench</title>"
        assert c.get("/static/app.js").text == "// the page"
        for path in ("/static/../secret.txt", "/static/%2e%2e/secret.txt", "/static/link.txt", "/static/nope.js"):
            assert "not for the client" not in _refused(c.get(path), 404)


def test_the_openapi_schema_documents_each_twin_field(client):
    schema = client.get("/openapi.json").json()
    post = schema["paths"]["/api/budget"]["post"]
    ref = post["requestBody"]["content"]["application/json"]["schema"]["$ref"]
    model = schema["components"]["schemas"][ref.rsplit("/", 1)[1]]
    assert model["required"] == ["baseline", "convergence"]
    assert model["additionalProperties"] is False
    assert model["properties"]["baseline"]["description"] == "Camera baseline b (m). Command line: --baseline."
    assert "Viewing distance H' (m)." in model["properties"]["viewing_distance"]["description"]
    assert {"422", "413"} <= set(post["responses"])
    assert "/api/mapping" in schema["paths"] and "/api/displays" in schema["paths"]


# -- data folders ------------------------------------------------------------------------------------

SCENE = {"camera": {}, "environment": {}, "materials": {}, "objects": []}


@pytest.fixture
def data_tree(tmp_path):
    """A data folder with a scene, three collections and links out of it; a secret folder beside it."""
    root, secret = tmp_path / "data", tmp_path / "secret"
    (root / "bundle").mkdir(parents=True)
    (root / "bundle" / "bundle.out").write_text("# Bundle file v0.3\n0 0\n")
    (root / "colmap" / "sparse").mkdir(parents=True)
    (root / "colmap" / "sparse" / "cameras.txt").write_text("# Camera list\n")
    (root / "colmap" / "sparse" / "images.txt").write_text("# Image list\n")
    (root / "dino").mkdir()
    (root / "dino" / "dino_par.txt").write_text("1\nimg.png " + " ".join(["1"] * 21) + "\n")
    (root / "room.json").write_text(json.dumps(SCENE))
    (root / "notes.json").write_text(json.dumps({"not": "a scene"}))
    (root / "fake.out").write_text("not a bundle file\n")
    secret.mkdir()
    (secret / "scene.json").write_text(json.dumps(SCENE))
    (secret / "bundle.out").write_text("# Bundle file v0.3\n0 0\n")
    os.symlink(secret / "scene.json", root / "linked.json")
    os.symlink(secret, root / "linked-folder")
    os.symlink(secret / "bundle.out", root / "bundle" / "linked.out")
    return root, secret


def test_data_lists_collections_and_scenes_by_id(data_tree):
    root, _ = data_tree
    with TestClient(create_app([root]), base_url="http://127.0.0.1") as c:
        listed = c.get("/api/data").json()
        collections = {e["name"]: e for e in listed["collections"]}
        assert {n: e["format"] for n, e in collections.items()} == {
            "tabletop (rendered: 12 views on an arc)": "builtin", "stadium (rendered: 12 views on an arc)": "builtin",
            "bundle/bundle.out": "bundler", "colmap/sparse/cameras.txt": "colmap", "dino/dino_par.txt": "middlebury"}
        assert [e["id"] for e in listed["collections"][:2]] == ["collection:tabletop", "collection:stadium"]
        scenes = {e["name"]: e for e in listed["scenes"]}
        assert list(scenes)[:3] == ["glasses", "stadium", "tabletop"] and scenes["glasses"]["id"] == "scene:glasses"
        assert set(scenes) == {"glasses", "stadium", "tabletop", "room.json"}
        for entry in [*collections.values(), *scenes.values()]:
            assert set(entry) == {"id", "kind", "name", "format"}  # no path leaves the server
            assert str(root) not in json.dumps(entry)
            assert c.get(f"/api/data/{entry['id']}").json() == entry


def test_links_out_of_the_data_folder_are_neither_listed_nor_accepted(data_tree):
    from vergence.web.data import _id

    root, secret = data_tree
    index = DataIndex([root])
    paths = {e.path for e in index.entries() if e.path is not None}
    assert all(p.is_relative_to(root) for p in paths)
    assert not any("linked" in e.name for e in index.entries())
    with TestClient(create_app([root]), base_url="http://127.0.0.1") as c:
        for outside in (secret / "scene.json", secret / "bundle.out"):
            kind = "scene" if outside.suffix == ".json" else "collection"
            forged = _id(kind, outside.resolve())  # the id it would have had, were it inside
            assert _refused(c.get(f"/api/data/{forged}"), 404) == \
                f"unknown data id {forged!r}; GET /api/data lists the ids"


@pytest.mark.parametrize("entry_id", ["..", "..%2Fsecret%2Fscene.json", "%2Fetc%2Fpasswd", "room.json",
                                      "scene:..%2F..%2Fetc%2Fpasswd", "scene:nope"])
def test_paths_as_ids_are_404(data_tree, entry_id):
    root, _ = data_tree
    with TestClient(create_app([root]), base_url="http://127.0.0.1") as c:
        _refused(c.get(f"/api/data/{entry_id}"), 404)


def test_a_missing_data_folder_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"^data folder .*nope does not exist$"):
        create_app([tmp_path / "nope"])
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match=r"^data folder .*file is not a folder$"):
        create_app([tmp_path / "file"])


# -- the real server -----------------------------------------------------------------------------------

def test_uvicorn_serves_the_api_on_a_free_port():
    import uvicorn

    sock = socket.create_server(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(create_app(), log_level="warning", ws="none"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        deadline = time.monotonic() + 60
        while not server.started and thread.is_alive() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert server.started
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=30) as response:
            assert response.status == 200
            assert json.load(response)["status"] == "ok"
    finally:
        server.should_exit = True
        thread.join(30)
        sock.close()
    assert not thread.is_alive()


def test_twins_are_built_from_any_command_definition(tmp_path):
    # a command of our own: a flag, a repeatable parameter, an input file, outputs (never fields),
    # a parameter the web does not expose
    from vergence.commands import Command, Parameter
    from vergence.web.twins import twin_of

    calls = []

    class Result:
        def __init__(self, values):
            self.values = values

        def to_dict(self):
            return {k: str(v) for k, v in self.values.items()}

    def work(**values):
        calls.append(values)
        return Result(values)

    command = Command("fake", "Do nothing.", (
        Parameter("level", "integer", "A level."),
        Parameter("tag", "texts", "A tag; repeat.", None),
        Parameter("fast", "flag", "Go fast.", False),
        Parameter("image", "file", "An image, like {level}.", None),
        Parameter("folder", "file", "A folder.", None, web=False),
        Parameter("out", "output", "Written."),
        Parameter("plot", "output", "A figure.", None),
    ), work)
    twin = twin_of(command)
    assert list(twin.model.model_fields) == ["level", "tag", "fast", "image"]
    assert twin.reads_files
    assert twin.model.model_fields["image"].description.startswith("An image, like level. An id standing")
    assert twin.model.model_fields["level"].description == "A level. Command line: --level."
    stored = tmp_path / "stored.png"
    stored.write_bytes(b"x")
    answer = json.loads(twin.run(twin.model(level=3, tag=["a b", "--json"], fast=True, image="abc"),
                                 lambda ident: (stored, ident, "")))
    assert calls[-1]["level"] == 3 and calls[-1]["tag"] == ["a b", "--json"] and calls[-1]["fast"] is True
    assert calls[-1]["folder"] is None and calls[-1]["plot"] is None
    assert answer["image"] == "abc" and answer["out"] == "out"  # named as the client knows them
