"""MLS similarity deformation (Schaefer, McPhail, Warren 2006) and the S2 per-source warp.

The Numba kernel is checked against a slow reference that restates the paper's matrix form
(§2.2: ``f_s(v) = sum_i q^_i A_i / mu_s + q*``) one point and one handle at a time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.stereospace import MLS_MIN_HANDLES, mls_similarity, mls_warp
from vergence.stereospace import _mls_kernels
from vergence.stereospace.mls import _grid_nodes, _source_map

# Kernel (complex form, rescaled weights) vs reference (matrix form): round-off of sums of a few
# dozen terms of pixel coordinates ~100.
REF_ATOL = 1e-9
# float32 maps and images in cv2.remap.
F32_ATOL = 1e-5


def _perp(a):
    return np.array([-a[1], a[0]])


def _mls_reference(points, src, dst, alpha=1.0):
    """Schaefer et al. 2006 §2.2 in the paper's matrix form, plain loops."""
    out = np.zeros((len(points), 2))
    for k, v in enumerate(np.asarray(points, float)):
        d2 = [float(np.sum((p - v) ** 2)) for p in src]
        if min(d2) == 0.0:
            out[k] = dst[int(np.argmin(d2))]
            continue
        w = np.array([1.0 / d ** alpha for d in d2])
        ps = sum(w[i] * src[i] for i in range(len(src))) / w.sum()
        qs = sum(w[i] * dst[i] for i in range(len(src))) / w.sum()
        mu = sum(w[i] * float((src[i] - ps) @ (src[i] - ps)) for i in range(len(src)))
        vv = v - ps
        f = np.zeros(2)
        for i in range(len(src)):
            ph, qh = src[i] - ps, dst[i] - qs
            A = w[i] * np.array([ph, -_perp(ph)]) @ np.array([vv, -_perp(vv)]).T
            f += qh @ (A / mu)
        out[k] = f + qs
    return out


def _handles(rng, m=12, size=100.0, spread=6.0):
    p = rng.uniform(0, size, (m, 2))
    return p, p + rng.normal(0, spread, (m, 2))


@pytest.mark.parametrize("alpha", [0.5, 1.0, 2.0])
def test_kernel_matches_the_matrix_form_reference(alpha):
    rng = np.random.default_rng(3)
    p, q = _handles(rng)
    v = np.vstack([rng.uniform(-20, 120, (40, 2)), p[:2]])
    assert_allclose(mls_similarity(v, p, q, alpha=alpha), _mls_reference(v, p, q, alpha), atol=REF_ATOL, rtol=0)


# float32 kernel (S2's views) vs float64: sums of a few hundred terms of pixel coordinates ~300 in
# float32; measured 7e-5 px here and 2e-3 px at most on dino's 6,019 handles (grid step 8).
F32_MLS_ATOL = 2e-3


def test_float32_kernel_matches_float64_for_each_set_of_handles():
    rng = np.random.default_rng(13)
    p = rng.uniform(0, 300, (400, 2)).astype(np.float32)
    q = (p + 4.0 * np.sin(p[:, ::-1] / 40.0)).astype(np.float32)
    v = np.vstack([rng.uniform(-30, 330, (500, 2)), p[:3] + [0.25, 0.0]]).astype(np.float32)
    out = np.empty((2, *v.shape), np.float32)
    _mls_kernels.mls_similarity_points(v, np.vstack([p, q]), np.vstack([q, p]), np.array([0, 400, 800]), 1.0, out)
    expected = mls_similarity(v, p, q)
    assert 1e-6 < np.abs(out[0] - expected).max() < F32_MLS_ATOL  # float32 rounding, and no more
    assert_allclose(out[1], mls_similarity(v, q, p), atol=F32_MLS_ATOL, rtol=0)  # the second set of handles


def _shared_sets(rng, groups, common, extras, dtype=np.float64):
    """Handle sets sharing ``common`` handle positions (targets of their own) plus ``extras[g]`` each:
    (the kernel's arguments, the sets as (src, dst) pairs)."""
    src = rng.uniform(0, 100, (common + sum(extras), 2))
    shared, own = src[:common], np.split(src[common:], np.cumsum(extras)[:-1])
    dst = np.stack([shared + rng.normal(0, 6.0, shared.shape) for _ in range(groups)])
    extra_dst = [e + rng.normal(0, 6.0, e.shape) for e in own]
    sets = [(np.vstack([shared, own[g]]), np.vstack([dst[g], extra_dst[g]])) for g in range(groups)]
    args = (shared.astype(dtype), dst.astype(dtype), np.vstack(own).astype(dtype).reshape(-1, 2),
            np.vstack(extra_dst).astype(dtype).reshape(-1, 2),
            np.concatenate([[0], np.cumsum(extras)]).astype(np.int64))
    return args, sets


@pytest.mark.parametrize("alpha", [0.5, 1.0, 2.0])
@pytest.mark.parametrize(("common", "extras"), [(10, [0, 3]), (12, [2, 0, 4]), (9, [1, 1, 0, 5]), (0, [3, 4])])
def test_shared_handles_kernel_matches_the_reference_for_each_set(alpha, common, extras):
    rng = np.random.default_rng(common + len(extras))
    args, sets = _shared_sets(rng, len(extras), common, extras)
    # points anywhere, on a shared handle and on a handle of one set only (its own target there)
    on_own = sets[-1][0][-1]
    v = np.vstack([rng.uniform(-20, 120, (40, 2)), args[0][:1], on_own[None]])
    out = np.full((len(extras), len(v), 2), np.nan)
    _mls_kernels.mls_shared_handles(v, *args, alpha, out)
    for g, (src, dst) in enumerate(sets):
        assert_allclose(out[g], _mls_reference(v, src, dst, alpha), atol=REF_ATOL, rtol=0)


def test_shared_handles_kernel_in_float32_matches_float64():
    rng = np.random.default_rng(14)
    args, sets = _shared_sets(rng, 4, 400, [0, 7, 2, 30], dtype=np.float32)
    args = tuple(a * np.float32(3.0) if a.dtype == np.float32 else a for a in args)  # pixels ~300
    v = rng.uniform(-30, 330, (300, 2)).astype(np.float32)
    out = np.empty((4, len(v), 2), np.float32)
    _mls_kernels.mls_shared_handles(v, *args, 1.0, out)
    for g, (src, dst) in enumerate(sets):
        expected = mls_similarity(v, 3.0 * src.astype(np.float32), 3.0 * dst.astype(np.float32))
        assert 1e-7 < np.abs(out[g] - expected).max() < F32_MLS_ATOL  # float32 rounding, and no more


def test_identity_handles_give_the_identity():
    rng = np.random.default_rng(4)
    p = rng.uniform(0, 100, (9, 2))
    v = rng.uniform(-50, 150, (50, 2))
    assert_allclose(mls_similarity(v, p, p.copy()), v, atol=REF_ATOL, rtol=0)


def test_a_global_similarity_is_reproduced_everywhere():
    rng = np.random.default_rng(5)
    p = rng.uniform(0, 100, (10, 2))
    th, s, t = 0.4, 1.3, np.array([5.0, -3.0])
    R = np.array([[math.cos(th), math.sin(th)], [-math.sin(th), math.cos(th)]])  # row vectors: v @ R
    v = rng.uniform(-50, 150, (60, 2))
    assert_allclose(mls_similarity(v, p, s * p @ R + t, alpha=1.5), s * v @ R + t, atol=REF_ATOL, rtol=0)


def test_handles_are_interpolated_exactly_and_continuously():
    rng = np.random.default_rng(6)
    p, q = _handles(rng, m=8)
    assert_array_equal(mls_similarity(p, p, q), q)
    assert_allclose(mls_similarity(p + 1e-7, p, q), q, atol=1e-5, rtol=0)


def test_weights_do_not_overflow_next_to_a_handle():
    # |v - p|^2 = 2e-320 is subnormal: 1/|v - p|^2 alone would be inf and the result NaN.
    rng = np.random.default_rng(7)
    p, q = _handles(rng, m=5)
    out = mls_similarity(p[:1] + 1e-160, p, q)
    assert_allclose(out, q[:1], atol=1e-9, rtol=0)


def test_no_points_give_an_empty_result():
    p = np.array([[0.0, 0.0], [1.0, 0.0]])
    assert mls_similarity(np.zeros((0, 2)), p, p).shape == (0, 2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"points": np.zeros((3, 3))}, "points must have shape"),
        ({"points": [[np.nan, 0.0]]}, "points must be finite"),
        ({"handles_src": [[0.0, 0.0]], "handles_dst": [[1.0, 1.0]]}, f"at least {MLS_MIN_HANDLES} handles"),
        ({"handles_src": [[0.0, 0.0], [0.0, 0.0]]}, "handles_src must not repeat a handle"),
        ({"handles_dst": [[0.0, 0.0], [1.0, 0.0], [2.0, 2.0]]}, "handles_dst must have the shape"),
        ({"handles_dst": [[0.0, np.inf], [1.0, 0.0]]}, "handles_dst must be finite"),
        ({"alpha": 0.0}, "alpha must be > 0"),
        ({"alpha": np.nan}, "alpha must be finite"),
    ],
)
def test_mls_similarity_refuses_bad_input(kwargs, match):
    args = {"points": [[1.0, 1.0]], "handles_src": [[0.0, 0.0], [1.0, 0.0]], "handles_dst": [[0.0, 0.0], [2.0, 0.0]]}
    args.update(kwargs)
    alpha = args.pop("alpha", 1.0)
    with pytest.raises(ValueError, match=match):
        mls_similarity(args["points"], args["handles_src"], args["handles_dst"], alpha=alpha)


def test_mls_similarity_refuses_non_numeric():
    with pytest.raises(TypeError, match="points must be numeric"):
        mls_similarity("ab", [[0.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [1.0, 0.0]])


# --- mls_warp ---------------------------------------------------------------------------------


def _bilinear_reference(img, x, y):
    """Colour at (x, y) inside the image, one pixel at a time."""
    h, w = img.shape[:2]
    x, y = min(max(x, 0.0), w - 1.0), min(max(y, 0.0), h - 1.0)  # edge pixels cover half a pixel more
    x0, y0 = min(int(math.floor(x)), w - 2), min(int(math.floor(y)), h - 2)
    s, t = x - x0, y - y0
    return ((1 - s) * (1 - t) * img[y0, x0] + s * (1 - t) * img[y0, x0 + 1]
            + (1 - s) * t * img[y0 + 1, x0] + s * t * img[y0 + 1, x0 + 1])


def test_per_pixel_warp_matches_a_slow_reference():
    rng = np.random.default_rng(8)
    img = rng.uniform(0, 1, (14, 17, 3)).astype(np.float32)
    p = rng.uniform(0, 16, (6, 2))
    q = p + rng.normal(0, 1.5, (6, 2))
    out, valid = mls_warp(img, p, q, grid_step=1)
    ys, xs = np.mgrid[0:14, 0:17]
    where = _mls_reference(np.stack([xs.ravel(), ys.ravel()], 1).astype(float), q, p).reshape(14, 17, 2)
    inside = (where[..., 0] >= -0.5) & (where[..., 0] <= 16.5) & (where[..., 1] >= -0.5) & (where[..., 1] <= 13.5)
    assert_array_equal(valid, inside)
    assert 0 < valid.sum() < valid.size
    for y, x in zip(*np.nonzero(inside)):
        assert_allclose(out[y, x], _bilinear_reference(img.astype(float), *where[y, x]), atol=1e-3, rtol=0)
    assert not out[~valid].any()


def test_integer_translation_moves_pixels_exactly():
    rng = np.random.default_rng(9)
    img = rng.uniform(0, 1, (30, 40)).astype(np.float32)
    p = rng.uniform(0, 30, (7, 2))
    out, valid = mls_warp(img, p, p + [3.0, 2.0], grid_step=8)
    assert_allclose(out[2:, 3:], img[:-2, :-3], atol=F32_ATOL)
    assert not valid[:2].any() and not valid[:, :3].any() and valid[2:, 3:].all()


def _source_map64(p, q, shape, step):
    return np.stack(_source_map(p, q, shape, step, 1.0, dtype=np.float64), axis=-1)


def _interp_axis(values, nodes, n, axis):
    """Linear interpolation of ``values`` (given at ``nodes`` along ``axis``) at 0, 1, ..., n - 1."""
    x = np.arange(n, dtype=np.float64)
    i = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    t = (x - nodes[i]) / (nodes[i + 1] - nodes[i])
    a, b = np.take(values, i, axis=axis), np.take(values, i + 1, axis=axis)
    shape = [1] * values.ndim
    shape[axis] = n
    return a + t.reshape(shape) * (b - a)


@pytest.mark.parametrize(("shape", "step"), [((50, 61), 8), ((33, 40), 4), ((17, 16), 16), ((9, 12), 3)])
def test_grid_interpolation_kernel_matches_separable_numpy(shape, step):
    rng = np.random.default_rng(12)
    p = rng.uniform(0, 40, (7, 2))
    q = p + rng.normal(0, 3, (7, 2))
    xs, ys = _grid_nodes(shape[1], step), _grid_nodes(shape[0], step)
    gx, gy = np.meshgrid(xs, ys)
    at_nodes = mls_similarity(np.stack([gx.ravel(), gy.ravel()], 1), q, p).reshape(ys.size, xs.size, 2)
    expected = _interp_axis(_interp_axis(at_nodes, xs, shape[1], 1), ys, shape[0], 0)
    assert_allclose(_source_map64(p, q, shape, step), expected, atol=1e-9, rtol=0)


@pytest.mark.parametrize("shape", [(1, 9), (9, 1), (1, 1)])
def test_one_pixel_wide_outputs(shape):
    p = np.array([[0.0, 0.0], [3.0, 1.0], [1.0, 4.0]])
    q = p + [0.5, -0.25]
    assert_allclose(_source_map64(p, q, shape, 4), _source_map64(p, q, shape, 1), atol=1e-9, rtol=0)


def test_the_grid_is_exact_for_a_global_similarity():
    # f is then affine in v, and bilinear interpolation between grid nodes reproduces it.
    rng = np.random.default_rng(10)
    p = rng.uniform(0, 60, (9, 2))
    th, s = 0.1, 1.05
    R = np.array([[math.cos(th), math.sin(th)], [-math.sin(th), math.cos(th)]])
    q = s * p @ R + [2.0, -1.0]
    assert_allclose(_source_map64(p, q, (50, 61), 8), _source_map64(p, q, (50, 61), 1), atol=1e-9, rtol=0)


def test_the_grid_error_is_zero_at_the_nodes_and_shrinks_with_the_step():
    # A smooth offset field (the parallax of a smooth surface): measured max errors 0.40 / 1.00 /
    # 1.70 px and mean 0.02 / 0.09 / 0.24 px at steps 4 / 8 / 16, largest next to the handles,
    # where f bends sharply to interpolate them.
    rng = np.random.default_rng(11)
    p = rng.uniform(0, 120, (40, 2))
    q = p + 4.0 * np.sin(p[:, ::-1] / 25.0)
    exact = _source_map64(p, q, (97, 121), 1)
    errs = []
    for step in (4, 8, 16):
        grid = _source_map64(p, q, (97, 121), step)
        assert_allclose(grid[::step, ::step], exact[::step, ::step], atol=1e-9, rtol=0)
        assert_allclose(grid[-1, -1], exact[-1, -1], atol=1e-9, rtol=0)  # the last pixel is a node
        errs.append(np.linalg.norm(grid - exact, axis=-1))
    assert errs[0].max() < errs[1].max() < errs[2].max()
    assert errs[1].max() < 1.2 and errs[1].mean() < 0.12


def test_warp_keeps_channels_dtype_and_output_shape():
    img = (np.arange(12 * 10 * 3) % 256).astype(np.uint8).reshape(12, 10, 3)
    p = np.array([[1.0, 1.0], [8.0, 2.0], [4.0, 9.0]])
    out, valid = mls_warp(img, p, p, output_shape=(7, 5))
    assert out.shape == (7, 5, 3) and out.dtype == np.float32 and valid.shape == (7, 5) and valid.all()
    assert_allclose(out, img[:7, :5] / 255.0, atol=F32_ATOL)
    grey, _ = mls_warp(img[..., :1], p, p)
    assert grey.shape == (12, 10, 1)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"image": np.zeros((0, 5))}, ValueError, "image must not be empty"),
        ({"image": np.full((4, 4), np.nan)}, ValueError, "image must be finite"),
        ({"handles_dst": [[0.0, 0.0], [0.0, 0.0]]}, ValueError, "handles_dst must not repeat a handle"),
        ({"handles_src": [[0.0, 0.0]], "handles_dst": [[1.0, 1.0]]}, ValueError, "at least 2 handles"),
        ({"handles_src": [[0.0, np.nan], [1.0, 0.0]]}, ValueError, "handles_src must be finite"),
        ({"grid_step": 0}, ValueError, "grid_step must be >= 1"),
        ({"grid_step": 2.5}, TypeError, "grid_step must be an integer"),
        ({"alpha": -1.0}, ValueError, "alpha must be > 0"),
        ({"output_shape": (4,)}, ValueError, "output_shape must be"),
        ({"output_shape": 4}, ValueError, "output_shape must be"),
        ({"output_shape": (0, 4)}, ValueError, r"output_shape\[0\] must be >= 1"),
    ],
)
def test_mls_warp_refuses_bad_input(kwargs, error, match):
    args = {"image": np.zeros((4, 4), np.float32), "handles_src": [[0.0, 0.0], [2.0, 1.0]],
            "handles_dst": [[0.0, 0.0], [2.0, 2.0]]}
    args.update(kwargs)
    image, src, dst = args.pop("image"), args.pop("handles_src"), args.pop("handles_dst")
    with pytest.raises(error, match=match):
        mls_warp(image, src, dst, **args)
