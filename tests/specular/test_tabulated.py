"""S3's tabulated g(y) (S3 §3.4): every row of analyse_table equals the public stages run on that
row's pair by hand; layer_lightness equals perceived_lightness's eyes."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from vergence.rigs import stereo_pair
from vergence.specular import (
    OffsetAnalysis,
    analyse_table,
    disparity_arcmin,
    importance,
    layer_disparity,
    layer_lightness,
    offset_camera,
    perceived_lightness,
    rivalry,
    tabulate_offsets,
)
from vergence.viewing import Display

W, H = 40, 30
DISPLAY = Display.preset("samsung-2233rz")


@pytest.fixture(scope="module")
def tracer():
    from vergence.render import Tracer, builtin_scene

    return Tracer(builtin_scene("glasses", width=W, height=H))


@pytest.fixture(scope="module")
def rig(tracer):
    return stereo_pair(tracer.scene.camera.build(), baseline=0.3, convergence=3.6)


@pytest.fixture(scope="module")
def table(tracer, rig):
    return tabulate_offsets(tracer, *rig, k=2, samples=2)


@pytest.fixture(scope="module")
def analysis(table):
    return analyse_table(table, DISPLAY)


def test_layer_lightness_is_perceived_lightness_per_eye(table):
    left, right = table.left, table.right
    both = perceived_lightness(left.radiance, right.radiance, left.position, right.position, DISPLAY)
    for res, want in ((left, both.left), (right, both.right)):
        got = layer_lightness(res.radiance, res.position, DISPLAY, exposure=both.exposure)
        assert_array_equal(got, want)
        assert_array_equal(layer_lightness(res.radiance, None, DISPLAY, exposure=both.exposure), want)


@pytest.mark.parametrize("m", [0, 1, 2])
def test_every_row_is_the_stages_on_that_rows_pair(tracer, rig, table, analysis, m):
    """Row m: the left eye rendered from offset_camera(m / k), matched, its L* against the right's."""
    left_cam, right_cam = rig
    res = tracer.render(offset_camera(left_cam, right_cam, m / 2), samples=2)
    match = layer_disparity(res.position, table.right.position, epsilon=table.epsilon)
    lit = perceived_lightness(res.radiance, table.right.radiance, res.position, table.right.position, DISPLAY,
                              exposure=analysis.exposure)  # fmt: skip
    assert_array_equal(analysis.disparity[m], disparity_arcmin(match.disparity_px, DISPLAY).astype(np.float32))
    assert_array_equal(analysis.importance[m], importance(lit, match).weight)
    assert_array_equal(analysis.rivalry[m], rivalry(lit, match).rivalry)


def test_the_default_exposure_is_the_physical_pairs(table, analysis):
    left, right = table.left, table.right
    assert analysis.exposure == perceived_lightness(left.radiance, right.radiance, left.position, right.position,
                                                    DISPLAY).exposure  # fmt: skip
    assert analysis.k == 2 and analysis.original.shape == (table.n_layers, H, W, 2)
    assert not analysis.disparity.flags.writeable


def test_row_zero_is_the_right_eye_against_itself(analysis, table):
    """y = 0 is the right camera: every layer with a surface matches itself, at zero disparity, no rivalry."""
    present = np.isfinite(table.right.position).all(axis=-1)
    d = analysis.disparity[0]
    assert_array_equal(np.isfinite(d[..., 0]), present)
    assert np.all(d[present] == 0.0)
    assert np.nanmax(analysis.rivalry[0][present]) == 0.0


def test_bad_inputs(table):
    with pytest.raises(TypeError, match="OffsetTable"):
        analyse_table("table", DISPLAY)
    with pytest.raises(TypeError, match="Display"):
        analyse_table(table, "samsung")
    with pytest.raises(ValueError, match="exposure"):
        analyse_table(table, DISPLAY, exposure=-1.0)
    with pytest.raises(ValueError, match="resolution"):
        analyse_table(table, Display(0.065, 0.6, 0.47))
    with pytest.raises(ValueError, match="radiance must be >= 0"):
        layer_lightness(-np.ones((1, 2, 2, 3)), None, DISPLAY, exposure=1.0)
    with pytest.raises(ValueError, match="radiance must be finite where the layer has a surface"):
        layer_lightness(np.full((1, 2, 2, 3), np.nan), np.zeros((1, 2, 2, 3)), DISPLAY, exposure=1.0)
    with pytest.raises(ValueError, match="must have shape"):
        OffsetAnalysis(offsets=np.zeros(2), disparity=np.zeros((3, 1, 2, 2, 2)), rivalry=np.zeros((3, 1, 2, 2)),
                       importance=np.zeros((3, 1, 2, 2)), exposure=1.0, display=DISPLAY, seconds=0.0)  # fmt: skip
