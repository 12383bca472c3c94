"""The on-surface and near-surface baselines of S3 §4.1.

References: a synthetic stereo ray tree built by hand (fronto-parallel planes, a texture linear in x
and y, which bilinear sampling reproduces exactly, so the expected layer is a formula), and a slow
per-pixel Python loop with its own projection and bilinear sampling, on a real render.
"""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import vergence.specular.surface_baselines as baselines_module
from vergence.camera import Camera, look_at
from vergence.rigs import stereo_pair
from vergence.specular import (
    NEAR_SURFACE_ARCMIN,
    SAME_SURFACE_FRACTION,
    layer_disparity,
    near_surface,
    on_surface,
)
from vergence.viewing import Display, pixels_from_arcmin

render = pytest.importorskip("vergence.render")  # RenderResult lives in the (Mitsuba) render package

# Radiance is sampled in float64 and stored in float32: equal to float32 rounding of values <= ~10.
RADIANCE_ATOL = 1e-5
W, H = 32, 12
BASELINE, CONVERGENCE = 0.2, 2.0
DISPLAY = Display.preset("samsung-2233rz")
OFFSET = 60.0  # arcmin: 37.1 display px, 0.71 image px at W = 32 (a non-integer shift)
# The left eye's own specular radiance in the synthetic pair: no right texture takes this value.
OWN = 7.0


def _rig(width: int = W, height: int = H) -> tuple[Camera, Camera]:
    cam = look_at([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0], fov_deg=60.0, width=width, height=height)
    return stereo_pair(cam, baseline=BASELINE, convergence=CONVERGENCE)


def _depth_for(disparity_px: float, cam: Camera) -> float:
    """The fronto-parallel depth whose points have disparity ``x_l - x_r = fx b (1/Z - 1/H)`` (stereo_pair, Notes)."""
    return 1.0 / (disparity_px / (cam.focal_px * BASELINE) + 1.0 / CONVERGENCE)


def _settings(max_depth: int):
    return render.RenderSettings(scene="synthetic", max_depth=max_depth, samples=1, deterministic=True,
                                 ao_distance=None, variant="none", environment="none")  # fmt: skip


def _linear(cam: Camera, i: int) -> np.ndarray:
    """Right eye's texture of layer i: linear in (x, y) per channel, in [0, 1]."""
    ys, xs = np.mgrid[0 : cam.height, 0 : cam.width].astype(np.float64)
    a = np.array([0.02, -0.01, 0.015]) * i
    return (0.3 + a * xs[..., None] + np.array([0.01, 0.02, -0.005]) * ys[..., None]).astype(np.float32)


def _eye(cam: Camera, depths: list[float], textures: list[np.ndarray]) -> object:
    """A RenderResult whose layer i is the plane z = depths[i] (NaN if None) with radiance textures[i]."""
    n = len(depths)
    pos = np.full((n, cam.height, cam.width, 3), np.nan, np.float32)
    nrm = np.full_like(pos, np.nan)
    for i, z in enumerate(depths):
        if z is not None:
            pos[i] = cam.backproject_depth(np.full((cam.height, cam.width), z))
            nrm[i] = (0.0, 0.0, -1.0)
    rad = np.stack(textures).astype(np.float32)
    depth = int(np.log2(n + 1)) - 1
    return render.RenderResult(radiance=rad, position=pos, normal=nrm, depth=pos[0, ..., 2].copy(),
                               beauty=rad.sum(axis=0), camera=cam, settings=_settings(depth))  # fmt: skip


def _pair(d0: float = 0.9237, d_behind: float = -1.0, d_front: float = 2.0):
    """Layer 0 a plane with disparity d0 px, layer 1 a plane behind it, layer 2 one in front (integer disparities)."""
    left, right = _rig()
    depths = [_depth_for(d, left) for d in (d0, d_behind, d_front)]
    own = np.full((H, W, 3), OWN, np.float32)
    diffuse = np.full((H, W, 3), 0.25, np.float32)
    left_eye = _eye(left, depths, [diffuse, own, own])
    right_eye = _eye(right, depths, [diffuse, _linear(right, 1), _linear(right, 2)])
    return left_eye, right_eye


def _expected(right_eye, i: int, x_sample: np.ndarray, d0: float) -> np.ndarray:
    """Right layer i's linear texture evaluated at (x_sample, y), the edge pixels repeated within half a pixel
    of the image's edge; OWN where x_sample or the surface's own projection x - d0 is off the image [-0.5, W - 0.5]."""
    xs = np.mgrid[0:H, 0:W][1].astype(np.float64)
    ys = np.mgrid[0:H, 0:W][0].astype(np.float64)
    a = np.array([0.02, -0.01, 0.015]) * i
    value = 0.3 + a * np.clip(x_sample, 0, W - 1)[..., None] + np.array([0.01, 0.02, -0.005]) * ys[..., None]
    inside = (x_sample >= -0.5) & (x_sample <= W - 0.5) & (xs - d0 >= -0.5) & (xs - d0 <= W - 0.5)
    return np.where(inside[..., None], value, OWN)


def _sign(d_layer: float, nominal: float) -> np.ndarray:
    """Expected s of a plane layer of integer disparity d_layer: +1 where its left pixel has no match on the right."""
    xs = np.mgrid[0:H, 0:W][1].astype(np.float64)
    return np.where((xs - d_layer < 0) | (xs - d_layer > W - 1), 1.0, nominal)


def test_doctests():
    assert doctest.testmod(baselines_module, raise_on_error=True).failed == 0


def test_near_surface_offset_is_ours_and_small():
    assert NEAR_SURFACE_ARCMIN == 5.0
    assert pixels_from_arcmin(NEAR_SURFACE_ARCMIN, DISPLAY) == pytest.approx(3.10, abs=0.01)


# ---------------------------------------------------------------------------------------------- on_surface
def test_on_surface_maps_the_right_texture_at_the_surface_disparity():
    left_eye, right_eye = _pair()
    d0 = left_eye.camera.focal_px * BASELINE * (1.0 / left_eye.position[0, 0, 0, 2] - 1.0 / CONVERGENCE)
    out = on_surface(left_eye, right_eye)
    xs = np.mgrid[0:H, 0:W][1].astype(np.float64)
    for i in (1, 2):
        assert_allclose(out.radiance[i], _expected(right_eye, i, xs - d0, d0), rtol=0, atol=RADIANCE_ATOL)
    assert (out.radiance[1] == OWN).all(axis=-1).sum() == H  # column 0 projects to u = -0.92, off the image: kept
    assert_array_equal(out.radiance[0], left_eye.radiance[0])
    for name in ("position", "normal", "depth"):
        assert_array_equal(getattr(out, name), getattr(left_eye, name))
    assert out.camera is left_eye.camera and out.settings is left_eye.settings
    assert_allclose(out.beauty, out.radiance.sum(axis=0), rtol=1e-6)


def test_on_surface_is_the_projection_of_each_pixel():
    """Layer i at p equals right's layer i at the projection of p's first hit (a random texture)."""
    left_eye, right_eye = _pair()
    rng = np.random.default_rng(3)
    right_eye = render.RenderResult(
        radiance=rng.random(right_eye.radiance.shape).astype(np.float32), position=right_eye.position,
        normal=right_eye.normal, depth=right_eye.depth, beauty=right_eye.beauty, camera=right_eye.camera,
        settings=right_eye.settings)  # fmt: skip
    out = on_surface(left_eye, right_eye)
    uv, _ = right_eye.camera.project(left_eye.position[0, 5, 10].astype(np.float64))
    u, v = uv
    x0, y0, fx, fy = int(np.floor(u)), int(np.floor(v)), u - np.floor(u), v - np.floor(v)
    r = right_eye.radiance[2].astype(np.float64)
    want = ((1 - fy) * ((1 - fx) * r[y0, x0] + fx * r[y0, x0 + 1])
            + fy * ((1 - fx) * r[y0 + 1, x0] + fx * r[y0 + 1, x0 + 1]))  # fmt: skip
    assert_allclose(out.radiance[2, 5, 10], want, rtol=0, atol=RADIANCE_ATOL)


def test_on_surface_keeps_the_physical_layer_where_the_right_eye_sees_another_surface():
    left_eye, right_eye = _pair()
    pos = np.array(right_eye.position)
    occluder = right_eye.camera.backproject_depth(np.full((H, W), 1.0))  # nearer than the plane (z = 1.5)
    pos[0, 3:7, 10:14] = occluder[3:7, 10:14]
    blocked = render.RenderResult(radiance=right_eye.radiance, position=pos, normal=right_eye.normal,
                                  depth=right_eye.depth, beauty=right_eye.beauty, camera=right_eye.camera,
                                  settings=right_eye.settings)  # fmt: skip
    out = on_surface(left_eye, blocked)
    u = right_eye.camera.project(left_eye.position[0].astype(np.float64))[0][..., 0]
    q = np.rint(u)
    hidden = np.zeros((H, W), bool)
    hidden[3:7] = (q[3:7] >= 10) & (q[3:7] < 14)
    assert hidden.sum() == 16
    kept = (out.radiance[1] == OWN).all(axis=-1)
    assert_array_equal(kept, hidden | (u < 0))


def test_the_silhouette_of_an_occluder_is_another_surface():
    """Points 0.3 m in front of the plane along the right eye's rays, with normals across those rays (the rim of a
    curved occluder): S lies on their tangent planes (n_P . (P - S) = 0), not they on S's, so the layer is kept."""
    left_eye, right_eye = _pair()
    cam = right_eye.camera
    rays = cam.ray_directions()
    plane = np.array(right_eye.position[0], dtype=np.float64)
    pos, nrm = np.array(right_eye.position), np.array(right_eye.normal)
    rim = (slice(3, 7), slice(10, 14))
    pos[0][rim] = plane[rim] - 0.3 * rays[rim]
    across = np.cross(rays[rim], [1.0, 0.0, 0.0])
    nrm[0][rim] = across / np.linalg.norm(across, axis=-1, keepdims=True)
    rimmed = render.RenderResult(radiance=right_eye.radiance, position=pos, normal=nrm, depth=right_eye.depth,
                                 beauty=right_eye.beauty, camera=cam, settings=right_eye.settings)  # fmt: skip
    out = on_surface(left_eye, rimmed)
    kept = (out.radiance[1] == OWN).all(axis=-1)
    assert kept[3:7].sum() == 16 + 4  # the 16 pixels seeing the rim, and column 0 (off the right image)
    assert_array_equal(kept, (out.radiance[2] == OWN).all(axis=-1))


def test_a_slanted_floor_is_the_same_surface_everywhere():
    """A tilted floor seen at grazing angles passes the tangent-plane test, at float32 rounding of its points (a
    plain 1 % distance would fail it at 32 px, and a zero tolerance too)."""
    left, right = _rig()
    n = 3
    up = np.array([0.15, -1.0, 0.1]) / np.linalg.norm([0.15, -1.0, 0.1])  # y points down: the floor faces up
    eyes = []
    for cam in (left, right):
        d = cam.ray_directions()
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (up @ np.array([0.0, 0.5, 2.0]) - up @ cam.center) / (d @ up)  # the plane through (0, 0.5, 2)
        t[~(t > 0)] = np.nan
        pos = np.full((n, H, W, 3), np.nan, np.float32)
        pos[0] = cam.center + t[..., None] * d
        nrm = np.full_like(pos, np.nan)
        nrm[0] = up
        rad = np.zeros((n, H, W, 3), np.float32)
        rad[1:] = OWN if cam is left else 0.5
        eyes.append(render.RenderResult(radiance=rad, position=pos, normal=nrm, depth=pos[0, ..., 2].copy(),
                                        beauty=rad.sum(axis=0), camera=cam, settings=_settings(1)))  # fmt: skip
    out = on_surface(*eyes)
    hit = np.isfinite(eyes[0].position[0, ..., 0])
    u = np.full((H, W), np.nan)
    u[hit] = right.project(eyes[0].position[0][hit].astype(np.float64))[0][:, 0]
    mapped = hit & (u >= -0.5) & (u <= W - 0.5)
    assert mapped.sum() > W * H // 5
    assert_array_equal((out.radiance[1:] == 0.5).all(axis=-1), np.broadcast_to(mapped, (2, H, W)))
    gaps = np.linalg.norm(np.diff(eyes[0].position[0], axis=0), axis=-1)  # metres between neighbouring rows
    dist = np.linalg.norm(eyes[0].position[0, :-1] - right.center, axis=-1)
    assert np.nanmax(gaps / dist) > 2 * SAME_SURFACE_FRACTION  # the rows really are far apart


def test_no_specular_layer_leaves_the_left_eye_unchanged():
    left_eye, right_eye = _pair()
    flat = []
    for eye in (left_eye, right_eye):
        rad = np.array(eye.radiance)
        rad[1:] = 0.0
        flat.append(render.RenderResult(radiance=rad, position=eye.position, normal=eye.normal, depth=eye.depth,
                                        beauty=rad.sum(axis=0), camera=eye.camera, settings=eye.settings))  # fmt: skip
    out = on_surface(*flat)
    assert_array_equal(out.radiance, flat[0].radiance)
    assert_array_equal(out.beauty, flat[0].beauty)
    one = [render.RenderResult(radiance=e.radiance[:1], position=e.position[:1], normal=e.normal[:1], depth=e.depth,
                               beauty=e.radiance[0], camera=e.camera, settings=_settings(0)) for e in flat]  # fmt: skip
    assert on_surface(*one) is one[0]
    assert near_surface(*one, DISPLAY) is one[0]


def test_inputs_are_not_modified():
    left_eye, right_eye = _pair()
    before = [np.array(a) for a in (left_eye.radiance, left_eye.beauty, right_eye.radiance)]
    near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=OFFSET)
    for a, b in zip(before, (left_eye.radiance, left_eye.beauty, right_eye.radiance), strict=True):
        assert_array_equal(a, b)


# ---------------------------------------------------------------------------------------------- near_surface
def test_near_surface_shifts_behind_and_in_front():
    left_eye, right_eye = _pair()
    d0 = left_eye.camera.focal_px * BASELINE * (1.0 / left_eye.position[0, 0, 0, 2] - 1.0 / CONVERGENCE)
    delta = pixels_from_arcmin(OFFSET, DISPLAY) * W / DISPLAY.resolution
    assert 0.5 < delta < 1.0
    out = near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=OFFSET)
    xs = np.mgrid[0:H, 0:W][1].astype(np.float64)
    # Layer 1 is behind the surface (s = +1): sampled at u + delta; layer 2 in front (s = -1): at u - delta,
    # but +1 in the columns x < 2 whose layer 2 has no match (its disparity is 2 px).
    assert_allclose(out.radiance[1], _expected(right_eye, 1, xs - d0 + delta, d0), rtol=0, atol=RADIANCE_ATOL)
    s2 = _sign(2.0, -1.0)
    assert (s2 > 0).sum() == 2 * H
    assert_allclose(out.radiance[2], _expected(right_eye, 2, xs - d0 + s2 * delta, d0), rtol=0, atol=RADIANCE_ATOL)


def test_near_surface_pushes_unmatched_layers_behind():
    left_eye, right_eye = _pair(d_front=2.0)
    pos = np.array(right_eye.position)
    pos[2] = np.nan  # layer 2 has no match anywhere: s = +1
    right_eye = render.RenderResult(radiance=right_eye.radiance, position=pos, normal=right_eye.normal,
                                    depth=right_eye.depth, beauty=right_eye.beauty, camera=right_eye.camera,
                                    settings=right_eye.settings)  # fmt: skip
    d0 = left_eye.camera.focal_px * BASELINE * (1.0 / left_eye.position[0, 0, 0, 2] - 1.0 / CONVERGENCE)
    delta = pixels_from_arcmin(OFFSET, DISPLAY) * W / DISPLAY.resolution
    out = near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=OFFSET)
    xs = np.mgrid[0:H, 0:W][1].astype(np.float64)
    assert_allclose(out.radiance[2], _expected(right_eye, 2, xs - d0 + delta, d0), rtol=0, atol=RADIANCE_ATOL)


def test_near_surface_at_zero_offset_is_on_surface():
    left_eye, right_eye = _pair()
    assert_array_equal(near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=0).radiance,
                       on_surface(left_eye, right_eye).radiance)  # fmt: skip


@settings(max_examples=25, deadline=None)
@given(d0=st.floats(-0.5, 2.5), offset=st.floats(0.0, 200.0))
def test_near_surface_formula_for_any_plane_and_offset(d0, offset):
    """Planes from 0.7 m to 7.2 m (disparities -2 to 5 px), offsets up to 200 arcmin (2.4 image px)."""
    d_behind, d_front = float(np.floor(d0) - 1.0), float(np.ceil(d0) + 2.0)
    left_eye, right_eye = _pair(d0=d0, d_behind=d_behind, d_front=d_front)
    delta = pixels_from_arcmin(offset, DISPLAY) * W / DISPLAY.resolution
    # a sample, or the surface's own projection, at a half pixel of the image's edge: float rounding decides
    edges = (-d0 + delta + 0.5) % 1.0, (-d0 - delta + 0.5) % 1.0, (-d0 + 0.5) % 1.0
    assume(all(min(e, 1.0 - e) > 1e-6 for e in edges))
    out = near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=offset)
    d = left_eye.camera.focal_px * BASELINE * (1.0 / left_eye.position[0, 0, 0, 2] - 1.0 / CONVERGENCE)
    xs = np.mgrid[0:H, 0:W][1].astype(np.float64)
    # s from the matching itself: whether a left pixel at the image's edge finds a neighbour within the cutoff
    # depends on the scene diameter; away from the edges layer 1 is behind (+1) and layer 2 in front (-1).
    disp = layer_disparity(left_eye.position, right_eye.position).disparity_px[..., 0]
    s1, s2 = np.where(-disp[1:] < -disp[0], -1.0, 1.0)
    assert (s1[:, 6:] == 1.0).all() and (s2[:, 6:] == -1.0).all()  # d_front <= 5 px
    assert_allclose(out.radiance[1], _expected(right_eye, 1, xs - d + s1 * delta, d), rtol=0, atol=RADIANCE_ATOL)
    assert_allclose(out.radiance[2], _expected(right_eye, 2, xs - d + s2 * delta, d), rtol=0, atol=RADIANCE_ATOL)


# ---------------------------------------------------------------------------------------------- slow reference
def _reference(left_eye, right_eye, delta: float = 0.0, sign: np.ndarray | None = None) -> np.ndarray:
    """The left radiance after the baseline, pixel by pixel: projection by K (R S + t), explicit bilinear weights."""
    cam = right_eye.camera
    n, h, w = left_eye.radiance.shape[:3]
    out = np.array(left_eye.radiance, dtype=np.float64)
    for y in range(h):
        for x in range(w):
            s = left_eye.position[0, y, x].astype(np.float64)
            if np.isnan(s).any():
                continue
            c = cam.R @ s + cam.t
            if c[2] <= 0:
                continue
            u, v = cam.K[0] @ c / c[2], cam.K[1] @ c / c[2]
            if not (-0.5 <= u <= w - 0.5 and -0.5 <= v <= h - 0.5):
                continue
            qx, qy = min(max(int(np.rint(u)), 0), w - 1), min(max(int(np.rint(v)), 0), h - 1)
            p = right_eye.position[0, qy, qx].astype(np.float64)
            tol = SAME_SURFACE_FRACTION * np.linalg.norm(s - cam.center)
            n_s = left_eye.normal[0, y, x].astype(np.float64)
            n_p = right_eye.normal[0, qy, qx].astype(np.float64)
            if not (abs(n_s @ (p - s)) <= tol and abs(n_p @ (p - s)) <= tol):
                continue
            for i in range(1, n):
                su = u + (0.0 if sign is None else sign[i - 1, y, x]) * delta
                if not -0.5 <= su <= w - 0.5:
                    continue
                cu, cv = min(max(su, 0.0), w - 1.0), min(max(v, 0.0), h - 1.0)  # the edge pixels repeat
                x0, y0 = int(np.floor(cu)), int(np.floor(cv))
                x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
                a, b = cu - x0, cv - y0
                r = right_eye.radiance[i].astype(np.float64)
                out[i, y, x] = ((1 - a) * (1 - b) * r[y0, x0] + a * (1 - b) * r[y0, x1]
                                + (1 - a) * b * r[y1, x0] + a * b * r[y1, x1])  # fmt: skip
    return out


@pytest.fixture(scope="module")
def glasses():
    scene = render.builtin_scene("glasses", width=24, height=16)
    left, right = stereo_pair(scene.camera.build(), baseline=0.4, convergence=50.0)
    tracer = render.Tracer(scene)
    return tracer.render(left, max_depth=2, samples=2), tracer.render(right, max_depth=2, samples=2)


def test_on_surface_matches_the_slow_reference_on_a_render(glasses):
    left_eye, right_eye = glasses
    out = on_surface(left_eye, right_eye)
    want = _reference(left_eye, right_eye)
    assert_allclose(out.radiance, want, rtol=1e-6, atol=RADIANCE_ATOL)
    changed = np.abs(out.radiance[1:] - left_eye.radiance[1:]).max(axis=-1) > 1e-3
    assert changed.sum() > 20  # the render has specular layers and the baseline moves them


def test_near_surface_matches_the_slow_reference_on_a_render(glasses):
    left_eye, right_eye = glasses
    disp = layer_disparity(left_eye.position, right_eye.position).disparity_px[..., 0]
    sign = np.where(-disp[1:] < -disp[0], -1.0, 1.0)  # NaN compares False: +1
    assert (sign < 0).any() and (sign > 0).any()
    delta = pixels_from_arcmin(OFFSET, DISPLAY) * 24 / DISPLAY.resolution
    out = near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=OFFSET)
    assert_allclose(out.radiance, _reference(left_eye, right_eye, delta, sign), rtol=1e-6, atol=RADIANCE_ATOL)


# ---------------------------------------------------------------------------------------------- errors
def test_bad_inputs():
    left_eye, right_eye = _pair()
    with pytest.raises(TypeError, match="left must be a vergence.render.RenderResult"):
        on_surface(left_eye.radiance, right_eye)
    with pytest.raises(TypeError, match="right must be a vergence.render.RenderResult"):
        near_surface(left_eye, None, DISPLAY)
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        on_surface(right_eye, left_eye)  # swapped eyes
    shallow = render.RenderResult(radiance=right_eye.radiance[:1], position=right_eye.position[:1],
                                  normal=right_eye.normal[:1], depth=right_eye.depth, beauty=right_eye.beauty,
                                  camera=right_eye.camera, settings=_settings(0))  # fmt: skip
    with pytest.raises(ValueError, match="right must have the layers and size of left"):
        on_surface(left_eye, shallow)
    with pytest.raises(TypeError, match="display must be a vergence.viewing.Display"):
        near_surface(left_eye, right_eye, "samsung")
    with pytest.raises(ValueError, match="resolution"):
        near_surface(left_eye, right_eye, Display(eye_separation=0.065, distance=0.6, width=0.47))
    for bad in (float("nan"), float("inf"), -1.0, 2e4):
        with pytest.raises(ValueError, match="offset_arcmin"):
            near_surface(left_eye, right_eye, DISPLAY, offset_arcmin=bad)
    with pytest.raises(TypeError, match="offset_arcmin must be a real number"):
        near_surface(left_eye, right_eye, DISPLAY, offset_arcmin="5")
