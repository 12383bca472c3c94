"""The final render's check for lost and foreign layer pixels, and its repair (issue 26): counts
against layers removed by hand, the repair against the physical left eye."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vergence.rigs import stereo_pair
from vergence.specular import REPAIR_STEPS, check_render, render_offsets, repair_render

W, H = 48, 36


@pytest.fixture(scope="module")
def rig():
    from vergence.render import Tracer, builtin_scene

    tracer = Tracer(builtin_scene("glasses", width=W, height=H))
    left, right = stereo_pair(tracer.scene.camera.build(), baseline=0.4, convergence=3.6)  # a wide rig: wide rims
    return tracer, left, right, tracer.render(left, samples=2)


def test_counts_are_the_layer_pixels_removed_or_added_by_hand(rig):
    _, _, _, phys = rig
    assert check_render(phys, phys).to_dict() == {"lost": [0] * 7, "foreign": [0] * 7, "rim": 0}
    pos = np.array(phys.position)
    has = np.isfinite(pos).all(axis=-1)
    ys, xs = np.nonzero(has[1])
    pos[1, ys[:5], xs[:5]] = np.nan  # five reflection pixels lost
    ys0, xs0 = np.nonzero(~has[2])
    pos[2, ys0[:3], xs0[:3]] = 1.0  # three refraction pixels where the pixel has none
    pos[3, ys[:5], xs[:5]] = np.nan  # the same pixels lose their second reflection, if they have one
    check = check_render(phys, replace(phys, position=pos))
    lost3 = int(has[3, ys[:5], xs[:5]].sum())
    assert check.lost.tolist() == [0, 5, 0, lost3, 0, 0, 0]
    assert check.foreign.tolist() == [0, 0, 3, 0, 0, 0, 0]
    assert check.rim == 8 and not check.clean


def test_repair_leaves_no_layer_pixel_lost_or_foreign(rig):
    tracer, left, right, phys = rig
    y = np.ones((7, H, W), np.float32)
    y[1:] = 0.1  # every specular layer nearly mono: rims around the spheres and the goblet
    raw = render_offsets(tracer, left, right, y, samples=2)
    fixed = repair_render(tracer, left, right, y, phys, raw, samples=2)
    assert fixed.before.rim > 0 and fixed.before.lost.sum() > 0 and fixed.before.foreign.sum() > 0
    assert fixed.after.rim == 0
    np.testing.assert_array_equal(np.isfinite(fixed.render.position).all(-1), np.isfinite(phys.position).all(-1))
    moved = fixed.y != y
    has = np.isfinite(phys.position).all(-1)
    lost = has & ~np.isfinite(raw.position).all(-1)
    assert np.all(fixed.y[1:][~has[1:]] == 1.0)  # a layer the pixel does not have: 1
    moved[1:][~has[1:]] = False
    assert not (moved & ~lost).any()  # otherwise only lost pixels change their offset ...
    allowed = [y[1, 0, 0] + (1 - y[1, 0, 0]) * t for t in (*REPAIR_STEPS, 1.0)]
    assert np.all(np.isin(np.round(fixed.y[moved], 5), np.round(np.array(allowed, np.float32), 5)))  # ... to these
    # layer pixels with nothing to repair keep what was traced; foreign ones are gone
    has, got = np.isfinite(phys.position).all(-1), np.isfinite(raw.position).all(-1)
    np.testing.assert_array_equal(fixed.render.radiance[has & got], raw.radiance[has & got])
    assert not fixed.render.radiance[~has & got].any()
    np.testing.assert_allclose(fixed.render.beauty, fixed.render.radiance.sum(axis=0), rtol=1e-6)


def test_a_clean_render_is_returned_as_it_is(rig):
    tracer, left, right, phys = rig
    fixed = repair_render(tracer, left, right, np.ones((7, H, W)), phys, phys, samples=2)
    assert fixed.render is phys and fixed.after.clean


def test_bad_input(rig):
    tracer, left, right, phys = rig
    with pytest.raises(TypeError, match="RenderResult"):
        check_render(phys, "render")
    small = tracer.render(stereo_pair(tracer.scene.camera.build(), baseline=0.4, convergence=3.6)[0], max_depth=1,
                          samples=1)  # fmt: skip
    with pytest.raises(ValueError, match="same layers and size"):
        check_render(phys, small)
