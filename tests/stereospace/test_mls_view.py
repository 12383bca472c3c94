"""S2's novel view (S2 §3.1): MLS-warped sources blended with angle + field-of-view penalties.

Scene: a textured plane at z = 5 m seen by cameras with parallel optical axes, so that the map
between any two views is a translation (a similarity, which MLS reproduces exactly).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import Camera, look_at
from vergence.stereospace import S2_MAX_SOURCES, S2_PENALTY_FLOOR, S2_THRESHOLD_SCALE, mls_similarity, s2_view
from vergence.stereospace import _mls_view_kernels
from vergence.stereospace.mls import _grid_nodes, node_grid
from vergence.stereospace.mls_view import NEGLIGIBLE_WEIGHT, S2_GRID_STEP, _node_angles, pack_rgb

PLANE_Z = 5.0
W, H = 64, 48
# P_ANG interpolated over 8-pixel grid cells against per pixel: the angle between two rays to a
# plane is smooth. Measured at most 7e-6 rad on the camera of the test (61 pixels over 5 degrees,
# the pixel pitch of a 640-pixel view over 50), 3.3e-5 rad on kermit's rhomboid pair view (angles
# about 0.28 rad: relative 1e-4), 3.5e-7 rad on dino's.
ANGLE_GRID_ATOL = 2e-5


def _camera(x, y=0.0, width=W, height=H):
    return look_at([x, y, 0.0], [x, y, PLANE_Z], [0.0, -1.0, 0.0], fov_deg=60.0, width=width, height=height)


def _render(cam):
    """The plane's smooth texture as the camera sees it."""
    d = cam.ray_directions()
    t = (PLANE_Z - cam.center[2]) / d[..., 2]
    x, y = cam.center[0] + t * d[..., 0], cam.center[1] + t * d[..., 1]
    return (0.5 + 0.4 * np.sin(1.3 * x) * np.cos(1.7 * y)).astype(np.float32)


def _points(rng, n=60):
    return np.column_stack([rng.uniform(-3.5, 3.5, n), rng.uniform(-2.5, 2.5, n), np.full(n, PLANE_Z)])


def test_view_of_a_plane_matches_the_target_render():
    rng = np.random.default_rng(1)
    target = _camera(0.1, 0.05)
    sources = [(c, _render(c)) for c in (_camera(-0.3), _camera(0.4), _camera(0.0, 0.3), _camera(0.2, -0.3))]
    res = s2_view(target, sources, points=_points(rng))
    assert res.image.shape == (H, W) and res.image.dtype == np.float32
    assert_array_equal(res.handle_counts > 0, True)
    assert_allclose(res.proxy_depth, PLANE_Z)
    assert res.coverage.mean() > 0.99
    err = np.abs(res.image - _render(target))[res.coverage]
    assert err.max() < 0.02  # bilinear resampling of a smooth texture only
    assert_allclose(res.weights.sum(axis=0)[res.coverage], 1.0, atol=1e-12)


def _angles_reference(target, centres, depth):
    """P_ANG with numpy: the angle at the proxy point between the rays to the two centres."""
    grid = target.pixel_grid()
    proxy = target.backproject(grid, np.full(grid.shape[:2], depth))
    to_t = target.center - proxy
    out = []
    for centre in centres:
        to_s = centre - proxy
        cos = np.sum(to_t * to_s, -1) / np.linalg.norm(to_t, axis=-1) / np.linalg.norm(to_s, axis=-1)
        out.append(np.arccos(np.clip(cos, -1, 1)))
    return np.array(out)


def _blend_reference(colours, penalty, k, scale):
    """ULR weights of one pixel's sources (inf penalty: no sample) and their blend."""
    finite = np.isfinite(penalty)
    if finite.sum() >= k:
        thresh = scale * np.sort(penalty)[k - 1]
        wt = np.where(finite, np.maximum(0.0, 1.0 - penalty / thresh), 0.0)
    else:
        wt = finite.astype(float)
    if wt.sum() > 0:
        wt = wt / wt.sum()
    return wt @ colours, wt


def _bilinear_reference(img, x, y):
    """Colour at (x, y) on the image (edge pixels repeated over their outer half)."""
    h, w = img.shape[:2]
    x, y = min(max(x, 0.0), w - 1.0), min(max(y, 0.0), h - 1.0)
    x0, y0 = min(int(math.floor(x)), w - 2), min(int(math.floor(y)), h - 2)
    s, t = x - x0, y - y0
    return ((1 - s) * (1 - t) * img[y0, x0] + s * (1 - t) * img[y0, x0 + 1]
            + (1 - s) * t * img[y0 + 1, x0] + s * t * img[y0 + 1, x0 + 1])


def _render_reference(images, ids, at_nodes, xs, ys, shape, k):
    """S2's view one pixel at a time: the map and the angle (the nodes interpolated linearly along
    x, then y), the field of view, ULR weights, bilinear samples."""
    h, w = shape
    n_ch = images[0].shape[2]
    image, weights = np.zeros((h, w, n_ch)), np.zeros((len(ids), h, w))
    for y in range(h):
        for x in range(w):
            pen, colours = np.full(len(ids), np.inf), np.zeros((len(ids), n_ch))
            for s, n in enumerate(ids):
                if n < 0:
                    continue
                along_x = np.array([[np.interp(x, xs, at_nodes[s, r, :, c]) for c in range(3)] for r in range(len(ys))])
                u, v, angle = (np.interp(y, ys, along_x[:, c]) for c in range(3))
                hs, ws = images[n].shape[:2]
                if -0.5 <= u <= ws - 0.5 and -0.5 <= v <= hs - 0.5:
                    pen[s] = max(S2_PENALTY_FLOOR, angle)
                    colours[s] = _bilinear_reference(images[n].astype(float), u, v)
            image[y, x], weights[:, y, x] = _blend_reference(colours, pen, k, S2_THRESHOLD_SCALE)
    return image, weights


def _render_kernel(stack, sizes, ids, at_nodes, xs, ys, shape, k, weights, negligible=0.0):
    image = np.empty((*shape, 3 if stack.ndim == 3 else stack.shape[3]), np.float32)  # 3-D: packed RGB
    if stack.dtype in (np.uint8, np.uint32):
        unit = 1.0 / 255.0
    else:
        unit = 1.0
    _mls_view_kernels.render_view(stack, np.array(sizes), ids, at_nodes, xs, ys, 4, S2_PENALTY_FLOOR, k,
                                  S2_THRESHOLD_SCALE, negligible, image, weights, unit)  # fmt: skip
    return image


@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_render_kernel_matches_a_slow_reference(k):
    rng = np.random.default_rng(k)
    sizes = [(9, 11), (7, 12), (10, 6)]
    images = [rng.uniform(0, 1, (hh, ww, 3)).astype(np.float32) for hh, ww in sizes]
    stack = np.zeros((3, 10, 12, 3), np.float32)
    for n, img in enumerate(images):
        stack[n, : img.shape[0], : img.shape[1]] = img
    xs, ys = _grid_nodes(13, 4), _grid_nodes(10, 4)
    ids = np.array([2, 0, -1, 1, 0])  # one source left out, one image used twice
    at_nodes = np.concatenate([rng.uniform(-2.0, 13.0, (5, ys.size, xs.size, 2)),
                               rng.uniform(0.0, 0.3, (5, ys.size, xs.size, 1))], axis=3)  # fmt: skip
    at_nodes[0, 0, 0, :2] = [-0.5, 8.5]  # on the valid border of image 2 (10 x 6)
    at_nodes[1:4, 1, 1, 2] = 0.2  # a tie at a node
    at_nodes[4, 2, 2, 2] = 0.0  # below the floor
    weights = np.empty((5, 10, 13))
    image = _render_kernel(stack, sizes, ids, at_nodes, xs, ys, (10, 13), k, weights)
    ref_image, ref_weights = _render_reference(images, ids, at_nodes, xs, ys, (10, 13), k)
    assert 0 < (weights > 0).sum(axis=0).mean() < 4  # pixels with few sources and with several
    assert_allclose(weights, ref_weights, atol=1e-12)
    assert_allclose(image, ref_image, atol=1e-5)  # float32 images, float64 weights
    assert_array_equal(_render_kernel(stack, sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0))), image)
    # the k-th source's weight (~1e-7) not sampled: the colour moves by less than the weights left out
    skipped = _render_kernel(stack, sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0)), NEGLIGIBLE_WEIGHT)
    assert_allclose(skipped, ref_image, atol=len(ids) * NEGLIGIBLE_WEIGHT + 1e-6, rtol=0)
    # 8-bit sources kept as bytes: the same view from the stored values scaled once by 1/255
    codes = rng.integers(0, 256, stack.shape).astype(np.uint8)
    as_float = codes.astype(np.float32) / np.float32(255.0)
    images8 = [as_float[n, : hh, : ww] for n, (hh, ww) in enumerate(sizes)]
    ref8, _ = _render_reference(images8, ids, at_nodes, xs, ys, (10, 13), k)
    assert_allclose(_render_kernel(codes, sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0))), ref8,
                    atol=1e-6)  # fmt: skip
    assert_allclose(_render_kernel(codes, sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0))),
                    _render_kernel(as_float, sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0))),
                    atol=2e-7, rtol=0)  # float32 round-off of one scaling  # fmt: skip
    # RGB bytes packed in a uint32 a pixel: the same sums in the same order, the same view
    assert_array_equal(_render_kernel(pack_rgb(codes), sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0))),
                       _render_kernel(codes, sizes, ids, at_nodes, xs, ys, (10, 13), k, np.empty((5, 0, 0))))


@pytest.mark.parametrize("channels", [1, 2, 4])
def test_render_kernel_other_channel_counts_match_the_reference(channels):
    """Grey, two- and four-channel sources take the kernel's per-channel sums (RGB alone has three
    sums of its own, and is packed when 8-bit): float32 and 8-bit stacks against the slow reference."""
    rng = np.random.default_rng(10 + channels)
    sizes = [(9, 11), (7, 12)]
    xs, ys = _grid_nodes(13, 4), _grid_nodes(10, 4)
    ids = np.array([1, 0, 1])
    at_nodes = np.concatenate([rng.uniform(-2.0, 13.0, (3, ys.size, xs.size, 2)),
                               rng.uniform(0.0, 0.3, (3, ys.size, xs.size, 1))], axis=3)  # fmt: skip
    codes = np.zeros((2, 9, 12, channels), np.uint8)
    for n, (hh, ww) in enumerate(sizes):
        codes[n, :hh, :ww] = rng.integers(0, 256, (hh, ww, channels))
    as_float = codes.astype(np.float32) / np.float32(255.0)
    images = [as_float[n, :hh, :ww] for n, (hh, ww) in enumerate(sizes)]
    ref, _ = _render_reference(images, ids, at_nodes, xs, ys, (10, 13), 2)
    for stack in (as_float, codes):
        out = _render_kernel(stack, sizes, ids, at_nodes, xs, ys, (10, 13), 2, np.empty((3, 0, 0)))
        assert out.shape == (10, 13, channels)
        assert_allclose(out, ref, atol=1e-6)


def test_node_angles_match_numpy_and_their_interpolation_error_is_tiny():
    target = look_at([0.1, 0.2, -0.3], [0.5, 0, 5], [0.1, -1.0, 0.0], fov_deg=5.0, width=61, height=45)
    centres = np.array([[-0.4, 0.0, 0.0], [0.3, 0.2, 0.0], target.center])
    xs, ys, nodes = node_grid((45, 61), 1)
    exact = _angles_reference(target, centres, 4.5)
    assert_allclose(_node_angles(target, nodes, centres, 4.5).reshape(3, 45, 61), exact, atol=1e-7)  # acos: sqrt(eps)
    xs, ys, nodes = node_grid((45, 61), 8)
    coarse = _node_angles(target, nodes, centres, 4.5).reshape(3, ys.size, xs.size)
    along_x = np.array([[np.interp(np.arange(61), xs, row) for row in a] for a in coarse])
    fine = np.array([[np.interp(np.arange(45), ys, along_x[s, :, x]) for x in range(61)] for s in range(3)])
    err = np.abs(fine.transpose(0, 2, 1) - exact)
    assert 0 < err.max() < ANGLE_GRID_ATOL


def test_weights_follow_the_angle_penalty():
    # k = 2 of 2 sources: w_i = 1 - P_i / (1.0000001 max P), normalised, at a grid node near the centre
    # (the angle is exact at the nodes, bilinear in between)
    target = _camera(0.1)
    cams = [_camera(-0.2), _camera(0.5)]
    res = s2_view(target, [(c, _render(c)) for c in cams], points=_points(np.random.default_rng(2)), k=2)
    y, x = (S2_GRID_STEP * round(n / 2 / S2_GRID_STEP) for n in (H, W))
    proxy = target.backproject([[x, y]], [PLANE_Z])[0]
    rays = [c.center - proxy for c in cams]
    to_t = target.center - proxy
    ang = [math.acos(r @ to_t / np.linalg.norm(r) / np.linalg.norm(to_t)) for r in rays]
    w = np.array([1 - a / (1.0000001 * max(ang)) for a in ang])
    assert_allclose(res.weights[:, y, x], w / w.sum(), rtol=1e-9)
    assert res.weights[0, y, x] > 0.99  # the nearer source (angle ~0.06 vs ~0.08 rad) ~ alone at k = 2


def test_a_source_at_the_target_gives_the_target_and_fewer_than_k_blend_equally():
    rng = np.random.default_rng(3)
    target = _camera(0.0)
    res = s2_view(target, [(target, _render(target))], points=_points(rng))
    assert_allclose(res.image, _render(target), atol=1e-5)
    res2 = s2_view(target, [(_camera(-0.2), _render(_camera(-0.2))), (_camera(0.2), _render(_camera(0.2)))],
                   points=_points(rng))
    both = res2.coverage & (res2.weights > 0).all(axis=0)
    assert_allclose(res2.weights[:, both], 0.5)  # 2 < k = 4 sources: equal weights (as render_ibr)


def test_a_source_seeing_too_few_points_is_left_out():
    rng = np.random.default_rng(4)
    target = _camera(0.0)
    far = look_at([50.0, 0, 0], [60.0, 0, 5], [0, -1.0, 0], fov_deg=60.0, width=W, height=H)  # sees none
    res = s2_view(target, [(_camera(0.1), _render(_camera(0.1))), (far, np.zeros((H, W), np.float32))],
                  points=_points(rng))
    assert res.handle_counts[1] == 0 and res.handle_counts[0] > 2
    assert not res.weights[1].any()


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        (lambda a: a.update(target="cam"), TypeError, "target must be a Camera"),
        (lambda a: a.update(sources=[]), ValueError, f"1 to {S2_MAX_SOURCES}"),
        (lambda a: a.update(sources=a["sources"] * 5), ValueError, f"1 to {S2_MAX_SOURCES}"),
        (lambda a: a.update(sources=[(1, 2)]), TypeError, r"sources\[0\] must be a \(Camera, image\) pair"),
        (lambda a: a.update(sources=[(_camera(0.1), np.zeros((H, W + 1)))]), ValueError, "of its camera"),
        (lambda a: a.update(sources=[a["sources"][0], (_camera(0.2), np.zeros((H, W, 3)))]), ValueError, "channel"),
        (lambda a: a.update(points=np.zeros((4, 2))), ValueError, "points must have shape"),
        (lambda a: a.update(points=np.full((4, 3), np.nan)), ValueError, "points must be finite"),
        (lambda a: a.update(points=-_points(np.random.default_rng(0))), ValueError, "in front of target"),
        (lambda a: a.update(points=_points(np.random.default_rng(0), 1)), ValueError, "sees at least 2"),
        (lambda a: a.update(grid_step=0), ValueError, "grid_step must be >= 1"),
        (lambda a: a.update(k=0), ValueError, "k must be >= 1"),
    ],
)
def test_s2_view_refuses_bad_input(change, error, match):
    args = {"target": _camera(0.0), "sources": [(_camera(0.1), _render(_camera(0.1)))],
            "points": _points(np.random.default_rng(0))}
    change(args)
    with pytest.raises(error, match=match):
        s2_view(args.pop("target"), args.pop("sources"), **args)


def test_leave_one_out_on_kermit(shared_data):
    # kermit001 from its two nearest cameras: measured 17.7 dB (covered pixels, coverage 0.998),
    # against 11.4 dB for the nearest photo unwarped.
    from vergence.io import read_cameras, read_image
    from vergence.metrics import psnr

    folder = shared_data / "collections" / "kermit"
    if not (folder / "bundle.out").is_file():
        pytest.skip(f"kermit collection not found in {folder}")
    cs = read_cameras(folder / "bundle.out", image_list=sorted(p.name for p in folder.glob("*.jpg")))
    photo = {i: read_image(folder / cs.names[i]) for i in (0, 1, 7)}
    res = s2_view(cs.cameras[1], [(cs.cameras[0], photo[0]), (cs.cameras[7], photo[7])], points=cs.points)
    assert res.coverage.mean() > 0.99
    score = psnr(res.image, photo[1], mask=res.coverage)
    assert score > 17.0
    assert score > psnr(photo[0], photo[1]) + 5.0


def test_one_handle_per_cell_changes_the_view_little(shared_data, monkeypatch):
    """Thinning the handles to one per S2_HANDLE_CELL_PX cell of the target: at most one handle a
    cell, and the view of dino within 0.003 mean absolute of the view with every handle (measured
    0.001-0.002); a cell of 1e-6 px keeps every distinct handle."""
    from vergence.stereospace import S2_HANDLE_CELL_PX, load_collection
    from vergence.stereospace import mls_view as module
    from vergence.stereospace.sources import load_view

    folder = shared_data / "collections" / "dino"
    if not (folder / "dino_par.txt").is_file():
        pytest.skip(f"dino collection not found in {folder}")
    col = load_collection(folder / "dino_par.txt", images=folder)
    target, ids = col.cameras[10], (9, 11, 8, 12)
    sources = [(col.cameras[i], load_view(col, i, None)) for i in ids]
    thin = s2_view(target, sources, points=col.points)
    q, z = target.project(col.points)
    cells = {tuple(c) for c in np.floor(q[z > 0] / S2_HANDLE_CELL_PX).astype(int)}
    assert (thin.handle_counts <= len(cells)).all()
    monkeypatch.setattr(module, "S2_HANDLE_CELL_PX", 1e-6)
    full = s2_view(target, sources, points=col.points)
    assert (full.handle_counts > 2 * thin.handle_counts).all()  # dino's cloud is dense: thinning matters
    assert np.abs(full.image - thin.image).mean() < 0.005


def _first_rows_reference(q):
    """Indices (ascending) of the first occurrence of each distinct row of ``q (M, 2)`` (numpy)."""
    order = np.lexsort((q[:, 1], q[:, 0]))  # stable: equal rows keep their order
    ranked = q[order]
    first = np.ones(len(q), dtype=bool)
    first[1:] = (ranked[1:] != ranked[:-1]).any(axis=1)
    return np.sort(order[first])


@pytest.mark.parametrize("cell", [4.0, 1.0, 1e-6, 37.5])
def test_handle_selection_kernel_matches_the_numpy_rule(cell):
    # One point per cell of the target, the first in index order, of the points a source sees in front
    # of the target; points far outside the image and exactly on cell borders included.
    rng = np.random.default_rng(int(cell * 10) % 97)
    n_points = 3000
    q = np.concatenate([rng.uniform(-50, 700, (n_points - 40, 2)), np.floor(rng.uniform(0, 20, (20, 2))) * cell,
                        rng.uniform(-1e7, 1e7, (20, 2))])  # fmt: skip
    q[rng.integers(0, n_points, 300)] = q[rng.integers(0, n_points, 300)]  # exact duplicates
    seen = rng.random((5, n_points)) < 0.6
    in_front = rng.random(n_points) < 0.9
    ids = np.array([3, 0, 4, 1])
    chosen = np.empty((len(ids), n_points), dtype=np.int64)
    counts = np.empty(len(ids), dtype=np.int64)
    from vergence.stereospace.mls_view import _cell_window

    window = _cell_window(640, 480, cell)
    assert (window[2] > window[0]) == (cell >= 1.0)  # a grid, or every point sorted
    _mls_view_kernels.select_handles(seen, ids, in_front, q, cell, window, chosen, counts)
    for s, n in enumerate(ids):
        sel = np.flatnonzero(seen[n] & in_front)
        expected = sel[_first_rows_reference(np.floor(q[sel] / cell))]
        assert_array_equal(chosen[s, : counts[s]], expected)


# float32 maps (tests/stereospace/test_mls.py's F32_MLS_ATOL): sums of a few hundred handles of pixel
# coordinates ~300 in float32, in two summation orders.
SOURCE_MAPS_ATOL = 2e-3


@pytest.mark.parametrize(("own", "shared"), [(0, True), (10, True), (60, False)])
def test_source_maps_share_the_common_handles_only_when_few_are_not(monkeypatch, own, shared):
    from vergence.stereospace import _mls_kernels
    from vergence.stereospace import mls_view

    rng = np.random.default_rng(own)
    n_points = 500
    q = rng.uniform(0, 300, (n_points, 2))  # the points in the target
    pixels = q[None] + rng.normal(0, 5.0, (4, n_points, 2)) + rng.uniform(-20, 20, (4, 1, 2))  # in 4 sources
    common = np.arange(200)
    handles = [(n, np.sort(np.concatenate([common, rng.choice(np.arange(200, n_points), own, replace=False)])))
               for n in (2, 0, 3)]  # fmt: skip
    nodes = rng.uniform(-10, 310, (150, 2)).astype(np.float32)
    calls = []
    kernel = _mls_kernels.mls_shared_handles
    monkeypatch.setattr(_mls_kernels, "mls_shared_handles", lambda *a: calls.append(1) or kernel(*a))
    maps = mls_view._source_maps(nodes, q, pixels, handles, 1.0)
    assert bool(calls) == shared  # 30 handles not shared against 200 shared: shared; 180: each its own
    for g, (n, sel) in enumerate(handles):  # each source's map on its own handles, float64
        expected = mls_similarity(nodes.astype(np.float64), q[sel], pixels[n, sel])
        assert_allclose(maps[g], expected, atol=SOURCE_MAPS_ATOL, rtol=0)


def test_a_one_pixel_wide_or_high_view_is_that_line_of_the_full_view():
    # A single node column (row) gets a phantom node one pixel on (mls.with_cells); the full view's
    # first column (row) lies on its nodes: the same values, the same weights.
    rng = np.random.default_rng(2)
    target = _camera(0.1, 0.05)
    sources = [(c, _render(c)) for c in (_camera(-0.3), _camera(0.4), _camera(0.0, 0.3))]
    points = _points(rng)
    full = s2_view(target, sources, points=points)
    for width, height, line in ((1, H, np.s_[:, :1]), (W, 1, np.s_[:1, :])):
        narrow = Camera(target.K, target.R, target.t, width, height)
        res = s2_view(narrow, sources, points=points)
        assert res.image.shape == (height, width)
        assert_allclose(res.image, full.image[line], atol=1e-6, rtol=0)
        assert_allclose(res.weights, full.weights[(slice(None), *line)], atol=1e-12, rtol=0)
