"""The renderer's stages alone and the public Tracer: rays from anywhere, segments, many cameras.

Analytic scenes only: a sphere of radius 1 at the origin and a wall, with hits worked out by hand.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import look_at
from vergence.render import (
    Diffuse,
    Environment,
    FisheyeCamera,
    Glass,
    Intersector,
    Rectangle,
    Scene,
    SceneCamera,
    Sphere,
    Tracer,
    WhittedShader,
    camera_rays,
    render,
    render_stereo,
    screen_disparity,
)
from vergence.rigs import stereo_pair

# float64 refinement of a float32 cast: the analytic hit is recovered to rounding of ~10 m coordinates.
T_ATOL = 1e-9
POS_ATOL = 1e-5  # positions are stored as float32
SKY = (0.25, 0.5, 0.75)


def _scene(objects, *, width=9, height=7) -> Scene:
    cam = SceneCamera(position=(0, 0, 5), look_at=(0, 0, 0), up=(0, 1, 0), fov_deg=40.0, width=width, height=height)
    mats = {"white": Diffuse(color=(0.5, 0.5, 0.5)), "glass": Glass(ior=1.5)}
    return Scene(camera=cam, environment=Environment(color=SKY), materials=mats, objects=tuple(objects))


BALL = Sphere(center=(0, 0, 0), radius=1.0, material="white")
WALL = Rectangle(center=(0, 0, -3), normal=(0, 0, 1), up=(0, 1, 0), size=(40, 40), material="white")


@pytest.fixture(scope="module")
def tracer():
    return Tracer(_scene([BALL, WALL]))


# ---------------------------------------------------------------------------- ray generation
@pytest.mark.parametrize("kind", ["pinhole", "fisheye"])
def test_camera_rays_pass_through_their_pixel_centres(kind):
    if kind == "pinhole":
        cam = look_at([0.3, 0.1, 2.0], [0, 0, 0], [0, 1, 0], fov_deg=50, width=11, height=8)
    else:
        cam = FisheyeCamera(R=np.eye(3), t=np.array([0.1, 0.0, 0.0]), width=11, height=9, fov_deg=180.0)
    rays = camera_rays(cam)
    assert rays.shape == (cam.height, cam.width)
    assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0, atol=1e-12)
    assert_allclose(rays.origins, np.broadcast_to(cam.center, rays.origins.shape), atol=1e-12)
    pixels, depth = cam.project(rays.origins + 3.0 * rays.directions)
    ys, xs = np.divmod(rays.pixels, cam.width)
    assert_allclose(pixels, np.stack([xs, ys], axis=1), atol=1e-9)
    assert (depth > 0).all()
    if kind == "fisheye":  # the corners lie outside the 180 deg image circle: no ray there
        assert 0 not in rays.pixels and len(rays.pixels) < cam.width * cam.height


def test_camera_rays_refuse_other_cameras():
    with pytest.raises(TypeError, match="camera must be one of Camera, FisheyeCamera; got str"):
        camera_rays("cam")  # type: ignore[arg-type]


# ---------------------------------------------------------------------------- intersection
def test_intersector_against_an_analytic_sphere_and_plane():
    inter = Intersector(_scene([BALL, WALL]))
    o = np.array([[0.0, 0.0, 5.0], [0.6, 0.0, 5.0], [5.0, 0.0, 0.0], [3.0, 3.0, 5.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    hits = inter(o, d)
    assert_array_equal(hits.rays, [0, 1, 2, 3])
    assert_array_equal(hits.obj, [0, 0, 0, 1])
    # |o + t d|^2 = 1: t = 5 - sqrt(1 - 0.36) = 4.2 for the off-axis ray; the wall plane at z = -3: t = 8.
    assert_allclose(hits.t, [4.0, 5.0 - np.sqrt(0.64), 4.0, 8.0], atol=T_ATOL)
    assert_allclose(hits.points[1], [0.6, 0.0, 0.8], atol=T_ATOL)
    assert_allclose(hits.n_geo[1], [0.6, 0.0, 0.8], atol=T_ATOL)  # outward
    assert_allclose(hits.n_geo[3], [0.0, 0.0, 1.0])
    # A bound below the hit distance: no hit.
    bounded = inter(o, d, tmax=np.array([3.9, 4.3, 4.0, 7.0]))
    assert_array_equal(bounded.rays, [1, 2])
    # The bound holds on the float64 distance: a hit 1e-9 m beyond it (below float32 resolution at 4 m,
    # where Mitsuba's float32 bound cannot tell) is no hit.
    assert len(inter(o[:1], d[:1], tmax=np.array([4.0 - 1e-9])).rays) == 0


# ---------------------------------------------------------------------------- shading
def test_shader_splits_glass_by_schlick_at_normal_incidence():
    scene = _scene([Sphere(center=(0, 0, 0), radius=1.0, material="glass")])
    shader = WhittedShader(scene)
    d = np.array([[0.0, 0.0, -1.0]])
    n = np.array([[0.0, 0.0, 1.0]])
    glass = np.array([list(scene.materials).index("glass")])
    rdir, rw, rows, tdir, tw = shader.specular(d, n, np.array([True]), glass)
    # R0 = ((1 - 1.5) / 2.5)^2 = 0.04 (Schlick 1994); straight through at normal incidence.
    assert_allclose(rdir, [[0.0, 0.0, 1.0]])
    assert_allclose(rw, [[0.04] * 3], atol=1e-15)
    assert_array_equal(rows, [0])
    assert_allclose(tdir, d, atol=1e-15)
    assert_allclose(tw, [[0.96] * 3], atol=1e-15)
    # Unoccluded upward diffuse point under a constant sky: E AO / pi = sky.
    assert_allclose(shader.diffuse(np.array([[0.0, 50.0, 0.0]]), n, n, samples=8, rng=None, ao_distance=None),
                    [SKY], atol=1e-12)  # fmt: skip


# ---------------------------------------------------------------------------- the tracer
def test_tracer_render_equals_render_and_is_reusable(tracer):
    cams = [look_at([x, 0.0, 5.0], [0, 0, 0], [0, 1, 0], fov_deg=40, width=9, height=7) for x in (0.0, 0.5)]
    for cam in cams:
        a = tracer.render(cam, samples=2)
        b = render(tracer.scene, camera=cam, samples=2)
        assert_array_equal(a.radiance, b.radiance)
        assert_array_equal(a.depth, b.depth)
        assert a.settings == b.settings


def test_render_stereo_one_wavefront_equals_two_renders(tracer):
    cam = tracer.scene.camera.build()
    left, right = render_stereo(tracer.scene, baseline=0.2, convergence=5.0, samples=2)
    pair = stereo_pair(cam, baseline=0.2, convergence=5.0)
    for joint, c in zip((left, right), pair):
        alone = render(tracer.scene, camera=c, samples=2)
        assert_array_equal(joint.radiance, alone.radiance)
        assert_array_equal(joint.position, alone.position)
        assert_array_equal(joint.depth, alone.depth)
        assert joint.settings == alone.settings  # ray counts per view


def test_trace_rays_from_per_pixel_origins(tracer):
    # A 2 x 3 grid of parallel rays (an orthographic camera): each origin its own.
    xs = np.array([[-0.5, 0.0, 0.5], [0.0, 0.3, 2.0]])
    origins = np.stack([xs, np.zeros_like(xs), np.full_like(xs, 5.0)], axis=-1)
    tree = tracer.trace_rays(origins, [0.0, 0.0, -2.0], max_depth=0, samples=1)
    assert tree.shape == (2, 3) and tree.radiance.shape == (1, 2, 3, 3)
    expected = np.where(np.abs(xs) < 1.0, 5.0 - np.sqrt(np.clip(1.0 - xs**2, 0.0, None)), 8.0)  # ball, else the wall at z = -3
    assert_allclose(tree.distance, expected, atol=T_ATOL)
    assert tree.hit.all()
    assert_allclose(tree.position[0, ..., 2], 5.0 - expected, atol=POS_ATOL)


def test_trace_rays_segments_chain_into_the_whole_ray(tracer):
    o = np.array([[0.2, 0.1, 5.0], [4.0, 4.0, 5.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # the second escapes
    whole = tracer.trace_rays(o, d, max_depth=1, samples=2)
    first = tracer.trace_rays(o, d, tmax=2.5, max_depth=1, samples=2)  # too short for either ray
    assert not first.hit.any() and np.isnan(first.distance).all()
    assert_array_equal(first.beauty, 0.0)  # an unfinished segment carries no light
    rest = tracer.trace_rays(o + 2.5 * d, d, tmax=np.inf, max_depth=1, samples=2)
    assert_array_equal(rest.hit, whole.hit)
    assert_allclose(rest.distance[0] + 2.5, whole.distance[0], atol=T_ATOL)
    assert_allclose(rest.beauty, whole.beauty, rtol=1e-6)
    assert_allclose(whole.beauty[1], SKY, rtol=1e-6)  # escaped: the environment


def test_trace_rays_shape_and_normalisation(tracer):
    o = np.zeros((6, 3)) + [0.0, 0.0, 5.0]
    d = np.tile([0.0, 0.0, -7.0], (6, 1))
    tree = tracer.trace_rays(o, d, shape=(2, 3), max_depth=0, samples=1)
    assert tree.shape == (2, 3)
    assert_allclose(tree.distance, 4.0, atol=T_ATOL)  # metres along the unit direction


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"directions": np.zeros((2, 2))}, ValueError, r"directions must have shape \(\.\.\., 3\); got \(2, 2\)"),
        ({"origins": np.zeros(2)}, ValueError, r"origins must have shape \(\.\.\., 3\); got \(2,\)"),
        ({"origins": np.zeros((3, 3))}, ValueError, r"origins and directions must broadcast together; got \(3, 3\) and \(2, 3\)"),
        ({"directions": [[0, 0, 0], [0, 0, 1.0]]}, ValueError, "directions must be non-zero; got 1 zero rows"),
        ({"directions": [[np.nan, 0, 1], [0, 0, 1.0]]}, ValueError, r"directions must be finite \(no NaN or inf\)"),
        ({"origins": [[np.inf, 0, 1], [0, 0, 1.0]]}, ValueError, r"origins must be finite \(no NaN or inf\)"),
        ({"shape": (3,)}, ValueError, r"shape must hold the 2 rays; got \(3,\)"),
        ({"tmax": "far"}, TypeError, "tmax must be numeric; got str"),
        ({"tmax": [np.nan, 1.0]}, ValueError, r"tmax must be > 0 \(inf allowed\) for every ray"),
        ({"tmax": 0.0}, ValueError, r"tmax must be > 0 \(inf allowed\) for every ray"),
        ({"tmax": [1.0, 2.0, 3.0]}, ValueError, r"tmax must broadcast to the rays' shape \(2,\)"),
        ({"max_depth": -1}, ValueError, r"max_depth must be an integer in \[0, 6\]; got -1"),
    ],
)
def test_trace_rays_bad_input(tracer, kwargs, error, match):
    args = {"origins": np.zeros((2, 3)), "directions": np.tile([0.0, 0.0, 1.0], (2, 1))} | kwargs
    with pytest.raises(error, match=match):
        tracer.trace_rays(args.pop("origins"), args.pop("directions"), **args)


def test_tracer_refuses_a_non_scene():
    with pytest.raises(TypeError, match="scene must be a vergence.render.Scene; got dict"):
        Tracer({})  # type: ignore[arg-type]


def test_tracer_takes_another_shader(tracer):
    class Flat(WhittedShader):
        def diffuse(self, points, n_geo, n_shade, **kw):  # noqa: ANN001, ANN003, ANN201
            return np.ones((len(points), 3))  # radiance = albedo

    t = Tracer(tracer.scene, shader=Flat(tracer.scene))
    tree = t.trace_rays([0.0, 0.0, 5.0], [[0.0, 0.0, -1.0]], max_depth=0, samples=1)
    assert_allclose(tree.beauty, [[0.5, 0.5, 0.5]])


# ---------------------------------------------------------------------------- measured disparity
def test_screen_disparity_of_a_fronto_parallel_wall():
    z, b, hc = 2.0, 0.1, 4.0
    cam = SceneCamera(position=(0, 0, 0), look_at=(0, 0, -1), up=(0, 1, 0), fov_deg=40.0, width=21, height=9)
    wall = Rectangle(center=(0, 0, -z), normal=(0, 0, 1), up=(0, 1, 0), size=(40, 40), material="white")
    scene = Scene(camera=cam, environment=Environment(color=SKY), materials={"white": Diffuse(color=(1, 1, 1))},
                  objects=(wall,))  # fmt: skip
    left, right = render_stereo(scene, baseline=b, convergence=hc, max_depth=0, samples=1)
    fx = left.camera.K[0, 0]
    # S0 Eq. (1a) in pixels: x_left - x_right = fx b (1/z - 1/H); float32 positions: ~1e-6 m -> 1e-4 px.
    assert_allclose(screen_disparity(left, right), fx * b * (1.0 / z - 1.0 / hc), atol=1e-4)
    with pytest.raises(TypeError, match="right must be a vergence.render.RenderResult; got str"):
        screen_disparity(left, "right")  # type: ignore[arg-type]


def test_importing_the_renderer_does_not_import_matplotlib():
    code = "import sys, vergence.render; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "False"


def test_hashed_ao_pattern_is_deterministic_unbiased_and_unstructured():
    # The half-space of test_raytree: a floor with an infinite wall behind the camera, AO = 1/2 exactly.
    floor = Rectangle(center=(0, 0, 0), normal=(0, 1, 0), up=(0, 0, -1), size=(4000.0, 4000.0), material="white")
    wall = Rectangle(center=(0, 0, 5), normal=(0, 0, -1), up=(0, 1, 0), size=(4000.0, 4000.0), material="white")
    cam = SceneCamera(position=(0, 1, 0), look_at=(0, 0, -2), up=(0, 1, 0), fov_deg=30.0, width=33, height=25)
    scene = Scene(camera=cam, environment=Environment(color=(1, 1, 1)), materials={"white": Diffuse(color=(1, 1, 1))},
                  objects=(floor, wall))  # fmt: skip
    hashed = Tracer(scene, shader=WhittedShader(scene, ao_pattern="hashed"))
    a, b = hashed.render(samples=16), hashed.render(samples=16)
    assert_array_equal(a.radiance, b.radiance)  # no rng: deterministic
    ao = a.radiance[0, ..., 0]  # albedo 1, sky 1: radiance = AO
    # Unbiased: the mean of ~800 points with 16 stratified directions each is within 2 % of 1/2 ...
    assert ao.mean() == pytest.approx(0.5, rel=0.02)
    # ... and the points do not all share one lattice (which gives the same AO at every point here).
    fixed = Tracer(scene).render(samples=16).radiance[0, ..., 0]
    assert np.ptp(fixed) < 1e-6 < np.ptp(ao)
    with pytest.raises(ValueError, match="ao_pattern must be one of lattice, hashed; got 'blue'"):
        WhittedShader(scene, ao_pattern="blue")


# ---------------------------------------------------------------------------- supersampling
def test_subpixel_rays_pass_through_their_offsets():
    from vergence.render import subpixel_rays

    cam = look_at([0.3, 0.1, 2.0], [0, 0, 0], [0, 1, 0], fov_deg=50, width=6, height=4)
    off = np.random.default_rng().uniform(-0.5, 0.5, (4, 6, 2))
    rays = subpixel_rays(cam, off)
    pixels, _ = cam.project(rays.origins + 2.0 * rays.directions)
    assert_allclose(pixels.reshape(4, 6, 2), cam.pixel_grid() + off, atol=1e-9)
    with pytest.raises(TypeError, match="sub-pixel rays need a pinhole Camera; got FisheyeCamera"):
        subpixel_rays(FisheyeCamera(R=np.eye(3), t=np.zeros(3), width=4, height=4, fov_deg=90.0), (0.0, 0.0))


def test_supersampling_averages_the_sub_pixel_trees(tracer):
    from vergence.render import subpixel_rays

    cam = tracer.scene.camera.build()
    plain = tracer.render(cam, samples=2)
    ss = tracer.render(cam, samples=2, supersample=2)
    # Geometry is the pixel-centre ray's; radiance is the mean of the 2 x 2 grid of cell centres.
    assert_array_equal(ss.position, plain.position)
    assert_array_equal(ss.depth, plain.depth)
    subs = []
    for dy in (-0.25, 0.25):
        for dx in (-0.25, 0.25):
            r = subpixel_rays(cam, (dx, dy))
            subs.append(tracer.trace_rays(r.origins, r.directions, shape=r.shape, samples=2).radiance)
    assert_allclose(ss.radiance, np.mean(subs, axis=0), rtol=1e-6, atol=1e-7)
    # The ball's silhouette is smoothed: some pixels now lie between ball and wall.
    assert not np.allclose(ss.beauty, plain.beauty)
    n = cam.width * cam.height
    assert ss.settings.supersample == 2 and ss.settings.tree_rays >= 5 * n and plain.settings.tree_rays < 5 * n
    jittered = tracer.render(cam, samples=2, supersample=2, rng=np.random.default_rng(1))
    assert_array_equal(jittered.position, plain.position)


def test_supersample_bad_input(tracer):
    with pytest.raises(ValueError, match="supersample must be >= 1; got 0"):
        tracer.render(supersample=0)
    fisheye = FisheyeCamera(R=np.eye(3), t=np.array([0.0, 0.0, -5.0]), width=8, height=8, fov_deg=90.0)
    with pytest.raises(TypeError, match="supersample > 1 needs a pinhole Camera; got FisheyeCamera"):
        tracer.render(fisheye, supersample=2)
    with pytest.raises(ValueError, match="supersample must be >= 1; got 0"):
        render_stereo(tracer.scene, baseline=0.1, convergence=5.0, supersample=0)


def test_supersampled_stereo_equals_two_supersampled_renders(tracer):
    left, right = render_stereo(tracer.scene, baseline=0.2, convergence=5.0, samples=1, supersample=2)
    for joint, c in zip((left, right), stereo_pair(tracer.scene.camera.build(), baseline=0.2, convergence=5.0)):
        alone = tracer.render(c, samples=1, supersample=2)
        assert_array_equal(joint.radiance, alone.radiance)
        assert joint.settings == alone.settings
