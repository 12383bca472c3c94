"""rigs.shoot: the Tri-Rig's mapped disparity is what the reference right camera sees of the distorted world."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.rigs import shot_from_dict
from vergence.rigs.shoot import mapped_disparity, render_shot


def _tri():
    return shot_from_dict({
        "rig": "tri", "scene": "stadium", "display": "tv-55",
        "camera": {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "up": [0, 1, 0], "fov_deg": 8.0,
                   "width": 48, "height": 27},
        "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=6"], "reference": "round", "near": 25.0,
    })  # fmt: skip


def test_mapped_disparity_is_the_disparity_of_phi_in_the_reference_right_camera():
    rig = _tri().plan()
    cam = rig.director
    rng = np.random.default_rng(0)
    depth = rng.uniform(26.0, 90.0, (cam.height, cam.width))
    depth[0, :5] = np.nan  # sky stays NaN
    d = mapped_disparity(rig, depth)
    points = cam.backproject_depth(np.nan_to_num(depth, nan=50.0))
    right, _ = rig.reference_right.project(rig.distortion.forward(points.reshape(-1, 3)))
    x_left = cam.pixel_grid()[..., 0]
    expected = x_left - right[:, 0].reshape(depth.shape)
    ok = np.isfinite(depth)
    np.testing.assert_allclose(d[ok], expected[ok], atol=2e-3)  # float32 output
    assert np.isnan(d[~ok]).all()
    # on the convergence plane psi(0) = 0: zero disparity; farther: uncrossed (x_left - x_right < 0)
    at_h = mapped_disparity(rig, np.full((1, 1), rig.reference.convergence))
    assert abs(float(at_h[0, 0])) < 1e-4
    assert float(mapped_disparity(rig, np.full((1, 1), 60.0))[0, 0]) < 0


@pytest.mark.parametrize(("kwargs", "needle"), [
    ({"weights": ("mean",)}, "weights"),
    ({"weights": "ulr"}, "weights"),
    ({"samples": 0}, "samples"),
    ({"supersample": 1.5}, "supersample"),
])
def test_render_shot_refuses_bad_options_before_rendering(kwargs, needle):
    with pytest.raises(ValueError, match=needle):
        render_shot(_tri(), **kwargs)


def test_render_shot_refuses_a_non_shot():
    with pytest.raises(TypeError, match="shot"):
        render_shot({"rig": "tri"})


def test_error_image_is_the_gained_difference_and_blue_holes():
    result = render_shot(_tri(), weights=("ulr",), samples=1, supersample=1)
    err = result.error_image("ulr", "right", gain=4.0)
    image, truth = result.images["ulr"]["right"], result.truth["right"]
    covered = result.results["ulr"]["right"].coverage
    slow = np.clip(4.0 * np.abs(image.astype(np.float64) - truth).mean(axis=-1), 0.0, 1.0)  # by hand
    assert err.shape == image.shape and err.dtype == np.float32
    np.testing.assert_allclose(err[covered], np.repeat(slow[covered][:, None], 3, axis=1), atol=1e-6)
    assert (~covered).any()  # the stadium's Tri-Rig leaves a few pixels unseen
    np.testing.assert_allclose(err[~covered], np.broadcast_to([0.1, 0.2, 0.8], err[~covered].shape), atol=1e-7)
    with pytest.raises(KeyError, match="no synthesised ulr/left eye; synthesised: ulr/right"):
        result.error_image("ulr", "left")
    with pytest.raises(KeyError, match="bayesian/right"):
        result.error_image("bayesian", "right")


def test_progress_reaches_inside_the_curved_truth_and_timings_are_per_stage():
    seen = []
    result = render_shot(_tri(), weights=("ulr",), samples=1, supersample=2, progress=lambda f, m: seen.append((f, m)))
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    inside = [m for _, m in seen if m.startswith("curved-ray truth: curved rays")]
    assert len(inside) >= 2  # octave by octave, not one step for the whole truth
    timings = result.report["timings"]
    assert list(timings["stages_s"]) == ["scene", "real_cameras", "curved_truth", "tone_mapping", "ibr_ulr", "measures"]
    assert all(v >= 0 for v in timings["stages_s"].values())
    parts = sum(timings["stages_s"][k] for k in ("scene", "real_cameras", "curved_truth"))
    assert timings["ray_tracing_s"] == pytest.approx(parts, abs=0.02)
    assert sum(timings["stages_s"].values()) <= timings["total_s"] + 0.02


def test_the_rig_cameras_side_by_side_equal_separate_renders():
    from vergence.rigs.shoot import _tracer

    shot = _tri()
    rig = shot.plan()
    tracer = _tracer(shot)
    cams = [rc.camera for rc in rig.cameras]
    together = tracer.render_many(cams, samples=2, supersample=2)
    for cam, res in zip(cams, together):
        np.testing.assert_array_equal(res.beauty, tracer.render(cam, samples=2, supersample=2).beauty)
