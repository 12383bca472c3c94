"""PatchMatch Stereo (Bleyer, Rhemann & Rother 2011): kernels against slow references, a slanted plane, LR check, refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vergence.cli import main
from vergence.depth import PatchMatchParameters, compute_disparity, patchmatch_stereo
from vergence.depth import _kernels
from vergence.depth.patchmatch import _gradient_x, _post_process

# Costs are sums of a few hundred float64 terms in a different order: 1e-9 relative.
COST_RTOL = 1e-9
# A textured slanted plane (8-bit images, linear interpolation): 99 % of the disparities found within
# this (pixels) of the truth, away from the left edge where matches leave the image (measured 0.09 px;
# the median error 0.017 px), and the slopes within SLOPE_TOL of the truth (measured 0.0033, 0.0011).
SLANT_TOL_PX = 0.15
SLANT_MEDIAN_TOL_PX = 0.03
SLOPE_TOL = 0.005
ALPHA, TAU_C, TAU_G, GAMMA = 0.9, 10.0, 2.0, 10.0


def _images(rng, h=14, w=26, ch=3):
    img = np.rint(rng.uniform(0, 255, (h, w, ch))).astype(np.float32)
    other = np.rint(rng.uniform(0, 255, (h, w, ch))).astype(np.float32)
    return img, _gradient_x(img), other, _gradient_x(other)


def _lut(ch=3):
    return np.exp(-np.arange(255 * ch + 1, dtype=np.float64) / GAMMA)


def _slow_cost(y, x, a, b, c, img, grad, other, ograd, radius, step, sgn, d_min=-1e9, d_max=1e9):
    """PMS Eq. (2)-(5) written out: every window sample, weight, interpolated match and truncated cost."""
    h, w, ch = img.shape
    if not d_min <= a * x + b * y + c <= d_max:
        return math.inf
    if 1.0 + sgn * a < 0.1:  # the plane seen edge-on or from behind in the other view
        return math.inf
    total = 0.0
    n = radius // step
    for i in range(-n, n + 1):
        for j in range(-n, n + 1):
            v, u = y + i * step, x + j * step
            if not (0 <= v < h and 0 <= u < w):
                continue
            weight = math.exp(-float(np.abs(img[y, x] - img[v, u]).sum()) / GAMMA)
            if weight < _kernels.PMS_MIN_WEIGHT:
                continue
            xm = min(max(u + sgn * (a * u + b * v + c), 0.0), w - 1.0)
            x0 = min(int(math.floor(xm)), w - 2)
            f = xm - x0
            colour = (1 - f) * other[v, x0].astype(np.float64) + f * other[v, x0 + 1].astype(np.float64)
            g = (1 - f) * ograd[v, x0].astype(np.float64) + f * ograd[v, x0 + 1].astype(np.float64)
            rho = ((1 - ALPHA) * min(float(np.abs(img[v, u] - colour).sum()), TAU_C)
                   + ALPHA * min(float(np.abs(grad[v, u] - g).sum()), TAU_G))
            total += weight * rho
    return total


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_plane_cost_matches_the_reference(seed):
    rng = np.random.default_rng(seed)
    img, grad, other, ograd = _images(rng)
    for _ in range(6):
        y, x = int(rng.integers(0, 14)), int(rng.integers(0, 26))
        a, b, c = rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(0, 8)
        radius, step = int(rng.integers(1, 6)), int(rng.integers(1, 3))
        sgn = float(rng.choice([-1.0, 1.0]))
        want = _slow_cost(y, x, a, b, c, img, grad, other, ograd, radius, step, sgn)
        got = _kernels.plane_cost(y, x, a, b, c, img, grad, other, ograd, _lut(), radius, step, sgn, ALPHA, TAU_C,
                                  TAU_G, -1e9, 1e9)
        np.testing.assert_allclose(got, want, rtol=COST_RTOL)
    # a plane whose disparity at the pixel leaves the range is never adopted
    assert _kernels.plane_cost(3, 3, 0.0, 0.0, 9.0, img, grad, other, ograd, _lut(), 2, 1, -1.0, ALPHA, TAU_C, TAU_G,
                               0.0, 8.0) == math.inf
    # nor one the other view sees edge-on or from behind: slope a >= 0.9 from the left, <= -0.9 from the right
    for a, sgn in ((0.95, -1.0), (-0.95, 1.0)):
        args = (img, grad, other, ograd, _lut(), 2, 1, sgn, ALPHA, TAU_C, TAU_G, 0.0, 8.0)
        assert _kernels.plane_cost(3, 3, a, 0.0, 4.0 - 3 * a, *args) == math.inf
        assert _kernels.plane_cost(3, 3, -a, 0.0, 4.0 + 3 * a, *args) < math.inf


def test_gradient_is_the_sobel_x_derivative_over_8():
    rng = np.random.default_rng(4)
    img = np.rint(rng.uniform(0, 255, (7, 9, 3))).astype(np.float32)
    grey = np.pad(img.mean(axis=2).astype(np.float64), 1, mode="edge")
    want = np.zeros((7, 9))
    for y in range(7):
        for x in range(9):
            for dy, wy in ((-1, 1), (0, 2), (1, 1)):
                want[y, x] += wy * (grey[y + 1 + dy, x + 2] - grey[y + 1 + dy, x]) / 8
    got = _gradient_x(img)
    assert got.shape == (7, 9, 1)
    np.testing.assert_allclose(got[:, :, 0], want, atol=1e-4)


def _slow_sweep_rows(planes, costs, img, grad, other, ograd, radius, step, sgn, forward, d_min, d_max):
    """Spatial propagation along the rows without refinement: each pixel, in scan order, tries its predecessor."""
    planes, costs = planes.copy(), costs.copy()
    h, w = costs.shape
    for y in range(h):
        for x in (range(w) if forward else range(w - 1, -1, -1)):
            xn = x - 1 if forward else x + 1
            if 0 <= xn < w:
                cand = _slow_cost(y, x, *planes[y, xn], img, grad, other, ograd, radius, step, sgn, d_min, d_max)
                if cand < costs[y, x]:
                    costs[y, x], planes[y, x] = cand, planes[y, xn]
    return planes, costs


@pytest.mark.parametrize("forward", [True, False])
def test_row_sweep_matches_the_reference(forward):
    rng = np.random.default_rng(7)
    img, grad, other, ograd = _images(rng, h=6, w=12)
    h, w = 6, 12
    planes = _kernels.random_planes(h, w, 0.0, 5.0, np.uint64(11))
    costs = _kernels.all_costs(planes, img, grad, other, ograd, _lut(), 2, 1, -1.0, ALPHA, TAU_C, TAU_G, 0.0, 5.0)
    want_p, want_c = _slow_sweep_rows(planes, costs, img, grad, other, ograd, 2, 1, -1.0, forward, 0.0, 5.0)
    got_p, got_c = planes.copy(), costs.copy()
    _kernels.sweep_rows(got_p, got_c, img, grad, other, ograd, _lut(), 2, 1, -1.0, ALPHA, TAU_C, TAU_G, 0.0, 5.0,
                        forward, 0.0, 1.0, np.uint64(0))  # dz_start < dz_stop: no refinement
    np.testing.assert_allclose(got_c, want_c, rtol=COST_RTOL)
    np.testing.assert_array_equal(got_p, want_p)
    assert (got_c <= costs).all() and (got_c < costs).any()  # it moved planes, and never to a worse one
    # the column sweep is the same rule on the transposed grid
    got_p, got_c = planes.copy(), costs.copy()
    _kernels.sweep_columns(got_p, got_c, img, grad, other, ograd, _lut(), 2, 1, -1.0, ALPHA, TAU_C, TAU_G, 0.0, 5.0,
                           forward)
    assert (got_c <= costs).all()
    for x in range(w):
        for y in range(h):
            yn = y - 1 if forward else y + 1
            if got_c[y, x] < costs[y, x]:  # an improvement came from the previous pixel of the column
                assert 0 <= yn < h and np.array_equal(got_p[y, x], got_p[yn, x])


def test_refinement_only_improves_and_view_propagation_transfers_planes():
    rng = np.random.default_rng(3)
    img, grad, other, ograd = _images(rng, h=8, w=16)
    planes = _kernels.random_planes(8, 16, 0.0, 6.0, np.uint64(5))
    args = (img, grad, other, ograd, _lut(), 2, 1, -1.0, ALPHA, TAU_C, TAU_G, 0.0, 6.0)
    costs = _kernels.all_costs(planes, *args)
    p, c = planes.copy(), costs.copy()
    _kernels.sweep_rows(p, c, *args, True, 3.0, 0.1, np.uint64(9))
    np.testing.assert_allclose(c, _kernels.all_costs(p, *args), rtol=COST_RTOL)  # the costs kept are the planes'
    assert (c <= costs).all()
    # view propagation: a right plane d' = a' x' + b' y + c' seen from the left is (a', b', c') / (1 + a')
    right = np.zeros((8, 16, 3))
    right[:, :, 0], right[:, :, 1], right[:, :, 2] = 0.1, 0.05, 2.0
    p, c = planes.copy(), np.full((8, 16), np.inf)
    _kernels.view_propagation(p, c, right, *args)
    np.testing.assert_allclose(p[c < np.inf], np.tile([0.1, 0.05, 2.0], (int((c < np.inf).sum()), 1)) / 1.1)


def test_plane_fill_takes_the_lower_plane_of_the_row_neighbours():
    disp = np.array([[2.0, np.nan, np.nan, 6.0, np.nan]])
    planes = np.zeros((1, 5, 3))
    planes[0, 0] = (0.5, 0.0, 2.0)  # d = 2 + x/2 at x = 1, 2: 2.5, 3
    planes[0, 3] = (0.0, 0.0, 6.0)
    out = _kernels.plane_fill(disp, planes)
    np.testing.assert_allclose(out, [[2.0, 2.5, 3.0, 6.0, 6.0]])


def test_left_right_check_invalidates_exactly_the_inconsistent_pixels():
    h, w = 4, 20
    left = np.zeros((h, w, 3))
    right = np.zeros((h, w, 3))
    left[:, :, 2] = 5.0  # the left view sees d = 5 everywhere
    right[:, :, 2] = 5.0
    right[:, 8:11, 2] = 7.0  # the right view disagrees at x' = 8..10, i.e. at left x = 13..15
    guide = np.zeros((h, w, 3), np.uint8)
    res = _post_process(left, right, guide, {"radius": 2, "step": 1, "gamma": GAMMA}, 0.0, 10.0)
    invalid = np.isnan(res.raw)
    expected = np.zeros((h, w), bool)
    expected[:, :5] = True  # x - 5 leaves the image
    expected[:, 13:16] = True
    np.testing.assert_array_equal(invalid, expected)
    # a 1 px disagreement is tolerated (PMS: "differ by more than 1")
    right[:, 8:11, 2] = 6.0
    res = _post_process(left, right, guide, {"radius": 2, "step": 1, "gamma": GAMMA}, 0.0, 10.0)
    assert np.isnan(res.raw).sum() == 5 * h
    assert np.isfinite(res.disparity).all()


def _slanted_pair(h=48, w=96, plane=(0.06, 0.04, 4.0), seed=0):
    """Left image of a textured plane d = a x + b y + c: left(x, y) = right(x - d(x, y), y); the right image is a
    smooth colour texture, a sum of plane waves (so that neighbouring rows look alike, as in a photograph)."""
    rng = np.random.default_rng(seed)
    fx = rng.uniform(0.15, 0.9, (3, 6))
    fy = rng.uniform(-0.4, 0.4, (3, 6))
    phases = rng.uniform(0, 2 * np.pi, (3, 6))
    a, b, c = plane
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)

    def texture(xq):
        return np.stack([0.5 + 0.08 * np.sin(fx[k][:, None, None] * xq[None] + fy[k][:, None, None] * yy[None]
                                             + phases[k][:, None, None]).sum(0) for k in range(3)], axis=-1)

    d = a * xx + b * yy + c
    return texture(xx - d).clip(0, 1).astype(np.float32), texture(xx).clip(0, 1).astype(np.float32), d


def test_a_textured_slanted_plane_is_recovered():
    left, right, d = _slanted_pair()
    prm = PatchMatchParameters(window=15, step=1)
    res = patchmatch_stereo(left, right, max_disparity=16, parameters=prm, rng=np.random.default_rng(1))
    inner = (slice(3, -3), slice(20, -3))  # away from the left edge, where matches leave the image
    err = np.abs(res.disparity - d)[inner]
    assert np.percentile(err, 99) < SLANT_TOL_PX and np.median(err) < SLANT_MEDIAN_TOL_PX
    np.testing.assert_allclose(np.median(res.planes[inner][..., 0]), 0.06, atol=SLOPE_TOL)
    np.testing.assert_allclose(np.median(res.planes[inner][..., 1]), 0.04, atol=SLOPE_TOL)
    # the same through compute_disparity
    out = compute_disparity(left, right, max_disparity=16, method="patchmatch", patchmatch=prm)
    assert np.percentile(np.abs(out.disparity - d)[inner], 99) < SLANT_TOL_PX


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"window": 4}, "window must be an odd number of pixels in \\[3, 255\\]; got 4"),
    ({"window": 1}, "window must be an odd number of pixels in \\[3, 255\\]; got 1"),
    ({"step": 0}, "step must be"),
    ({"window": 5, "step": 3}, "step must be at most half the window \\(2 px\\); got 3"),
    ({"alpha": 1.5}, "alpha must"),
    ({"gamma": 0.0}, "gamma must"),
    ({"tau_color": -1.0}, "tau_color must"),
    ({"tau_gradient": float("nan")}, "tau_gradient must"),
    ({"iterations": 0}, "iterations must"),
])
def test_bad_parameters_are_refused_in_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        PatchMatchParameters(**kwargs)
    assert "\n" not in str(info.value)


def test_refusals_of_the_functions_and_the_cli(capsys, tmp_path):
    rng = np.random.default_rng(0)
    img = rng.random((20, 40)).astype(np.float32)
    with pytest.raises(ValueError, match="window must not exceed the image's smaller side \\(20 px\\); got 35"):
        patchmatch_stereo(img, img, max_disparity=8)
    with pytest.raises(TypeError, match="parameters must be a PatchMatchParameters; got dict"):
        patchmatch_stereo(img, img, max_disparity=8, parameters={"window": 9})
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        patchmatch_stereo(img, img, max_disparity=8, parameters=PatchMatchParameters(window=9), rng=3)
    with pytest.raises(ValueError, match="patchmatch parameters apply to method 'patchmatch' only; got method 'sgbm'"):
        compute_disparity(img, img, max_disparity=8, patchmatch=PatchMatchParameters(window=9))
    from vergence.io import write_image
    write_image(tmp_path / "l.png", img)
    for extra, message in ((["--method", "patchmatch", "--pm-step", "0"], "error: --pm-step must be"),
                           (["--pm-alpha", "0.5"],
                            "error: --pm-alpha: for --method patchmatch only; got --method sgbm"),
                           (["--method", "patchmatch", "--pm-alpha", "2"], "error: --pm-alpha must lie in [0, 1]")):
        code = main(["match", str(tmp_path / "l.png"), str(tmp_path / "l.png"), "--max-disparity", "8",
                     "--out", str(tmp_path / "d.pfm"), *extra])
        err = capsys.readouterr().err
        assert code == 2 and err.startswith(message) and err.count("\n") == 1, err


def test_compute_disparity_keeps_the_left_right_check_and_the_smoothing_choice():
    left, right, d = _slanted_pair(h=30, w=60)
    prm = PatchMatchParameters(window=9, step=1)
    res = patchmatch_stereo(left, right, max_disparity=12, parameters=prm)
    kept = compute_disparity(left, right, max_disparity=12, method="patchmatch", patchmatch=prm, keep_invalid=True)
    np.testing.assert_array_equal(np.isnan(kept.disparity), np.isnan(res.raw))
    np.testing.assert_array_equal(kept.matched, np.isfinite(res.raw))
    assert np.isnan(res.raw[:, :3]).all()  # the left columns match outside the right image
    plain = compute_disparity(left, right, max_disparity=12, method="patchmatch", patchmatch=prm, smoothing="none")
    np.testing.assert_array_equal(plain.disparity, res.filled)
    full = compute_disparity(left, right, max_disparity=12, method="patchmatch", patchmatch=prm)
    np.testing.assert_array_equal(full.disparity, res.disparity)
