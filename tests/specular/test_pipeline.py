"""S3 end to end (specular_stereo): the offsets, the final render measured by an independent match,
the baselines, the report; a scene without glass or mirror; bad input refused before any render."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.rigs import stereo_pair
from vergence.specular import (
    COST_TERMS,
    LayerState,
    comfort_share,
    disparity_arcmin,
    layer_disparity,
    specular_stereo,
)
from vergence.viewing import ComfortZone, Display

W, H = 48, 36
DISPLAY = Display.preset("samsung-2233rz")
# A wide baseline: at 48 px across, the glasses' reflections then lie far outside the +-60' zone.
BASELINE = 0.4


def _setup(name: str):
    from vergence.render import Tracer, builtin_scene

    tracer = Tracer(builtin_scene(name, width=W, height=H))
    return tracer, stereo_pair(tracer.scene.camera.build(), baseline=BASELINE, convergence=3.6)


@pytest.fixture(scope="module")
def glasses():
    tracer, (left, right) = _setup("glasses")
    return specular_stereo(tracer, left, right, DISPLAY, k=4, samples=2), left, right


def test_the_after_state_is_what_an_independent_matcher_measures(glasses):
    result, left, right = glasses
    # the cutoff of the physical pair (1 % of its scene diameter), as for every state of the run
    epsilon = layer_disparity(result.physical_left.position, result.right.position).epsilon
    assert result.settings["match_epsilon_m"] == epsilon  # the report gives it to any other matcher
    match = layer_disparity(result.optimised_left.position, result.right.position, epsilon=epsilon)
    assert_allclose(result.after.disparity, disparity_arcmin(match.disparity_px, DISPLAY).astype(np.float32))
    assert_array_equal(result.after.present, np.isfinite(result.optimised_left.position).all(axis=-1))


def test_offsets_keep_the_diffuse_layer_and_stay_in_range(glasses):
    result, _, _ = glasses
    assert result.specular
    assert result.y.shape == (7, H, W) and result.y.dtype == np.float32
    assert np.all(result.y[0] == 1.0)
    assert result.y.min() >= 0.0 and result.y.max() <= 1.0
    assert result.y[1:].min() < 1.0  # something specular was moved
    # the diffuse layer is shaded from the left eye in every method
    assert_array_equal(result.optimised_left.radiance[0], result.physical_left.radiance[0])
    assert_array_equal(result.on_surface_left.radiance[0], result.physical_left.radiance[0])


def test_the_optimised_pair_is_more_comfortable_than_the_physical_one(glasses):
    result, _, _ = glasses
    before, after = comfort_share(result.before, result.zone), comfort_share(result.after, result.zone)
    spec = [i for i in range(1, 7) if np.isfinite(before[i]) and before[i] < 0.9]
    assert spec, "the wide rig must put some specular layer outside the zone"
    gained = [after[i] - before[i] for i in spec if np.isfinite(after[i])]
    assert np.mean(gained) > 0.1
    assert result.cost_after.total.mean() < result.cost_before.total.mean()


def test_report_is_json_and_says_what_it_measured(glasses):
    result, _, _ = glasses
    report = json.loads(json.dumps(result.report(), allow_nan=False))
    assert report["specular"] is True
    assert set(report["cost_before"]) == {*COST_TERMS, "total"}
    # the comfort objective's data term pulls to the nearest comfortable disparity: on the physical
    # pair it is the absolute term's excess again (both are the distance to the target zone)
    assert report["cost_before"]["data"] == pytest.approx(report["cost_before"]["absolute"], rel=1e-9)
    assert report["cost_before"]["absolute"] > 0.0
    assert [layer["layer"] for layer in report["layers"]] == list(range(1, 8))
    assert report["layers"][0]["offset_mean"] == 1.0
    assert report["comfort_zone_arcmin"] == [-60.0, 60.0]
    assert report["settings"]["k"] == 4 and report["settings"]["variant"] == "comfort"
    for key in ("tabulate_render", "tabulate_analyse", "plan_solve", "final_render", "total"):
        assert report["seconds"][key] >= 0.0


def test_reoptimise_equals_a_fresh_run_with_the_new_weights(glasses):
    """Re-optimising reuses the table: its offsets, renders and figures are those of a run from
    scratch with the same weights and maps (the table, the planner and the renders are deterministic)."""
    result, left, right = glasses
    tracer, _ = _setup("glasses")
    rng = np.random.default_rng(3)
    maps = {"absolute": rng.uniform(0.0, 4.0, (7, H, W))}
    alpha = (2.0, 1.0, 5.0, 0.5)
    again = result.reoptimise(alpha=alpha, variant="screen", maps=maps)
    fresh = specular_stereo(tracer, left, right, DISPLAY, k=4, samples=2, alpha=alpha, variant="screen", maps=maps)
    assert_array_equal(again.y, fresh.y)
    assert_array_equal(again.optimised_left.radiance, fresh.optimised_left.radiance)
    assert again.report()["layers"] == fresh.report()["layers"]
    assert again.report()["cost_after"] == fresh.report()["cost_after"]
    assert again.settings["variant"] == "screen" and again.settings["maps"] == ["absolute"]
    assert not np.array_equal(again.y, result.y)  # the new weights moved something
    # the defaults are the first run's weights and variant: the same offsets
    assert_array_equal(result.reoptimise().y, result.y)
    assert again.physical_left is result.physical_left  # the physical pair and baselines are reused


def test_reoptimise_refuses_bad_weights_and_a_released_result(glasses):
    result, _, _ = glasses
    with pytest.raises(ValueError, match="map"):
        result.reoptimise(maps={"absolute": np.ones((7, H + 1, W))})
    with pytest.raises(ValueError, match="variant"):
        result.reoptimise(variant="nearest")
    released = result.release()
    assert_array_equal(released.y, result.y)
    with pytest.raises(ValueError, match="re-optimise"):
        released.reoptimise()


def test_a_scene_without_glass_or_mirror_is_its_physical_pair():
    tracer, (left, right) = _setup("tabletop")
    result = specular_stereo(tracer, left, right, DISPLAY, k=4, samples=2)
    assert not result.specular
    assert result.optimised_left is result.physical_left
    assert np.all(result.y == 1.0)
    assert "tabulate_render" not in result.seconds  # no table was rendered
    assert_array_equal(result.on_surface_left.radiance, result.physical_left.radiance)
    assert result.cost_after.total.mean() == result.cost_before.total.mean()


def test_comfort_share_by_hand():
    d = np.full((2, 1, 4, 2), np.nan, np.float32)
    d[0, 0, :, 0] = [0.0, 70.0, -50.0, -80.0]
    d[0, 0, :, 1] = 0.0
    w = np.array([[[1.0, 1.0, 2.0, 0.0]], [[1.0, 1.0, 1.0, 1.0]]], np.float32)
    state = LayerState(disparity=d, importance=w, rivalry=np.zeros((2, 1, 4), np.float32),
                       present=np.ones((2, 1, 4), bool))  # fmt: skip
    share = comfort_share(state, ComfortZone(crossed_arcmin=60.0, uncrossed_arcmin=60.0))
    assert share[0] == pytest.approx(3.0 / 4.0)  # 0' and -50' (weight 1 + 2) of total weight 4
    assert np.isnan(share[1])  # nothing matched
    with pytest.raises(TypeError, match="ComfortZone"):
        comfort_share(state, (-60, 60))


class _NoRender:
    """A tracer stand-in whose renders fail the test: bad input must be refused before any render."""

    def __init__(self, tracer):
        self.scene = tracer.scene

    def render(self, *args, **kwargs):
        raise AssertionError("rendered before refusing the input")


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"k": 1}, ValueError, "k must be an integer in"),
        ({"alpha": (1, 1, -1, 0)}, ValueError, "alpha must be"),
        ({"variant": "flat"}, ValueError, "variant must be one of"),
        ({"maps": {"rivalry": np.ones((7, 3, 3))}}, ValueError, "rivalry weight map must have shape"),
        ({"maps": {"absolute": -np.ones((7, H, W))}}, ValueError, "must be finite and >= 0"),
        ({"zone": (-60, 60)}, TypeError, "ComfortZone"),
        ({"max_depth": -1}, ValueError, "max_depth"),
        ({"factor": 0}, ValueError, "factor must be an integer in"),
        ({"near_arcmin": -1.0}, ValueError, "near_arcmin must lie in"),
    ],
)
def test_bad_input_is_refused_before_any_render(monkeypatch, kwargs, error, match):
    tracer, (left, right) = _setup("glasses")
    spy = _NoRender(tracer)
    monkeypatch.setattr("vergence.specular.offsets.tracer_of", lambda scene: spy)
    with pytest.raises(error, match=match):
        specular_stereo(tracer, left, right, DISPLAY, **kwargs)


def test_a_table_past_the_memory_limit_is_refused_before_any_render(monkeypatch):
    from vergence.camera import look_at
    from vergence.specular import MAX_TABLE_BYTES

    tracer, _ = _setup("glasses")
    monkeypatch.setattr("vergence.specular.offsets.tracer_of", lambda scene: _NoRender(tracer))
    cam = look_at([0.0, 1.15, 3.2], [0.1, 0.55, -0.6], [0.0, -1.0, 0.0], fov_deg=42.0, width=120, height=80)
    left, right = stereo_pair(cam, baseline=0.065, convergence=3.6)
    # 257 offsets x 127 layers x 9600 px x 56 B = 17.5 GB
    assert 257 * 127 * 120 * 80 * 56 > MAX_TABLE_BYTES
    with pytest.raises(ValueError, match=r"offset table of 120x80 pixels, 127 layers and k = 256 would take about 16.3 GiB"):
        specular_stereo(tracer, left, right, DISPLAY, k=256, max_depth=6)


def test_bad_rig_and_display():
    tracer, (left, right) = _setup("glasses")
    with pytest.raises(ValueError, match="shifted-sensor rig"):
        specular_stereo(tracer, right, left, DISPLAY)
    with pytest.raises(ValueError, match="resolution"):
        specular_stereo(tracer, left, right, Display(0.065, 0.6, 0.47))
    with pytest.raises(TypeError, match="Display"):
        specular_stereo(tracer, left, right, "samsung-2233rz")
    with pytest.raises(TypeError, match="Scene or Tracer"):
        specular_stereo("glasses", left, right, DISPLAY)
