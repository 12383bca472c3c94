"""General 3D warping: round trips between cameras, z-buffer vs McMillan order, epipole, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import Camera, look_at
from vergence.synthesis import epipole, forward_warp, refine_camera_warp, warp_to_camera
from vergence.synthesis._stages3d import mesh_links as _mesh_links

# Depths of a plane after a project/back-project round trip: float32 storage, ~1e-7 relative.
DEPTH_RTOL = 1e-6


def _cam(x=0.0, z=0.0, *, width=40, height=30, target=None) -> Camera:
    tgt = (x, 0.0, z + 1.0) if target is None else target
    return look_at([x, 0.0, z], tgt, [0.0, -1.0, 0.0], fov_deg=60.0, width=width, height=height)


def _texture(points: np.ndarray) -> np.ndarray:
    """A smooth grey texture painted on the world: value of each world point, in [0.1, 0.9]."""
    return (0.5 + 0.4 * np.sin(3.0 * points[..., 0]) * np.cos(2.0 * points[..., 1])).astype(np.float32)


def _frontal_plane(viewer: Camera, other: Camera, distance: float):
    """Depth maps of the plane ``distance`` in front of ``viewer``, parallel to its image plane."""
    normal = viewer.R[2]  # forward axis in world coordinates
    offset = normal @ viewer.center + distance

    def depth(cam: Camera) -> np.ndarray:
        rays = cam.ray_directions()
        t = (offset - normal @ cam.center) / (rays @ normal)
        return ((cam.center + rays * t[..., None]) - cam.center) @ cam.R[2]

    return depth(other), depth(viewer)


@pytest.mark.parametrize("swap", [False, True])
def test_plane_round_trip_between_two_cameras(swap):
    # A plane facing the target camera, seen obliquely by the source (moved and turned): every
    # warped pixel has exactly the target's depth, and the texture carried along matches the
    # texture at the target pixel's own plane point to within half a pixel of its slope.
    a = _cam(0.0)
    b = look_at([0.3, 0.1, -0.2], [0.1, 0.0, 4.0], [0.0, -1.0, 0.0], fov_deg=60.0, width=40, height=30)
    src, tgt = (b, a) if swap else (a, b)
    z_src, z_tgt = _frontal_plane(tgt, src, 3.0)
    img = _texture(src.backproject_depth(z_src))
    res = warp_to_camera(img, z_src, src, tgt)
    seen = ~res.holes
    assert seen.mean() > 0.5
    assert_allclose(res.depth[seen], 3.0, rtol=DEPTH_RTOL)
    truth = _texture(tgt.backproject_depth(z_tgt))
    # Texture slope <= 0.4 * 3.6 per metre; half a pixel at 3 m with f ~ 35 px is ~0.043 m.
    assert_allclose(res.image[seen], truth[seen], atol=1.44 * 0.5 * 3.0 / tgt.focal_px)


def test_identity_warp_is_exact():
    cam = _cam()
    img = np.random.default_rng(1).random((30, 40), dtype=np.float32)
    depth = np.random.default_rng(2).uniform(1.0, 5.0, (30, 40))
    res = warp_to_camera(img, depth, cam, cam)
    assert_array_equal(res.image, img)
    assert_allclose(res.depth, depth, rtol=DEPTH_RTOL)


def _slabs(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    z = np.full((h, w), rng.uniform(8.0, 12.0))
    for _ in range(4):  # random fronto-parallel slabs, as in spec/checks/verify_dibr_perception.py
        y0, y1 = sorted(rng.integers(0, h, 2))
        x0, x1 = sorted(rng.integers(0, w, 2))
        z[y0 : y1 + 1, x0 : x1 + 1] = rng.uniform(2.0, 12.0)
    return z


@pytest.mark.parametrize("gradient_limit", [None, 1.0])
@pytest.mark.parametrize("tx", [0.3, -0.25, 0.05])
def test_mcmillan_order_equals_zbuffer_on_rectified_rows(tx, gradient_limit):
    # McMillan 1997: for a sideways move the occlusion-compatible order gives the z-buffer result,
    # with point splats and with mesh facets (painted with their top-left pixel).
    rng = np.random.default_rng(int(abs(tx) * 100))
    src, tgt = _cam(0.0, width=60, height=20), _cam(tx, width=60, height=20)
    depth = _slabs(rng, 20, 60)
    img = rng.random((20, 60, 3), dtype=np.float32)
    zb = warp_to_camera(img, depth, src, tgt, order="zbuffer", gradient_limit=gradient_limit)
    mc = warp_to_camera(img, depth, src, tgt, order="mcmillan", gradient_limit=gradient_limit)
    assert_array_equal(mc.holes, zb.holes)
    assert_array_equal(mc.image, zb.image)
    assert_array_equal(mc.depth, zb.depth)


@pytest.mark.parametrize("gradient_limit", [None, 1.0])
@pytest.mark.parametrize("centre", [(0.3, 0.1, 1.0), (-0.4, 0.2, -1.5)])
def test_mcmillan_order_matches_zbuffer_visibility_in_2d(centre, gradient_limit):
    # McMillan 1997: with forward/backward moves (positive and negative epipoles) the painter's
    # order picks the same surface as the z-buffer except for rounding collisions (< 1 %).
    rng = np.random.default_rng(7)
    src = _cam(0.0, width=80, height=60)
    tgt = look_at(centre, np.add(centre, [0, 0, 1]), [0, -1, 0], fov_deg=60.0, width=80, height=60)
    depth = np.full((60, 80), 10.0)
    depth[15:40, 20:50] = 4.0
    depth[30:55, 45:70] = 6.0
    img = rng.random((60, 80), dtype=np.float32)
    zb = warp_to_camera(img, depth, src, tgt, gradient_limit=gradient_limit)
    mc = warp_to_camera(img, depth, src, tgt, order="mcmillan", gradient_limit=gradient_limit)
    both = ~zb.holes & ~mc.holes
    wrong = np.abs(zb.depth[both] - mc.depth[both]) > 0.5
    assert wrong.mean() < 0.01


def test_reversed_mcmillan_order_would_fail():
    # Negative control for the test above: painting away from a positive epipole lets the
    # background overwrite the foreground, which the z-buffer never does.
    src = _cam(0.0, width=80, height=60)
    tgt = look_at([0.3, 0.1, 1.0], [0.3, 0.1, 2.0], [0, -1, 0], fov_deg=60.0, width=80, height=60)
    assert epipole(src, tgt)[2] > 0
    depth = np.full((60, 80), 10.0)
    depth[15:40, 20:50] = 4.0
    zb = warp_to_camera(np.zeros((60, 80), np.float32), depth, src, tgt)
    # Paint far-first by hand in the wrong (ascending-distance) order: near pixels get overwritten.
    e = epipole(src, tgt)
    ys, xs = np.mgrid[0:60, 0:80]
    order = np.argsort(np.hypot(xs - e[0] / e[2], ys - e[1] / e[2]).ravel(), kind="stable")
    pix, z = tgt.project(src.backproject_depth(depth).reshape(-1, 3))
    out = np.full((60, 80), np.nan)
    for i in order:
        u, v = np.rint(pix[i]).astype(int)
        if 0 <= u < 80 and 0 <= v < 60:
            out[v, u] = z[i]
    both = ~zb.holes & ~np.isnan(out)
    assert np.mean(np.abs(out[both] - zb.depth[both]) > 0.5) > 0.01


def test_epipole_signs():
    src = _cam(0.0)
    assert epipole(src, _cam(0.0, z=1.0))[2] > 0  # target in front
    assert epipole(src, _cam(0.0, z=-1.0))[2] < 0  # behind
    e = epipole(src, _cam(0.2))
    assert e[2] == pytest.approx(0.0, abs=1e-12) and e[0] > 0  # sideways: at infinity to the right


def test_rectified_3d_warp_matches_forward_warp_nearest_splats():
    # Two cameras side by side: d = f b / Z; the 3D point splat equals the rectified warp wherever
    # the latter moves a pixel by a whole number (constant depth with an integer disparity).
    src, tgt = _cam(0.0), _cam(0.1)
    f = src.focal_px
    depth = np.full((30, 40), f * 0.1 / 3.0)  # disparity exactly 3 px
    img = np.random.default_rng(3).random((30, 40, 3), dtype=np.float32)
    res3d = warp_to_camera(img, depth, src, tgt)
    res2d = forward_warp(img, np.full((30, 40), 3.0))
    assert_array_equal(res3d.holes, res2d.holes)
    assert_allclose(res3d.image, res2d.image, atol=1e-6)


def test_refine_closes_sampling_gaps_of_a_magnified_plane():
    # Moving toward a fronto-parallel plane magnifies it: point splats leave cracks that the median
    # depth + inverse warping closes with the right colour (a smooth ramp, exact to 1 grey level).
    # From 2 m to 1.7 m: 1.18x, so a 3x3 window meets at most one missing row and one missing column.
    src = _cam(0.0, width=40, height=30)
    tgt = _cam(0.0, z=0.3, width=40, height=30)
    depth = np.full((30, 40), 2.0)
    ramp = np.tile(np.linspace(0.0, 1.0, 40, dtype=np.float32), (30, 1))
    raw = warp_to_camera(ramp, depth, src, tgt, gradient_limit=None)  # point splats: cracks
    refined = refine_camera_warp(raw, ramp, depth, src, tgt)
    inner = np.zeros((30, 40), bool)
    inner[8:22, 10:30] = True
    assert raw.holes[inner].any()
    assert not refined.holes[inner].any()
    # Target pixel x sees the plane point that the source saw at cx + (x - cx) * 1.7 / 2.0.
    cx = (40 - 1) / 2.0
    expected = (cx + (np.arange(40) - cx) * 1.7 / 2.0) / 39.0
    assert_allclose(refined.image[inner], np.broadcast_to(expected, (30, 40))[inner], atol=1.5 / 39.0)


# Mesh warp of a smooth texture: perspective-correct interpolation between pixel centres, so the
# error is the texture's curvature over one source pixel (slope 7 * 0.4 / m, pixel ~ 2 m / 35 px):
# a few thousandths; 0.01 leaves room while any crack (0) or wrong pixel (~0.4) fails.
MESH_ATOL = 0.01


@pytest.mark.parametrize("magnification", [1.5, 2.0, 3.0])
def test_mesh_warp_has_no_cracks_when_the_target_magnifies(magnification):
    # Moving toward a plane at 2 m (and turning a little) magnifies it; point splats leave cracks
    # (most of the target at 2x), the mesh closes them with the plane's own texture.
    w, h = 80, 60
    src = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60.0, width=w, height=h)
    z_t = 2.0 - 2.0 / magnification
    tgt = look_at([0, 0, z_t], [0.15, 0, z_t + 1.0], [0, -1, 0], fov_deg=60.0, width=w, height=h)

    def texture(p):
        return (0.5 + 0.4 * np.sin(7.0 * p[..., 0]) * np.cos(5.0 * p[..., 1])).astype(np.float32)

    depth = np.full((h, w), 2.0)
    img = texture(src.backproject_depth(depth))
    rays = tgt.ray_directions()
    points = tgt.center + rays * ((2.0 - tgt.center[2]) / rays[..., 2])[..., None]
    pix, _ = src.project(points)
    inside = (pix[..., 0] > 0) & (pix[..., 0] < w - 1) & (pix[..., 1] > 0) & (pix[..., 1] < h - 1)
    points_only = warp_to_camera(img, depth, src, tgt, gradient_limit=None)
    assert points_only.holes[inside].mean() > 0.3
    mesh = warp_to_camera(img, depth, src, tgt)
    assert not mesh.holes[inside].any()
    assert_allclose(mesh.image[inside], texture(points)[inside], atol=MESH_ATOL)
    assert_allclose(mesh.depth[inside], (points - tgt.center)[inside] @ tgt.R[2], rtol=DEPTH_RTOL)


def test_mesh_links_kernel_matches_the_camera_round_trip():
    # Slow reference: lift the right / lower neighbour with this pixel's depth through the Camera
    # API and measure how far its projection moves; linked when <= 1 px and both are drawable.
    rng = np.random.default_rng(11)
    src = _cam(0.0)
    tgt = look_at([0.2, -0.1, 0.4], [0.5, 0.0, 3.0], [0.0, -1.0, 0.0], fov_deg=50.0, width=40, height=30)
    depth = rng.uniform(1.0, 4.0, (30, 40)) * (1.0 + (rng.random((30, 40)) < 0.3))
    pix, zt = tgt.project(src.backproject_depth(depth))
    grid = src.pixel_grid()
    ok = np.isfinite(pix).all(axis=-1) & (zt > 0)
    expected = []
    for a, b in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))), ((slice(None, -1),), (slice(1, None),))):
        moved, _ = tgt.project(src.backproject(grid[b], depth[a]))
        link = np.zeros((30, 40), bool)
        link[a] = (np.hypot(*np.moveaxis(moved - pix[b], -1, 0)) <= 1.0) & ok[a] & ok[b]
        expected.append(link)
    u, v = (np.ascontiguousarray(pix[..., k].ravel()) for k in (0, 1))
    link_r, link_d = _mesh_links(depth, u, v, np.ascontiguousarray(zt.ravel()), src, tgt, 1.0)
    assert 0.1 < link_r.mean() < 0.9  # both outcomes occur
    assert_array_equal(link_r, expected[0])
    assert_array_equal(link_d, expected[1])


def test_mesh_warp_keeps_disocclusions_open():
    # Rectified pair, background d = 3 px, a slab d = 9 px: the 6-px jump is an occlusion boundary,
    # so the 6 columns the slab uncovers beside it stay holes, as in forward_warp.
    src, tgt = _cam(0.0), _cam(0.1)
    fb = src.focal_px * 0.1
    d = np.full((30, 40), 3.0)
    d[10:20, 15:25] = 9.0
    img = np.random.default_rng(4).random((30, 40), dtype=np.float32)
    mesh = warp_to_camera(img, fb / d, src, tgt)
    flat = forward_warp(img, d)
    assert mesh.holes[12:18, 16:22].all()  # the slab's columns 15..24 move to 6..15, background 25.. to 22..
    assert_array_equal(mesh.holes[:, :36], flat.holes[:, :36])
    assert_allclose(mesh.image[~mesh.holes], flat.image[~mesh.holes], atol=1e-6)


@pytest.mark.parametrize(
    ("depth", "kwargs", "error", "match"),
    [
        (np.full((30, 40), 2.0), {"gradient_limit": -1.0}, ValueError, "gradient_limit must be >= 0 or None; got -1"),
        (np.full((30, 40), 2.0), {"gradient_limit": np.nan}, ValueError, "gradient_limit must be finite"),
        (np.full((30, 41), 2.0), {}, ValueError, r"depth must have shape \(30, 40\) matching the source camera; got \(30, 41\)"),
        (np.full((30, 40), -1.0), {}, ValueError, "depth must be > 0 metres where known; got min -1"),
        (np.full((30, 40), np.inf), {}, ValueError, "depth must not contain inf"),
        (np.full((30, 40), np.nan), {}, ValueError, "at least one known value"),
        (np.full((30, 40), 2.0), {"order": "painter"}, ValueError, "order must be one of mcmillan, zbuffer; got 'painter'"),
    ],
)
def test_warp_to_camera_bad_input(depth, kwargs, error, match):
    cam = _cam()
    with pytest.raises(error, match=match):
        warp_to_camera(np.zeros((30, 40), np.float32), depth, cam, cam, **kwargs)


def test_warp_to_camera_refuses_non_cameras_and_mismatched_images():
    cam = _cam()
    with pytest.raises(TypeError, match="target must be a Camera; got dict"):
        warp_to_camera(np.zeros((30, 40)), np.ones((30, 40)), cam, {})
    with pytest.raises(ValueError, match=r"image must have shape \(30, 40\) matching the source camera"):
        warp_to_camera(np.zeros((20, 40)), np.ones((30, 40)), cam, cam)
