"""The fused IBR kernels (``_ibr_fused_kernels``) against the staged path they replaced (issue 31):
``_ibr_stages.ulr_staged`` (per-source full-frame maps: slopes, projection, visibility, colour; then
ULR weights; then the blend) and ``_ibr_stages.sample_sources_staged``, whose kernels are checked
against plain Python loops in test_ibr.py. Several scenes: a wall behind an occluder, sources of
two sizes, grazing ground (the slope-aware visibility test), random points (behind the sources,
outside their images, NaN) with random desired rays, and a range of ULR options."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import Camera, look_at
from vergence.synthesis import IBRSource, render_ibr
from vergence.synthesis import _ibr_fused_kernels, _ibr_stages
from vergence.synthesis.ibr import (
    IBR_OCCLUSION_SLOPE_CAP,
    IBR_OCCLUSION_TOLERANCE,
    ULR_FOV_BAND,
    ULR_GAMMA,
    ULR_PENALTY_FLOOR,
    ULR_RELATIVE_THRESHOLD,
    ULR_THRESHOLD_SCALE,
)

PLANE_Z = 10.0
# Fused against staged: the same float64 operations and float32 storage, but for the angle's
# arccos (fdlibm's in the fused kernel, within 1 ulp of the C library's). Measured on the scenes
# below (every option set of these tests) and on benchmarks/ibr.py's 1080p scene: max |difference|
# 0, weights and images equal to the last bit. 1e-6 (16 float32 steps at 1) leaves room for a
# 1-ulp angle moving a float32 weight by a step or two; a changed rule moves them by far more.
FUSED_ATOL = 1e-6


def _cam(x: float, *, look: float | None = None, y: float = 0.0, z: float = 0.0, width: int = 48, height: int = 36) -> Camera:
    aim = x if look is None else look
    return look_at([x, y, z], [aim, 0.0, PLANE_Z], [0.0, -1.0, 0.0], fov_deg=50.0, width=width, height=height)


def _texture(points: np.ndarray) -> np.ndarray:
    x, y = points[..., 0], points[..., 1]
    return np.stack([0.5 + 0.4 * np.sin(2 * x), 0.5 + 0.4 * np.cos(3 * y), 0.5 + 0.3 * np.sin(x + y)], axis=-1).astype(np.float32)


def _wall(cam: Camera, occluder: tuple[float, float, float] | None = (0.5, 5.0, 0.6)) -> tuple[np.ndarray, np.ndarray]:
    """Image and depth of the textured wall z = PLANE_Z behind a red square (x centre, z, half side)."""
    rays = cam.ray_directions()
    points = cam.center + ((PLANE_Z - cam.center[2]) / rays[..., 2])[..., None] * rays
    image = _texture(points)
    if occluder is not None:
        xo, zo, half = occluder
        hit = cam.center + ((zo - cam.center[2]) / rays[..., 2])[..., None] * rays
        inside = (np.abs(hit[..., 0] - xo) <= half) & (np.abs(hit[..., 1]) <= half)
        points = np.where(inside[..., None], hit, points)
        image[inside] = (1.0, 0.0, 0.0)
    return image, (points - cam.center) @ cam.R[2]


def _ground(x: float, height: float) -> tuple[Camera, np.ndarray, np.ndarray]:
    """A camera ``height`` m above the ground y = 0 looking along z nearly level (NaN sky)."""
    cam = look_at([x, -height, 0.0], [x, -height + 0.35, 10.0], [0.0, -1.0, 0.0], fov_deg=40.0, width=64, height=48)
    rays = cam.ray_directions()
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -cam.center[1] / rays[..., 1]
    points = cam.center + np.where(s > 0, s, np.nan)[..., None] * rays
    return cam, np.nan_to_num(_texture(points[..., [0, 2, 1]])), (points - cam.center) @ cam.R[2]


def _settings(*, cubic=True, k=4, gamma=ULR_GAMMA, relative=ULR_RELATIVE_THRESHOLD, cap=IBR_OCCLUSION_SLOPE_CAP,
              alpha=1.0, beta=0.1) -> _ibr_stages.ULRSettings:
    return _ibr_stages.ULRSettings(IBR_OCCLUSION_TOLERANCE, cap, cubic, k, alpha, beta, gamma, relative, ULR_FOV_BAND,
                                   ULR_PENALTY_FLOOR, ULR_THRESHOLD_SCALE)


def _wall_scene() -> tuple[np.ndarray, np.ndarray, list[IBRSource]]:
    srcs = [IBRSource(_cam(x, y=0.1 * x), *_wall(_cam(x, y=0.1 * x))) for x in (-1.0, -0.3, 0.4, 1.1)]
    big = _cam(0.1, width=96, height=72)  # a source of another size
    srcs.append(IBRSource(big, *_wall(big)))
    target = _cam(0.3, look=-0.2, z=1.0, width=40, height=30)
    points = _ibr_stages.backproject(target, _wall(target)[1])
    return points, target.center, srcs


def _ground_scene() -> tuple[np.ndarray, np.ndarray, list[IBRSource]]:
    srcs = [IBRSource(*_ground(x, h)) for x, h in ((-0.2, 0.27), (0.2, 0.34), (0.0, 0.31))]
    target, _, depth = _ground(0.05, 0.3)
    return _ibr_stages.backproject(target, depth), target.center, srcs


def _random_scene() -> tuple[np.ndarray, np.ndarray, list[IBRSource]]:
    """Points on the wall, in front of it, behind the sources, NaN; the sources see the occluded wall."""
    rng = np.random.default_rng(11)
    _, _, srcs = _wall_scene()
    h, w = 24, 32
    points = np.stack([rng.uniform(-8, 8, (h, w)), rng.uniform(-5, 5, (h, w)), rng.uniform(-3, 14, (h, w))], axis=-1)
    seen = srcs[1].camera.backproject_depth(srcs[1].depth)
    on = seen[rng.integers(0, 36, (h, w)), rng.integers(0, 48, (h, w))]
    points = np.where(rng.random((h, w, 1)) < 0.6, on, points)
    points[rng.random((h, w)) < 0.05] = np.nan
    return points, np.array([0.2, -0.1, -0.5]), srcs


def _step_scene() -> tuple[np.ndarray, np.ndarray, list[IBRSource]]:
    """A ramp (depth +0.05 m per column from 4 m) with a 0.12 m step between columns 23 and 24, and
    points near the step on the mesh that bridges it: there the slope on the step's side (0.17 m
    per pixel on its own) counts as at most SLOPE_RATIO times the other side's (0.05), which
    decides whether a point between the surfaces passes."""
    cam = _cam(0.0)
    cols = np.arange(cam.width, dtype=np.float64)
    depth = np.tile(4.0 + 0.05 * cols + 0.12 * (cols >= 24), (cam.height, 1))
    src = IBRSource(cam, np.tile(_texture(np.stack([cols, cols, cols], axis=-1))[None], (cam.height, 1, 1)), depth)
    rng = np.random.default_rng(5)
    u = rng.uniform(21.0, 26.0, (20, 30))
    v = rng.uniform(2.0, 33.0, (20, 30))
    near = 4.0 + 0.05 * u + 0.12 * np.clip(u - 23.0, 0.0, 1.0) * rng.uniform(0.0, 1.6, u.shape)  # bridge, +-
    points = cam.backproject(np.stack([u, v], axis=-1), near)
    other = _cam(0.4)  # a second source, which sees the wall: two sources to weigh where both see a point
    return points, np.array([0.3, 0.0, -1.0]), [src, IBRSource(other, *_wall(other))]


SCENES = {"ground": _ground_scene, "random": _random_scene, "step": _step_scene, "wall": _wall_scene}


def _compare(points, rays, centre, srcs, settings) -> float:
    fused = _ibr_stages.ulr_fused(points, rays, centre, srcs, settings)
    staged = _ibr_stages.ulr_staged(points, rays, centre, srcs, settings)
    assert_array_equal(fused[2], staged[2])  # coverage
    assert_allclose(fused[0], staged[0], rtol=0, atol=FUSED_ATOL)  # weights
    assert_allclose(fused[1], staged[1], rtol=0, atol=FUSED_ATOL)  # image
    return float(max(np.abs(fused[0] - staged[0]).max(), np.abs(fused[1] - staged[1]).max()))


@pytest.mark.parametrize("scene", sorted(SCENES))
@pytest.mark.parametrize("cubic", [True, False])
def test_fused_ulr_equals_the_staged_path(scene, cubic):
    points, centre, srcs = SCENES[scene]()
    fused_cov = _ibr_stages.ulr_fused(points, np.zeros((0, 0, 3)), centre, srcs, _settings(cubic=cubic))[2]
    assert 0.3 < fused_cov.mean() <= (0.9 if scene == "random" else 1.0)  # random: both outcomes, often
    _compare(points, np.zeros((0, 0, 3)), centre, srcs, _settings(cubic=cubic))


@pytest.mark.parametrize("cap", [0.0, 0.03, IBR_OCCLUSION_SLOPE_CAP])
def test_fused_visibility_follows_the_slope_cap_as_the_staged_one(cap):
    """Grazing ground: the slope cap decides which pixels pass (fewer at 0, issue 27's stripes)."""
    points, centre, srcs = _ground_scene()
    cov = _ibr_stages.ulr_fused(points, np.zeros((0, 0, 3)), centre, srcs, _settings(cap=cap))[2]
    full = _ibr_stages.ulr_fused(points, np.zeros((0, 0, 3)), centre, srcs, _settings())[2]
    assert cov.sum() < full.sum() or cap == IBR_OCCLUSION_SLOPE_CAP
    _compare(points, np.zeros((0, 0, 3)), centre, srcs, _settings(cap=cap))


@pytest.mark.parametrize(("k", "relative", "gamma"), [(1, 2.0, ULR_GAMMA), (2, 1.0, 0.1), (3, math.inf, 0.0),
                                                      (4, math.inf, ULR_GAMMA), (6, 2.0, 1.0)])
def test_fused_ulr_options_and_desired_rays_equal_the_staged_path(k, relative, gamma):
    """ULR options, and desired rays given per pixel (as under a world distortion): random rays."""
    points, centre, srcs = _wall_scene()
    rng = np.random.default_rng(k)
    rays = (points - centre) * rng.uniform(0.5, 2.0, points.shape[:2] + (1,)) + rng.normal(0, 0.2, points.shape)
    rays[rng.random(points.shape[:2]) < 0.05] = np.nan
    for r in (np.zeros((0, 0, 3)), rays):
        settings = _settings(k=k, relative=relative, gamma=gamma)
        _compare(points, r, centre, srcs, settings)
        w = _ibr_stages.ulr_fused(points, r, centre, srcs, settings)[0]
        assert ((w > 0).sum(axis=0) <= k).all()


def test_render_ibr_ulr_is_the_fused_path():
    """render_ibr's ULR result equals the staged path on its own proxy (forward-warped), both samplings."""
    _, _, srcs = _wall_scene()
    target = _cam(0.3, look=-0.2, z=1.0, width=40, height=30)
    for interpolation in ("cubic", "linear"):
        res = render_ibr(target, srcs, interpolation=interpolation)
        w, image, coverage = _ibr_stages.ulr_staged(res.proxy_points, np.zeros((0, 0, 3)), target.center, srcs,
                                                    _settings(cubic=interpolation == "cubic"))
        assert 0.8 < coverage.mean()
        assert_array_equal(res.coverage, coverage)
        assert_allclose(res.weights, w, rtol=0, atol=FUSED_ATOL)
        assert_allclose(res.image, image, rtol=0, atol=FUSED_ATOL)


@pytest.mark.parametrize("scene", sorted(SCENES))
@pytest.mark.parametrize("cubic", [True, False])
def test_sample_sources_equals_the_staged_sampling(scene, cubic):
    """The one-pass sampling of all sources (the Bayesian weights' input) equals the per-source
    kernel with its full-frame slope maps, to the last bit (the same operations)."""
    points, _, srcs = SCENES[scene]()
    for store in (True, False):
        got = _ibr_stages.sample_sources(points, srcs, IBR_OCCLUSION_TOLERANCE, IBR_OCCLUSION_SLOPE_CAP, store, cubic)
        ref = _ibr_stages.sample_sources_staged(points, srcs, IBR_OCCLUSION_TOLERANCE, IBR_OCCLUSION_SLOPE_CAP, store,
                                                cubic)
        assert 0 < ref[1].mean() < 1
        for a, b in zip(got, ref):
            assert_array_equal(a, b)


def test_side_slope_is_each_of_the_staged_slope_maps():
    rng = np.random.default_rng(4)
    depth = rng.uniform(1, 3, (7, 9))
    depth[rng.random(depth.shape) < 0.2] = np.nan
    depth[3, :] = np.nan  # a row with no vertical neighbours known
    for cap in (0.0, 0.05, 10.0):
        maps = _ibr_stages.surface_slopes(depth, cap)
        for side, (dx, dy) in enumerate(((-1, 0), (1, 0), (0, -1), (0, 1))):
            got = [[_ibr_fused_kernels.side_slope(depth, x, y, dx, dy, cap, 2.0) for x in range(9)] for y in range(7)]
            assert_array_equal(np.array(got), maps[side])


def test_acos_is_within_one_ulp_of_the_c_library():
    """fdlibm's arccos against numpy's over [-1, 1]: the branch points +-1/2, both ends, values near
    1 (small angles, the common case of ULR) and random values."""
    rng = np.random.default_rng(0)
    x = np.concatenate([np.linspace(-1, 1, 4001), 1 - np.logspace(-17, -1, 400), -1 + np.logspace(-17, -1, 400),
                        np.nextafter(0.5, [0, 1]), np.nextafter(-0.5, [-1, 0]), [-1.0, -0.5, 0.0, 0.5, 1.0],
                        rng.uniform(-1, 1, 4000)])
    got = np.array([_ibr_fused_kernels.acos(float(v)) for v in x])
    want = np.arccos(x)
    assert (np.abs(got - want) <= np.spacing(want)).all()
    assert (got == want).mean() > 0.9
