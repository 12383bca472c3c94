"""render_ibr and IBRSource: bad input refused by name, empty proxies, progress."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.camera import Camera, look_at
from vergence.synthesis import IBR_WEIGHTS, IBRSource, render_ibr


def _cam(x: float) -> Camera:
    return look_at([x, 0.0, 0.0], [x, 0.0, 10.0], [0.0, -1.0, 0.0], fov_deg=50.0, width=48, height=36)


def _source(x: float) -> IBRSource:
    """A grey wall 10 m in front of a camera at (x, 0, 0)."""
    return IBRSource(_cam(x), np.full((36, 48, 3), 0.5, dtype=np.float32), np.full((36, 48), 10.0))


class _Identity:
    def forward(self, p):
        return np.asarray(p)

    def inverse(self, q):
        return np.asarray(q)

    def jacobian(self, p):
        return np.broadcast_to(np.eye(3), np.shape(p) + (3,)).copy()


def _good():
    return _cam(0.3), [_source(0.0), _source(1.0)]


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"weights": "sibr"}, ValueError, "weights must be one of ulr, bayesian"),
        ({"k": 0}, ValueError, "k must be >= 1"),
        ({"k": 2.0}, TypeError, "k must be an integer"),
        ({"alpha": np.nan}, ValueError, "alpha must be finite"),
        ({"beta": -0.1}, ValueError, "beta must be >= 0"),
        ({"alpha": 0.0, "beta": 0.0}, ValueError, "alpha and beta"),
        ({"occlusion_tolerance": 0.0}, ValueError, "occlusion_tolerance must be > 0"),
        ({"occlusion_tolerance": np.inf}, ValueError, "occlusion_tolerance must be finite"),
        ({"gradient_limit": -1.0}, ValueError, "gradient_limit must be >= 0"),
        ({"iterations": -1}, ValueError, "iterations must be >= 0"),
        ({"sigma_sensor": 0.0}, ValueError, "sigma_sensor must be > 0"),
        ({"sigma_depth": np.nan}, ValueError, "sigma_depth must be finite"),
        ({"deformation_cap": -1.0}, ValueError, "deformation_cap must be > 0"),
        ({"deformation_cap": 0.5}, ValueError, "deformation_cap must be >= 1"),
        ({"progress": "yes"}, TypeError, "progress must be a callable"),
        ({"proxy_depth": np.ones((3, 3))}, ValueError, r"proxy_depth must have shape \(36, 48\)"),
        ({"proxy_depth": np.full((36, 48), np.inf)}, ValueError, "proxy_depth must not contain inf"),
        ({"proxy_depth": np.zeros((36, 48))}, ValueError, "proxy_depth must be > 0"),
        ({"proxy_depth": "deep"}, TypeError, "proxy_depth must be numeric"),
        ({"distortion": object()}, TypeError, "distortion must have callable forward, inverse and jacobian"),
    ],
)
def test_bad_options_are_refused_by_name(kwargs, error, match):
    target, srcs = _good()
    with pytest.raises(error, match=match):
        render_ibr(target, srcs, **kwargs)


def test_bad_target_and_sources_are_refused_by_name():
    target, srcs = _good()
    with pytest.raises(TypeError, match="target must be a Camera"):
        render_ibr("cam", srcs)
    with pytest.raises(ValueError, match="sources must hold at least one IBRSource"):
        render_ibr(target, [])
    with pytest.raises(TypeError, match=r"sources\[1\] must be an IBRSource"):
        render_ibr(target, [srcs[0], (srcs[1].camera, srcs[1].image, srcs[1].depth)])
    with pytest.raises(TypeError, match="sources must be a sequence of IBRSource"):
        render_ibr(target, srcs[0])


def test_a_bad_distortion_output_is_refused_by_name():
    class Flat(_Identity):
        def inverse(self, q):
            return np.zeros(3)

    target, srcs = _good()
    with pytest.raises(ValueError, match="distortion.inverse must return shape"):
        render_ibr(target, srcs, distortion=Flat())


def test_bad_sources_are_refused_by_name():
    cam = _cam(0.0)
    image, depth = _source(0.0).image, _source(0.0).depth
    with pytest.raises(TypeError, match="camera must be a Camera"):
        IBRSource(None, image, depth)
    with pytest.raises(ValueError, match=r"image must have shape \(36, 48, 3\) matching the camera"):
        IBRSource(cam, image[:-1], depth)
    with pytest.raises(ValueError, match=r"image must have shape \(H, W, 3\)"):
        IBRSource(cam, image[..., 0], depth)
    with pytest.raises(ValueError, match="image values must lie in"):
        IBRSource(cam, image * 3, depth)
    with pytest.raises(ValueError, match=r"depth must have shape \(36, 48\) matching the image and camera"):
        IBRSource(cam, image, depth[:, :-1])
    for bad, match in ((np.inf, "depth must not contain inf"), (-np.inf, "depth must not contain inf"),
                       (0.0, "depth must be > 0"), (-2.0, "depth must be > 0")):
        d = depth.copy()
        d[3, 4] = bad
        with pytest.raises(ValueError, match=match):
            IBRSource(cam, image, d)
    with pytest.raises(TypeError, match="depth must be real"):
        IBRSource(cam, image, depth.astype(complex))
    d = depth.copy()
    d[:5] = np.nan  # no surface: allowed
    assert np.isnan(IBRSource(cam, image, d).depth[:5]).all()


def test_nothing_seen_leaves_holes_and_weights_listed():
    target, srcs = _good()
    res = render_ibr(target, srcs, proxy_depth=np.full((36, 48), np.nan))
    assert not res.coverage.any() and (res.image == 0).all() and (res.weights == 0).all()
    assert np.isnan(res.proxy_points).all()
    assert IBR_WEIGHTS == ("ulr", "bayesian")


def test_progress_is_told_each_stage():
    target, srcs = _good()
    seen = []
    render_ibr(target, srcs, progress=lambda f, m: seen.append((f, m)))
    assert seen[0][0] == 0.0 and seen[-1] == (1.0, "done") and len(seen) >= 4


def test_sources_whose_depth_is_all_nan_are_refused_in_one_line():
    target, srcs = _good()
    blind = [IBRSource(s.camera, s.image, np.full(s.depth.shape, np.nan)) for s in srcs]
    with pytest.raises(ValueError, match="every source depth is NaN"):
        render_ibr(target, blind)
    # with a given proxy there is something to sample (nothing here): holes, no error
    res = render_ibr(target, blind, proxy_depth=np.full((target.height, target.width), 5.0))
    assert not res.coverage.any()
