"""The twins of the commands that read files (issue 13): ids instead of paths, outputs in a temporary folder.

``POST /api/match`` with two upload ids answers what ``vergence match LEFT RIGHT --out F --json``
prints on the same files, with the files named as the client knows them (an input by its id, an
output by its name); a data id stands for a listed file; unknown ids are 404, bad options 422 in the
command's words, and no server path is ever in an answer.
"""

from __future__ import annotations

import io
import json
import warnings
from contextlib import redirect_stdout

import numpy as np
import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.web import create_app
from web_checks import refused as _refused

SHIFT = 6  # px: the right view is the left one moved left by SHIFT (x_left - x_right = SHIFT)


def _png(array: np.ndarray) -> bytes:
    import cv2

    ok, data = cv2.imencode(".png", array)
    assert ok
    return data.tobytes()


@pytest.fixture(scope="module")
def pair() -> tuple[bytes, bytes]:
    import cv2

    rng = np.random.default_rng(5)
    texture = cv2.resize((rng.random((40, 60)) * 255).astype(np.uint8), (240, 160), interpolation=cv2.INTER_NEAREST)
    return _png(texture[:, :200]), _png(texture[:, SHIFT:200 + SHIFT])


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    data = tmp_path_factory.mktemp("data")
    # a Middlebury camera file of two cameras looking down z, 0.1 apart (name K R t per line)
    (data / "two_par.txt").write_text("2\nl.png 100 0 100 0 100 80 0 0 1 1 0 0 0 1 0 0 0 1 0 0 0\n"
                                      "r.png 100 0 100 0 100 80 0 0 1 1 0 0 0 1 0 0 0 1 -0.1 0 0\n")
    with TestClient(create_app([data]), base_url="http://127.0.0.1") as c:
        yield c


def _upload(client, content: bytes, content_type: str = "image/png", name: str = "") -> str:
    response = client.post(f"/api/uploads?name={name}", content=content, headers={"Content-Type": content_type})
    assert response.status_code == 201, response.text
    return response.json()["id"]


def test_every_command_that_prints_json_has_its_twin(client):
    assert sorted(client.app.state.twins) == ["analyze", "budget", "compare", "evaluate-disparity", "interpolate",
                                              "mapping", "match", "rectify", "rig/plan", "synthesize"]
    fields = client.app.state.twins["match"].model.model_fields
    assert {"left", "right", "mask", "max_disparity"} <= set(fields) and "out" not in fields
    assert "preview" not in fields and "confidence" not in fields
    # a folder and a text side file: no id stands for them, so no field (the work takes its default)
    assert "masks" not in client.app.state.twins["evaluate-disparity"].model.model_fields
    assert "image_list" not in client.app.state.twins["rectify"].model.model_fields
    assert "upload" in fields["left"].description and "Command line: the argument LEFT." in fields["left"].description


def test_match_twin_answers_what_the_command_prints_on_the_same_files(client, pair, tmp_path):
    from vergence.cli import main

    left, right = (_upload(client, png) for png in pair)
    response = client.post("/api/match", json={"left": left, "right": right, "max_disparity": 16})
    assert response.status_code == 200, response.text
    answer = response.json()
    uploads = client.app.state.uploads
    out = io.StringIO()
    with redirect_stdout(out):
        code = main(["match", str(uploads.get(left).path), str(uploads.get(right).path), "--max-disparity=16",
                     f"--out={tmp_path / 'disparity.pfm'}", "--json"])
    assert code == 0
    expected = json.loads(out.getvalue())
    assert answer["left"] == left and answer["right"] == right and answer["out"] == "disparity.pfm"
    for key in ("left", "right", "out", "seconds"):
        expected.pop(key), answer.pop(key)
    assert answer == expected
    assert expected["disparity_max"] >= SHIFT - 1
    assert client.app.state.workdir.as_posix() not in response.text


def test_a_data_id_stands_for_its_file_and_an_upload_keeps_its_name(client, pair):
    """rectify finds each image's camera by file name: the uploads are seen as l.png and r.png, the
    camera file is a collection of the data folder chosen by its id."""
    cameras = next(e["id"] for e in client.get("/api/data").json()["collections"] if e["name"] == "two_par.txt")
    left = _upload(client, pair[0], name="l.png")
    right = _upload(client, pair[1], name="r.png")
    response = client.post("/api/rectify", json={"left": left, "right": right, "cameras": cameras})
    assert response.status_code == 200, response.text
    answer = response.json()
    assert answer["left"] == "l.png" and answer["right"] == "r.png"  # rectify prints the images' names
    assert answer["left_camera"]["K"][0][0] > 0
    assert client.app.state.workdir.as_posix() not in response.text and "vergence-twin-" not in response.text
    # named otherwise, the image has no camera: the command says so, naming the id
    other = _upload(client, pair[0], name="zz.png")
    error = _refused(client.post("/api/rectify", json={"left": other, "right": right, "cameras": cameras}), 422)
    assert "no camera named 'zz.png'" in error
    # a name that is a path is not used (the stored file keeps its own name)
    sneaky = _upload(client, pair[0], name="../l.png")
    error = _refused(client.post("/api/rectify", json={"left": sneaky, "right": right, "cameras": cameras}), 422)
    assert "no camera named" in error and ".." not in error.split("no camera named")[1].split(";")[0]


@pytest.mark.parametrize(("path", "body", "status", "message"), [
    ("/api/match", {"left": "nope", "right": "nope", "max_disparity": 16}, 404,
     "unknown id 'nope': neither an upload (POST /api/uploads) nor a data entry (GET /api/data)"),
    ("/api/match", {"left": "scene:glasses", "right": "scene:glasses", "max_disparity": 16}, 404,
     "'scene:glasses' is a built-in scene, not a file"),
    ("/api/match", {"left": "/etc/passwd", "right": "../x.png", "max_disparity": 16}, 404, "unknown id '/etc/passwd'"),
    ("/api/match", {"right": "x", "max_disparity": 16}, 422, "missing field left"),
    ("/api/match", {"left": "x", "right": "x", "max_disparity": 16, "out": "/tmp/x.pfm"}, 422, "unknown field 'out'"),
    ("/api/synthesize", {"image": "x", "depth": "x", "preview": "p.png"}, 422, "unknown field 'preview'"),
    ("/api/rig", {}, 404, "vergence rig is a group: POST to its commands' twins: /api/rig/plan"),
])
def test_refusals(client, path, body, status, message):
    assert message in _refused(client.post(path, json=body), status)


def test_the_work_refuses_naming_the_field_and_no_server_path(client, pair):
    left = _upload(client, pair[0])
    small = _upload(client, _png(np.zeros((10, 10), np.uint8)))
    error = _refused(client.post("/api/match", json={"left": left, "right": small, "max_disparity": 16}), 422)
    assert "size" in error or "shape" in error or "same" in error, error
    assert client.app.state.workdir.as_posix() not in error
    error = _refused(client.post("/api/match", json={"left": left, "right": left, "max_disparity": -3}), 422)
    assert error.startswith("max_disparity ") and "--" not in error  # the field, not the command line's option


def test_the_temporary_outputs_are_removed(client, pair):
    root = client.app.state.workdir / "twins"
    left, right = (_upload(client, png) for png in pair)
    assert client.post("/api/match", json={"left": left, "right": right, "max_disparity": 16}).status_code == 200
    assert root.is_dir() and list(root.iterdir()) == []
