"""Bayesian view-synthesis weights (Pujades, Devernay & Goldluecke 2014): analytic cases, properties,
the Numba kernel against a slow Python reference, and input validation."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import Camera
from vergence.synthesis import (
    BAYES_DEPTH_CONTINUITY,
    BAYES_MIN_DEFORMATION,
    BAYES_SIGMA_SENSOR,
    bayesian_weights,
)

VAR_S = BAYES_SIGMA_SENSOR**2
# float32 output against float64 references: a few float32 ulps.
F32_RTOL = 1e-5
# Central differences of a homography over one pixel at f = 60 px: second-order error about
# (1 px / (f / tan(slant)))^2 relative; measured below 1e-3 here.
HOMOGRAPHY_RTOL = 2e-3
# One-sided differences at the image border: first-order error, about 1 px x (d^2 beta) / (d beta).
ONE_SIDED_RTOL = 1e-2
# Central finite difference of the reference's velocity (relative step 1e-6) against the kernel's
# analytic Jacobian: truncation ~1e-12, round-off ~1e-10 relative.
VELOCITY_RTOL = 1e-6


def _camera(center, *, f=60.0, width=24, height=18, R=None, pp=None):
    R = np.eye(3) if R is None else np.asarray(R, float)
    cx, cy = ((width - 1) / 2, (height - 1) / 2) if pp is None else pp
    K = [[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]]
    return Camera(K=K, R=R, t=-R @ np.asarray(center, float), width=width, height=height)


def _rot_y(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _plane_depth(cam, normal, offset):
    """Target camera-frame depth of the plane ``normal . X = offset`` at every pixel."""
    n = np.asarray(normal, float)
    rays = cam.pixel_grid() @ np.linalg.inv(cam.K)[:, :2].T + np.linalg.inv(cam.K)[:, 2]  # z = 1
    return (offset - n @ cam.center) / ((rays @ cam.R) @ n)


def _observe(target, cameras, depth, distortion=None):
    """Proxy points (undistorted), source pixels and visibility (field of view, no occluders)."""
    points = target.backproject_depth(depth)
    if distortion is not None:
        points = distortion.inverse(points)
    known = np.isfinite(points).all(axis=-1)
    pixels, visible = [], []
    for cam in cameras:
        pix, z = cam.project(np.where(known[..., None], points, 1.0))  # project() refuses NaN
        pix[~known] = np.nan
        inside = known & (z > 0) & (pix[..., 0] >= -0.5) & (pix[..., 0] <= cam.width - 0.5)
        inside &= (pix[..., 1] >= -0.5) & (pix[..., 1] <= cam.height - 0.5)
        pixels.append(pix)
        visible.append(inside)
    return points, np.stack(pixels), np.stack(visible)


class ScaleAbout:
    """A test world distortion ``phi(p) = c + s(z) (p - c)``, ``z = (p - c)_z``, s smooth and
    ``z s(z)`` increasing (the shape of S0's phi, which scales about the left centre)."""

    def __init__(self, center, a=0.3, z0=4.0, length=2.0):
        self.c, self.a, self.z0, self.length = np.asarray(center, float), a, z0, length

    def _s(self, z):
        return 1.0 + self.a * np.tanh((z - self.z0) / self.length)

    def _ds(self, z):
        return self.a / self.length / np.cosh((z - self.z0) / self.length) ** 2

    def forward(self, points):
        d = np.asarray(points, float) - self.c
        return self.c + self._s(d[..., 2])[..., None] * d

    def inverse(self, points):
        d = np.asarray(points, float) - self.c
        zq = d[..., 2]
        z = zq.copy()
        for _ in range(60):  # Newton on z s(z) = zq
            z = z - (z * self._s(z) - zq) / (self._s(z) + z * self._ds(z))
        return self.c + (z / zq)[..., None] * d

    def jacobian(self, points):
        d = np.asarray(points, float) - self.c
        z = d[..., 2]
        jac = self._s(z)[..., None, None] * np.eye(3)
        jac[..., :, 2] += d * self._ds(z)[..., None]  # (p - c) (grad s)^T, grad s = s'(z) e_z
        return jac


class Identity:
    def forward(self, points):
        return np.array(points, float)

    def jacobian(self, points):
        return np.broadcast_to(np.eye(3), np.shape(points) + (3,)).copy()


# ------------------------------------------------------------------ slow reference


def _gradient_reference(img):
    lum = img @ np.array([0.2126, 0.7152, 0.0722]) if img.ndim == 3 and img.shape[2] == 3 else img.reshape(img.shape[:2])
    h, w = lum.shape
    gx, gy = np.zeros((h, w)), np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            ys = [max(y - 1, 0), y, min(y + 1, h - 1)]
            xs = [max(x - 1, 0), x, min(x + 1, w - 1)]
            taps = [1.0, 2.0, 1.0]
            if xs[2] > xs[0]:
                gx[y, x] = sum(t * (lum[ys[k], xs[2]] - lum[ys[k], xs[0]]) for k, t in enumerate(taps)) / (4 * (xs[2] - xs[0]))
            if ys[2] > ys[0]:
                gy[y, x] = sum(t * (lum[ys[2], xs[k]] - lum[ys[0], xs[k]]) for k, t in enumerate(taps)) / (4 * (ys[2] - ys[0]))
    return gx, gy


def _velocity_reference(point, center, target, distortion):
    """d tau / d(log z): central difference of the target pixel as p moves along the source ray."""
    phi = (lambda p: p) if distortion is None else distortion.forward
    h = 1e-6
    ahead, _ = target.project(phi(center + (1 + h) * (point - center)))
    behind, _ = target.project(phi(center + (1 - h) * (point - center)))
    return (ahead - behind) / (2 * h)


def _reference(estimate, points, pixels, visible, target, cameras, distortion=None, *, sigma_sensor=BAYES_SIGMA_SENSOR,
               sigma_depth=0.01, cap=20.0, threshold=0.01, geometric_cap=0.5):
    n_src, h, w = visible.shape
    grads = _gradient_reference(estimate) if estimate is not None else (np.zeros((h, w)), np.zeros((h, w)))
    out = np.zeros((n_src, h, w))
    for i, cam in enumerate(cameras):
        c = cam.center

        def same(y, x, r0, i=i, c=c):
            if not (0 <= y < h and 0 <= x < w) or not np.isfinite(points[y, x]).all() or not np.isfinite(pixels[i, y, x]).all():
                return False
            return abs(np.linalg.norm(points[y, x] - c) - r0) <= BAYES_DEPTH_CONTINUITY * r0

        for y in range(h):
            for x in range(w):
                if not visible[i, y, x]:
                    continue
                r0 = np.linalg.norm(points[y, x] - c)
                cols = []
                for dy, dx in ((0, 1), (1, 0)):
                    fwd, bwd = same(y + dy, x + dx, r0), same(y - dy, x - dx, r0)
                    if fwd and bwd:
                        cols.append((pixels[i, y + dy, x + dx] - pixels[i, y - dy, x - dx]) / 2)
                    elif fwd:
                        cols.append(pixels[i, y + dy, x + dx] - pixels[i, y, x])
                    elif bwd:
                        cols.append(pixels[i, y, x] - pixels[i, y - dy, x - dx])
                det = abs(np.linalg.det(np.column_stack(cols))) if len(cols) == 2 else 1.0
                w_def = min(max(det, BAYES_MIN_DEFORMATION), cap)
                g = np.array([grads[0][y, x], grads[1][y, x]])
                if np.linalg.norm(g) > threshold:
                    g = g / np.linalg.norm(g) * threshold
                s_geom = 0.0
                if g.any():
                    s_geom = sigma_depth * abs(g @ _velocity_reference(points[y, x], c, target, distortion))
                    s_geom = min(s_geom, geometric_cap) if np.isfinite(s_geom) else geometric_cap
                out[i, y, x] = w_def / (sigma_sensor**2 + s_geom**2)
    return out


# ------------------------------------------------------------------ resolution term


@pytest.mark.parametrize("f_source", [90.0, 30.0])
def test_fronto_parallel_plane_gives_the_squared_focal_ratio(f_source):
    target = _camera([0, 0, 0], f=60.0)
    source = _camera([0.3, -0.1, 0.0], f=f_source, width=60, height=48)  # centres in one fronto-parallel plane
    points, pixels, visible = _observe(target, [source], np.full((18, 24), 5.0))
    assert visible.all()
    w = bayesian_weights(None, points, pixels, visible, target, [source])
    assert_allclose(w * VAR_S, (f_source / 60.0) ** 2, rtol=F32_RTOL)  # |det D tau|^-1 = (f_s / f_t)^2


@settings(max_examples=25, deadline=None)
@given(
    f_source=st.floats(20.0, 400.0),
    offset=st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)),
    depth=st.floats(1.0, 50.0),
)
def test_fronto_parallel_plane_any_focal_and_offset(f_source, offset, depth):
    target = _camera([0, 0, 0], f=60.0, width=8, height=6)
    # principal point chosen so that the source sees the whole target image
    ratio = f_source / 60.0
    pp = (3.5 * ratio + f_source * offset[0] / depth + 2, 2.5 * ratio + f_source * offset[1] / depth + 2)
    source = _camera([offset[0], offset[1], 0.0], f=f_source, width=int(8 * ratio) + 5, height=int(6 * ratio) + 5, pp=pp)
    points, pixels, visible = _observe(target, [source], np.full((6, 8), depth))
    assert visible.all()
    w = bayesian_weights(None, points, pixels, visible, target, [source])
    assert_allclose(w * VAR_S, min(max(ratio**2, BAYES_MIN_DEFORMATION), 20.0), rtol=F32_RTOL)


def test_weights_do_not_change_when_scene_and_rig_scale_together():
    target = _camera([0.1, 0, 0])
    sources = [_camera([0, 0, 0], f=50.0), _camera([0.5, 0.1, -0.2], f=70.0, width=30)]
    stripes = _stripes("x")
    base = None
    for k in (1.0, 7.5):
        scaled_t = _camera(k * np.array([0.1, 0, 0]))
        scaled = [_camera(k * c.center, f=c.K[0, 0], width=c.width) for c in sources]
        points, pixels, visible = _observe(scaled_t, scaled, k * _plane_depth(target, [0.3, 0.1, 1.0], 4.0))
        w = bayesian_weights(stripes, points, pixels, visible, scaled_t, scaled, sigma_depth=0.1)
        if base is None:
            base = w
        assert_allclose(w, base, rtol=1e-4)  # sigma_depth is relative: no metre in the weights
    assert (base > 0).sum() > 300


def test_slanted_plane_matches_the_homography_jacobian():
    target = _camera([0, 0, 0], f=60.0)
    source = _camera([0.8, 0.2, 0.3], f=70.0, width=40, height=30, R=_rot_y(-0.15))
    normal, offset = np.array([0.5, 0.2, 1.0]), 5.0
    points, pixels, visible = _observe(target, [source], _plane_depth(target, normal, offset))
    w = bayesian_weights(None, points, pixels, visible, target, [source])
    # Plane-induced homography target -> source: H = K_s (R_rel - t_rel n_t^T / d_t) K_t^-1.
    R_rel = source.R @ target.R.T
    t_rel = source.t - R_rel @ target.t
    n_t = target.R @ normal
    d_t = offset - normal @ target.center  # n_t . x_cam = d_t on the plane
    H = source.K @ (R_rel + np.outer(t_rel, n_t) / d_t) @ np.linalg.inv(target.K)
    m = np.concatenate([target.pixel_grid(), np.ones((18, 24, 1))], axis=-1)
    det = np.linalg.det(H) / (m @ H[2]) ** 3  # det of the Jacobian of x -> (H x)_12 / (H x)_3
    assert np.isfinite(det).all() and det.min() > 0.5 and np.ptp(det) > 0.05  # a real slant
    assert_allclose(pixels[0], (m @ H.T)[..., :2] / (m @ H.T)[..., 2:], atol=1e-9)  # the scene is that plane
    assert_allclose(w[0, 1:-1, 1:-1] * VAR_S, det[1:-1, 1:-1], rtol=HOMOGRAPHY_RTOL)
    assert_allclose(w[0] * VAR_S, det, rtol=ONE_SIDED_RTOL)  # the border: one-sided differences


def test_depth_step_uses_one_sided_differences_and_slivers_fall_back_to_one():
    target = _camera([0, 0, 0], f=60.0)
    source = _camera([0.6, 0.0, 0.0], f=45.0, width=40, height=30)
    depth = np.full((18, 24), 4.0)
    depth[:, 12:] = 8.0  # a depth step: beta jumps by the disparity difference across it
    depth[5:9, 3] = 2.0  # a one-pixel-wide sliver
    points, pixels, visible = _observe(target, [source], depth)
    w = bayesian_weights(None, points, pixels, visible, target, [source]) * VAR_S
    expected = np.full((18, 24), (45.0 / 60.0) ** 2)
    expected[5:9, 3] = 1.0  # no neighbour on its surface along x: neutral 1
    assert_allclose(w[0], expected, rtol=F32_RTOL)


def test_deformation_cap_bounds_dense_sources():
    target = _camera([0, 0, 0], f=10.0)
    source = _camera([0, 0, 0], f=60.0, width=150, height=110)  # 36x denser in area
    points, pixels, visible = _observe(target, [source], np.full((18, 24), 5.0))
    assert_allclose(bayesian_weights(None, points, pixels, visible, target, [source]) * VAR_S, 20.0, rtol=F32_RTOL)
    one = bayesian_weights(None, points, pixels, visible, target, [source], deformation_cap=1.0)
    assert_allclose(one * VAR_S, 1.0, rtol=F32_RTOL)


# ------------------------------------------------------------------ geometric term


def _stripes(axis, shape=(18, 24), period=7.3):  # no column of zero gradient
    y, x = np.mgrid[0 : shape[0], 0 : shape[1]]
    s = 0.5 + 0.4 * np.sin(2 * np.pi * (x if axis == "x" else y) / period)
    return np.repeat(s[..., None], 3, axis=2).astype(np.float32)


def test_flat_estimate_reduces_to_the_resolution_weights():
    target = _camera([0, 0, 0])
    sources = [_camera([0.2, 0, 0], f=50.0), _camera([-0.5, 0.1, 0.2], f=80.0, width=30)]
    points, pixels, visible = _observe(target, sources, _plane_depth(target, [0.3, 0.0, 1.0], 5.0))
    first = bayesian_weights(None, points, pixels, visible, target, sources)
    flat = bayesian_weights(np.full((18, 24, 3), 0.4, np.float32), points, pixels, visible, target, sources)
    assert_array_equal(flat, first)
    textured = bayesian_weights(_stripes("x"), points, pixels, visible, target, sources)
    assert (textured[visible] < first[visible]).all()  # texture along the baselines costs weight


def test_source_at_the_target_has_no_geometric_uncertainty():
    target = _camera([0, 0, 0])
    points, pixels, visible = _observe(target, [target], _plane_depth(target, [0.4, -0.2, 1.0], 5.0))
    w = bayesian_weights(_stripes("x"), points, pixels, visible, target, [target], sigma_depth=1.0)
    assert_allclose(w * VAR_S, 1.0, rtol=F32_RTOL)  # d_z tau = 0 along its own rays, |det| = 1


def test_larger_baseline_costs_weight_only_along_the_epipolar_direction():
    target = _camera([0, 0, 0])
    sources = [_camera([b, 0, 0], width=32, pp=(16.5, 8.5)) for b in (0.1, 0.3)]  # pp: both see it all
    z = 5.0
    points, pixels, visible = _observe(target, sources, np.full((18, 24), z))
    assert visible.all()
    sigma_depth = 0.05
    along = bayesian_weights(_stripes("x"), points, pixels, visible, target, sources, sigma_depth=sigma_depth)
    across = bayesian_weights(_stripes("y"), points, pixels, visible, target, sources, sigma_depth=sigma_depth)
    assert (along[0] > along[1]).all()
    assert_array_equal(across[0], across[1])
    # Analytic: v = (-f b / z, 0) px per unit relative depth; grad u capped at 0.01 along x.
    gx, _ = _gradient_reference(_stripes("x"))
    g = np.clip(gx, -0.01, 0.01)
    for i, b in enumerate((0.1, 0.3)):
        expected = 1.0 / (VAR_S + (sigma_depth * g * 60.0 * b / z) ** 2)
        assert_allclose(along[i], expected, rtol=F32_RTOL)
    assert_allclose(across * VAR_S, 1.0, rtol=F32_RTOL)  # texture along y, baseline along x


def test_geometric_cap_and_grey_estimates():
    target = _camera([0, 0, 0])
    sources = [_camera([b, 0, 0], width=32, pp=(16.5, 8.5)) for b in (0.1, 0.3)]
    points, pixels, visible = _observe(target, sources, np.full((18, 24), 5.0))
    stripes = _stripes("x")
    huge = bayesian_weights(stripes, points, pixels, visible, target, sources, sigma_depth=1e4, geometric_cap=0.2)
    gx, _ = _gradient_reference(stripes)
    assert_allclose(huge[:, np.abs(gx) > 1e-3], 1 / (VAR_S + 0.2**2), rtol=F32_RTOL)  # sigma_geom capped at 0.2
    grey = np.ascontiguousarray(stripes[..., 0])  # luminance of a grey RGB image is its value
    rgb = bayesian_weights(stripes, points, pixels, visible, target, sources, sigma_depth=0.05)
    assert_allclose(bayesian_weights(grey, points, pixels, visible, target, sources, sigma_depth=0.05), rgb, rtol=F32_RTOL)


def test_invisible_sources_get_exactly_zero_and_the_output_is_finite_float32():
    target = _camera([0, 0, 0])
    sources = [_camera([0.2, 0, 0]), _camera([-0.3, 0.1, 0])]
    depth = _plane_depth(target, [0.2, 0.1, 1.0], 5.0)
    depth[:4, :5] = np.nan  # no proxy there
    points, pixels, visible = _observe(target, sources, depth)
    visible[1, 10:, 10:] = False  # occluded in source 1
    pixels[1, 12:, 12:] = np.nan  # and its pixels unknown there
    w = bayesian_weights(_stripes("x"), points, pixels, visible, target, sources)
    assert w.dtype == np.float32 and w.shape == (2, 18, 24)
    assert np.isfinite(w).all()
    assert (w[~visible] == 0).all()
    assert (w[visible] > 0).all()


# ------------------------------------------------------------------ distortion


def test_distortion_velocity_matches_a_finite_difference_through_phi():
    phi = ScaleAbout([0.0, 0.0, 0.0])
    target = _camera([0.4, 0.0, 0.0], R=_rot_y(0.05))  # lives in the distorted world
    sources = [_camera([0.0, 0.0, 0.0]), _camera([0.7, 0.1, -0.3], f=50.0, width=30)]
    points, pixels, visible = _observe(target, sources, _plane_depth(target, [0.2, 0.0, 1.0], 5.0), phi)
    ramp = np.broadcast_to((0.3 + 0.008 * np.arange(24) - 0.004 * np.arange(18)[:, None])[..., None], (18, 24, 3))
    ramp = np.ascontiguousarray(ramp, dtype=np.float32)
    sigma_depth = 2.0
    first = bayesian_weights(None, points, pixels, visible, target, sources, distortion=phi)
    w = bayesian_weights(ramp, points, pixels, visible, target, sources, distortion=phi, sigma_depth=sigma_depth)
    gx, gy = _gradient_reference(ramp)
    for i, cam in enumerate(sources):
        for y, x in np.argwhere(visible[i])[::37]:
            v = _velocity_reference(points[y, x], cam.center, target, phi)
            s_geom = sigma_depth * abs(gx[y, x] * v[0] + gy[y, x] * v[1])
            assert s_geom > BAYES_SIGMA_SENSOR  # the geometric term weighs: a sharp check
            assert_allclose(w[i, y, x], first[i, y, x] / (1 + s_geom**2 / VAR_S), rtol=F32_RTOL)
    # Without phi the velocities differ: the check above can tell.
    plain = bayesian_weights(ramp, points, pixels, visible, target, sources, sigma_depth=sigma_depth)
    assert np.abs(plain[visible] / w[visible] - 1).max() > 0.05


def test_identity_distortion_equals_no_distortion():
    target = _camera([0.1, 0, 0])
    sources = [_camera([0, 0, 0]), _camera([0.5, 0.1, 0], f=45.0)]
    points, pixels, visible = _observe(target, sources, _plane_depth(target, [0.3, 0.1, 1.0], 4.0))
    a = bayesian_weights(_stripes("x"), points, pixels, visible, target, sources, distortion=Identity(), sigma_depth=0.1)
    b = bayesian_weights(_stripes("x"), points, pixels, visible, target, sources, sigma_depth=0.1)
    assert_allclose(a, b, rtol=1e-6)


# ------------------------------------------------------------------ kernel against reference


@pytest.mark.parametrize("with_distortion", [False, True])
def test_kernel_matches_the_slow_reference(with_distortion):
    rng = np.random.default_rng(7)
    phi = ScaleAbout([0.0, 0.0, 0.0]) if with_distortion else None
    target = _camera([0.2, 0.0, 0.0], f=40.0, width=14, height=11)
    sources = [
        _camera([0.0, 0.0, 0.0], f=40.0, width=14, height=11),
        _camera([0.6, -0.1, 0.2], f=55.0, width=20, height=15, R=_rot_y(-0.1)),
        _camera([-0.3, 0.2, -0.4], f=25.0, width=10, height=8),
    ]
    depth = _plane_depth(target, [0.3, -0.2, 1.0], 5.0)
    depth[:, 8:] = 9.0  # a step: one-sided differences
    depth[3:6, 4] = 3.0  # a sliver: fallback 1
    depth[0, :3] = np.nan  # no proxy
    points, pixels, visible = _observe(target, sources, depth, phi)
    visible &= rng.random(visible.shape) > 0.15  # random occlusions
    estimate = rng.random((11, 14, 3)).astype(np.float32) * 0.05 + 0.5  # gradients near the threshold
    for est in (None, estimate):
        fast = bayesian_weights(est, points, pixels, visible, target, sources, distortion=phi, sigma_depth=0.3)
        slow = _reference(est, points, pixels, visible, target, sources, phi, sigma_depth=0.3)
        assert_allclose(fast, slow, rtol=F32_RTOL)


def test_gradient_kernel_matches_reference_on_random_images():
    from vergence.synthesis import _ibr_bayes_kernels as kern

    rng = np.random.default_rng(3)
    for shape in [(7, 9, 3), (1, 5, 3), (6, 1, 1), (5, 4, 1)]:
        img = rng.random(shape)
        gx, gy = np.empty(shape[:2]), np.empty(shape[:2])
        kern.luminance_gradient_rows(img, np.empty(shape[:2]), gx, gy)
        rx, ry = _gradient_reference(img)
        assert_allclose(gx, rx, atol=1e-12)
        assert_allclose(gy, ry, atol=1e-12)
    ramp = np.broadcast_to((0.01 * np.arange(6))[None, :, None], (4, 6, 3)).copy()  # grey ramp: Y = 0.01 x
    kern.luminance_gradient_rows(ramp, np.empty((4, 6)), gx := np.empty((4, 6)), gy := np.empty((4, 6)))
    assert_allclose(gx, 0.01, rtol=1e-12)  # Sobel/8 gives the slope per pixel, borders included
    assert_allclose(gy, 0.0, atol=1e-15)


# ------------------------------------------------------------------ a tiny IBR loop end to end


def test_iterated_blend_prefers_the_nearer_source_on_texture():
    """Two sources see the target's stripes; the farther one's colours are off. Iterating
    w = omega(u) -> u = normalised blend moves u toward the nearer source (texture along x)."""
    target = _camera([0, 0, 0])
    sources = [_camera([b, 0, 0], width=32, pp=(16.5, 8.5)) for b in (0.05, 0.4)]
    points, pixels, visible = _observe(target, sources, np.full((18, 24), 5.0))
    assert visible.all()
    truth = _stripes("x")
    colours = np.stack([truth, truth + np.float32(0.1)])  # source 1's samples are off by 0.1
    u, errors = None, []
    for _ in range(3):
        w = bayesian_weights(u, points, pixels, visible, target, sources, sigma_depth=0.1)
        u = (np.einsum("shw,shwc->hwc", w, colours) / w.sum(axis=0)[..., None]).astype(np.float32)
        errors.append(float(np.abs(u - truth).mean()))
    assert errors[0] == pytest.approx(0.05, rel=1e-4)  # first pass: equal weights, halfway
    assert errors[-1] < 0.6 * errors[0]


def test_importing_vergence_synthesis_does_not_load_the_bayesian_kernels():
    code = (
        "import sys; import vergence.synthesis as s; print('vergence.synthesis.ibr_bayes' in sys.modules); "
        "s.bayesian_weights; print('vergence.synthesis._ibr_bayes_kernels' in sys.modules); "
        "s.BAYES_SIGMA_SENSOR; print('vergence.synthesis.ibr_bayes' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False", "True"]  # the kernels load on the first call only


# ------------------------------------------------------------------ validation


def _valid():
    target = _camera([0, 0, 0], width=6, height=5)
    sources = [_camera([0.2, 0, 0], width=6, height=5)]
    points, pixels, visible = _observe(target, sources, np.full((5, 6), 3.0))
    return dict(estimate=None, proxy_points=points, source_pixels=pixels, visible=visible, target=target, cameras=sources)


def _call(**changes):
    args = _valid() | changes
    opts = {k: args.pop(k) for k in list(args) if k not in ("estimate", "proxy_points", "source_pixels", "visible", "target", "cameras")}
    return bayesian_weights(args["estimate"], args["proxy_points"], args["source_pixels"], args["visible"], args["target"], args["cameras"], **opts)


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        (dict(target="cam"), TypeError, "target must be a Camera"),
        (dict(cameras=[None]), TypeError, r"cameras\[0\] must be a Camera"),
        (dict(cameras=_camera([0, 0, 0])), TypeError, "cameras must be a sequence"),
        (dict(cameras=[]), ValueError, "cameras must hold at least one"),
        (dict(cameras=[_camera([0, 0, 0])] * 2), ValueError, r"source_pixels must have shape .*S = len\(cameras\)"),
        (dict(proxy_points=np.zeros((5, 7, 3))), ValueError, "proxy_points must have shape"),
        (dict(proxy_points=np.full((5, 6, 3), np.inf)), ValueError, "proxy_points must not contain inf"),
        (dict(proxy_points=np.full((5, 6, 3), "a")), TypeError, "proxy_points must be a float array"),
        (dict(source_pixels=np.zeros((1, 5, 6, 3))), ValueError, "source_pixels must have shape"),
        (dict(source_pixels=np.full((1, 5, 6, 2), np.nan)), ValueError, "source_pixels must be finite where visible"),
        (dict(visible=np.ones((1, 5, 6))), TypeError, "visible must be a boolean array"),
        (dict(visible=np.ones((1, 5, 5), bool)), ValueError, "visible must have shape"),
        (dict(proxy_points=np.full((5, 6, 3), np.nan)), ValueError, "visible must be False where proxy_points is NaN"),
        (dict(estimate=np.zeros((5, 5, 3), np.float32)), ValueError, "estimate must have shape"),
        (dict(estimate=np.full((5, 6, 3), np.nan, np.float32)), ValueError, "estimate"),
        (dict(estimate=np.full((5, 6, 3), 2.0, np.float32)), ValueError, r"estimate values must lie in \[0, 1\]"),
        (dict(sigma_sensor=0.0), ValueError, "sigma_sensor must be > 0"),
        (dict(sigma_depth=-1.0), ValueError, "sigma_depth must be > 0"),
        (dict(sigma_depth=float("nan")), ValueError, "sigma_depth must be finite"),
        (dict(gradient_threshold="0.1"), TypeError, "gradient_threshold must be a real number"),
        (dict(geometric_cap=float("inf")), ValueError, "geometric_cap must be finite"),
        (dict(deformation_cap=0.5), ValueError, "deformation_cap must be >= 1"),
        (dict(deformation_cap=float("inf")), ValueError, "deformation_cap must be finite"),
        (dict(distortion=object()), TypeError, "distortion must have callable forward"),
    ],
)
def test_bad_inputs_are_refused_by_name(changes, error, match):
    with pytest.raises(error, match=match):
        _call(**changes)


def test_a_distortion_returning_the_wrong_shape_is_named():
    class Bad(Identity):
        def jacobian(self, points):
            return np.zeros(np.shape(points))

    with pytest.raises(ValueError, match="distortion.jacobian must return shape"):
        _call(estimate=np.full((5, 6, 3), 0.5, np.float32), distortion=Bad())


def test_inputs_are_not_modified():
    args = _valid()
    args["estimate"] = _stripes("x", (5, 6))
    before = {k: np.array(v, copy=True) for k, v in args.items() if isinstance(v, np.ndarray)}
    _call(**args)
    for k, v in before.items():
        assert_array_equal(args[k], v)
