"""Ray-tree renders checked against geometry worked out by hand (S3 §3.1; Whitted 1980, Schlick 1994).

All renders are tiny (33 x 25 unless stated) and deterministic (no rng) so the file stays fast.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.render import (
    Diffuse,
    Environment,
    FisheyeCamera,
    Glass,
    Mirror,
    Rectangle,
    Scene,
    SceneCamera,
    Sphere,
    builtin_scene,
    layer_names,
    load_scene,
    render,
    render_stereo,
    scene_from_dict,
)
from vergence.rigs import stereo_pair
from vergence.viewing.geometry import Shooting, disparity

W, H = 33, 25  # odd sizes: pixel (16, 12) lies on the optical axis
CX, CY = 16, 12
# Results are stored as float32: positions of ~10 m carry ~1e-6 m of rounding, radiance ~1e-7.
POS_ATOL = 1e-5
RAD_RTOL = 1e-6
# Reprojection of float32 positions through float64 cameras: far below a thousandth of a pixel.
PIX_ATOL = 1e-3


def _scene(objects, materials, *, env=(1.0, 1.0, 1.0), camera=None) -> Scene:
    cam = camera or SceneCamera(position=(0, 0, 0), look_at=(0, 0, -1), up=(0, 1, 0), fov_deg=40.0, width=W, height=H)
    return Scene(camera=cam, environment=Environment(color=env), materials=materials, objects=tuple(objects))


def _backdrop(z: float, facing: float = 1.0, size: float = 400.0) -> Rectangle:
    return Rectangle(center=(0, 0, z), normal=(0, 0, facing), up=(0, 1, 0), size=(size, size), material="wall")


@pytest.fixture(scope="module")
def glasses():
    """The built-in glasses scene at 32 x 24 (constant sky: independent of the shared data)."""
    from dataclasses import replace

    scene = builtin_scene("glasses", width=32, height=24)
    scene = replace(scene, environment=Environment(color=(0.9, 0.8, 0.7)))
    return render(scene, samples=4)


def test_result_shapes_and_dtypes(glasses):
    assert glasses.radiance.shape == (7, 24, 32, 3) and glasses.radiance.dtype == np.float32
    assert glasses.position.shape == glasses.normal.shape == (7, 24, 32, 3)
    assert glasses.depth.shape == (24, 32) and glasses.beauty.shape == (24, 32, 3)
    assert glasses.n_layers == 7 and glasses.settings.max_depth == 2 and glasses.settings.deterministic
    assert layer_names(2) == ["first hit", "R", "T", "RR", "RT", "TR", "TT"]
    with pytest.raises(ValueError, match="read-only"):
        glasses.radiance[0, 0, 0, 0] = 1.0


def test_layers_sum_to_beauty_and_tree_structure(glasses):
    assert_array_equal(glasses.beauty, glasses.radiance.sum(axis=0))
    # The glasses scene exercises every branch: reflections, refractions and their children.
    exists = ~np.isnan(glasses.position[..., 0])
    assert exists[[0, 1, 2, 6]].any(axis=(1, 2)).all()
    for i in range(2, 8):  # a child exists only where its parent hit a surface
        parent = i // 2
        orphan = ~exists[parent - 1] & exists[i - 1]
        assert not orphan.any(), f"node {i} exists where node {parent} does not"
    # Radiance is never negative; unit normals face the arriving ray at the first hit.
    assert (glasses.radiance >= 0).all()
    n, p = glasses.normal[0], glasses.position[0]
    ok = exists[0]
    assert_allclose(np.linalg.norm(n[ok], axis=-1), 1.0, atol=1e-6)
    assert (np.einsum("ik,ik->i", n[ok], p[ok] - glasses.camera.center) < 0).all()


def test_first_hit_positions_project_to_their_pixel_centres(glasses):
    cam = glasses.camera
    ok = ~np.isnan(glasses.depth)
    assert ok.mean() > 0.9
    pix, z = cam.project(glasses.position[0][ok])
    assert_allclose(pix, cam.pixel_grid()[ok], atol=PIX_ATOL)
    assert_allclose(z, glasses.depth[ok], rtol=1e-6)


def test_sphere_depth_by_hand():
    scene = _scene([Sphere(center=(0, 0, -5), radius=1.0, material="m")], {"m": Diffuse(color=(0.5, 0.5, 0.5))})
    res = render(scene, max_depth=0, samples=2)
    assert res.n_layers == 1
    # The nearest point of the sphere, on the axis: z = 5 - 1.
    assert res.depth[CY, CX] == pytest.approx(4.0, abs=POS_ATOL)
    assert_allclose(res.position[0, CY, CX], [0, 0, -4], atol=POS_ATOL)
    assert_allclose(res.normal[0, CY, CX], [0, 0, 1], atol=1e-6)
    # Every pixel: t = -b - sqrt(b^2 - c) with b = d.(o - c), c = |o - c|^2 - r^2; depth = t d_z(camera).
    cam = scene.camera.build()
    d = cam.ray_directions()
    b = d @ np.array([0.0, 0.0, 5.0])
    disc = b * b - 24.0
    t = -b - np.sqrt(np.where(disc > 0, disc, np.nan))
    expected = t * (d @ cam.R[2])
    clear = np.abs(disc) > 1e-2  # leave out pixels grazing the silhouette
    assert_array_equal(np.isnan(res.depth)[clear], np.isnan(expected)[clear])
    assert_allclose(res.depth[clear], expected[clear], rtol=1e-6)


def test_unoccluded_diffuse_radiance_is_albedo_times_sky():
    # Constant sky c: E = pi c, AO = 1, L = albedo / pi * E = albedo * c (S3 §3.1 shading).
    mats = {"wall": Diffuse(color=(0.5, 0.25, 1.0))}
    res = render(_scene([_backdrop(-3.0, size=1.5)], mats, env=(2.0, 2.0, 2.0)), samples=8)
    wall = ~np.isnan(res.position[0, ..., 0])
    assert 0 < wall.sum() < W * H
    assert_allclose(res.radiance[0][wall], np.broadcast_to([1.0, 0.5, 2.0], (wall.sum(), 3)), rtol=RAD_RTOL)
    # Escaping primary rays take the sky colour; nothing else exists.
    assert_allclose(res.radiance[0][~wall], 2.0, rtol=RAD_RTOL)
    assert np.isnan(res.position[1:]).all() and (res.radiance[1:] == 0).all()


def test_ambient_occlusion_of_a_half_space():
    # A floor in front of an (effectively) infinite wall behind the camera: every direction with
    # d_z > 0 is blocked, half of the cosine-weighted hemisphere: AO = 1/2, L = albedo c / 2.
    floor = Rectangle(center=(0, 0, 0), normal=(0, 1, 0), up=(0, 0, -1), size=(4000.0, 4000.0), material="floor")
    wall = Rectangle(center=(0, 0, 5), normal=(0, 0, -1), up=(0, 1, 0), size=(4000.0, 4000.0), material="floor")
    cam = SceneCamera(position=(0, 1, 0), look_at=(0, 0, -2), up=(0, 1, 0), fov_deg=30.0, width=W, height=H)
    scene = _scene([floor, wall], {"floor": Diffuse(color=(0.8, 0.8, 0.8))}, camera=cam)
    fixed = render(scene, samples=64)
    # The lattice splits the hemisphere unevenly by at most a few samples in 64.
    assert_allclose(fixed.radiance[0, ..., 1], 0.4, atol=0.4 * 0.06)
    noisy = render(scene, samples=64, rng=np.random.default_rng(7))
    assert noisy.radiance[0, ..., 1].mean() == pytest.approx(0.4, rel=0.02)
    assert noisy.radiance[0, ..., 1].std() > 0


def test_planar_mirror_image():
    n = np.array([0.0, 0.2, 1.0]) / np.linalg.norm([0.0, 0.2, 1.0])
    mirror = Rectangle(center=(0, 0, -4), normal=n, up=(0, 1, 0), size=(10.0, 10.0), material="mirror")
    mats = {"mirror": Mirror(color=(0.9, 0.8, 0.7)), "wall": Diffuse(color=(0.5, 0.5, 0.5))}
    res = render(_scene([mirror, _backdrop(6.0, facing=-1.0)], mats), samples=4)
    p1 = res.position[0].reshape(-1, 3).astype(np.float64)
    p2 = res.position[1].reshape(-1, 3).astype(np.float64)
    assert not np.isnan(p1).any() and not np.isnan(p2).any()
    # Mirror image of the camera centre C = 0 in the plane through (0, 0, -4) with normal n.
    c_img = -2.0 * np.dot(np.array([0.0, 0.0, 4.0]), n) * n
    # The reflected ray continues the line C' -> p1 until it meets the backdrop z = 6.
    s = (6.0 - c_img[2]) / (p1[:, 2] - c_img[2])
    expected = c_img + s[:, None] * (p1 - c_img)
    assert_allclose(p2, expected, atol=1e-4)
    # The mirror has no refraction child and no diffuse light of its own; its colour tints node 2.
    assert np.isnan(res.position[2]).all()
    assert (res.radiance[0] == 0).all()
    ratio = res.radiance[1] / np.array([0.9, 0.8, 0.7], dtype=np.float32)
    assert_allclose(ratio[..., 0], ratio[..., 1], rtol=1e-5)
    assert_allclose(ratio[..., 0], ratio[..., 2], rtol=1e-5)


@pytest.fixture(scope="module")
def glass_ball():
    ball = Sphere(center=(0, 0, -5), radius=1.5, material="glass")
    mats = {"glass": Glass(ior=1.5), "wall": Diffuse(color=(0.6, 0.6, 0.6))}
    return render(_scene([ball, _backdrop(-12.0)], mats), samples=4)


def test_refracted_ray_hits_the_back_surface(glass_ball):
    c, r, eta = np.array([0.0, 0.0, -5.0]), 1.5, 1.0 / 1.5
    d = glass_ball.camera.ray_directions().reshape(-1, 3)
    p1 = glass_ball.position[0].reshape(-1, 3).astype(np.float64)
    p3 = glass_ball.position[2].reshape(-1, 3).astype(np.float64)
    on = ~np.isnan(p1[:, 0]) & (np.abs(np.linalg.norm(p1 - c, axis=1) - r) < 1e-4)
    assert on.sum() > 50
    # Snell by hand at the entry point, then the chord: the second root of |p1 + s t - c| = r.
    nrm = (p1[on] - c) / r
    cos_i = -np.einsum("ij,ij->i", d[on], nrm)
    t = eta * d[on] + (eta * cos_i - np.sqrt(1 - eta**2 * (1 - cos_i**2)))[:, None] * nrm
    s = -2.0 * np.einsum("ij,ij->i", t, p1[on] - c)
    assert_allclose(p3[on], p1[on] + s[:, None] * t, atol=1e-4)
    assert_allclose(np.linalg.norm(p3[on] - c, axis=1), r, atol=1e-4)


def test_ray_through_the_centre_is_undeviated(glass_ball):
    p = glass_ball.position[:, CY, CX]
    assert_allclose(p[0], [0, 0, -3.5], atol=POS_ATOL)  # enters the front
    assert_allclose(p[2], [0, 0, -6.5], atol=POS_ATOL)  # node 3: the back surface, straight on
    assert_allclose(p[6], [0, 0, -12.0], atol=POS_ATOL)  # node 7: the wall, where no glass would put it
    assert_allclose(p[5], [0, 0, -3.5], atol=POS_ATOL)  # node 6: reflected back inside to the front


def test_glass_energy_at_normal_incidence():
    # Constant sky c, glass ball alone: through the centre R0 = 0.04 of the sky is reflected
    # (node 2), (1 - R0)^2 comes through (node 7), the inner reflection (node 6) is cut at D = 2.
    res = render(_scene([Sphere(center=(0, 0, -5), radius=1.5, material="g")], {"g": Glass(ior=1.5)}), samples=1)
    rad = res.radiance[:, CY, CX, 0]
    assert rad[1] == pytest.approx(0.04, rel=RAD_RTOL)
    assert rad[6] == pytest.approx(0.96**2, rel=RAD_RTOL)
    assert rad[0] == rad[2] == rad[5] == 0.0
    assert res.beauty[CY, CX, 0] == pytest.approx(0.04 + 0.96**2, rel=RAD_RTOL)


def test_total_internal_reflection():
    # Camera inside a glass ball, off centre: the axis ray meets the surface at
    # cos = 0.436 (64 deg > asin(1/1.5) = 41.8 deg): no refraction child, all light reflected.
    ball = Sphere(center=(0.9, 0, 0), radius=1.0, material="g")
    res = render(_scene([ball], {"g": Glass(ior=1.5)}), samples=1)
    p = res.position[:, CY, CX]
    assert_allclose(p[0], [0, 0, -np.sqrt(1 - 0.81)], atol=POS_ATOL)
    assert np.isnan(p[2]).all()  # node 3 does not exist
    assert abs(np.linalg.norm(p[1] - [0.9, 0, 0]) - 1.0) < 1e-4  # node 2 stays inside the ball


def test_stereo_rig_zero_disparity_at_H_and_eq1_elsewhere():
    # fx = 20 px: d = fx b (1/z - 1/H) = 20 * 0.4 * (1/2 - 1/4) = 2 px for a wall at z = 2, H = 4.
    fov = float(np.degrees(2 * np.arctan(W / 40.0)))
    cam = SceneCamera(position=(0, 0, 0), look_at=(0, 0, -1), up=(0, 1, 0), fov_deg=fov, width=W, height=H)
    mats = {"wall": Diffuse(color=(0.5, 0.5, 0.5))}
    for z, shift in ((4.0, 0), (2.0, 2)):
        left, right = render_stereo(_scene([_backdrop(-z)], mats, camera=cam), baseline=0.4, convergence=4.0, samples=1)
        # Pixel (x, y) of the left view sees what pixel (x - shift, y) of the right view sees.
        pl, pr = left.position[0], right.position[0]
        assert_allclose(pr[:, : W - shift], pl[:, shift:], atol=POS_ATOL)
        # And projecting the left points into the right camera gives S0 Eq. (1a).
        xl = left.camera.project(pl)[0][..., 0]
        xr = right.camera.project(pl)[0][..., 0]
        window = 4.0 * W / 20.0
        d = disparity(z, Shooting(baseline=0.4, convergence=4.0, window=window))
        assert_allclose((xr - xl) / W, d, atol=PIX_ATOL / W)
    expected_left, _ = stereo_pair(cam.build(), baseline=0.4, convergence=4.0)
    assert left.camera == expected_left


def test_fisheye_first_hits_project_to_their_pixels():
    fisheye = SceneCamera(position=(0, 0, 0), look_at=(0, 0, -1), up=(0, 1, 0), fov_deg=180.0, width=W, height=H,
                          lens="fisheye")  # fmt: skip
    mats = {"wall": Diffuse(color=(0.5, 0.5, 0.5))}
    room = [_backdrop(-2.0, size=6.0), Sphere(center=(1.0, 0.2, -1.0), radius=0.4, material="wall")]
    res = render(_scene(room, mats, camera=fisheye), max_depth=0, samples=1)
    assert isinstance(res.camera, FisheyeCamera)
    ok = ~np.isnan(res.depth)
    assert ok.sum() > 100 and not ok[0, 0]  # corners are outside the image circle
    pix, z = res.camera.project(res.position[0][ok])
    grid = np.stack(np.meshgrid(np.arange(W), np.arange(H)), axis=-1)[ok]
    assert_allclose(pix, grid, atol=PIX_ATOL)
    assert_allclose(z, res.depth[ok], rtol=1e-6)


def test_environment_map_seen_by_escaping_rays():
    img = np.tile(np.arange(1.0, 5.0)[None, :, None], (2, 1, 3)).astype(np.float32)
    scene = Scene(camera=_scene([], {}).camera, environment=Environment(image=img, intensity=2.0), materials={}, objects=())
    res = render(scene, samples=1)
    # The axis looks down -z at the horizon: between columns 1 and 2, (2 + 3) / 2, times 2.
    assert_allclose(res.radiance[0, CY, CX], [5.0] * 3, rtol=1e-5)
    assert np.isnan(res.depth).all()


def test_mesh_from_obj_file(tmp_path):
    corners = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    text = "".join(f"v {x} {y} {z}\n" for x, y, z in corners) + "".join(
        "f " + " ".join(str(i + 1) for i in q) + "\n" for q in quads
    )
    (tmp_path / "cube.obj").write_text(text)
    data = {
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0], "fov_deg": 40, "width": W, "height": H},
        "environment": {"color": [1, 1, 1]},
        "materials": {"m": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}},
        "objects": [{"type": "mesh", "path": "cube.obj", "material": "m", "smooth": False,
                     "transform": {"translate": [0, 0, -6], "scale": 0.5, "rotate_deg": [0, 45, 0]}}],
    }  # fmt: skip
    res = render(scene_from_dict(data, base_dir=tmp_path), max_depth=0, samples=1)
    # A unit-half-size cube turned 45 deg about y: its front edge is 0.5 sqrt(2) in front of the centre.
    assert res.depth[CY, CX] == pytest.approx(6.0 - 0.5 * np.sqrt(2.0), abs=POS_ATOL)
    assert_allclose(np.abs(res.normal[0, CY, CX]), [np.sqrt(0.5), 0, np.sqrt(0.5)], atol=1e-6)


def test_determinism_and_seeds():
    scene = builtin_scene("tabletop", width=16, height=12)
    a, b = render(scene, samples=4), render(scene, samples=4)
    assert_array_equal(a.radiance, b.radiance)
    c = render(scene, samples=4, rng=np.random.default_rng(3))
    d = render(scene, samples=4, rng=np.random.default_rng(3))
    e = render(scene, samples=4, rng=np.random.default_rng(4))
    assert_array_equal(c.radiance, d.radiance)
    assert not np.array_equal(c.radiance, e.radiance)
    assert_array_equal(c.position, a.position)  # only the shading is random


def test_render_bad_input():
    scene = _scene([], {})
    with pytest.raises(TypeError, match="scene must be a vergence.render.Scene; got dict"):
        render({})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"max_depth must be an integer in \[0, 6\]; got 7"):
        render(scene, max_depth=7)
    with pytest.raises(ValueError, match="samples must be >= 1; got 0"):
        render(scene, samples=0)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator or None; got int"):
        render(scene, rng=3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="camera must be a Camera, a FisheyeCamera or None; got str"):
        render(scene, camera="left")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="ao_distance must be > 0; got -1"):
        render(scene, ao_distance=-1.0)
    with pytest.raises(TypeError, match="render_stereo needs a pinhole Camera; got FisheyeCamera"):
        render_stereo(scene, baseline=0.1, convergence=2.0,
                      camera=FisheyeCamera(R=np.eye(3), t=np.zeros(3), width=8, height=8, fov_deg=90.0))  # fmt: skip


def test_stereo_preview_one_call():
    from vergence.render import stereo_preview

    pair = stereo_preview("tabletop", width=16, height=12, samples=1)
    assert pair.left.shape == pair.right.shape == (12, 16, 3) and pair.left.dtype == np.float32
    assert 0.0 <= pair.left.min() and pair.left.max() <= 1.0
    assert (pair.baseline, pair.convergence) == (0.04, 1.2)  # the scene's rig
    assert_allclose(pair.right_result.camera.center - pair.left_result.camera.center,
                    0.04 * pair.left_result.camera.R[0], atol=1e-12)  # fmt: skip
    assert not np.array_equal(pair.left, pair.right)
    with pytest.raises(ValueError, match="scene 'scene' has no stereo block: give baseline and convergence"):
        stereo_preview(_scene([], {}))


def _own_rays(position, look_at, fov_deg, width, height, pp):
    """Unit ray directions by hand: right = f x up, down = f x right, fx = width / (2 tan(fov / 2))."""
    fwd = np.subtract(look_at, position) / np.linalg.norm(np.subtract(look_at, position))
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    f = width / (2.0 * np.tan(np.radians(fov_deg) / 2.0))
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    d = ((xs - pp[0]) / f)[..., None] * right + ((ys - pp[1]) / f)[..., None] * down + fwd
    return d / np.linalg.norm(d, axis=-1, keepdims=True), fwd


def test_scene_file_with_off_centre_principal_point_against_analytic_hits(tmp_path):
    # Two spheres and a finite tilted rectangle seen through an off-centre principal point: the
    # first hit of every pixel from ray-sphere / ray-plane algebra, independent of the library.
    cam = {"position": [0.3, 1.4, 5.0], "look_at": [0.1, 0.6, -1.0], "up": [0, 1, 0], "fov_deg": 55,
           "width": W, "height": H, "principal_point": [12.25, 15.5]}  # fmt: skip
    spheres = [([-1.0, 0.7, -1.0], 0.7), ([1.3, 0.5, 0.0], 0.5)]
    n = np.array([0.2, 0.0, 1.0]) / np.hypot(0.2, 1.0)
    rect_c, rect_up, rect_size = np.array([0.2, 2.0, -5.0]), np.array([0.0, 1.0, 0.0]), (6.0, 4.0)
    data = {
        "camera": cam, "environment": {"color": [1, 1, 1]},
        "materials": {"m": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}},
        "objects": [{"type": "sphere", "center": c, "radius": r, "material": "m"} for c, r in spheres]
        + [{"type": "rectangle", "center": rect_c.tolist(), "normal": [0.2, 0, 1], "up": rect_up.tolist(),
            "size": list(rect_size), "material": "m"}],
    }  # fmt: skip
    (tmp_path / "own.json").write_text(json.dumps(data))
    res = render(load_scene(tmp_path / "own.json"), max_depth=0, samples=1)
    d, fwd = _own_rays(cam["position"], cam["look_at"], cam["fov_deg"], W, H, cam["principal_point"])
    o = np.array(cam["position"], dtype=np.float64)
    best = np.full((H, W), np.inf)
    grazing = np.zeros((H, W), dtype=bool)
    for c, r in spheres:
        oc = o - np.array(c)
        b = d @ oc
        disc = b * b - (oc @ oc - r * r)
        t = -b - np.sqrt(np.abs(disc))
        best = np.where((disc >= 0) & (t > 0), np.minimum(best, t), best)
        grazing |= np.abs(disc) < 1e-3
    t = ((rect_c - o) @ n) / (d @ n)
    rel = o + t[..., None] * d - rect_c
    u_axis = np.cross(rect_up, n)
    inside = (np.abs(rel @ u_axis) <= rect_size[0] / 2) & (np.abs(rel @ rect_up) <= rect_size[1] / 2) & (t > 0)
    best = np.where(inside, np.minimum(best, t), best)
    grazing |= np.abs(np.abs(rel @ u_axis) - rect_size[0] / 2) < 1e-3
    hit = np.isfinite(best)
    assert 0.3 < hit.mean() < 0.95  # sky, spheres and wall all in view
    assert_array_equal(np.isnan(res.depth)[~grazing], ~hit[~grazing])
    ok = hit & ~grazing
    expected = o + best[..., None] * d
    assert_allclose(res.position[0][ok], expected[ok], atol=POS_ATOL)
    assert_allclose(res.depth[ok], (best * (d @ fwd))[ok], rtol=1e-6)


def test_stereo_views_of_the_convergence_plane_coincide_off_centre():
    # A wall at depth H, off-centre principal point: both eyes see the same point at every pixel
    # (the same window, S0 §2); at depth z the left pixel x sees what the right pixel x - d sees,
    # d = fx b (1/z - 1/H) = 3 px here.
    cam = SceneCamera(position=(0, 0, 0), look_at=(0, 0, -1), up=(0, 1, 0), fov_deg=60.0, width=W, height=H,
                      principal_point=(10.0, 17.5))  # fmt: skip
    fx = W / (2.0 * np.tan(np.radians(30.0)))
    mats = {"wall": Diffuse(color=(0.5, 0.5, 0.5))}
    hc, z, shift = 3.0, 2.0, 3
    b = shift / (fx * (1.0 / z - 1.0 / hc))
    for depth, px in ((hc, 0), (z, shift)):
        left, right = render_stereo(_scene([_backdrop(-depth)], mats, camera=cam), baseline=b, convergence=hc, samples=1)
        assert_allclose(left.depth, depth, rtol=1e-6)
        assert_allclose(right.position[0][:, : W - px], left.position[0][:, px:], atol=POS_ATOL)


def test_out_of_memory_is_a_value_error(monkeypatch):
    from vergence.camera import Camera
    from vergence.render import RAY_GENERATORS

    def boom(camera):
        raise MemoryError

    monkeypatch.setitem(RAY_GENERATORS, Camera, boom)  # the first allocation of a render
    with pytest.raises(ValueError, match=r"width x height 33x25 with 7 layers does not fit in memory"):
        render(_scene([], {}))
