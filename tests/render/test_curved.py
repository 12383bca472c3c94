"""Curved rays (vergence.render.curved): a camera of a distorted world traced through the real scene.

Analytic scenes only. The curved map is the Tri-Rig's kind (S0 §6): a depth-dependent scaling about
the left centre c = 0, ``to_world(q) = g(z_q) q`` with ``g(z) = 1 + z / L``, seen by a camera offset
from c (through c the curves would stay straight). Along the ray of pixel direction ``r`` (unit
camera depth) from the centre C, ``P(z) = g(z) (C + z r)`` has real depth ``h(z) = z + z^2 / L``:
it meets the plane ``Z = z0`` at ``z* = (L / 2) (sqrt(1 + 4 z0 / L) - 1)``. Identity and affine maps
are checked against ``Tracer.render`` of the correspondingly moved straight camera.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import Camera, look_at
from vergence.render import (
    Checker,
    Diffuse,
    Environment,
    FisheyeCamera,
    Mirror,
    Rectangle,
    Scene,
    SceneCamera,
    Sphere,
    Tracer,
    render_curved,
)
from vergence.render import curved
from vergence.render.curved import INITIAL_SEGMENTS, sample_curves, trace_curved

SKY = (0.25, 0.5, 0.75)
W, H = 24, 16
BASE = 0.3  # the straight camera's offset from the origin, metres
OFFSET = 2.0  # the curved camera's offset from the scaling centre c = 0, metres: bends the curves
L = 1.0  # g(z) = 1 + z / L
Z_PLANE = 6.0
CAM = look_at([BASE, 0, 0], [BASE, 0, 1], [0, -1, 0], fov_deg=60, width=W, height=H)
OFF_CAM = look_at([OFFSET, 0, 0], [OFFSET, 0, 1], [0, -1, 0], fov_deg=60, width=W, height=H)
# Positions are stored as float32 (~1e-6 relative at ~10 m); depths likewise.
POS_ATOL = 2e-5
# Identity and affine maps: the same hits refined in float64 from other origins; radiance agrees to
# float32 rounding of the shading sums.
RAD_ATOL = 1e-5

PLANE = Rectangle(center=(0, 0, Z_PLANE), normal=(0, 0, -1), up=(0, 1, 0), size=(60, 60), material="checker")
BALL = Sphere(center=(0.6, 0.2, 3.5), radius=0.7, material="white")
MIRROR_BALL = Sphere(center=(-0.8, -0.3, 4.0), radius=0.5, material="mirror")
CURVED_BALL = Sphere(center=(5.0, 0.3, 3.5), radius=0.7, material="white")  # in view of OFF_CAM through bend


def _scene(objects) -> Scene:
    cam = SceneCamera(position=(BASE, 0, 0), look_at=(BASE, 0, 1), up=(0, -1, 0), fov_deg=60.0, width=W, height=H)
    mats = {"white": Diffuse(color=(0.6, 0.6, 0.6)), "mirror": Mirror(),
            "checker": Checker(colors=[[0.9, 0.9, 0.9], [0.1, 0.2, 0.1]], squares=(30, 30))}  # fmt: skip
    return Scene(camera=cam, environment=Environment(color=SKY), materials=mats, objects=tuple(objects))


@pytest.fixture(scope="module")
def tracer():
    return Tracer(_scene([PLANE, BALL, MIRROR_BALL]))


@pytest.fixture(scope="module")
def curved_tracer():
    return Tracer(_scene([PLANE, CURVED_BALL]))


def g(z):
    return 1.0 + z / L


def h_inv(zr):
    """Distorted depth of real depth zr: the root of z + z^2 / L = zr."""
    return 0.5 * L * (np.sqrt(1.0 + 4.0 * zr / L) - 1.0)


def bend(q):
    """to_world: g(z_q) q, scaling about c = 0 along the +z axis."""
    q = np.asarray(q, dtype=np.float64)
    return g(q[..., 2:3]) * q


def unbend(p):
    """phi = bend^-1."""
    zr = p[..., 2:3]
    return (h_inv(zr) / zr) * p


def _rays(camera: Camera) -> np.ndarray:
    ys, xs = np.mgrid[0 : camera.height, 0 : camera.width]
    pix = np.stack([xs, ys, np.ones_like(xs)], axis=-1).reshape(-1, 3).astype(np.float64)
    return pix @ np.linalg.inv(camera.K).T @ camera.R  # R^T K^-1 (x, y, 1): unit camera depth


def _pixel_error(camera: Camera, points: np.ndarray) -> np.ndarray:
    """Pixels between where the distorted point phi(points) projects and each pixel's centre."""
    px, _ = camera.project(unbend(points.reshape(-1, 3)))
    ys, xs = np.mgrid[0 : camera.height, 0 : camera.width]
    return np.hypot(px[:, 0] - xs.ravel(), px[:, 1] - ys.ravel())


# ---------------------------------------------------------------------------- (1) identity
def test_identity_map_reproduces_render(tracer):
    want = tracer.render(CAM, samples=4)
    got = trace_curved(tracer, CAM, lambda q: q, near=0.05, far=np.inf, samples=4)
    assert np.isfinite(want.depth).all() and (want.position[1] == want.position[1]).any()  # mirror layer used
    assert_allclose(got.depth, want.depth, rtol=1e-6)
    assert_allclose(got.position, want.position, atol=POS_ATOL)
    assert_allclose(got.radiance, want.radiance, atol=RAD_ATOL)
    assert_allclose(got.beauty, want.beauty, atol=RAD_ATOL)
    # Segments cast: each ray's up to the one holding its hit (identity: joints at the sample depths).
    joints = sample_curves(CAM, lambda q: q, near=0.05, far=np.inf)
    z = joints.depth[joints.start[0] : joints.start[1]]
    assert np.isfinite(want.depth).all() and (joints.segments == len(z) - 1).all()
    cast = np.searchsorted(z, want.depth.astype(np.float64), side="left").sum()
    assert got.settings.tree_rays == want.settings.tree_rays + cast  # segments + shading
    assert got.settings.ao_rays == want.settings.ao_rays


def test_module_level_render_curved_matches_the_method():
    scene = _scene([PLANE, CURVED_BALL])
    a = render_curved(scene, OFF_CAM, bend, near=0.1, far=np.inf, samples=2, max_depth=0)
    b = trace_curved(Tracer(scene), OFF_CAM, bend, near=0.1, far=np.inf, samples=2, max_depth=0)
    assert_array_equal(a.beauty, b.beauty)
    assert_array_equal(a.depth, b.depth)
    assert a.radiance.shape == (1, H, W, 3)


def test_hit_exactly_at_a_joint_is_neither_missed_nor_doubled():
    # near 1, far 5: the first joints lie at z = 5^(j/4) = 1, 1.50, 2.24, 3.34, 5 (INITIAL_SEGMENTS = 4
    # octave-bounded steps) for every pixel; a wall facing the camera at z = sqrt(5) meets every ray at a joint.
    cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=40, width=W, height=H)
    wall = Rectangle(center=(0, 0, np.sqrt(5.0)), normal=(0, 0, -1), up=(0, 1, 0), size=(10, 10), material="checker")
    t = Tracer(_scene([wall]))
    samples = sample_curves(cam, lambda q: q, near=1.0, far=5.0)
    assert_allclose(samples.depth[samples.start[:-1] + 2], np.sqrt(5.0), rtol=1e-12)  # the wall is at a joint
    got = trace_curved(t, cam, lambda q: q, near=1.0, far=5.0, samples=2)
    want = t.render(cam, samples=2)
    assert np.isfinite(got.depth).all()
    assert_allclose(got.depth, np.sqrt(5.0), rtol=1e-6)
    assert_allclose(got.beauty, want.beauty, atol=RAD_ATOL)


# ---------------------------------------------------------------------------- (2) affine maps
def test_rigid_motion_equals_the_moved_straight_camera(tracer):
    a = np.radians(20.0)
    rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    shift = np.array([0.4, -0.2, 0.5])
    # Rays from the camera of the distorted world: q = R^T (x_cam - t). In the real world p = rot q + shift.
    cam_q = look_at([BASE, 0, -0.5], [-1.0, 0, 8.0], [0, -1, 0], fov_deg=60, width=W, height=H)
    moved = Camera(cam_q.K, cam_q.R @ rot.T, cam_q.t - cam_q.R @ rot.T @ shift, W, H)
    want = tracer.render(moved, samples=4)
    got = trace_curved(tracer, cam_q, lambda q: q @ rot.T + shift, near=0.05, far=np.inf, samples=4)
    assert np.isnan(want.depth).sum() < W * H // 2
    assert_allclose(got.depth, want.depth, rtol=1e-6)
    assert_allclose(got.position, want.position, atol=POS_ATOL)
    assert_allclose(got.beauty, want.beauty, atol=RAD_ATOL)


def test_uniform_scaling_reports_the_distorted_depth(tracer):
    # p = c0 + s (q - c0): the straight camera (K, R, s t + (s - 1) R c0) sees the same; its depth is s z.
    s, c0 = 1.6, np.array([0.2, 0.1, 2.0])
    moved = Camera(CAM.K, CAM.R, s * CAM.t + (s - 1.0) * CAM.R @ c0, W, H)
    want = tracer.render(moved, samples=4)
    got = trace_curved(tracer, CAM, lambda q: c0 + s * (q - c0), near=0.05, far=np.inf, samples=4)
    assert_allclose(got.depth, want.depth / s, rtol=1e-6)
    assert_allclose(got.position, want.position, atol=POS_ATOL)
    assert_allclose(got.beauty, want.beauty, atol=RAD_ATOL)
    straight = sample_curves(CAM, lambda q: q, near=0.05, far=np.inf).segments  # one per octave of depth
    assert_array_equal(sample_curves(CAM, lambda q: c0 + s * (q - c0), near=0.05, far=np.inf).segments, straight)
    assert_array_equal(straight, np.ceil(np.log2(curved.CURVE_CUT_DEPTH / 0.05)))  # no split


# ---------------------------------------------------------------------------- (3) a curved map
def _reference_hits(camera: Camera):
    """Closed-form plane hits, sphere hits by dense search and bisection on the curve; per pixel."""
    r = _rays(camera)
    centre = camera.center
    z_plane = h_inv(Z_PLANE)
    s, rad = np.asarray(CURVED_BALL.center), CURVED_BALL.radius
    f = lambda z: np.sum((g(z)[..., None] * (centre + z[..., None] * r) - s) ** 2, axis=-1) - rad**2  # noqa: E731
    zs = np.linspace(0.05, z_plane, 4001)[:, None] * np.ones(len(r))
    vals = f(zs)
    inside = vals < 0
    first = np.argmax(inside, axis=0)
    on_ball = inside.any(axis=0)
    lo, hi = zs[np.maximum(first - 1, 0), np.arange(len(r))], zs[first, np.arange(len(r))]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        out = f(mid) > 0
        lo, hi = np.where(out, mid, lo), np.where(out, hi, mid)
    depth = np.where(on_ball, 0.5 * (lo + hi), z_plane)
    points = g(depth)[:, None] * (centre + depth[:, None] * r)
    # Pixels whose curve grazes the ball (closest approach within 0.1 radius of the surface) are ambiguous.
    closest = np.sqrt(np.maximum(vals.min(axis=0) + rad**2, 0.0))
    clear = np.abs(closest - rad) > 0.1 * rad
    return depth.reshape(camera.height, camera.width), points.reshape(camera.height, camera.width, 3), on_ball, clear


@pytest.mark.parametrize("tolerance_px", [0.25, 0.05])
def test_curved_map_hits_match_closed_form(curved_tracer, tolerance_px):
    depth, points, on_ball, clear = _reference_hits(OFF_CAM)
    assert 10 < on_ball.sum() < W * H - 100  # both the ball and the plane are seen
    got = trace_curved(curved_tracer, OFF_CAM, bend, near=0.05, far=np.inf, tolerance_px=tolerance_px, samples=2)
    m = clear.reshape(H, W)
    assert np.isfinite(got.depth).all()
    # As the camera sees them, the found hits lie within the tolerance of the pixel centres (the rule
    # bounds the polyline's gap to the curve; the hit's pixel error is that gap seen across the surface).
    err = _pixel_error(OFF_CAM, got.position[0].astype(np.float64)).reshape(H, W)
    assert err.max() <= 1.5 * tolerance_px
    # Depth and position: the gap in pixels times the metres of a pixel there (z g(z) / f), doubled
    # for surfaces at a slant to the gap.
    metres_px = 2.0 * tolerance_px * depth * g(depth) / OFF_CAM.K[0, 0]
    assert (np.abs(got.depth - depth)[m] <= metres_px[m] + POS_ATOL).all()
    assert (np.linalg.norm(got.position[0] - points, axis=-1)[m] <= metres_px[m] + POS_ATOL).all()
    assert_allclose(got.position[0][~on_ball.reshape(H, W), 2], Z_PLANE, atol=POS_ATOL)  # on the plane


def test_a_loose_tolerance_misses_where_a_tight_one_hits(curved_tracer):
    loose = trace_curved(curved_tracer, OFF_CAM, bend, near=0.05, far=np.inf, tolerance_px=4.0, samples=1, max_depth=0)
    err = _pixel_error(OFF_CAM, loose.position[0].astype(np.float64))
    assert err.max() > 1.5 * 0.25  # so the bound of the test above is not met by any polyline


def _worst_gap(cs, camera: Camera, phi) -> float:
    """Largest pixel distance between chord points, mapped back by ``phi``, and their pixel centre.

    Per chord: 33 evenly spaced points, and the points at real depths Z = 0.05 m to 10 km in steps
    of 2% (a chord reaching far away is checked near the camera too).
    """
    levels = np.geomspace(0.05, 1e4, 670)
    worst = 0.0
    for i in range(camera.width * camera.height):
        p = cs.points[cs.start[i] : cs.start[i + 1]]
        for a, b in zip(p[:-1], p[1:], strict=True):
            on = levels[(levels > min(a[2], b[2])) & (levels < max(a[2], b[2]))]
            s = np.concatenate([np.linspace(0.0, 1.0, 33), (on - a[2]) / (b[2] - a[2])])
            px, _ = camera.project(phi(a + s[:, None] * (b - a)))
            worst = max(worst, np.hypot(px[:, 0] - i % camera.width, px[:, 1] - i // camera.width).max())
    return worst


def test_sampling_rule_bounds_the_gap_along_every_chord():
    """Dense points of every chord, mapped back by phi, project within tolerance_px of their pixel."""
    for tol in (1.0, 0.25, 0.05):
        worst = _worst_gap(sample_curves(OFF_CAM, bend, near=0.05, far=40.0, tolerance_px=tol), OFF_CAM, unbend)
        assert 0.2 * tol < worst <= 1.1 * tol  # within the tolerance, and not over-split either
    tight = sample_curves(OFF_CAM, bend, near=0.05, far=40.0, tolerance_px=0.05).segments
    loose = sample_curves(OFF_CAM, bend, near=0.05, far=40.0, tolerance_px=1.0).segments
    assert (tight >= loose).all() and tight.mean() > 2 * loose.mean()
    assert tight.min() > INITIAL_SEGMENTS  # the curve bends: splits happen


def test_a_bend_far_from_the_camera_is_found():
    # Straight up to z = 30 m, then stretched: Z = z + (z - 30)^2 / 60 (scaling about c = 0), seen by a
    # narrow camera 0.3 m from c. Four first segments equal in 1/z from 0.5 m would end at 2 m and
    # CURVE_CUT_DEPTH: the chord of the last one runs along the straight ray and its midpoint (4 m)
    # does not bend, so nothing splits and the polyline misses the bend by ~0.15 px here (1.9 px at
    # 320 px wide); first segments of one octave each find it.
    def late(q):
        z = q[..., 2:3]
        return np.where(z > 30.0, (z + (z - 30.0) ** 2 / 60.0) / z, 1.0) * q

    def late_inv(p):
        zr = p[..., 2:3]
        return np.where(zr > 30.0, (30.0 + 30.0 * (np.sqrt(1.0 + np.abs(zr - 30.0) / 15.0) - 1.0)) / zr, 1.0) * p

    narrow = look_at([BASE, 0, 0], [BASE, 0, 1], [0, -1, 0], fov_deg=8, width=W, height=H)
    cs = sample_curves(narrow, late, near=0.5, far=np.inf, tolerance_px=0.02)
    assert_allclose(late_inv(late(cs.points)), cs.points, rtol=1e-12)
    assert _worst_gap(cs, narrow, late_inv) <= 1.1 * 0.02


def test_sample_depths_increase_and_points_are_the_map_of_the_straight_ray():
    cs = sample_curves(OFF_CAM, bend, near=0.5, far=30.0, tolerance_px=0.25)
    r = _rays(OFF_CAM)
    for i in (0, 100, W * H - 1):
        z = cs.depth[cs.start[i] : cs.start[i + 1]]
        assert z[0] == pytest.approx(0.5) and z[-1] == pytest.approx(30.0)
        assert (np.diff(z) > 0).all()
        assert_allclose(cs.points[cs.start[i] : cs.start[i + 1]], bend(OFF_CAM.center + z[:, None] * r[i]), rtol=1e-12)
    assert not cs.open_end.any()
    assert sample_curves(OFF_CAM, bend, near=0.5, far=np.inf).open_end.all()
    beyond = sample_curves(OFF_CAM, bend, near=0.5, far=1e12)  # a finite far past the cut ends there, closed
    assert_allclose(beyond.depth[beyond.start[1:] - 1], curved.CURVE_CUT_DEPTH, rtol=1e-12)
    assert not beyond.open_end.any()


# ---------------------------------------------------------------------------- (4) undefined map
def _undefined_beyond(z_max):
    def to_world(q):
        q = np.array(q, dtype=np.float64)
        q[q[..., 2] > z_max] = np.nan
        return q

    return to_world


def test_nan_from_to_world_ends_the_ray_without_a_hit(curved_tracer):
    cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=40, width=W, height=H)  # the ball is beyond z = 2.8
    got = trace_curved(curved_tracer, cam, _undefined_beyond(2.0), near=0.1, far=np.inf, samples=2)
    assert np.isnan(got.depth).all() and np.isnan(got.position).all()
    assert_allclose(got.beauty, np.broadcast_to(SKY, (H, W, 3)), atol=1e-6)  # left along the last segment
    # the curve stops at the last defined sample, found by bisection just short of z = 2
    cs = sample_curves(cam, _undefined_beyond(2.0), near=0.1, far=np.inf)
    last = cs.depth[cs.start[1:] - 1]
    assert (last <= 2.0).all() and (last > 1.99).all() and not cs.open_end.any()


def test_nan_on_half_the_rays(curved_tracer):
    def to_world(q):
        q = np.array(q, dtype=np.float64)
        q[q[..., 0] > BASE] = np.nan
        return q

    got = trace_curved(curved_tracer, CAM, to_world, near=0.1, far=np.inf, samples=2)
    want = curved_tracer.render(CAM, samples=2)
    left = np.arange(W) < (W - 1) / 2  # the columns whose rays keep x <= BASE
    assert_allclose(got.depth[:, left], want.depth[:, left], rtol=1e-6)
    assert np.isnan(got.depth[:, ~left]).all()
    assert_allclose(got.beauty[:, ~left], np.broadcast_to(SKY, (H, (~left).sum(), 3)), atol=1e-6)


def test_gap_is_measured_beside_an_undefined_region():
    # Undefined right of x = OFFSET: the forward one-pixel step of the column next to it is undefined,
    # the backward one measures the gap there.
    def half(q):
        p = bend(q)
        p[np.asarray(q)[..., 0] > OFFSET] = np.nan
        return p

    cs = sample_curves(OFF_CAM, half, near=0.05, far=40.0, tolerance_px=0.05)
    left = np.arange(W * H) % W < (W - 1) / 2
    assert (cs.segments[left] > 0).all() and (cs.segments[~left] == 0).all()
    assert _worst_gap(cs, OFF_CAM, unbend) <= 1.1 * 0.05


def test_undefined_from_near_on_sees_the_environment(curved_tracer):
    got = trace_curved(curved_tracer, CAM, lambda q: np.full_like(q, np.inf), near=0.1, far=10.0, samples=1)
    assert np.isnan(got.depth).all()
    assert_allclose(got.beauty, np.broadcast_to(SKY, (H, W, 3)), atol=1e-6)
    assert (sample_curves(CAM, lambda q: q * np.nan, near=0.1, far=10.0).segments == 0).all()


# ---------------------------------------------------------------------------- progress, (5) validation
def test_progress_reports_to_one(curved_tracer):
    seen = []
    trace_curved(curved_tracer, CAM, bend, near=0.1, far=np.inf, samples=1, progress=lambda f, m: seen.append(f))
    assert seen[-1] == 1.0 and seen == sorted(seen) and len(seen) >= 3


FISHEYE = FisheyeCamera(R=np.eye(3), t=np.zeros(3), width=8, height=8, fov_deg=90.0)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"near": 0.0}, ValueError, "near must be > 0"),
        ({"near": -1.0}, ValueError, "near must be > 0"),
        ({"near": np.nan}, ValueError, "near"),
        ({"near": np.inf}, ValueError, "near"),
        ({"near": 1e-9}, ValueError, "near must be >= 1e-06 m"),
        ({"far": 0.1}, ValueError, "far must be > near"),
        ({"far": 0.05}, ValueError, "far must be > near"),
        ({"far": np.nan}, ValueError, "far must be > near"),
        ({"far": "far"}, TypeError, "far must be a number"),
        ({"tolerance_px": 0.0}, ValueError, "tolerance_px must be > 0"),
        ({"tolerance_px": -0.25}, ValueError, "tolerance_px must be > 0"),
        ({"tolerance_px": np.inf}, ValueError, "tolerance_px"),
        ({"to_world": "phi"}, TypeError, "to_world must be a callable"),
        ({"to_world": lambda q: q[..., :2]}, ValueError, "to_world must return an array of its input's shape"),
        ({"to_world": lambda q: 1.0}, ValueError, "to_world must return an array of its input's shape"),
        ({"to_world": lambda q: np.full(q.shape, "x")}, TypeError, "to_world must return a numeric array"),
        ({"to_world": lambda q: q.no_such_attribute}, AttributeError, "no_such_attribute"),  # its own error
        ({"camera": None}, TypeError, "camera must be a pinhole"),
        ({"camera": FISHEYE}, TypeError, "camera must be a pinhole"),
        ({"samples": 0}, ValueError, "samples must be >= 1"),
        ({"progress": 3}, TypeError, "progress must be a callable"),
    ],
)
def test_bad_input_is_refused_in_one_line(curved_tracer, kwargs, error, match):
    args = {"camera": CAM, "to_world": bend, "near": 0.1, "far": np.inf, **kwargs}
    with pytest.raises(error, match=match) as info:
        trace_curved(curved_tracer, args.pop("camera"), args.pop("to_world"), **args)
    assert "\n" not in str(info.value)


def test_a_map_too_rough_to_follow_is_refused(curved_tracer):
    rng = np.random.default_rng(0)
    rough = lambda q: q + 0.05 * rng.standard_normal(q.shape)  # noqa: E731
    with pytest.raises(ValueError, match="MAX_MEAN_SEGMENTS"):
        trace_curved(curved_tracer, CAM, rough, near=0.1, far=np.inf, samples=1)


def test_module_level_refuses_a_non_scene():
    with pytest.raises(TypeError, match="scene must be"):
        render_curved("stadium", CAM, bend, near=0.1, far=np.inf)


def test_rendering_is_independent_of_the_chunking(curved_tracer, monkeypatch):
    whole = trace_curved(curved_tracer, CAM, bend, near=0.1, far=np.inf, samples=1, max_depth=0)
    monkeypatch.setattr(curved, "_CHUNK_RAYS", 50)
    parts = trace_curved(curved_tracer, CAM, bend, near=0.1, far=np.inf, samples=1, max_depth=0)
    assert_array_equal(parts.depth, whole.depth)
    assert_array_equal(parts.beauty, whole.beauty)


def test_a_bend_that_crosses_its_chord_at_the_midpoint_is_still_split():
    """A curve that leaves its chord on one side and comes back on the other (an inflection of psi in
    the Tri-Rig) has its midpoint on the chord: the quarter points must reveal the bend. Measured on
    the stadium Tri-Rig before the fix: 0.94 px off at a 0.25 px tolerance."""
    from vergence.camera import look_at
    from vergence.render.curved import _far_grid, sample_curves

    cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=40, width=3, height=1)
    near, far = 1.0, 2.0
    grid = _far_grid(near, far)  # first samples in inverse depth; the bend spans the first segment
    ua, ub = grid[0], grid[1]
    px_at_1m = 2.0 * np.tan(np.radians(20.0)) / cam.width  # metres per pixel at depth 1
    amp = 5.0 * px_at_1m  # a lateral swing of ~5 pixels at 1 m

    def to_world(q):
        u = 1.0 / q[..., 2]
        phase = np.clip((u - ua) / (ub - ua), 0.0, 1.0)  # zero at both ends and at the midpoint
        out = np.array(q, dtype=np.float64)
        out[..., 0] += amp * q[..., 2] * np.sin(2.0 * np.pi * phase)
        return out

    curves = sample_curves(cam, to_world, near=near, far=far, tolerance_px=0.25)
    for i in range(cam.width):
        pts, zs = curves.points[curves.start[i]:curves.start[i + 1]], curves.depth[curves.start[i]:curves.start[i + 1]]
        # the true curve, densely, against the polyline at the same depths (lateral offset in pixels)
        z = np.linspace(zs[0], zs[-1], 2001)
        ray = cam.ray_directions().reshape(-1, 3)[i]
        ray = ray / ray[2]
        true = to_world(z[:, None] * ray[None, :])
        poly_x = np.interp(z, zs, pts[:, 0])
        err_px = np.abs(true[:, 0] - poly_x) / (z * px_at_1m)
        assert err_px.max() <= 0.3, (i, err_px.max())
