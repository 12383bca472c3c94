"""Shot files (docs/shots.md): parsing, refusals by name, round trips, and the example shots."""

from __future__ import annotations

import copy
import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from vergence.rigs import EXAMPLE_SHOTS, QuadriRig, Shot, TriRig, load_shot, plan_document, shot_from_dict
from vergence.viewing import DISPLAY_PRESETS, DirectorConstraint, Display

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples" / "shots").glob("*.json"))

CAMERA = {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "up": [0.0, 1.0, 0.0], "fov_deg": 8.0,
          "width": 480, "height": 270}
QUADRI = {"rig": "quadri", "scene": "stadium", "display": "tv-55",
          "camera": {**CAMERA, "position": [0.0, 1.6, -20.0], "look_at": [0.0, 1.0, -30.0], "fov_deg": 24.0},
          "baseline": 0.2, "convergence": 10.0, "setback": 20.0,
          "elements": [{"name": "subject", "point": [0.0, 1.0, -30.0]}, {"name": "background", "point": [0, 2, -63]}]}
TRI = {"rig": "tri", "scene": "stadium", "display": "tv-55", "camera": CAMERA,
       "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=6"]}


def _with(base: dict, path: tuple, value) -> dict:
    """A deep copy of ``base`` with ``value`` at ``path`` (a missing-field marker deletes the key)."""
    data = copy.deepcopy(base)
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


_DELETE = object()


def test_tri_shot_fields_and_defaults():
    shot = shot_from_dict(TRI)
    assert shot.rig == "tri" and shot.scene == "stadium" and shot.display is DISPLAY_PRESETS["tv-55"]
    assert shot.constraints == (DirectorConstraint(30.0, 3.0, 1.0), DirectorConstraint(65.0, 6.0))
    assert shot.reference == "round" and shot.near is None and math.isinf(shot.far) and shot.path is None
    cam = shot.camera
    assert cam.width == 480 and cam.center == pytest.approx([0.0, 2.2, 0.0], abs=1e-15)
    rig = shot.plan()
    assert isinstance(rig, TriRig) and rig.director == cam and rig.mapping.near == 15.0


def test_quadri_shot_plans():
    shot = shot_from_dict(QUADRI)
    assert (shot.baseline, shot.convergence, shot.setback) == (0.2, 10.0, 20.0)
    assert shot.elements == (("subject", (0.0, 1.0, -30.0)), ("background", (0.0, 2.0, -63.0)))
    rig = shot.plan()
    assert isinstance(rig, QuadriRig) and [c.name for c in rig.cameras][:2] == ["subject_left", "subject_right"]


def test_up_defaults_to_y_and_display_may_be_an_object():
    data = _with(TRI, ("camera", "up"), _DELETE)
    data["display"] = {"eye_separation": 0.065, "distance": 2.0, "width": 1.0}
    shot = shot_from_dict(data)
    assert shot.view.up == (0.0, 1.0, 0.0)
    assert shot.display == Display(0.065, 2.0, 1.0)
    assert shot_from_dict(_with(TRI, ("near",), 20.0)).near == 20.0
    assert shot_from_dict(_with(TRI, ("far",), None)).far == math.inf
    assert shot_from_dict(_with(TRI, ("reference",), "div")).plan().reference.baseline < 0.3


@pytest.mark.parametrize("base", [QUADRI, TRI, _with(TRI, ("display",), {"eye_separation": 0.06, "distance": 2.0,
                                                                         "width": 1.0, "resolution": 1280})])
def test_to_dict_round_trip(base):
    shot = shot_from_dict(base)
    again = shot_from_dict(json.loads(json.dumps(shot.to_dict())))
    assert again == shot


@pytest.mark.parametrize(
    ("data", "error", "message"),
    [
        ([], TypeError, "shot must be a JSON object; got list"),
        (_with(TRI, ("rig",), _DELETE), ValueError, "shot is missing field.* rig"),
        (_with(TRI, ("rig",), "penta"), ValueError, "rig must be one of quadri, tri; got 'penta'"),
        (_with(TRI, ("colour",), 1), ValueError, "a tri shot has unknown key.* 'colour'; valid keys: rig, scene, "
                                                 "display, camera, constraints, reference \\(optional\\)"),
        (_with(TRI, ("setback",), 1), ValueError, "a tri shot has unknown key.* 'setback'"),
        (_with(QUADRI, ("constraints",), []), ValueError, "a quadri shot has unknown key.* 'constraints'"),
        (_with(TRI, ("constraints",), _DELETE), ValueError, "a tri shot is missing field.* constraints"),
        (_with(QUADRI, ("setback",), _DELETE), ValueError, "a quadri shot is missing field.* setback"),
        (_with(TRI, ("camera", "zoom"), 2), ValueError, "camera has unknown key.* 'zoom'; valid keys: position"),
        (_with(TRI, ("camera", "fov_deg"), _DELETE), ValueError, "camera is missing field.* fov_deg"),
        (_with(TRI, ("camera", "fov_deg"), "8"), TypeError, "camera.fov_deg must be a real number"),
        (_with(TRI, ("camera", "width"), 480.5), TypeError, "camera.width must be an integer"),
        (_with(TRI, ("camera", "position"), [0, 2.2]), ValueError, r"camera.position must have shape \(3,\)"),
        (_with(TRI, ("camera", "position"), "0,2,0"), TypeError, "camera.position must be a list of 3 numbers"),
        (_with(TRI, ("camera", "look_at"), [0.0, 2.2, 0.0]), ValueError, "camera: target must differ from position"),
        (_with(TRI, ("camera",), "stadium"), TypeError, "camera must be a JSON object"),
        (_with(TRI, ("display",), "tv-99"), ValueError, "unknown display preset 'tv-99'; valid presets: cinema"),
        (_with(TRI, ("display",), {"eye_separation": 0.065, "distance": 3.0}), ValueError,
         "display is missing field.* width"),
        (_with(TRI, ("display",), {"eye_separation": 0.065, "distance": 3.0, "width": 1.2, "dpi": 90}), ValueError,
         "display has unknown key.* 'dpi'"),
        (_with(TRI, ("display",), {"eye_separation": -0.065, "distance": 3.0, "width": 1.2}), ValueError,
         "display eye_separation must be > 0"),
        (_with(TRI, ("display",), 55), TypeError, "display must be a JSON object"),
        (_with(TRI, ("constraints",), "z=30,perceived=3"), TypeError, "constraints must be a list"),
        (_with(TRI, ("constraints",), ["z=30,perceived=3,roundness=1", 65]), TypeError, r"constraints\[1\] must be a string"),
        (_with(TRI, ("constraints",), ["z=30,perceived=3,roundness=1", "z=65"]), ValueError, "constraint 'z=65' is malformed"),
        (_with(TRI, ("reference",), "flat"), ValueError, "reference must be one of round, div; got 'flat'"),
        (_with(TRI, ("near",), "15"), TypeError, "near must be a real number"),
        (_with(QUADRI, ("baseline",), "0.2"), TypeError, "baseline must be a real number"),
        (_with(QUADRI, ("elements",), {"subject": [0, 1, -30]}), TypeError, "elements must be a list"),
        (_with(QUADRI, ("elements", 0, "weight"), 1), ValueError, r"elements\[0\] has unknown key.* 'weight'; valid keys: name, point"),
        (_with(QUADRI, ("elements", 1, "point"), _DELETE), ValueError, r"elements\[1\] is missing field.* point"),
        (_with(QUADRI, ("elements", 1, "point"), [0, 2, None]), TypeError, r"elements\[1\].point must be a list of 3 numbers"),
        (_with(QUADRI, ("elements", 1, "name"), 7), TypeError, r"elements\[1\].name must be a str"),
        (_with(QUADRI, ("elements", 1, "name"), "the crowd"), ValueError, r"elements\[1\].name must be letters"),
        (_with(TRI, ("scene",), "arena"), ValueError, "scene must be a scene file or a built-in scene \\(glasses, stadium"),
        (_with(TRI, ("scene",), ""), TypeError, "scene must be a non-empty string"),
        (_with(TRI, ("scene",), "no/such/scene.json"), FileNotFoundError, "scene file not found: no/such/scene.json"),
    ],
)
def test_bad_shots_are_refused_by_name(data, error, message):
    with pytest.raises(error, match=message):
        shot_from_dict(data)


def test_shot_validates_when_built_directly():
    shot = shot_from_dict(TRI)
    with pytest.raises(ValueError, match="rig must be one of quadri, tri; got 'penta'"):
        replace(shot, rig="penta")
    with pytest.raises(TypeError, match="display must be a vergence.viewing.Display; got str"):
        replace(shot, display="tv-55")
    with pytest.raises(ValueError, match="reference must be one of round, div"):
        replace(shot, reference="flat")


def test_planning_errors_name_the_element_or_constraint():
    with pytest.raises(ValueError, match="element 'subject' .* is behind or on the virtual cameras"):
        shot_from_dict(_with(QUADRI, ("elements", 0, "point"), [0.0, 1.0, -10.0])).plan()
    with pytest.raises(ValueError, match="constraint z=65,perceived=2.5: no background camera"):
        shot_from_dict(_with(TRI, ("constraints", 1), "z=65,perceived=2.5")).plan()


def test_scene_path_is_relative_to_the_shot_file(tmp_path):
    (tmp_path / "scenes").mkdir()
    scene = tmp_path / "scenes" / "arena.json"
    scene.write_text("{}")  # the planner never opens it: only its existence is checked here
    (tmp_path / "shots").mkdir()
    shot_file = tmp_path / "shots" / "a.json"
    shot_file.write_text(json.dumps({**TRI, "scene": "../scenes/arena.json"}))
    shot = load_shot(shot_file)
    assert shot.scene == scene.resolve() and shot.path == shot_file
    # The round trip keeps the absolute path.
    assert shot_from_dict(shot.to_dict()) == replace(shot, path=None)
    (tmp_path / "shots" / "b.json").write_text(json.dumps({**TRI, "scene": "scenes/arena.json"}))
    with pytest.raises(FileNotFoundError, match=r"scene file not found: .*shots/scenes/arena.json"):
        load_shot(tmp_path / "shots" / "b.json")


def test_a_bare_built_in_scene_name_is_never_shadowed_by_a_folder_beside_the_shot(tmp_path):
    (tmp_path / "stadium").mkdir()  # e.g. what `vergence render stadium --out stadium/` wrote
    shot_file = tmp_path / "a.json"
    shot_file.write_text(json.dumps({**TRI, "scene": "stadium"}))
    assert load_shot(shot_file).scene == "stadium"
    shot_file.write_text(json.dumps({**TRI, "scene": "./stadium"}))
    with pytest.raises(IsADirectoryError, match="is a folder; give a scene file .*bare name: "):
        load_shot(shot_file)


def test_load_shot_prefixes_the_file(tmp_path):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps({**TRI, "extra": 1}))
    with pytest.raises(ValueError, match=f"shot file {f}: a tri shot has unknown key"):
        load_shot(f)
    f.write_text("{not json")
    with pytest.raises(ValueError, match="bad.json"):
        load_shot(f)
    with pytest.raises(FileNotFoundError):
        load_shot(tmp_path / "missing.json")


def test_example_shots_exist():
    names = {p.name for p in EXAMPLES}
    assert {"stadium-quadri.json", "stadium-tri.json"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_every_example_shot_plans(path):
    shot = load_shot(path)
    assert isinstance(shot, Shot)
    rig = shot.plan()
    assert rig.cameras
    if shot.rig == "tri":
        assert rig.mapping.monotone and not rig.mapping.diverges
        if path.name == "stadium-tri.json":  # inside the comfort zone from near = 25 m on
            assert not rig.mapping.warnings
        for c in shot.constraints:  # psi meets every constraint (S0 Eq. (7), (9))
            assert rig.mapping.perceived_depth(c.depth) == pytest.approx(c.perceived_depth, rel=1e-9)
            if c.roundness is not None:
                assert rig.mapping.roundness(c.depth) == pytest.approx(c.roundness, rel=1e-9)
    else:
        for rc in rig.cameras:  # every element in front of its real camera and of the virtual eye
            point = dict(rig.elements)[rc.element]
            assert rc.camera.project(point[None])[1][0] > rig.virtual(rc.eye).project(point[None])[1][0] > 0


@pytest.mark.parametrize("name", sorted(EXAMPLE_SHOTS))
def test_example_shots_are_the_files_of_examples_shots(name):
    assert json.loads((REPO / "examples" / "shots" / f"{name}.json").read_text()) == EXAMPLE_SHOTS[name]
    assert shot_from_dict(EXAMPLE_SHOTS[name]).scene == "stadium"  # built in: no source tree needed


def test_plan_document_rows_by_hand():
    doc = plan_document(shot_from_dict(QUADRI))
    assert doc["rig"] == "quadri" and doc["shot"] is None and doc["setback"] == 20.0
    rows = {r["name"]: r for r in doc["cameras"]}
    assert list(rows) == ["subject_left", "subject_right", "background_left", "background_right"]
    # S0 Eq. (10): k = (z_e + s) / z_e, s = 20 m, z_e the subject's depth: the camera looks straight at it
    # from (0, 1.6, -20), 0.6 m above and 10 m before it; the shifted eyes keep the centre camera's axis
    z_e = math.hypot(0.6, 10.0)
    k = (z_e + 20.0) / z_e
    assert rows["subject_left"]["fx_ratio"] == pytest.approx(k, rel=1e-9)
    assert rows["subject_left"]["baseline"] == pytest.approx(k * 0.2, rel=1e-9)  # b_e = k b_v
    assert rows["subject_left"]["baseline"] == rows["subject_right"]["baseline"]
    assert doc["elements"] == [{"name": "subject", "point": [0.0, 1.0, -30.0]},
                               {"name": "background", "point": [0.0, 2.0, -63.0]}]
    tri = plan_document(shot_from_dict(TRI))
    assert [r["name"] for r in tri["cameras"]] == ["director", "subject", "background"]
    assert tri["cameras"][0]["baseline"] == 0.0 and tri["cameras"][0]["fx_ratio"] == 1.0
    # S0 Eq. (5): b_round = b' H / H' with H = 30 m, the tv-55's b' and H'
    tv = DISPLAY_PRESETS["tv-55"]
    assert tri["cameras"][1]["baseline"] == pytest.approx(tv.eye_separation * 30.0 / tv.distance, rel=1e-9)
    assert tri["monotone"] is True and tri["diverges"] is False
    json.dumps(tri, allow_nan=False)


def test_plan_document_refuses_a_non_shot_and_passes_planner_errors():
    with pytest.raises(TypeError, match="shot must be a vergence.rigs.Shot"):
        plan_document(QUADRI)
    bad = _with(QUADRI, ("elements", 0, "point"), [0.0, 1.0, -10.0])  # behind the virtual rig (z = -20)
    with pytest.raises(ValueError, match="subject"):
        plan_document(shot_from_dict(bad))


@pytest.mark.parametrize(("field", "value", "error"), [
    ("position", (), ValueError), ("position", (0.0, math.nan, 0.0), ValueError), ("look_at", "abc", TypeError),
    ("look_at", None, ValueError), ("up", (), ValueError), ("fov_deg", math.nan, ValueError),
    ("width", -math.inf, TypeError), ("height", 0, ValueError), ("look_at", (0.0, 1.6, -20.0), ValueError),  # = position
])
def test_a_shot_camera_built_directly_is_checked_as_a_file_would_be(field, value, error):
    from vergence.rigs import ShotCamera

    args = {"position": (0.0, 1.6, -20.0), "look_at": (0.0, 1.0, -30.0), "up": (0.0, 1.0, 0.0), "fov_deg": 24.0,
            "width": 480, "height": 270, field: value}
    with pytest.raises(error, match="target must differ" if value == args["position"] and field == "look_at" else field):
        ShotCamera(**args)
