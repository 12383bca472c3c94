"""Page 4 of the workbench (issue 13), "Rig planner": the presets, the plan (the twin of ``vergence rig plan
--json``), the ``rig`` render job and each refusal."""

from __future__ import annotations

import copy
import json
import warnings
from pathlib import Path

import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.cli import main
from vergence.rigs import EXAMPLE_SHOTS
from vergence.web import create_app
from web_checks import refused as _refused, wait_job
from vergence.web.job_kinds import MAX_RENDER_JOB_RAYS
from vergence.web.rigs_page import MAX_RIG_JOB_SIDE

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
SHOT_FILES = sorted((EXAMPLES / "shots").glob("*.json"))
WAIT_S = 300.0  # a handful of tiny renders; the first compiles Numba kernels
TINY = {"width": 48, "samples": 1, "supersample": 1}


def _wait(client, job_id: str) -> dict:
    return wait_job(client, job_id, timeout=WAIT_S)


@pytest.fixture(scope="module")
def client():
    """The app with the repository's examples as its data folder (the quarry scene and the shot files)."""
    with TestClient(create_app([EXAMPLES]), base_url="http://127.0.0.1") as c:
        yield c


def _cli(capsys, *args: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def _presets(client) -> dict[str, dict]:
    return {p["name"]: p for p in client.get("/api/rigs/shots").json()["shots"]}


# ---------------------------------------------------------------- presets


def test_presets_are_the_built_in_examples_without_a_data_folder():
    with TestClient(create_app(), base_url="http://127.0.0.1") as c:
        shots = c.get("/api/rigs/shots").json()["shots"]
    assert [(p["id"], p["name"], p["source"]) for p in shots] == [
        ("example:stadium-quadri", "stadium-quadri", "built-in"), ("example:stadium-tri", "stadium-tri", "built-in")]
    assert [p["shot"] for p in shots] == [EXAMPLE_SHOTS["stadium-quadri"], EXAMPLE_SHOTS["stadium-tri"]]


def test_presets_add_the_data_folders_shot_files_by_scene_id(client):
    presets = _presets(client)
    assert sorted(presets) == ["quarry-quadri", "quarry-tri", "stadium-quadri", "stadium-tri"]  # stadium: once
    scenes = {e["name"]: e["id"] for e in client.get("/api/data").json()["scenes"]}
    for name in ("quarry-quadri", "quarry-tri"):
        p = presets[name]
        assert p["source"] == "data" and p["id"].startswith("shot-")
        assert p["shot"]["scene"] == scenes["scenes/quarry/scene.json"]  # an id, never a path
        on_disk = json.loads((EXAMPLES / "shots" / f"{name}.json").read_text())
        assert {**on_disk, "scene": p["shot"]["scene"]} == p["shot"]


# ---------------------------------------------------------------- the plan: the twin of `vergence rig plan --json`


@pytest.mark.parametrize("path", SHOT_FILES, ids=[p.stem for p in SHOT_FILES])
def test_plan_is_what_rig_plan_json_prints(client, capsys, path):
    code, out, _ = _cli(capsys, "rig", "plan", str(path), "--json")
    assert code == 0
    expected = json.loads(out)
    assert expected["shot"] == str(path)
    body = _presets(client)[path.stem]["shot"]  # the quarry's scene by its data id
    answer = client.post("/api/rigs/plan", json=body)
    assert answer.status_code == 200, answer.text
    assert answer.json() == {**expected, "shot": None}  # no shot file on the server's side


def test_plan_follows_an_edited_field(client):
    shot = copy.deepcopy(EXAMPLE_SHOTS["stadium-quadri"])
    before = client.post("/api/rigs/plan", json=shot).json()
    shot["setback"] = 30.0
    after = client.post("/api/rigs/plan", json=shot).json()
    assert after["setback"] == 30.0 and after["cameras"][0]["fx_ratio"] > before["cameras"][0]["fx_ratio"]


def _bad_file(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(data))
    return path


def _with(data: dict, **changes) -> dict:
    out = copy.deepcopy(data)
    out.update(changes)
    return out


QUADRI, TRI = EXAMPLE_SHOTS["stadium-quadri"], EXAMPLE_SHOTS["stadium-tri"]
BAD_SHOTS = {
    "unknown key": _with(QUADRI, lens=35),
    "missing field": {k: v for k, v in QUADRI.items() if k != "setback"},
    "unknown rig": _with(QUADRI, rig="octo"),
    "wrong type": _with(QUADRI, baseline="wide"),
    "bad camera": _with(QUADRI, camera={**QUADRI["camera"], "fov_deg": 0.0}),
    "unknown display": _with(TRI, display="imax-9000"),
    "element behind the cameras": _with(QUADRI, elements=[{"name": "subject", "point": [0.0, 1.0, -10.0]}]),
    "constraints psi cannot meet": _with(TRI, constraints=["z=30,perceived=3,roundness=1", "z=65,perceived=2"]),
    "bad constraint": _with(TRI, constraints=["z=30,perceived=3,roundness=1", "z=sixty"]),
    "bad reference": _with(TRI, reference="square"),
}


@pytest.mark.parametrize("case", sorted(BAD_SHOTS))
def test_a_bad_shot_is_refused_with_the_line_rig_plan_gives(client, capsys, tmp_path, case):
    path = _bad_file(tmp_path, BAD_SHOTS[case])
    code, _, err = _cli(capsys, "rig", "plan", str(path), "--json")
    assert code == 2
    line = err.strip().removeprefix("error: ").removeprefix(f"shot file {path}: ")  # the CLI names its file
    assert _refused(client.post("/api/rigs/plan", json=BAD_SHOTS[case]), 422) == line


def test_plan_refuses_bodies_that_are_no_shot(client):
    assert _refused(client.post("/api/rigs/plan", content=b"{not json", headers={"Content-Type": "application/json"}),
                    422).startswith("the body is not valid JSON")
    assert _refused(client.post("/api/rigs/plan", json=[1, 2]), 422) == "shot must be a JSON object; got list"
    assert _refused(client.post("/api/rigs/plan", json={"scene": "stadium"}), 422).startswith(
        "shot is missing field(s) rig")
    # nested past Python's recursion limit (the sweep's body=nested): a refusal, not an internal error
    assert _refused(client.post("/api/rigs/plan", content=b"[" * 100_000 + b"]" * 100_000,
                                headers={"Content-Type": "application/json"}), 422).startswith(
        "the body is not valid JSON (maximum recursion depth exceeded")


@pytest.mark.parametrize("scene", ["wembley", "../scenes/quarry/scene.json", "/etc/passwd", "stadium/.."])
def test_a_scene_is_a_built_in_name_or_a_data_id_never_a_path(client, scene):
    message = _refused(client.post("/api/rigs/plan", json=_with(QUADRI, scene=scene)), 422)
    assert message == (f"scene must be a built-in scene (glasses, stadium, tabletop) or a scene id of GET /api/data; "
                       f"got {scene!r}")


def test_an_unknown_or_wrong_kind_of_data_id_is_refused(client):
    message = _refused(client.post("/api/rigs/plan", json=_with(QUADRI, scene="scene-0123456789abcdef")), 404)
    assert message == "unknown data id 'scene-0123456789abcdef'; GET /api/data lists the ids"
    shot_id = _presets(client)["quarry-tri"]["id"]
    message = _refused(client.post("/api/rigs/plan", json=_with(QUADRI, scene=shot_id)), 422)
    assert message == f"scene: {shot_id!r} is a shot, not a scene; GET /api/data lists the scenes"
    builtin = client.post("/api/rigs/plan", json=_with(QUADRI, scene="scene:stadium"))  # the built-in's data id
    assert builtin.status_code == 200 and builtin.json() == client.post("/api/rigs/plan", json=QUADRI).json()


def test_plan_is_documented_in_openapi(client):
    schema = client.get("/openapi.json").json()
    assert "/api/rigs/plan" in schema["paths"] and "/api/rigs/shots" in schema["paths"]
    kinds = {k["name"]: k for k in client.get("/api/jobs").json()["kinds"]}
    assert set(kinds["rig"]["parameters"]["properties"]) == {"shot", "width", "weights", "samples", "supersample"}


# ---------------------------------------------------------------- the render job


@pytest.mark.parametrize("name", ["stadium-quadri", "quarry-tri"])
def test_a_tiny_rig_job_writes_the_pair_truth_and_error(client, tmp_path, name):
    import numpy as np

    from vergence.io import read_image

    shot = _presets(client)[name]["shot"]
    first = client.post("/api/jobs/rig", json={"shot": shot, **TINY})
    assert first.status_code == 202, first.text
    job = _wait(client, first.json()["id"])
    assert job["state"] == "done", job
    result = job["result"]
    height = round(48 * 270 / 480)
    assert result["size"] == [48, height] and result["rig"] == shot["rig"] and result["scene"] == shot["scene"]
    assert result["samples"] == 1 and result["supersample"] == 1
    eyes = result["methods"]["ulr"]
    synthesised = ["left", "right"] if shot["rig"] == "quadri" else ["right"]
    for eye in synthesised:
        assert 10.0 < eyes[eye]["psnr"] < 60.0 and 0.0 < eyes[eye]["dssim"] < 0.5 and eyes[eye]["coverage"] > 0.5
    if shot["rig"] == "tri":
        assert eyes["left"]["note"] == "the director's image"
    cameras = [c["name"] for c in client.post("/api/rigs/plan", json=shot).json()["cameras"]]
    assert result["cameras"] == cameras
    expected = {"ulr_left.png", "ulr_right.png", "ulr_anaglyph.png", "truth_left.png", "truth_right.png",
                *(f"ulr_error_{eye}.png" for eye in synthesised), *(f"camera_{n}.png" for n in cameras)}
    assert set(job["files"]) == expected
    for file in job["files"]:
        got = client.get(f"/api/jobs/{job['id']}/files/{file}")
        assert got.status_code == 200 and got.headers["content-type"] == "image/png"
    # the error image is |pair - truth| x 4 where covered: it agrees with the pair and the truth served
    eye = synthesised[-1]
    images = {}
    for name in (f"ulr_error_{eye}.png", f"ulr_{eye}.png", f"truth_{eye}.png"):
        (tmp_path / name).write_bytes(client.get(f"/api/jobs/{job['id']}/files/{name}").content)
        images[name] = read_image(tmp_path / name)
    err, pair, truth = images[f"ulr_error_{eye}.png"], images[f"ulr_{eye}.png"], images[f"truth_{eye}.png"]
    assert err.shape == pair.shape == (height, 48, 3)
    grey = err[..., 0] == err[..., 2]  # covered pixels are grey, holes blue
    assert grey.mean() > 0.5
    slow = np.clip(4 * np.abs(pair.astype(float) - truth).mean(axis=-1), 0, 1)
    # pair and truth each rounded to 8 bits (0.5/255 each), their difference x 4, the error rounded again
    np.testing.assert_allclose(err[..., 0][grey], slow[grey], atol=4.5 / 255)
    again = client.post("/api/jobs/rig", json={"shot": shot, **TINY})
    assert again.status_code == 200 and again.json()["cached"] is True and again.json()["id"] == job["id"]


def test_the_job_refuses_bad_shots_like_the_plan(client):
    for case in ("unknown key", "element behind the cameras", "constraints psi cannot meet"):
        planned = _refused(client.post("/api/rigs/plan", json=BAD_SHOTS[case]), 422)
        assert _refused(client.post("/api/jobs/rig", json={"shot": BAD_SHOTS[case], **TINY}), 422) == planned
    assert _refused(client.post("/api/jobs/rig", json={"shot": _with(QUADRI, scene="wembley")}), 422).startswith(
        "scene must be a built-in scene")
    assert _refused(client.post("/api/jobs/rig", json={"shot": _with(QUADRI, scene="scene-0123456789abcdef")}),
                    404).startswith("unknown data id")


def test_the_job_refuses_sizes_and_costs_past_its_limits(client):
    message = _refused(client.post("/api/jobs/rig", json={"shot": QUADRI, "width": MAX_RIG_JOB_SIDE + 1}), 422)
    assert message == f"width: less than or equal to {MAX_RIG_JOB_SIDE} (got {MAX_RIG_JOB_SIDE + 1})"
    tall = _with(QUADRI, camera={**QUADRI["camera"], "width": 100, "height": 400})
    message = _refused(client.post("/api/jobs/rig", json={"shot": tall, "width": 200}), 422)
    assert message == ("width 200 gives a height of 800 pixels at the shot's aspect; the limit is 640 "
                       "(MAX_RIG_JOB_SIDE): lower width")
    # one view of 320x180 at 2x2 rays and 16 samples casts 2.0e7 rays; the Tri-Rig's 3 cameras and its
    # curved-ray truth (CURVED_TRUTH_VIEWS) count 13 views: 2.7e8, over the limit
    costly = {"shot": TRI, "width": 320, "samples": 16, "supersample": 2}
    message = _refused(client.post("/api/jobs/rig", json=costly), 422)
    assert "the 13 views of this rig at 320x180 pixels, samples 16, supersample 2 may cast up to 2.66e+08" in message
    assert message.endswith(f"a job's limit is {MAX_RENDER_JOB_RAYS:.0e} (MAX_RENDER_JOB_RAYS): lower width, "
                            "samples or supersample")
    huge = {"shot": TRI, "width": 640, "samples": 64, "supersample": 4}  # one view alone needs 4.6 GiB
    assert _refused(client.post("/api/jobs/rig", json=huge), 422).startswith(
        "one view of this rig at 640x360 pixels, samples 64, supersample 4 may cast up to")
    assert _refused(client.post("/api/jobs/rig", json={"shot": QUADRI, "weights": "nearest"}), 422) == (
        "weights must be one of ulr, bayesian, both; got 'nearest'")
    assert _refused(client.post("/api/jobs/rig", json={"shot": QUADRI, "supersample": 5}), 422) == (
        "supersample: less than or equal to 4 (got 5)")
    assert _refused(client.post("/api/jobs/rig", json={"shot": QUADRI, "lens": 3}), 422).startswith(
        "unknown field 'lens'; valid fields: shot, width, weights, samples, supersample")
    assert _refused(client.post("/api/jobs/rig", json={"width": 64}), 422) == "missing field shot"


def test_a_running_rig_job_can_be_cancelled(client):
    body = {"shot": QUADRI, "width": 480, "samples": 4, "supersample": 2}  # about 15 s: 6 views of 480x270
    job = client.post("/api/jobs/rig", json=body)
    assert job.status_code == 202, job.text
    job = job.json()
    assert client.delete(f"/api/jobs/{job['id']}").status_code == 202
    final = _wait(client, job["id"])
    assert final["state"] == "cancelled" and final["files"] == []


def test_shot_files_are_indexed_but_not_listed_as_data(client):
    listed = client.get("/api/data").json()
    assert set(listed) == {"collections", "scenes", "skipped"}
    assert all(not e["id"].startswith("shot-") for e in listed["scenes"] + listed["collections"])
    shot_id = _presets(client)["quarry-quadri"]["id"]
    entry = client.get(f"/api/data/{shot_id}").json()
    assert entry == {"id": shot_id, "kind": "shot", "name": "shots/quarry-quadri.json", "format": "json"}


def test_a_data_shot_is_a_preset_only_when_its_scene_is_reachable(tmp_path):
    data = tmp_path / "data"
    (data / "shots").mkdir(parents=True)
    (tmp_path / "outside.json").write_text((EXAMPLES / "scenes" / "far_mirror.json").read_text())
    (data / "shots" / "builtin.json").write_text(json.dumps(_with(TRI, scene="tabletop")))
    (data / "shots" / "escapes.json").write_text(json.dumps(_with(TRI, scene="../../outside.json")))
    (data / "shots" / "broken.json").write_text(json.dumps(_with(TRI, constraints=["z=30,perceived=3"])))
    with TestClient(create_app([data]), base_url="http://127.0.0.1") as c:
        presets = _presets(c)
    assert sorted(presets) == ["builtin", "stadium-quadri", "stadium-tri"]  # no escape, no shot that cannot plan
    assert presets["builtin"]["source"] == "data" and presets["builtin"]["shot"]["scene"] == "tabletop"
