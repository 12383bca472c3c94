"""User-input errors of the renderer that no other test reaches: scene files, meshes, scene classes, figures.

Each is one line naming the argument (or the file and entry), the expectation and what came.
"""

from __future__ import annotations

import copy
import json
import struct

import numpy as np
import pytest

from vergence.render import Checker, Environment, Mesh, Scene, load_scene, scene_from_dict, tonemap
from vergence.render.meshio import read_mesh

MINIMAL = {
    "camera": {"position": [0, 1, 4], "look_at": [0, 1, 0], "up": [0, 1, 0], "fov_deg": 40, "width": 8, "height": 6},
    "environment": {"color": [1, 1, 1]},
    "materials": {"m": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}},
    "objects": [{"type": "sphere", "center": [0, 1, 0], "radius": 1, "material": "m"}],
}
PLY_HEAD = ["ply", "format ascii 1.0", "element vertex 3", "property float x", "property float y", "property float z",
            "element face 1", "property list uchar int vertex_indices", "end_header"]  # fmt: skip
PLY_BODY = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"


def _ply(tmp_path, head=PLY_HEAD, body=PLY_BODY, name="m.ply"):
    p = tmp_path / name
    p.write_bytes(("\n".join(head) + "\n").encode() + (body.encode() if isinstance(body, str) else body))
    return p


def test_a_valid_ply_reads(tmp_path):
    assert read_mesh(_ply(tmp_path)).faces.tolist() == [[0, 1, 2]]


@pytest.mark.parametrize(
    ("head", "body", "match"),
    [
        (["plx", *PLY_HEAD[1:]], PLY_BODY, r"not a PLY file \(no 'ply' magic or no end_header\)"),
        (PLY_HEAD[:-1], PLY_BODY, r"not a PLY file \(no 'ply' magic or no end_header\)"),
        (["ply", "format binary_middle_endian 1.0", *PLY_HEAD[2:]], PLY_BODY, "unsupported PLY format 'binary_middle_endian'"),
        ([*PLY_HEAD[:3], "property quad x", *PLY_HEAD[4:]], PLY_BODY, "unknown PLY property type 'quad'"),
        ([*PLY_HEAD[:7], "property list uchar int corners", "end_header"], PLY_BODY,
         "the face element has no vertex_indices list"),
        (PLY_HEAD[:6] + ["end_header"], "0 0 0\n1 0 0\n0 1 0\n", "needs a 'vertex' element with x, y, z and a 'face'"),
        (PLY_HEAD, "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "face indices out of range or no faces"),
        (PLY_HEAD, "0 0 0\n1 0 0\n0 1\n", "truncated or malformed ASCII body"),
        (PLY_HEAD, "0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n", "truncated or malformed ASCII body"),
        (PLY_HEAD, "0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n", "vertex coordinates must be finite"),
        (["ply", "format binary_little_endian 1.0", *PLY_HEAD[2:]], struct.pack("<5f", 0, 0, 0, 1, 0),
         "truncated binary body"),
    ],
)
def test_bad_ply_files(tmp_path, head, body, match):
    path = _ply(tmp_path, head, body)
    with pytest.raises(ValueError, match=f"cannot read mesh .*m.ply: {match}"):
        read_mesh(path)


def test_bad_scene_files_beyond_json(tmp_path):
    p = tmp_path / "latin.json"
    p.write_bytes('{"name": "caf\u00e9"}'.encode("latin-1"))
    with pytest.raises(ValueError, match=r"scene file .*latin.json is not UTF-8 text"):
        load_scene(p)
    named = copy.deepcopy(MINIMAL) | {"name": 7}
    p.write_text(json.dumps(named))
    with pytest.raises(TypeError, match="^latin.json: name must be a string; got int$"):
        load_scene(p)  # the file's name leads the message
    with pytest.raises(TypeError, match="materials must be a JSON object of named materials; got list"):
        scene_from_dict(copy.deepcopy(MINIMAL) | {"materials": []})
    textured = copy.deepcopy(MINIMAL)
    textured["materials"]["t"] = {"type": "texture", "path": "missing.png"}
    with pytest.raises((OSError, ValueError), match=r"materials\['t'\]: .*missing.png"):
        scene_from_dict(textured, base_dir=tmp_path)


def test_scene_classes_refuse_bad_values():
    with pytest.raises(ValueError, match=r"environment needs exactly one of color or image \(an .hdr map\)"):
        Environment()
    with pytest.raises(ValueError, match=r"image must have shape \(h, w, 3\) with h, w >= 2; got \(1, 4, 3\)"):
        Environment(image=np.ones((1, 4, 3)))
    with pytest.raises(ValueError, match="image must be radiance >= 0; got min -1"):
        Environment(image=-np.ones((2, 4, 3)))
    with pytest.raises(ValueError, match=r"squares must be a pair \[nu, nv\]; got 8"):
        Checker(colors=[[1, 1, 1], [0, 0, 0]], squares=8)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"faces must be a non-empty \(F, 3\) integer array; got \(1, 3\) float64"):
        Mesh(vertices=np.eye(3), faces=[[0.0, 1.0, 2.0]], material="m")
    with pytest.raises(ValueError, match="normals must be non-zero vectors"):
        Mesh(vertices=np.eye(3), faces=[[0, 1, 2]], material="m", normals=np.zeros((3, 3)))
    scene = scene_from_dict(MINIMAL)
    with pytest.raises(TypeError, match="stereo must be a Stereo or None; got tuple"):
        Scene(camera=scene.camera, environment=scene.environment, materials={}, objects=(), stereo=(0.1, 2.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="material names must be non-empty strings; got ''"):
        Scene(camera=scene.camera, environment=scene.environment, materials={"": scene.materials["m"]}, objects=())


def test_figures_refuse_bad_input(tmp_path):
    from vergence.render import render
    from vergence.report.preview import save_render

    with pytest.raises(ValueError, match=r"radiance must have shape \(H, W, 3\) and not be empty; got \(4, 4\)"):
        tonemap(np.zeros((4, 4)))
    result = render(scene_from_dict(MINIMAL), max_depth=0, samples=1)
    with pytest.raises(FileNotFoundError, match="output folder does not exist: .*nowhere"):
        save_render(result, tmp_path / "nowhere")


# Issue 9: a scene JSON nested 100,000 levels deep raised RecursionError ("internal error").
def test_deeply_nested_scene_is_refused_before_parsing(tmp_path):
    from vergence.io import MAX_JSON_DEPTH

    p = tmp_path / "deep.json"
    p.write_text('{"camera": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(ValueError, match=rf"scene file .*deep.json nests arrays/objects more than {MAX_JSON_DEPTH} "):
        load_scene(p)


def test_scene_nesting_limit_is_exact(tmp_path):
    from vergence.io import MAX_JSON_DEPTH, read_json

    ok, deep = tmp_path / "ok.json", tmp_path / "deep.json"
    ok.write_text("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH)
    deep.write_text("[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1))
    assert read_json(ok) is not None
    with pytest.raises(ValueError, match="MAX_JSON_DEPTH"):
        read_json(deep)
    # brackets inside strings (with escaped quotes) do not count as nesting
    strings = tmp_path / "strings.json"
    strings.write_text(json.dumps({"name": "\"[" * 200}))
    assert read_json(strings) == {"name": "\"[" * 200}


def test_oversized_json_is_refused_before_reading(tmp_path, monkeypatch):
    from vergence.io import jsonfile, read_json

    p = tmp_path / "big.json"
    p.write_text(json.dumps(MINIMAL))
    monkeypatch.setattr(jsonfile, "MAX_JSON_BYTES", 100)
    with pytest.raises(ValueError, match=r"big.json is \d+ bytes; the limit is 100 \(MAX_JSON_BYTES\)"):
        read_json(p)


def test_scene_file_with_byte_order_mark_loads(tmp_path):
    p = tmp_path / "bom.json"
    p.write_bytes(b"\xef\xbb\xbf" + json.dumps(MINIMAL).encode())
    assert load_scene(p).name == "bom"


# Issue 9: a folder given as a scene said "scene file not found".
def test_folder_as_scene_says_folder(tmp_path):
    from vergence.render import open_scene

    with pytest.raises(IsADirectoryError, match=r"scene .* is a folder; give a scene file \(\.json\)"):
        open_scene(tmp_path)
    with pytest.raises(IsADirectoryError, match=r"is a folder"):
        load_scene(tmp_path)


def test_render_cost_bounds_by_hand():
    from vergence.render.limits import LAYER_BYTES, RAY_BYTES, render_cost

    # 4 x 3 pixels, D = 1 (N = 3 nodes, 2 leaves), 5 AO samples, stereo, supersample 2 (1 + 4 trees per pixel)
    c = render_cost(4, 3, max_depth=1, samples=5, supersample=2, views=2)
    assert c.trees == 4 * 3 * 2 * 5
    assert c.rays == c.trees * (3 + 2 * 5)
    assert c.bytes == c.trees * (RAY_BYTES + 3 * LAYER_BYTES)
    assert c.problem() is None


def test_render_cost_limits_fire_at_their_values(monkeypatch):
    from vergence.render import limits

    c = limits.render_cost(100, 100, max_depth=0, samples=1)  # 10,000 trees, 20,000 rays
    monkeypatch.setattr(limits, "MAX_RENDER_RAYS", 20_000)
    assert c.problem() is None
    monkeypatch.setattr(limits, "MAX_RENDER_RAYS", 19_999)
    assert "MAX_RENDER_RAYS" in c.problem()
    monkeypatch.setattr(limits, "MAX_RENDER_BYTES", c.bytes - 1)
    assert "MAX_RENDER_BYTES" in c.problem()


# Issue 9 (kin): the library refuses an oversized render before allocating, in its own words.
def test_library_render_refuses_past_the_limits():
    from dataclasses import replace

    from vergence.camera import look_at
    from vergence.render import builtin_scene, render

    sc = builtin_scene("tabletop")
    with pytest.raises(ValueError, match=r"width must be <= 32768 pixels \(MAX_RENDER_SIDE\); got 40000"):
        replace(sc, camera=sc.camera.resized(width=40000))
    big = look_at([0, 0, 0], [0, 0, -1], [0, 1, 0], fov_deg=40, width=30000, height=30000)
    with pytest.raises(ValueError, match=r"a render of 1 view\(s\) of 30000x30000 pixels .* \(MAX_RENDER_BYTES\)"):
        render(sc, camera=big)
    with pytest.raises(ValueError, match=r"may cast up to .* \(MAX_RENDER_RAYS\)"):
        render(sc, samples=100_000_000)


# Issue 9: contact_sheet([]) raised AttributeError.
@pytest.mark.parametrize("bad", [[], None, "render.npz"])
def test_figures_of_a_non_result_are_type_errors(bad, tmp_path):
    from vergence.report.preview import contact_sheet, save_render

    with pytest.raises(TypeError, match=r"^result must be a vergence.render.RenderResult; got "):
        contact_sheet(bad)
    with pytest.raises(TypeError, match=r"^result must be a vergence.render.RenderResult; got "):
        save_render(bad, tmp_path)


# Issue 9: tonemap of NaN or negative radiance returned values (NaN became black) instead of an error.
@pytest.mark.parametrize(
    ("value", "message"),
    [(np.nan, r"radiance must be finite; got 1 NaN or inf value\(s\)"), (np.inf, "radiance must be finite"),
     (-0.5, "radiance must be >= 0; got min -0.5")],
)
def test_tonemap_refuses_nan_and_negative_radiance(value, message):
    from vergence.render import auto_exposure

    radiance = np.full((2, 2, 3), 0.25)
    radiance[1, 0, 2] = value
    with pytest.raises(ValueError, match=message):
        tonemap(radiance)
    with pytest.raises(ValueError, match=message):
        auto_exposure(radiance)
    with pytest.raises(ValueError, match="exposure must be finite"):
        tonemap(np.zeros((2, 2, 3)), exposure=float("nan"))
    with pytest.raises(TypeError, match="radiance must be a real-valued array; got list"):
        tonemap([["a", "b", "c"]])


# Issue 9 (kin, the old sweep): wrong-typed arguments raised AttributeError deep inside.
def test_wrong_types_to_the_render_stages_are_type_errors():
    from vergence.render import Intersector, RayTree, RenderResult, RenderSettings, WhittedShader, builtin_scene

    with pytest.raises(TypeError, match="^scene must be a vergence.render.Scene; got NoneType"):
        Intersector(None)
    with pytest.raises(TypeError, match="^scene must be a vergence.render.Scene; got list"):
        WhittedShader([])
    sc = builtin_scene("tabletop", width=4, height=3)
    with pytest.raises(TypeError, match="^packed must be a PackedScene or None; got str"):
        WhittedShader(sc, "packed")
    with pytest.raises(ValueError, match=r"^origins must have shape"):
        Intersector(sc)(np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises((TypeError, ValueError), match="^origins"):
        Intersector(sc)("a", "b")
    with pytest.raises(TypeError, match="^settings must be a RenderSettings; got NoneType"):
        RenderResult(None, None, None, None, None, None, None)
    with pytest.raises(TypeError, match="^settings must be a RenderSettings; got NoneType"):
        RayTree(None, None, None, None, None, None, None)
    settings = RenderSettings(scene="s", max_depth=0, samples=1, deterministic=True, ao_distance=None,
                              variant="v", environment="e")  # fmt: skip
    z = np.zeros((1, 2, 3))
    with pytest.raises(TypeError, match="^radiance must be a numpy array; got list"):
        RayTree([], z, z, np.zeros(2), np.zeros(2, bool), np.zeros((2, 3)), settings)
    with pytest.raises(ValueError, match=r"^position must have shape \(1, 2, 3\); got \(1, 3, 3\)"):
        RayTree(z, np.zeros((1, 3, 3)), z, np.zeros(2), np.zeros(2, bool), np.zeros((2, 3)), settings)
    with pytest.raises(TypeError, match="^camera must be a Camera or a FisheyeCamera; got str"):
        RenderResult(z[None], z[None], z[None], np.zeros((1, 2)), z, "camera", settings)


@pytest.mark.parametrize(
    ("args", "exc", "message"),
    [
        (("a", 1.0, 1.5), TypeError, "^cos_i must be"),
        ((None, 1.0, 1.5), (TypeError, ValueError), "^cos_i must be"),
        ((np.nan, 1.0, 1.5), ValueError, "^cos_i must be finite"),
        ((2.0, 1.0, 1.5), ValueError, r"^cos_i must be in \[0, 1\]; got 2..2"),
        ((0.5, -1.0, 1.5), ValueError, "^n1 must be > 0; got min -1"),
        (([0.5, 0.2, 0.1], 1.0, [1.0, 2.0]), ValueError, "^cos_i, n1 and n2 must broadcast together"),
    ],
)
def test_schlick_refuses_bad_arguments(args, exc, message):
    from vergence.render import schlick

    with pytest.raises(exc, match=message):
        schlick(*args)


# Scene limits (the old sweep): a scene past float32 precision, an overflowing sky, an unphysical glass.
@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        ("objects.0.center", [2e5, 0, 0], r"objects\[0\] \(sphere\): center must lie within 100000 m of the origin "
                                          r"\(MAX_SCENE_EXTENT\); reaches 200000 m"),
        ("objects.0.radius", 1e300, r"sphere must lie within 100000 m .*reaches 1e\+300 m"),
        ("camera.position", [0, 1, 1e6], r"camera: position must lie within 100000 m"),
        ("environment.color", [1e300, 1, 1], r"environment: color x intensity must be <= 1e\+07 \(MAX_RADIANCE\); "
                                             r"got 1e\+300"),
        ("materials.m", {"type": "glass", "ior": 1e9}, r"materials\['m'\]: ior must be in \[1, 4\] \(IOR_RANGE\); "
                                                       r"got 1e\+09"),
        ("materials.m", {"type": "glass", "ior": 0.5}, r"ior must be in \[1, 4\] \(IOR_RANGE\); got 0.5"),
    ],
)
def test_scene_limits(path, value, message):
    data = copy.deepcopy(MINIMAL)
    *keys, last = path.split(".")
    node = data
    for k in keys:
        node = node[int(k)] if k.isdigit() else node[k]
    node[int(last) if last.isdigit() else last] = value
    with pytest.raises(ValueError, match=message):
        scene_from_dict(data)


def test_scene_limits_admit_their_bounds():
    from vergence.render import IOR_RANGE, MAX_RADIANCE, Environment, Glass, Sphere

    assert Glass(ior=IOR_RANGE[0]).ior == 1.0 and Glass(ior=IOR_RANGE[1]).ior == 4.0
    assert Environment(color=[MAX_RADIANCE, 0, 0]).color[0] == MAX_RADIANCE
    assert Environment(color=[1, 1, 1], intensity=MAX_RADIANCE).intensity == MAX_RADIANCE
    Sphere(center=[99_999, 0, 0], radius=1.0, material="m")
    with pytest.raises(ValueError, match="MAX_RADIANCE"):
        Environment(image=np.full((2, 4, 3), 2.0, np.float32), intensity=MAX_RADIANCE)


@pytest.mark.parametrize(
    ("kwargs", "exc", "message"),
    [({"width": 3.5}, TypeError, "^width must be an integer; got float"), ({"samples": 0}, ValueError, "^samples must be >= 1"),
     ({"max_depth": -1}, ValueError, r"^max_depth must be an integer in \[0, 6\]; got -1"), ({"views": None}, TypeError, "^views")],
)
def test_render_cost_refuses_bad_arguments(kwargs, exc, message):
    from vergence.render import render_cost

    args = {"width": 4, "height": 3, "max_depth": 1, "samples": 1, **kwargs}
    with pytest.raises(exc, match=message):
        render_cost(args.pop("width"), args.pop("height"), **args)


def test_trace_rays_refuses_past_the_ray_limit():
    from vergence.render import Tracer, builtin_scene

    tracer = Tracer(builtin_scene("tabletop", width=4, height=3))
    with pytest.raises(ValueError, match=r"^tracing 2 rays with max_depth 2, samples 200000000 may cast up to 1.6e\+09 "
                                         r"rays; the limit is 1e\+09 \(MAX_RENDER_RAYS\)"):  # fmt: skip
        tracer.trace_rays(np.zeros((2, 3)), [[0, 0, -1], [0, 0, -1]], samples=200_000_000)
