"""render_collection: a photo collection ray-traced from a scene (cameras on an arc), read back by
load_collection; its triangulated points lie on the scene's surfaces (the truth is known)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from vergence.io import read_cameras, read_image
from vergence.render import Tracer, builtin_scene, open_scene
from vergence.stereospace import load_collection, render_collection

W, H, VIEWS, ARC = 96, 72, 7, 48.0


@pytest.fixture(scope="module")
def tabletop(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tabletop")
    seen = []
    path = render_collection(builtin_scene("tabletop", width=W, height=H), folder, views=VIEWS, arc_deg=ARC,
                             samples=2, progress=lambda f, m: seen.append((f, m)))
    return path, folder, seen


def test_views_on_the_arc_around_the_look_at_point(tabletop):
    path, folder, seen = tabletop
    assert path == folder / "cameras.json"
    cameras = read_cameras(path)
    assert cameras.names == tuple(f"view_{i:02d}.png" for i in range(VIEWS))
    scene_camera = builtin_scene("tabletop", width=W, height=H).camera
    target, start = np.asarray(scene_camera.look_at), np.asarray(scene_camera.position)
    centres = np.array([c.center for c in cameras.cameras])
    radius = np.linalg.norm(start - target)
    assert np.allclose(np.linalg.norm(centres - target, axis=1), radius)
    assert np.allclose(centres[:, 1], start[1])  # the arc is horizontal (y up)
    assert np.allclose(centres[VIEWS // 2], start)  # odd views: the middle one is the scene camera's
    flat = centres - target
    angles = np.degrees(np.arctan2(flat[:, 0], flat[:, 2]))
    assert np.allclose(np.diff(angles), ARC / (VIEWS - 1))
    for name, cam in zip(cameras.names, cameras.cameras, strict=True):
        assert read_image(folder / name).shape[:2] == (H, W) and (cam.width, cam.height) == (W, H)
        # every view looks at the look-at point: it projects to the principal point
        assert np.allclose(cam.project(target[None])[0], [(W - 1) / 2, (H - 1) / 2], atol=1e-6)
    assert seen[-1][0] == 1.0 and all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))
    assert '"vergence-cameras"' in path.read_text()  # our JSON format, without points


def test_triangulated_points_lie_on_the_rendered_surfaces(tabletop):
    path, folder, _ = tabletop
    collection = load_collection(path, images=folder)
    assert len(collection) == VIEWS and collection.point_count > 100
    cam = collection.cameras[0]
    depth = np.asarray(Tracer(builtin_scene("tabletop", width=W, height=H)).render(cam, max_depth=0, samples=1).depth)
    px, z = cam.project(collection.points)
    inside = (px[:, 0] >= 0) & (px[:, 0] <= W - 1) & (px[:, 1] >= 0) & (px[:, 1] <= H - 1) & (z > 0)
    truth = depth[np.round(px[inside, 1]).astype(int), np.round(px[inside, 0]).astype(int)]
    ok = np.isfinite(truth)
    relative = np.abs(z[inside][ok] - truth[ok]) / truth[ok]
    assert ok.sum() > 50 and np.median(relative) < 0.02


def test_a_full_circle_does_not_repeat_its_first_view(tmp_path):
    path = render_collection(builtin_scene("tabletop", width=16, height=12), tmp_path, views=4, arc_deg=360, samples=1)
    centres = np.array([c.center for c in read_cameras(path).cameras])
    assert len({tuple(np.round(c, 9)) for c in centres}) == 4


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"views": 2}, ValueError, "views must be a whole number in \\[3, 360\\]"),
    ({"views": 3.0}, ValueError, "views"),
    ({"views": True}, ValueError, "views"),
    ({"arc_deg": 0}, ValueError, "arc_deg must be in \\(0, 360\\]"),
    ({"arc_deg": float("nan")}, ValueError, "arc_deg"),
    ({"arc_deg": 361}, ValueError, "arc_deg"),
])
def test_bad_arguments(tmp_path, kwargs, error, match):
    with pytest.raises(error, match=match):
        render_collection(builtin_scene("tabletop", width=16, height=12), tmp_path, **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_bad_scene_or_folder(tmp_path):
    with pytest.raises(TypeError, match="scene must be a vergence.render.Scene"):
        render_collection("tabletop", tmp_path)
    with pytest.raises(ValueError, match="folder must be an existing folder"):
        render_collection(builtin_scene("tabletop", width=16, height=12), tmp_path / "nope")
    fisheye = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "fisheye_room.json"
    if fisheye.is_file():
        with pytest.raises(ValueError, match="pinhole"):
            render_collection(open_scene(fisheye, width=16, height=16), tmp_path)
    scene = builtin_scene("tabletop", width=16, height=12)
    with pytest.raises(ValueError, match="pinhole"):
        render_collection(dataclasses.replace(scene, camera=dataclasses.replace(scene.camera, lens="fisheye",
                                                                                fov_deg=180)), tmp_path)


def test_the_start_is_the_most_comfortable_of_its_candidates(tabletop):
    """start_state: among the states between three consecutive cameras of a capture path, the smallest
    disparity range on the display (every candidate scored here through the public functions)."""
    from vergence.stereospace import (PreparedCollection, capture_paths, pair_cameras, pair_quality, start_state,
                                      state_near)
    from vergence.viewing import Display

    path, folder, _ = tabletop
    prepared = PreparedCollection(load_collection(path, images=folder), grid_step=16)
    display = Display.preset("desktop-24")
    state, (p, q, r), best = start_state(prepared, display)
    ranges = []
    for cams in capture_paths(prepared.graph):
        for a, b, c in zip(cams, cams[1:], cams[2:]):
            candidate = state_near(prepared, a, b, c, 0.5)
            pair = pair_cameras(prepared.space, prepared.collection, candidate, segment_cameras=prepared.segment_cameras)
            ranges.append(pair_quality(prepared.collection, pair, display)["range_arcmin"])
    assert best == min(r for r in ranges if r is not None)
    assert state == state_near(prepared, p, q, r, 0.5)
    with pytest.raises(ValueError, match="not joined by a segment"):
        state_near(prepared, 0, VIEWS - 1, 1, 0.5)
