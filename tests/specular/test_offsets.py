"""Per-layer camera offsets (S3 §3.4): the shading camera, the tabulation and the per-pixel final render.

References: the convergence plane projected by :meth:`Camera.project`, the renderer's own ray
generator (:func:`vergence.render.camera_rays`) and whole renders of :meth:`Tracer.render` from
:func:`offset_camera`'s cameras.
"""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import vergence.specular.offsets as offsets_module
from vergence.camera import Camera, look_at
from vergence.rigs import stereo_pair
from vergence.specular import (
    MAX_OFFSET_STEPS,
    OffsetTable,
    layer_disparity,
    offset_camera,
    offset_rays,
    render_offsets,
    tabulate_offsets,
)

# Pixel coordinates of one point seen from cameras whose centres differ by ~1e-2 m: float64 rounding
# of the projection is ~1e-13 px; 1e-9 px fails for any real shift of the convergence plane.
PIXEL_TOL = 1e-9
# Radiance of two traces of the same rays whose directions were computed by two routes (the renderer's
# pinhole kernel and offset_rays' matrix product): equal to float32 rounding, ~1e-7 relative.
RADIANCE_RTOL = 1e-5
# World positions likewise (float32 storage of float64 hits within 1.2 m of the origin: ~1e-7 m).
POSITION_ATOL = 1e-6
W, H = 24, 16
# A wide, nearly parallel rig so that the tiny renders carry disparities of several pixels (fx = 31 px).
BASELINE, CONVERGENCE = 0.4, 50.0


def _rig(width: int = W, height: int = H, baseline: float = BASELINE, convergence: float = CONVERGENCE):
    cam = look_at([0.0, 1.15, 3.2], [0.1, 0.55, -0.6], [0.0, -1.0, 0.0], fov_deg=42.0, width=width, height=height)
    return stereo_pair(cam, baseline=baseline, convergence=convergence), cam


@pytest.fixture(scope="module")
def tracer():
    from vergence.render import Tracer, builtin_scene

    return Tracer(builtin_scene("glasses", width=W, height=H))


@pytest.fixture(scope="module")
def rig(tracer):
    cam = tracer.scene.camera.build()
    return stereo_pair(cam, baseline=BASELINE, convergence=CONVERGENCE)


@pytest.fixture(scope="module")
def pair(tracer, rig):
    left, right = rig
    return tracer.render(left, max_depth=2, samples=2), tracer.render(right, max_depth=2, samples=2)


# ---------------------------------------------------------------------------------------------- offset_camera
def test_doctests():
    assert doctest.testmod(offsets_module, raise_on_error=True).failed == 0


def test_endpoints_are_the_rig_itself():
    (left, right), _ = _rig()
    assert offset_camera(left, right, 1.0) is left
    assert offset_camera(left, right, 0) is right
    mid = offset_camera(left, right, 0.25)
    assert_allclose(mid.center, right.center + 0.25 * (left.center - right.center), rtol=0, atol=1e-15)
    assert_array_equal(mid.R, left.R)
    assert mid.principal_point[0] == pytest.approx(right.K[0, 2] + 0.25 * (left.K[0, 2] - right.K[0, 2]))


@settings(max_examples=40, deadline=None)
@given(y=st.floats(0.0, 1.0), conv=st.floats(0.5, 20.0), xs=st.floats(-2.0, 2.0), ys=st.floats(-1.0, 1.0))
def test_convergence_plane_keeps_its_pixel(y, conv, xs, ys):
    (left, right), cam = _rig(width=101, height=51, convergence=conv)
    # A point of the convergence plane z = H of the central (and left) camera frame, in the world.
    p = cam.R.T @ (np.array([xs * conv, ys * conv, conv]) - cam.t)
    pix_left, _ = left.project(p[None])
    pix_y, depth_y = offset_camera(left, right, y).project(p[None])
    assert_allclose(pix_y, pix_left, rtol=0, atol=PIXEL_TOL)
    assert depth_y[0] == pytest.approx(conv)


def test_points_off_the_plane_move_linearly_with_y():
    """x_y - x_R = y (x_L - x_R): the disparity of any point scales with the offset (pinhole geometry)."""
    (left, right), cam = _rig(width=101, height=51)
    p = (np.array([[0.3, 0.2, 1.5], [-0.5, 0.1, 9.0]]) - cam.t) @ cam.R  # camera frame to world
    xl, xr = left.project(p)[0], right.project(p)[0]
    for y in (0.0, 0.3, 0.75, 1.0):
        assert_allclose(offset_camera(left, right, y).project(p)[0], xr + y * (xl - xr), rtol=0, atol=PIXEL_TOL)
    assert np.all(np.abs(xl[:, 0] - xr[:, 0]) > 1.0)  # the points really do have disparity


def test_bad_rigs_and_offsets():
    (left, right), cam = _rig()
    with pytest.raises(TypeError, match="left must be a pinhole"):
        offset_camera("left", right, 0.5)
    with pytest.raises(TypeError, match="y must be a real number"):
        offset_camera(left, right, True)
    for y in (-0.01, 1.01, float("nan")):
        with pytest.raises(ValueError, match=r"y must lie in \[0, 1\]"):
            offset_camera(left, right, y)
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        offset_camera(right, left, 0.5)  # swapped: the "right" eye is on the left
    turned = look_at(right.center, right.center + np.array([0.3, 0.0, -1.0]), [0.0, -1.0, 0.0], fov_deg=42.0,
                     width=W, height=H)  # fmt: skip
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        offset_camera(left, turned, 0.5)  # a toed-in eye
    raised = Camera(K=right.K, R=right.R, t=right.t - right.R @ np.array([0.0, 0.0, 0.0]) + np.array([0, 0.01, 0]),
                    width=W, height=H)  # fmt: skip
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        offset_camera(left, raised, 0.5)  # a vertical baseline component
    bigger = Camera(K=right.K, R=right.R, t=right.t, width=W + 1, height=H)
    with pytest.raises(ValueError, match="share an image size"):
        offset_camera(left, bigger, 0.5)
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        offset_camera(left, left, 0.5)  # no baseline


# ---------------------------------------------------------------------------------------------- offset_rays
def test_offset_rays_are_the_cameras_rays():
    from vergence.render import camera_rays

    (left, right), _ = _rig()
    ymap = np.where(np.arange(W)[None, :] < W // 2, 0.2, 0.9) * np.ones((H, 1))
    origins, directions = offset_rays(left, right, ymap)
    assert origins.shape == directions.shape == (H, W, 3)
    for y, cols in ((0.2, slice(0, W // 2)), (0.9, slice(W // 2, W))):
        cam = offset_camera(left, right, y)
        ref = camera_rays(cam)
        assert_allclose(directions[:, cols], ref.directions.reshape(H, W, 3)[:, cols], rtol=0, atol=1e-14)
        assert_allclose(origins[:, cols], np.broadcast_to(cam.center, (H, W // 2, 3)), rtol=0, atol=1e-15)


def test_offset_rays_bad_maps():
    (left, right), _ = _rig()
    with pytest.raises(ValueError, match=r"y must have shape \(16, 24\)"):
        offset_rays(left, right, np.ones((H, W + 1)))
    with pytest.raises(ValueError, match=r"offsets in \[0, 1\]"):
        offset_rays(left, right, np.full((H, W), 1.5))
    with pytest.raises(ValueError, match=r"offsets in \[0, 1\]"):
        offset_rays(left, right, np.full((H, W), np.nan))
    with pytest.raises(TypeError, match="real numeric array"):
        offset_rays(left, right, np.ones((H, W), bool))


# ---------------------------------------------------------------------------------------------- render_offsets
def _assert_layer(result, reference, i, mask=None):
    mask = np.ones((H, W), bool) if mask is None else mask
    assert_allclose(result.radiance[i][mask], reference.radiance[i][mask], rtol=RADIANCE_RTOL, atol=1e-7)
    assert_allclose(result.position[i][mask], reference.position[i][mask], rtol=0, atol=POSITION_ATOL)
    assert_array_equal(np.isnan(result.position[i][mask]), np.isnan(reference.position[i][mask]))


def test_all_ones_is_the_left_render(tracer, rig, pair):
    left, right = rig
    out = render_offsets(tracer, left, right, np.ones((7, H, W)), samples=2)
    assert out.camera is left and out.n_layers == 7
    for i in range(7):
        _assert_layer(out, pair[0], i)
    assert_allclose(out.depth, pair[0].depth, rtol=1e-6)
    assert_allclose(out.beauty, out.radiance.sum(axis=0), rtol=1e-6)
    assert out.settings.tree_rays == pair[0].settings.tree_rays  # one pass: the maps are equal
    assert out.settings.ao_rays == pair[0].settings.ao_rays


def test_zero_layers_come_from_the_right_eye(tracer, rig, pair):
    left, right = rig
    y = np.ones((7, H, W))
    y[[1, 4]] = 0.0  # the reflection and the reflection of the refraction: mono
    out = render_offsets(tracer, left, right, y, samples=2)
    for i in range(7):
        _assert_layer(out, pair[1] if i in (1, 4) else pair[0], i)
    # The physical pair differs in those layers (else this test would prove nothing).
    assert not np.allclose(np.nan_to_num(pair[0].position[1]), np.nan_to_num(pair[1].position[1]), atol=1e-3)


def test_per_pixel_offsets_follow_each_pixels_camera(tracer, rig, pair):
    """A map that is 0.5 on the left half of the image and 1 on the right half, on one layer."""
    left, right = rig
    half = np.arange(W)[None, :] < W // 2
    y = np.ones((7, H, W))
    y[2] = np.where(half, 0.5, 1.0)
    out = render_offsets(tracer, left, right, y, samples=2)
    mid = tracer.render(offset_camera(left, right, 0.5), max_depth=2, samples=2)
    mask = np.broadcast_to(half, (H, W))
    _assert_layer(out, mid, 2, mask)
    _assert_layer(out, pair[0], 2, ~mask)
    _assert_layer(out, pair[0], 0)


def test_render_offsets_depth_one(tracer, rig):
    left, right = rig
    out = render_offsets(tracer, left, right, np.zeros((3, H, W)), samples=1)
    ref = tracer.render(right, max_depth=1, samples=1)
    assert out.settings.max_depth == 1
    for i in range(3):
        _assert_layer(out, ref, i)


def test_render_offsets_bad_input(tracer, rig):
    left, right = rig
    with pytest.raises(ValueError, match=r"N = 2\^\(D\+1\) - 1"):
        render_offsets(tracer, left, right, np.ones((6, H, W)))
    with pytest.raises(ValueError, match=r"y must have shape \(7, 16, 24\)"):
        render_offsets(tracer, left, right, np.ones((7, H, W + 2)))
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        render_offsets(tracer, left, right, np.full((3, H, W), -0.5))
    with pytest.raises(TypeError, match="numeric array"):
        render_offsets(tracer, left, right, None)
    with pytest.raises(TypeError, match="Scene or Tracer"):
        render_offsets("glasses", left, right, np.ones((1, H, W)))
    with pytest.raises(TypeError, match="progress"):
        render_offsets(tracer, left, right, np.ones((1, H, W)), progress=3)


# ---------------------------------------------------------------------------------------------- tabulate_offsets
@pytest.fixture(scope="module")
def table(tracer, rig):
    left, right = rig
    calls = []
    out = tabulate_offsets(tracer, left, right, k=4, max_depth=2, samples=2, keep_position=True,
                           progress=lambda f, msg: calls.append((f, msg)))  # fmt: skip
    return out, calls


def test_table_rows_are_the_offset_renders(tracer, rig, pair, table):
    left, right = rig
    t, _ = table
    assert isinstance(t, OffsetTable) and t.k == 4 and t.n_layers == 7
    assert_array_equal(t.offsets, [0.0, 0.25, 0.5, 0.75, 1.0])
    assert t.radiance.shape == t.position.shape == (5, 7, H, W, 3)
    assert t.disparity_px.shape == (5, 7, H, W, 2) and t.distance.shape == (5, 7, H, W)
    assert t.radiance.dtype == t.disparity_px.dtype == np.float32
    assert_array_equal(t.radiance[-1], pair[0].radiance)
    assert_array_equal(t.radiance[0], pair[1].radiance)
    ref = tracer.render(offset_camera(left, right, 0.75), max_depth=2, samples=2)
    assert_array_equal(t.radiance[3], ref.radiance)
    assert_array_equal(t.position[3], ref.position)
    match = layer_disparity(ref.position, pair[1].position, epsilon=t.epsilon)
    assert_array_equal(t.disparity_px[3], match.disparity_px)
    physical = layer_disparity(pair[0].position, pair[1].position)  # the default epsilon is the physical pair's
    assert t.epsilon == physical.epsilon
    assert_array_equal(t.disparity_px[-1], physical.disparity_px)
    assert not t.radiance.flags.writeable


def test_table_disparity_shrinks_to_zero(table):
    t, _ = table
    d0 = t.disparity_px[0][t.distance[0] == t.distance[0]]
    assert d0.size and np.all(d0 == 0.0)  # y = 0 is the right eye: every match is the same pixel
    # The first hit's horizontal disparity scales with y (x_y - x_R = y (x_L - x_R), rounded to whole pixels).
    mean = [np.nanmean(t.disparity_px[m, 0, ..., 0]) for m in range(5)]
    assert mean[-1] > 2.0
    assert_allclose(mean, t.offsets * mean[-1], rtol=0, atol=1.0)


def test_table_progress(table):
    _, calls = table
    fractions = [f for f, _ in calls]
    assert fractions == sorted(fractions) and fractions[0] == 0.0 and fractions[-1] == 1.0
    assert len(calls) == 6  # five offsets and "done"


def test_table_without_positions(tracer, rig, table):
    left, right = rig
    t = tabulate_offsets(tracer, left, right, k=2, max_depth=0, samples=1)
    assert t.position is None and t.radiance.shape == (3, 1, H, W, 3)
    assert t.seconds_render > 0.0 and t.seconds_match > 0.0


def test_table_bad_input(tracer, rig):
    left, right = rig
    for k in (1, 0, MAX_OFFSET_STEPS + 1):
        with pytest.raises(ValueError, match=r"k must be an integer in \[2, 256\]"):
            tabulate_offsets(tracer, left, right, k=k)
    with pytest.raises(TypeError, match="k must be an integer"):
        tabulate_offsets(tracer, left, right, k=4.0)
    with pytest.raises(TypeError, match="keep_position"):
        tabulate_offsets(tracer, left, right, k=2, keep_position=1)
    with pytest.raises(ValueError, match="max_depth"):
        tabulate_offsets(tracer, left, right, k=2, max_depth=9)
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        tabulate_offsets(tracer, right, left, k=2)
