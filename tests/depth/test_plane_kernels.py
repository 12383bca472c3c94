"""Numba kernels of the segment planes against their references: scikit-image's ``felzenszwalb`` for the
segmentation (the same labels, numbering included) and the vectorised NumPy IRLS it replaced (the same
planes to the bit: each segment's sums are added in the same order)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.segmentation import felzenszwalb

from vergence.depth import _plane_kernels, fill_from_planes, fit_segment_planes, match_sgbm, segment_image
from vergence.depth.planes import (
    _HUBER_ITERATIONS,
    _MIN_SPREAD_PX,
    _SINGULAR,
    _TUKEY_ITERATIONS,
    SegmentPlanes,
    _fit,
    _pixel_graph,
    _sort_costs,
)
from vergence.io import read_image


def _skimage_labels(img: np.ndarray, scale: float, sigma: float, min_size: int) -> np.ndarray:
    """The reference: scikit-image's Felzenszwalb-Huttenlocher segmentation on [0, 255] levels."""
    return felzenszwalb(img.astype(np.float64) * 255.0, scale=scale, sigma=sigma, min_size=min_size,
                        channel_axis=None if img.ndim == 2 else -1)


def _numpy_fit(x, y, d, lab, n, k, need) -> SegmentPlanes:
    """The vectorised NumPy IRLS (``numpy.bincount`` sums over all pixels) that the kernels replaced."""
    support = np.bincount(lab, minlength=n)

    def sums(v: np.ndarray) -> np.ndarray:
        return np.bincount(lab, weights=v, minlength=n)

    safe = np.maximum(support, 1)
    cx, cy = sums(x) / safe, sums(y) / safe
    u, v = x - cx[lab], y - cy[lab]
    suu, suv, svv = sums(u * u) / safe, sums(u * v) / safe, sums(v * v) / safe
    narrow = 0.5 * (suu + svv) - np.sqrt(0.25 * (suu - svv) ** 2 + suv * suv)
    ok = (support >= need) & (narrow >= _MIN_SPREAD_PX ** 2)
    order = np.lexsort((d, lab))
    start = np.concatenate([[0], np.cumsum(support)[:-1]])
    med = d[order][np.minimum(start + support // 2, max(d.size - 1, 0))] if d.size else np.zeros(n)
    abc = np.zeros((n, 3))
    abc[:, 2] = np.where(support > 0, med, 0.0)
    for it in range(_HUBER_ITERATIONS + _TUKEY_ITERATIONS):
        r = np.abs(d - (abc[lab, 0] * u + abc[lab, 1] * v + abc[lab, 2]))
        if it < _HUBER_ITERATIONS:
            w = np.minimum(1.0, k / np.maximum(r, k))
        else:
            w = np.clip(1.0 - (r / (3.0 * k)) ** 2, 0.0, None) ** 2
        m = np.empty((n, 3, 3))
        m[:, 0, 0], m[:, 0, 1], m[:, 0, 2] = sums(w * u * u), sums(w * u * v), sums(w * u)
        m[:, 1, 1], m[:, 1, 2], m[:, 2, 2] = sums(w * v * v), sums(w * v), sums(w)
        m[:, 1, 0], m[:, 2, 0], m[:, 2, 1] = m[:, 0, 1], m[:, 0, 2], m[:, 1, 2]
        rhs = np.stack([sums(w * u * d), sums(w * v * d), sums(w * d)], axis=1)
        det = np.linalg.det(m)
        solvable = ok & (np.abs(det) > _SINGULAR * np.maximum(m[:, 0, 0] * m[:, 1, 1] * m[:, 2, 2], 1e-300))
        m[~solvable] = np.eye(3)
        rhs[~solvable] = abc[~solvable]
        abc = np.where(solvable[:, None], np.linalg.solve(m, rhs[:, :, None])[:, :, 0], abc)
    r = np.abs(d - (abc[lab, 0] * u + abc[lab, 1] * v + abc[lab, 2]))
    inliers = np.bincount(lab, weights=(r <= k).astype(np.float64), minlength=n)
    planes = np.column_stack([abc[:, 0], abc[:, 1], abc[:, 2] - abc[:, 0] * cx - abc[:, 1] * cy])
    planes[~ok] = np.nan
    share = np.where(ok, inliers / safe, 0.0)
    return SegmentPlanes(planes, support.astype(np.int64), share)


def _assert_same_fit(a: SegmentPlanes, b: SegmentPlanes) -> None:
    np.testing.assert_array_equal(a.planes, b.planes)  # the same sums in the same order: equal to the bit
    np.testing.assert_array_equal(a.support, b.support)
    np.testing.assert_array_equal(a.inlier_share, b.inlier_share)


def _random_image(rng: np.random.Generator, h: int, w: int, channels: int, levels: int) -> np.ndarray:
    """Blocky noise (segments worth finding) quantised to ``levels`` grey levels (0: not quantised): few
    levels, many equal edge costs, so the order of ties matters."""
    coarse = rng.random((h // 4 + 1, w // 4 + 1) + ((channels,) if channels > 1 else ()))
    img = np.kron(coarse, np.ones((4, 4) + ((1,) if channels > 1 else ())))[:h, :w]
    img = np.clip(img + 0.15 * rng.standard_normal(img.shape), 0.0, 1.0)
    return (img if levels == 0 else np.round(img * (levels - 1)) / (levels - 1)).astype(np.float32)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), h=st.integers(1, 40), w=st.integers(1, 50), channels=st.sampled_from([1, 3]),
       levels=st.sampled_from([0, 2, 5, 256]), scale=st.floats(1.0, 3000.0), sigma=st.sampled_from([0.0, 0.5, 0.8, 2.0]),
       min_size=st.integers(1, 400))
def test_segment_image_gives_the_labels_of_skimage(seed, h, w, channels, levels, scale, sigma, min_size):
    img = _random_image(np.random.default_rng(seed), h, w, channels, levels)
    if channels == 1 and seed % 2:
        img = img[:, :, None]  # (H, W, 1) as (H, W)
    ref = _skimage_labels(img[:, :, 0] if img.ndim == 3 and img.shape[2] == 1 else img, scale, sigma, min_size)
    np.testing.assert_array_equal(segment_image(img, scale=scale, sigma=sigma, min_size=min_size), ref)


@pytest.mark.parametrize(("seed", "h", "w", "levels"), [(0, 35, 35, 3), (1, 24, 30, 5)])
@pytest.mark.parametrize(("scale", "min_size"), [(50.0, 10), (1000.0, 100)])
def test_segment_image_orders_equal_costs_as_skimage(seed, h, w, levels, scale, min_size):
    """Unsmoothed images of a few levels: many equal edge costs, whose order changes the segments (a
    stable sort gives others); scikit-image's order is NumPy's ``argsort``, and so is ours."""
    img = _random_image(np.random.default_rng(seed), h, w, 3, levels)
    labels = segment_image(img, scale=scale, sigma=0.0, min_size=min_size)
    np.testing.assert_array_equal(labels, _skimage_labels(img, scale, 0.0, min_size))
    c = img.astype(np.float64) * 255.0
    cost = np.concatenate([np.sqrt(((a - b) ** 2).sum(-1)).ravel() for a, b in
                           [(c[:, 1:], c[:, :-1]), (c[1:], c[:-1]), (c[1:, 1:], c[:-1, :-1]), (c[1:, :-1], c[:-1, 1:])]])
    stable = np.argsort(cost, kind="stable")  # equal costs in edge order
    p, q = _plane_kernels.grid_edges(stable, h, w)
    other = _plane_kernels.segment_graph(p, q, cost[stable], h * w, scale / 255.0, min_size).reshape(h, w)
    assert not np.array_equal(other, labels)


@pytest.mark.parametrize(("scene", "name"), [("tsukuba", "im3.png"), ("venus", "im2.ppm")])
@pytest.mark.parametrize(("scale", "min_size"), [(2000.0, 1000), (500.0, 250), (200.0, 100), (20.0, 10)])
def test_segment_image_gives_the_labels_of_skimage_on_real_images(shared_data, scene, name, scale, min_size):
    img = read_image(shared_data / "stereo" / scene / name)
    labels = segment_image(img, scale=scale, min_size=min_size)
    np.testing.assert_array_equal(labels, _skimage_labels(img, scale, 0.8, min_size))
    grey = segment_image(img[..., 1], scale=scale, min_size=min_size)
    np.testing.assert_array_equal(grey, _skimage_labels(img[..., 1], scale, 0.8, min_size))


@pytest.mark.parametrize(("excess", "segments"), [(1e-6, 2), (1e-5, 1), (-1e-6, 2)])
def test_the_merge_threshold_is_rounded_to_float32_as_skimage(excess, segments):
    """Two pixels 127.5 levels apart merge when 127.5 < k (FH 2004 Eq. 5, |C| = 1, Int(C) = 0), with
    k = scale / 255 rounded to float32: 127.5 + 1e-6 rounds to 127.5 (float32 spacing there: 7.6e-6)."""
    img = np.array([[0.0, 0.5]], np.float32)
    scale = (127.5 + excess) * 255.0
    labels = segment_image(img, scale=scale, sigma=0.0, min_size=1)
    np.testing.assert_array_equal(labels, _skimage_labels(img, scale, 0.0, 1))
    assert labels.max() + 1 == segments


def _slow_grid_edges(h: int, w: int) -> np.ndarray:
    """scikit-image's edge list, pixel pairs in its order: right, down, down-right, up-right."""
    ids = np.arange(h * w).reshape(h, w)
    blocks = [(ids[:, :-1], ids[:, 1:]), (ids[:-1, :], ids[1:, :]), (ids[:-1, :-1], ids[1:, 1:]),
              (ids[:-1, 1:], ids[1:, :-1])]
    return np.concatenate([np.column_stack([a.ravel(), b.ravel()]) for a, b in blocks])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), size=st.integers(0, 3000), spread=st.sampled_from([1e-3, 1.0, 450.0, 1e300]))
def test_sort_distinct_is_argsort_on_distinct_keys_and_reports_ties(seed, size, spread):
    rng = np.random.default_rng(seed)
    keys = rng.random(size) * spread
    keys[: size // 10] = 0.0 if seed % 2 else keys[: size // 10]  # zeros among the keys, some draws
    order, distinct = _plane_kernels.sort_distinct(keys)
    assert distinct == (np.unique(keys).size == size)
    np.testing.assert_array_equal(keys[order], np.sort(keys))
    np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))  # a radix sort is stable
    if distinct:
        np.testing.assert_array_equal(order, np.argsort(keys))


@pytest.mark.parametrize("case", ["distinct", "ties apart", "ties in a row", "empty", "one"])
def test_sort_costs_is_numpy_argsort(case):
    rng = np.random.default_rng(4)
    values = rng.random(5000) * 400.0
    cost = {"distinct": values, "ties apart": np.concatenate([values, values]),
            "ties in a row": np.repeat(values, 2), "empty": values[:0], "one": values[:1]}[case]
    order = _sort_costs(cost)
    np.testing.assert_array_equal(order, np.argsort(cost))
    if case == "ties apart":  # the radix sort's stable order is not argsort's: the fallback is needed
        assert not np.array_equal(_plane_kernels.sort_distinct(cost)[0], order)


@pytest.mark.parametrize(("h", "w"), [(1, 1), (1, 7), (6, 1), (5, 8), (9, 4)])
def test_grid_edges_are_skimage_s_edge_list(h, w):
    edges = _slow_grid_edges(h, w)
    order = np.random.default_rng(h * w).permutation(edges.shape[0])
    p, q = _plane_kernels.grid_edges(order, h, w)
    np.testing.assert_array_equal(np.column_stack([p, q]), edges[order])


def test_one_graph_serves_every_scale():
    img = _random_image(np.random.default_rng(7), 60, 90, 3, 256)
    graph = _pixel_graph(img, 0.8)
    assert graph.p.size == 60 * 89 + 59 * 90 + 2 * 59 * 89
    assert (np.diff(graph.cost) >= 0).all()
    for scale in (2000.0, 200.0, 30.0):
        labels = _plane_kernels.segment_graph(graph.p, graph.q, graph.cost, img.shape[0] * img.shape[1],
                                              scale / 255.0, int(scale) // 2).reshape(img.shape[:2])
        np.testing.assert_array_equal(labels, _skimage_labels(img, scale, 0.8, int(scale) // 2))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 12), size=st.integers(0, 400))
def test_grouping_and_medians_match_a_stable_sort(seed, n, size):
    rng = np.random.default_rng(seed)
    lab = rng.integers(0, n, size)
    d = np.round(rng.normal(0.0, 5.0, size), 1)  # ties among the values
    perm, start = _plane_kernels.group_by_segment(lab, n)
    np.testing.assert_array_equal(perm, np.argsort(lab, kind="stable"))
    np.testing.assert_array_equal(np.diff(start), np.bincount(lab, minlength=n))
    med = _plane_kernels.segment_medians(d[perm], start)
    expected = [np.sort(d[lab == s])[(lab == s).sum() // 2] if (lab == s).any() else 0.0 for s in range(n)]
    np.testing.assert_array_equal(med, expected)


def _fit_inputs(d: np.ndarray, labels: np.ndarray):
    rel = np.isfinite(d)
    ys, xs = np.nonzero(rel)
    return xs.astype(np.float64), ys.astype(np.float64), d[rel].astype(np.float64), labels[rel].astype(np.int64)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 30), unknown=st.floats(0.0, 0.9),
       inlier_px=st.sampled_from([0.5, 1.0, 3.0]), min_support=st.integers(3, 60))
def test_fit_kernels_give_the_numpy_planes(seed, n, unknown, inlier_px, min_support):
    rng = np.random.default_rng(seed)
    h, w = 40, 60
    labels = rng.integers(0, n, (h // 8 + 1, w // 8 + 1)).repeat(8, 0).repeat(8, 1)[:h, :w]
    ys, xs = np.mgrid[0:h, 0:w]
    abc = rng.uniform([-0.3, -0.3, 5.0], [0.3, 0.3, 60.0], (n, 3))
    d = abc[labels, 0] * xs + abc[labels, 1] * ys + abc[labels, 2] + rng.normal(0.0, 0.3, (h, w))
    wild = rng.random((h, w)) < 0.2
    d[wild] += rng.uniform(-20.0, 20.0, wild.sum())
    d[rng.random((h, w)) < unknown] = np.nan
    d[labels == 0] = np.round(d[labels == 0])  # ties for the median
    args = (*_fit_inputs(d, labels), n, inlier_px, min_support)
    _assert_same_fit(_fit(*args), _numpy_fit(*args))


def test_fit_kernels_give_the_numpy_planes_on_a_real_scene(shared_data):
    folder = shared_data / "stereo" / "venus"
    left, right = read_image(folder / "im2.ppm"), read_image(folder / "im6.ppm")
    d = match_sgbm(left, right, max_disparity=31)
    for scale in (2000.0, 200.0):
        labels = segment_image(left, scale=scale, min_size=int(scale) // 2)
        args = (*_fit_inputs(d, labels), int(labels.max()) + 1, 1.0, 20)
        fit = _fit(*args)
        _assert_same_fit(fit, _numpy_fit(*args))
        assert np.isfinite(fit.planes).any(axis=1).mean() > 0.5
        _assert_same_fit(fit_segment_planes(d, labels), fit)
    assert np.isfinite(fill_from_planes(d, left)).mean() > np.isfinite(d).mean()


@pytest.mark.parametrize("sigma", [1e300, 1001.0])
def test_segment_image_refuses_a_gaussian_wider_than_its_limit(sigma):
    with pytest.raises(ValueError, match="sigma must be at most 1000 px"):
        segment_image(np.zeros((8, 8)), sigma=sigma)
