"""Scene files: the JSON format, its errors, mesh files, the example scenes, the built-in scenes."""

from __future__ import annotations

import copy
import json
import logging
import struct
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import Camera
from vergence.render import (
    BUILTIN_SCENES,
    FisheyeCamera,
    Glass,
    Mesh,
    Scene,
    builtin_scene,
    load_scene,
    open_scene,
    scene_from_dict,
)
from vergence.render.meshio import read_mesh

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples" / "scenes").glob("*.json"))

MINIMAL = {
    "camera": {"position": [0, 1, 4], "look_at": [0, 1, 0], "up": [0, 1, 0], "fov_deg": 40, "width": 64, "height": 48},
    "environment": {"color": [1, 1, 1]},
    "materials": {"m": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}, "g": {"type": "glass", "ior": 1.5}},
    "objects": [{"type": "sphere", "center": [0, 1, 0], "radius": 1, "material": "m"}],
}


def _with(path: str, value, *, delete: bool = False) -> dict:
    """A copy of MINIMAL with the entry at ``path`` ("objects.0.radius") replaced or deleted."""
    data = copy.deepcopy(MINIMAL)
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = data
    for k in keys[:-1]:
        node = node[k]
    if delete:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


def test_minimal_scene_and_defaults():
    scene = scene_from_dict(MINIMAL, name="mini")
    assert scene.name == "mini" and scene.stereo is None
    cam = scene.camera.build()
    assert isinstance(cam, Camera)
    assert cam.principal_point == (31.5, 23.5)  # ((W - 1)/2, (H - 1)/2)
    assert cam.fov_deg == pytest.approx(40.0)
    assert_allclose(cam.center, [0, 1, 4])
    assert isinstance(scene.materials["g"], Glass) and scene.materials["g"].ior == 1.5
    assert_allclose(scene.materials["g"].color, [1, 1, 1])
    assert scene.environment.intensity == 1.0 and scene.environment.image is None


def test_resized_camera_keeps_the_framing():
    data = _with("camera.principal_point", [40.0, 20.0])
    cam = scene_from_dict(data).camera
    half = cam.resized(width=32)
    assert (half.width, half.height) == (32, 24)
    # (c + 0.5) * new / old - 0.5: (40.5 / 2 - 0.5, 20.5 / 2 - 0.5)
    assert half.principal_point == pytest.approx((19.75, 9.75))
    assert half.build().fov_deg == pytest.approx(cam.build().fov_deg)
    assert cam.resized() is cam
    with pytest.raises(ValueError, match="height must be >= 1; got 0"):
        cam.resized(height=0)


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_scenes_load(path):
    scene = load_scene(path)
    assert scene.name == path.stem and scene.objects
    assert isinstance(scene.camera.build(), Camera | FisheyeCamera)


def test_examples_exist():
    assert {p.stem for p in EXAMPLES} >= {"spheres_and_mirror", "textured_vase", "fisheye_room", "far_mirror"}


BAD = [
    (_with("camera", None, delete=True), ValueError, r"scene is missing field\(s\) camera"),
    (_with("lights", []), ValueError, r"scene has unknown field\(s\) lights; valid fields: camera, description"),
    (_with("camera.fov_deg", None, delete=True), ValueError, r"camera is missing field\(s\) fov_deg"),
    (_with("camera.fov_deg", 180), ValueError, "fov_deg must lie strictly between 0 and 180; got 180"),
    (_with("camera.width", 0), ValueError, "camera: width must be >= 1; got 0"),
    (_with("camera.lens", "tilt-shift"), ValueError, "lens must be one of fisheye, pinhole; got 'tilt-shift'"),
    (_with("camera.up", [0, 0, 1]), ValueError, "up must not be parallel to the viewing direction"),
    (_with("objects.0.radius", -1), ValueError, r"objects\[0\] \(sphere\): radius must be > 0; got -1"),
    (_with("objects.0.radius", "big"), TypeError, r"objects\[0\] \(sphere\): radius must be a real number; got str"),
    (_with("objects.0.center", [0, 1]), ValueError, r"objects\[0\] \(sphere\): center must have shape \(3,?\); got \(2,\)"),
    (_with("objects.0.material", "gold"), ValueError, r"objects\[0\] uses unknown material 'gold'; defined: g, m"),
    (_with("objects.0.type", "cube"), ValueError, r"objects\[0\].type must be one of mesh, rectangle, sphere; got 'cube'"),
    (_with("objects.0.colour", [1, 0, 0]), ValueError, r"objects\[0\] \(sphere\) has unknown field\(s\) colour"),
    (_with("objects", {"a": 1}), TypeError, "objects must be a JSON list; got dict"),
    (_with("objects.0", 3), TypeError, r"objects\[0\] must be a JSON object; got int"),
    (_with("materials.m", [0.5, 0.5, 0.5]), TypeError, r"materials\['m'\] must be a JSON object; got list"),
    (_with("materials.m.type", "metal"), ValueError, r"materials\['m'\].type must be one of checker, diffuse"),
    (_with("materials.m.color", [0.5, 2.0, 0.5]), ValueError, r"materials\['m'\]: color must have components in \[0, 1\]"),
    (_with("materials.g.ior", 0), ValueError, r"materials\['g'\]: ior must be > 0; got 0"),
    (_with("materials.c", {"type": "checker", "colors": [[1, 1, 1]]}), ValueError, r"colors must have shape \(2, 3\)"),
    (_with("environment.color", [-1, 0, 0]), ValueError, r"environment: color must have components >= 0"),
    (_with("environment.intensity", -2), ValueError, "environment: intensity must be >= 0; got -2"),
    (_with("environment", {"hdr": "sky.png"}), ValueError, "environment.hdr must be a Radiance .hdr file; got 'sky.png'"),
    (_with("environment", {"color": [1, 1, 1], "hdr": "a.hdr"}), ValueError, r"environment has unknown field\(s\) color"),
    (_with("stereo", {"baseline": -0.1, "convergence": 2}), ValueError, "stereo: baseline must be > 0; got -0.1"),
    (
        _with("objects.0", {"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "up": [0, 2, 0],
                            "size": [1, 1], "material": "m"}),  # fmt: skip
        ValueError,
        "up must not be parallel to normal",
    ),
    (
        _with("objects.0", {"type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "up": [0, 0, 1],
                            "size": [1, 1], "material": "g"}),  # fmt: skip
        ValueError,
        r"objects\[0\]: glass 'g' needs a closed surface \(sphere or mesh\), not a rectangle",
    ),
    (_with("objects.0", {"type": "mesh", "path": "nowhere.obj", "material": "m"}), FileNotFoundError, "mesh file not found"),
    (_with("objects.0", {"type": "mesh", "path": "x.stl", "material": "m"}), ValueError, "mesh path must end in .obj or .ply"),
]


@pytest.mark.parametrize(("data", "exc", "match"), BAD, ids=[m[:40] for _, _, m in BAD])
def test_bad_scene_dicts(data, exc, match, tmp_path):
    with pytest.raises(exc, match=match):
        scene_from_dict(data, base_dir=tmp_path)


def test_bad_scene_files(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"camera": {,}')
    with pytest.raises(ValueError, match=r"scene file .*bad.json is not valid JSON: Expecting"):
        load_scene(bad)
    bad.write_text(json.dumps(_with("objects.0.radius", 0)))
    with pytest.raises(ValueError, match=r"^bad.json: objects\[0\] \(sphere\): radius must be > 0; got 0$"):
        load_scene(bad)
    with pytest.raises(FileNotFoundError, match="scene file not found"):
        load_scene(tmp_path / "missing.json")
    bad.write_text(json.dumps(_with("objects.0", {"type": "mesh", "path": "gone.obj", "material": "m"})))
    with pytest.raises(FileNotFoundError, match=r"^bad.json: objects\[0\] \(mesh\): mesh file not found: .*gone.obj$"):
        load_scene(bad)  # a missing file names the scene file too
    (tmp_path / "cube.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    textured = _with("objects.0", {"type": "mesh", "path": "cube.obj", "material": "c"})
    textured["materials"]["c"] = {"type": "checker", "colors": [[1, 1, 1], [0, 0, 0]]}
    with pytest.raises(ValueError, match="textured material 'c' needs a mesh with texture coordinates"):
        scene_from_dict(textured, base_dir=tmp_path)
    flat = _with("objects.0", {"type": "mesh", "path": "cube.obj", "material": "m", "transform": {"scale": 0}})
    with pytest.raises(ValueError, match="transform must be invertible; got determinant 0"):
        scene_from_dict(flat, base_dir=tmp_path)
    (tmp_path / "broken.obj").write_text("v 0 0 0\nf 1 2 3\n")
    broken = _with("objects.0", {"type": "mesh", "path": "broken.obj", "material": "m"})
    with pytest.raises(ValueError, match=r"cannot read mesh .*broken.obj: line 2: index 2 out of range \(1..1\)"):
        scene_from_dict(broken, base_dir=tmp_path)


def test_scene_class_validation():
    scene = scene_from_dict(MINIMAL)
    with pytest.raises(TypeError, match="camera must be a SceneCamera; got str"):
        Scene(camera="cam", environment=scene.environment, materials={}, objects=())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"faces must index vertices 0..2; got 0..3"):
        Mesh(vertices=np.zeros((3, 3)), faces=[[0, 1, 3]], material="m")


def _obj_and_ply(tmp_path: Path) -> tuple[Path, Path, Path]:
    verts = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0)]
    uv = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    obj = tmp_path / "quad.obj"
    obj.write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in verts) + "".join(f"vt {u} {v}\n" for u, v in uv)
        + "vn 0 0 1\n" + "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
    )  # fmt: skip
    head = ["ply", "format {}", "element vertex 4", "property float x", "property float y", "property float z",
            "property float nx", "property float ny", "property float nz", "property float u", "property float v",
            "element face 1", "property list uchar int vertex_indices", "end_header"]  # fmt: skip
    ascii_ = tmp_path / "quad_ascii.ply"
    rows = [f"{x} {y} {z} 0 0 1 {u} {v}" for (x, y, z), (u, v) in zip(verts, uv)]
    ascii_.write_text("\n".join(head).format("ascii 1.0") + "\n" + "\n".join(rows) + "\n4 0 1 2 3\n")
    binary = tmp_path / "quad_binary.ply"
    body = b"".join(struct.pack("<8f", x, y, z, 0, 0, 1, u, v) for (x, y, z), (u, v) in zip(verts, uv))
    body += struct.pack("<B4i", 4, 0, 1, 2, 3)
    binary.write_bytes(("\n".join(head).format("binary_little_endian 1.0") + "\n").encode() + body)
    return obj, ascii_, binary


def test_mesh_files_obj_and_ply_agree(tmp_path):
    meshes = [read_mesh(p) for p in _obj_and_ply(tmp_path)]
    for m in meshes:
        assert_array_equal(m.faces, [[0, 1, 2], [0, 2, 3]])  # the quad split into a fan
        assert_allclose(m.vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
        assert_allclose(m.uv, [[0, 0], [1, 0], [1, 1], [0, 1]])
        assert_allclose(m.normals, [[0, 0, 1]] * 4)
    bad = tmp_path / "bad.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n")
    with pytest.raises(ValueError, match="needs a 'vertex' element with x, y, z and a 'face' element"):
        read_mesh(bad)
    bad.write_bytes(b"PK\x03\x04 not a ply")
    with pytest.raises(ValueError, match="not a PLY file"):
        read_mesh(bad)


def test_builtin_scenes():
    assert BUILTIN_SCENES == ("glasses", "stadium", "tabletop")
    for name in BUILTIN_SCENES:
        scene = builtin_scene(name, width=40, height=30)
        assert scene.name == name and scene.stereo is not None
        assert (scene.camera.width, scene.camera.height) == (40, 30)
    stadium = builtin_scene("stadium")
    # S0 §4: the subject 30 m away, the rig converged on it, a long lens.
    assert stadium.stereo.convergence == 30.0 and stadium.camera.fov_deg == 8.0
    with pytest.raises(ValueError, match="unknown built-in scene 'moon'; valid scenes: glasses, stadium, tabletop"):
        builtin_scene("moon")


def test_open_scene(tmp_path):
    assert open_scene("tabletop", width=20).camera.height == 15
    (tmp_path / "s.json").write_text(json.dumps(MINIMAL))
    assert open_scene(tmp_path / "s.json", height=24).camera.width == 32
    with pytest.raises(ValueError, match="scene must be a scene file or one of glasses, stadium, tabletop; got 'moon'"):
        open_scene("moon")


def test_a_bare_built_in_name_is_never_shadowed(tmp_path, monkeypatch):
    """Issue 31: `vergence render glasses --out glasses/` made a folder that the README's next line,
    `vergence specular glasses`, then took for the scene ("scene glasses is a folder; give ... one of
    glasses, ..."). A bare name is the built-in; a file of that name is reached as a path."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "glasses").mkdir()
    wide = _with("camera.height", 32)  # 2:1, where the built-in tabletop is 4:3
    (tmp_path / "tabletop").write_text(json.dumps(wide))  # a file named as a built-in, no suffix
    assert open_scene("glasses", width=8).camera.width == 8  # the built-in, not the folder
    assert open_scene("tabletop", width=20).camera.height == 15  # the built-in, not the file
    assert open_scene("./tabletop", width=20).camera.height == 10  # the file, by its path
    assert open_scene(Path("tabletop"), width=20).camera.height == 10  # a Path is a path
    with pytest.raises(IsADirectoryError, match=r"^scene \./glasses is a folder; give a scene file \(\.json\), or a "
                                                 r"built-in scene by its bare name: glasses, stadium, tabletop$"):
        open_scene("./glasses")


def test_glasses_sky_from_shared_data(shared_data, monkeypatch):
    monkeypatch.setenv("VERGENCE_SHARED_DATA", str(shared_data))
    env = builtin_scene("glasses", width=8, height=6).environment
    assert env.image is not None and env.image.shape == (512, 1024, 3) and env.note is None
    assert env.source.endswith("venice_sunset_1k.hdr")


def test_glasses_sky_fallback_is_announced(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("VERGENCE_SHARED_DATA", str(tmp_path))
    with caplog.at_level(logging.WARNING, logger="vergence.render"):
        env = builtin_scene("glasses", width=8, height=6).environment
    assert env.image is None and env.source == "fallback"
    assert "venice_sunset_1k.hdr not found: constant sky colour [0.9, 0.8, 0.7] used instead" in env.note
    assert env.note in env.describe()
    assert any("not found" in r.getMessage() for r in caplog.records)


def test_scene_files_are_the_files_loading_reads(monkeypatch):
    """scene_files lists exactly what load_scene opens (textured_vase: an .hdr sky, a texture, a mesh)."""
    import vergence.io
    import vergence.render.scenefile as scenefile

    opened = []
    read_image, read_mesh_ = vergence.io.read_image, scenefile.read_mesh
    monkeypatch.setattr(vergence.io, "read_image", lambda p, *a, **k: opened.append(Path(p)) or read_image(p, *a, **k))
    monkeypatch.setattr(scenefile, "read_mesh", lambda p, *a, **k: opened.append(Path(p)) or read_mesh_(p, *a, **k))
    path = REPO / "examples" / "scenes" / "textured_vase.json"
    scene_data = json.loads(path.read_text())
    listed = scenefile.scene_files(scene_data, base_dir=path.parent)
    load_scene(path)
    assert sorted(listed) == sorted(opened) and len(listed) == 3
    assert scenefile.scene_files({**scene_data, "environment": {"color": [1, 1, 1]}}, base_dir=path.parent) == \
        tuple(p for p in listed if p.suffix != ".hdr")
    assert scenefile.scene_files({"materials": {"m": {"type": "texture", "path": "/abs/t.png"}}}) == (Path("/abs/t.png"),)
    assert scenefile.scene_files([1, 2]) == () and scenefile.scene_files({"objects": [{"type": "mesh", "path": 3}]}) == ()
