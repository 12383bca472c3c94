"""Unit tests of the shading maths and lenses: Schlick (Schlick 1994), Snell, IBL, AO directions, fisheye."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from vergence.render import Environment, FisheyeCamera, schlick
from vergence.render import _kernels
from vergence.render.shading import Lighting, ao_directions, ao_lattice, reflect, refract

# Closed-form values computed in float64: a few ulps.
EXACT = 1e-12
# Irradiance tabulated for 32 x 16 normals from a 64 x 32 copy of the map, looked up bilinearly:
# on the half-bright sky the largest error over all normals is 0.2 % of pi (measured).
IRRADIANCE_RTOL = 1e-2


def test_schlick_spec_values():
    # Schlick 1994: R0 = ((n1 - n2)/(n1 + n2))^2 = 0.04 for glass n = 1.5.
    assert float(schlick(1.0, 1.0, 1.5)) == pytest.approx(0.04, abs=EXACT)
    assert float(schlick(0.0, 1.0, 1.5)) == pytest.approx(1.0, abs=EXACT)
    # Inside glass at 60 deg: sin^2 theta_t = 1.5^2 * 0.75 = 1.6875 > 1, total internal reflection.
    assert float(schlick(math.cos(math.radians(60.0)), 1.5, 1.0)) == 1.0
    # By hand: cos = 0.5 from air, R = 0.04 + 0.96 * 0.5^5 = 0.07.
    assert float(schlick(0.5, 1.0, 1.5)) == pytest.approx(0.07, abs=EXACT)
    # From glass at normal incidence the transmitted cosine is 1: R = R0 again.
    assert float(schlick(1.0, 1.5, 1.0)) == pytest.approx(0.04, abs=EXACT)
    # Just below the critical angle asin(1/1.5) = 41.81 deg: transmitted cosine ~ 0, R ~ 1 but < 1.
    below = schlick(math.cos(math.asin(1 / 1.5) - 1e-6), 1.5, 1.0)
    assert 0.99 < float(below) < 1.0


def test_schlick_matches_spec_reference_implementation():
    # A scalar restatement of Schlick 1994 (with TIR), against the vectorised one.
    def reference(cos_i, n1, n2):
        r0 = ((n1 - n2) / (n1 + n2)) ** 2
        if n1 > n2:
            sin_t2 = (n1 / n2) ** 2 * (1 - cos_i**2)
            if sin_t2 > 1:
                return 1.0
            cos_i = math.sqrt(1 - sin_t2)
        return r0 + (1 - r0) * (1 - cos_i) ** 5

    cos = np.linspace(0.0, 1.0, 41)
    for n1, n2 in ((1.0, 1.5), (1.5, 1.0), (1.0, 1.33), (1.6, 1.0)):
        assert_allclose(schlick(cos, n1, n2), [reference(c, n1, n2) for c in cos], atol=EXACT)


def test_reflect_and_refract_by_hand():
    d = np.array([[np.sin(0.5), -np.cos(0.5), 0.0]])
    n = np.array([[0.0, 1.0, 0.0]])
    assert_allclose(reflect(d, n), [[np.sin(0.5), np.cos(0.5), 0.0]], atol=EXACT)
    t, tir = refract(d, n, np.array([1.0 / 1.5]))
    # Snell: sin theta_t = sin(0.5) / 1.5; the ray keeps its plane and goes down.
    s = np.sin(0.5) / 1.5
    assert_allclose(t, [[s, -np.sqrt(1 - s * s), 0.0]], atol=EXACT)
    assert not tir[0]
    # From glass at 60 deg: total internal reflection.
    d = np.array([[np.sin(np.radians(60)), -np.cos(np.radians(60)), 0.0]])
    _, tir = refract(d, n, np.array([1.5]))
    assert tir[0]


@settings(max_examples=30, deadline=None)
@given(theta=st.floats(0.0, 1.5), eta=st.floats(0.5, 2.0))
def test_refract_obeys_snell(theta, eta):
    d = np.array([[np.sin(theta), -np.cos(theta), 0.0]])
    n = np.array([[0.0, 1.0, 0.0]])
    t, tir = refract(d, n, np.array([eta]))
    if eta * np.sin(theta) > 1.0 + 1e-12:
        assert tir[0]
    elif eta * np.sin(theta) < 1.0 - 1e-12:
        assert_allclose(np.linalg.norm(t), 1.0, atol=1e-12)
        assert_allclose(t[0, 0], eta * np.sin(theta), atol=1e-12)  # n1 sin theta_i = n2 sin theta_t


def test_ao_directions_are_cosine_weighted_unit_vectors_in_the_hemisphere():
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 2.0, 2.0]]) / np.array([[1.0], [1.0], [3.0]])
    dirs = ao_directions(normals, 256, None)
    assert dirs.shape == (3, 256, 3)
    assert_allclose(np.linalg.norm(dirs, axis=-1), 1.0, atol=1e-12)
    cos = np.einsum("msk,mk->ms", dirs, normals)
    assert (cos > 0).all()
    # Cosine-weighted hemisphere: E[cos] = 2/3 (stratified lattice: error ~ 1/S).
    assert_allclose(cos.mean(axis=1), 2.0 / 3.0, atol=5e-3)
    # The deterministic pattern is identical for every call; the random one depends on the seed.
    assert_allclose(ao_directions(normals, 16, None), ao_directions(normals, 16, None))
    a = ao_directions(normals, 16, np.random.default_rng(1))
    b = ao_directions(normals, 16, np.random.default_rng(1))
    c = ao_directions(normals, 16, np.random.default_rng(2))
    assert_allclose(a, b)
    assert not np.allclose(a, c)


def test_ao_kernel_matches_the_numpy_reference():
    rng = np.random.default_rng(0)
    p = rng.uniform(-5, 5, (50, 3))
    ns = rng.normal(size=(50, 3))
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    ns[0] = (0.0, 0.0, -1.0)  # the frame's branch for n_z < 0 at its singular direction
    ng = -ns
    eps = 1e-4 * (1 + np.abs(p).max(axis=1))
    for shifts, seed in ((np.empty((0, 2)), None), (np.random.default_rng(5).random((50, 2)), 5)):
        o, d = _kernels.ao_rays(p, ng, ns, ao_lattice(7), shifts, 1e-4)
        ref = ao_directions(ns, 7, None if seed is None else np.random.default_rng(seed))
        # float32 output: 1e-6 is a few ulps of unit vectors and of coordinates up to 5.
        assert_allclose(d.T, ref.reshape(-1, 3), atol=1e-6)
        assert_allclose(o.T, np.repeat(p + eps[:, None] * ng, 7, axis=0), atol=5e-6)


def test_constant_environment_irradiance_is_pi_c():
    light = Lighting(Environment(color=(0.5, 1.0, 2.0), intensity=2.0))
    n = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    assert_allclose(light.irradiance(n), np.pi * np.array([[1.0, 2.0, 4.0]] * 2), rtol=EXACT)
    assert_allclose(light.radiance(n), [[1.0, 2.0, 4.0]] * 2, rtol=EXACT)


def test_map_lookup_and_rotation_by_hand():
    # Column k of a 2 x 4 map holds k + 1; direction -z at the horizon is u = 1/2, v = 1/2:
    # x = 0.5 * 4 - 0.5 = 1.5 between columns 1 and 2, y between the two rows: (2 + 3) / 2.
    img = np.tile(np.arange(1.0, 5.0)[None, :, None], (2, 1, 3)).astype(np.float32)
    light = Lighting(Environment(image=img))
    assert_allclose(light.radiance(np.array([[0.0, 0.0, -1.0]])), [[2.5] * 3], rtol=1e-6)
    # Rotated by 90 deg about +y, the column that faced -z faces (sin 90, 0, -cos 90) = +x.
    turned = Lighting(Environment(image=img, rotation_deg=90.0, intensity=3.0))
    assert_allclose(turned.radiance(np.array([[1.0, 0.0, 0.0]])), [[7.5] * 3], rtol=1e-6)


def test_half_sky_irradiance():
    # Upper hemisphere radiance 1, lower 0: E(up) = pi, E(horizontal) = pi / 2, E(down) = 0.
    img = np.zeros((64, 128, 3), dtype=np.float32)
    img[:32] = 1.0
    light = Lighting(Environment(image=img))
    e = light.irradiance(np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))
    assert_allclose(e[:, 0], [np.pi, np.pi / 2, 0.0], rtol=IRRADIANCE_RTOL, atol=IRRADIANCE_RTOL)


def test_fisheye_projection_by_hand_and_round_trip():
    cam = FisheyeCamera(R=np.eye(3), t=np.zeros(3), width=101, height=81, fov_deg=180.0)
    # f = (101 / 2) / (pi / 2) px per radian; 45 deg off axis lands f pi / 4 = 25.25 px from the centre.
    assert cam.focal_px == pytest.approx(50.5 / (np.pi / 2))
    pix, depth = cam.project([[0.0, 1.0, 1.0]])
    assert_allclose(pix, [[50.0, 40.0 + 25.25]], atol=1e-9)
    assert_allclose(depth, [1.0])
    dirs = cam.ray_directions()
    valid = ~np.isnan(dirs[..., 0])
    # Corners are outside the image circle (theta > 90 deg); the centre row is inside.
    assert not valid[0, 0] and valid[40].all()
    pix, _ = cam.project(dirs[valid] * 3.0)
    grid = np.stack(np.meshgrid(np.arange(101.0), np.arange(81.0)), axis=-1)[valid]
    assert_allclose(pix, grid, atol=1e-9)


def test_fisheye_bad_input():
    with pytest.raises(ValueError, match=r"fov_deg must lie in \(0, 180\] for a fisheye; got 200"):
        FisheyeCamera(R=np.eye(3), t=np.zeros(3), width=8, height=8, fov_deg=200.0)
    with pytest.raises(ValueError, match="R must be a rotation"):
        FisheyeCamera(R=2 * np.eye(3), t=np.zeros(3), width=8, height=8, fov_deg=90.0)
