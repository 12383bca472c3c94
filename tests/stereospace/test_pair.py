"""The stereo pair at a state of the stereospace: novel cameras, rectification, packing, quality.

Scene: a textured plane at z = 5 m seen by a row of four cameras toed in towards (0, 0, 5), so the
rectification is not the identity; the images are written to a temporary folder.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import look_at
from vergence.io import write_image
from vergence.stereospace import (
    S2_MAX_SOURCES,
    Collection,
    PreparedCollection,
    StereoSpace,
    StereoState,
    camera_graph,
    load_collection,
    pair_cameras,
    pair_quality,
    s2_view,
    space_from_graph,
    stereo_pair,
)
from vergence.viewing import ComfortZone, Display, arcmin_from_pixels

PLANE_Z = 5.0
W, H = 64, 48
XS = (-0.6, -0.2, 0.2, 0.6)


def _camera(x, *, toe=True):
    return look_at([x, 0.0, 0.0], [0.0 if toe else x, 0.0, PLANE_Z], [0.0, -1.0, 0.0], fov_deg=60.0, width=W, height=H)


def _render(cam):
    d = cam.ray_directions()
    t = (PLANE_Z - cam.center[2]) / d[..., 2]
    x, y = cam.center[0] + t * d[..., 0], cam.center[1] + t * d[..., 1]
    return (0.5 + 0.4 * np.sin(1.3 * x) * np.cos(1.7 * y)).astype(np.float32)


def _plane_points(n=80, seed=3):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-2.0, 2.0, n), rng.uniform(-1.5, 1.5, n), np.full(n, PLANE_Z)])


@pytest.fixture(scope="module")
def plane(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plane")
    cams = tuple(_camera(x) for x in XS)
    names = tuple(f"v{k}.png" for k in range(len(cams)))
    for name, cam in zip(names, cams):
        write_image(folder / name, _render(cam))
    col = Collection(names=names, cameras=cams, image_paths=tuple(folder / n for n in names), points=_plane_points())
    return col, PreparedCollection(col)


def _bilinear(img, x, y):
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    fx, fy = x - x0, y - y0
    return ((1 - fx) * (1 - fy) * img[y0, x0] + fx * (1 - fy) * img[y0, x0 + 1]
            + (1 - fx) * fy * img[y0 + 1, x0] + fx * fy * img[y0 + 1, x0 + 1])


def test_space_from_graph_has_one_segment_per_edge(plane):
    col, prep = plane
    space, pairs = space_from_graph(col, camera_graph(col))
    assert_array_equal(pairs, prep.graph.edges)
    assert_allclose(space.segments[:, 0], col.centers[pairs[:, 0]])
    assert_allclose(space.segments[:, 1], col.centers[pairs[:, 1]])


def test_cameras_at_the_segment_ends_are_the_graph_cameras(plane):
    col, prep = plane
    a, b = (int(v) for v in prep.segment_cameras[0])
    first, second = pair_cameras(prep.space, col, StereoState((0, 0), 0.0, 1.0))
    assert first is col.cameras[a] and second is col.cameras[b]
    mid, _ = pair_cameras(prep.space, col, StereoState((0, 0), 0.5, 1.0))
    assert_allclose(mid.center, (col.centers[a] + col.centers[b]) / 2, atol=1e-12)


def test_pair_is_row_aligned_and_left_is_left(plane):
    col, prep = plane
    res = stereo_pair(prep, StereoState((0, 0), 0.2, 0.9), layout="sbs")
    cam_l, cam_r = res.rectified
    assert cam_l.center[0] < cam_r.center[0]  # the left eye has the smaller x (all cameras face +z)
    assert (cam_r.center - cam_l.center) @ cam_l.R[0] > 0
    xl, _ = cam_l.project(col.points)
    xr, _ = cam_r.project(col.points)
    assert_allclose(xl[:, 1], xr[:, 1], atol=1e-9)  # rows agree
    assert res.left.shape == (H, W) and res.packed.shape == (H, 2 * W)
    # image content agrees along the rows: each plane point has one grey value in both views
    inside = (xl[:, 0] > 2) & (xl[:, 0] < W - 3) & (xr[:, 0] > 2) & (xr[:, 0] < W - 3) & (xl[:, 1] > 2) & (xl[:, 1] < H - 3)
    assert inside.sum() > 10
    diff = [abs(_bilinear(res.left, *p) - _bilinear(res.right, *q)) for p, q in zip(xl[inside], xr[inside])]
    assert np.median(diff) < 0.03
    assert_allclose(res.point, prep.space.point(0, 0.2, 0, 0.9))


def test_left_is_left_whichever_eye_comes_first(plane):
    col, prep = plane
    space, seen = prep.space, set()
    for i, j in space.regions:
        for li, lj in ((0.0, 1.0), (1.0, 0.0)) if i != j else ((0.0, 1.0),):
            first, second = space.eyes(StereoState((i, j), li, lj))
            if np.allclose(first, second):
                continue
            res = stereo_pair(prep, StereoState((i, j), li, lj), method=lambda p, cam: _render(cam))
            assert res.swapped == (first[0] > second[0])
            assert res.rectified[0].center[0] < res.rectified[1].center[0]
            assert_allclose(res.rectified[int(res.swapped)].center, first, atol=1e-12)
            seen.add(res.swapped)
    assert seen == {False, True}


def test_prepared_and_unprepared_pairs_are_equal(plane):
    col, prep = plane
    state = StereoState((0, 1), 0.3, 0.6)
    a, b = stereo_pair(prep, state), stereo_pair(col, state)
    assert_array_equal(a.left, b.left)
    assert_array_equal(a.right, b.right)


def test_prepared_views_are_s2_views_of_the_nearest_cameras(plane):
    col, prep = plane
    res = stereo_pair(prep, StereoState((0, 1), 0.3, 0.6))
    for view, cam in zip((res.left, res.right), res.rectified):
        nearest = np.argsort(np.linalg.norm(col.centers - cam.center, axis=1), kind="stable")[:S2_MAX_SOURCES]
        expected = s2_view(cam, [(col.cameras[k], prep.image(k)) for k in nearest], points=col.points)
        assert_array_equal(view, expected.image)


def test_a_coarser_grid_changes_the_pair_little(plane):
    # The plane's views differ by homographies, smooth maps: measured mean 9e-4, max 0.026 at step 16
    # (cropped: the fitted views have the edge of the sources' coverage inside the frame, where a
    # pixel is covered at one step and not at the other).
    col, prep = plane
    coarse = PreparedCollection(col, grid_step=16)
    state = StereoState((0, 1), 0.3, 0.6)
    a, b = stereo_pair(prep, state, framing="crop"), stereo_pair(coarse, state, framing="crop")
    diff = np.abs(a.left - b.left)
    assert 0 < diff.mean() < 2e-3 and diff.max() < 0.05
    with pytest.raises(ValueError, match="grid_step must be >= 1"):
        PreparedCollection(col, grid_step=0)


def test_a_callable_method_renders_in_the_rectified_cameras(plane):
    col, prep = plane
    res = stereo_pair(prep, StereoState((0, 0), 0.0, 1.0), method=lambda p, cam: _render(cam))
    assert_allclose(res.left, _render(res.rectified[0]))


def test_quality_on_known_disparities(tmp_path):
    # two parallel cameras 0.2 m apart: rectification is the identity, disparity x_r - x_l = -f b / z
    cams = (_camera(0.0, toe=False), _camera(0.2, toe=False))
    depths = np.array([2.0, 4.0, 8.0])
    pts = np.column_stack([np.full(3, 0.1), np.zeros(3), depths])
    col = Collection(names=("a", "b"), cameras=cams, image_paths=(tmp_path / "a", tmp_path / "b"), points=pts)
    display = Display.preset("desktop-24")
    q = pair_quality(col, cams, display)
    f = cams[0].focal_px
    want_px = -f * 0.2 / depths
    assert q["points_seen"] == 3 and not q["swapped"]
    assert_allclose(q["disparity_px"], (want_px.min(), want_px.max()), rtol=1e-9)
    scale = display.resolution / W
    assert_allclose(q["disparity_arcmin"], arcmin_from_pixels(np.array([want_px.min(), want_px.max()]) * scale, display))
    assert_allclose(q["range_arcmin"], q["disparity_arcmin"][1] - q["disparity_arcmin"][0])
    assert_allclose(q["rectification_distortion"], 0.0, atol=1e-12)
    assert_allclose(q["rectification_rotation_deg"], 0.0, atol=1e-6)
    assert q["inside"] == (q["disparity_arcmin"][0] >= -60.0)
    wide = pair_quality(col, cams, display, zone=ComfortZone(crossed_arcmin=5000.0, uncrossed_arcmin=60.0))
    assert wide["inside"] and wide["fits_with_shift"]
    # the reversed pair is the same pair, swapped
    assert pair_quality(col, cams[::-1], display)["swapped"]
    with pytest.raises(TypeError, match="^display must be a vergence.viewing.Display; got str$"):
        pair_quality(col, cams, "desktop-24")
    with pytest.raises(ValueError, match="^display resolution is unknown: give the screen width in pixels$"):
        pair_quality(col, cams, Display(0.065, 0.6, 0.5))


def test_toed_in_pair_has_rectification_distortion(plane):
    col, _ = plane
    q = pair_quality(col, (col.cameras[0], col.cameras[3]), Display.preset("desktop-24"))
    assert min(q["rectification_distortion"]) > 1e-4 and min(q["rectification_rotation_deg"]) > 1.0


@pytest.mark.parametrize(
    ("state", "kwargs", "message"),
    [
        (StereoState((0, 1), 1.5, 0.5), {}, "li must"),
        (StereoState((0, 1), 0.5, -0.1), {}, "lj must"),
        (StereoState((0, 99), 0.5, 0.5), {}, "does not exist"),
        (StereoState((0, 1), 0.5, 0.5), {"layout": "hologram"}, "layout must be one of"),
        (StereoState((0, 1), 0.5, 0.5), {"method": "magic"}, "method must be one of"),
    ],
)
def test_bad_input_is_one_line(plane, state, kwargs, message):
    _, prep = plane
    with pytest.raises(ValueError, match=message) as err:
        stereo_pair(prep, state, **kwargs)
    assert "\n" not in str(err.value)


def test_bad_types(plane):
    col, prep = plane
    with pytest.raises(TypeError, match="prepared must be"):
        stereo_pair("kermit", StereoState((0, 0), 0.0, 1.0))
    with pytest.raises(TypeError, match="cameras must be a pair"):
        pair_quality(col, col.cameras[0], Display.preset("desktop-24"))
    with pytest.raises(ValueError, match="space must have its segments"):
        pair_cameras(StereoSpace([[[9, 9, 9], [8, 8, 8]]]), col, StereoState((0, 0), 0.0, 1.0))


def test_kermit_pair(shared_data):
    folder = shared_data / "collections" / "kermit"
    col = load_collection(folder / "bundle.out", images=folder)
    prep = PreparedCollection(col)
    res = stereo_pair(prep, StereoState((0, 0), 0.0, 1.0), layout="anaglyph")
    assert res.left.shape == (480, 640, 3) and res.packed.shape[:2] == (480, 640)
    xl, zl = res.rectified[0].project(col.points)
    xr, zr = res.rectified[1].project(col.points)
    assert_allclose(xl[:, 1], xr[:, 1], atol=1e-6)
    assert (res.left.max(axis=2) > 0).mean() > 0.5


def test_anaglyphs_of_the_built_in_views_skip_the_checks_and_equal_pack(plane):
    # stereo_pair packs its own views (float32 in [0, 1]) into an anaglyph without pack's validation:
    # the same image as pack, for every anaglyph layout, grey and colour views; a callable method's
    # views and views with alpha go through pack (its checks).
    from vergence.display import LAYOUTS, pack
    from vergence.stereospace import pair as pair_module

    _, prep = plane
    state = StereoState((0, 1), 0.3, 0.6)
    res = stereo_pair(prep, state)
    rng = np.random.default_rng(4)
    colour = [np.clip(v[..., None] * rng.uniform(0.5, 1.0, 3), 0, 1).astype(np.float32) for v in (res.left, res.right)]
    colour[0][:3, :3] = 0.0  # black pixels: sRGB's linear segment
    anaglyphs = [name for name in LAYOUTS if name.startswith("anaglyph")]
    assert len(anaglyphs) == 7
    for layout in anaglyphs:
        assert_array_equal(stereo_pair(prep, state, layout=layout).packed, pack(res.left, res.right, layout=layout))
        for views in ((res.left, res.right), colour):
            fast = pair_module._packed(*views, layout, own=True)
            assert fast.dtype == np.float32 and fast.flags.c_contiguous
            assert_array_equal(fast, pack(*views, layout=layout))
    bad = np.full((H, W), np.nan, dtype=np.float32)
    with pytest.raises(ValueError, match="must be finite"):
        pair_module._packed(bad, bad, "anaglyph", own=False)
    alpha = np.zeros((H, W, 4), dtype=np.float32)
    with pytest.raises(ValueError, match="shape"):
        pair_module._packed(alpha, alpha, "anaglyph", own=True)
    assert_array_equal(pair_module._packed(res.left, res.right, "sbs", own=True), pack(res.left, res.right))


def test_coincident_eyes_give_one_unrectified_view(plane):
    _, prep = plane
    res = stereo_pair(prep, StereoState((0, 0), 0.4, 0.4), method=lambda p, cam: _render(cam))
    assert res.rectification is None and res.point[3] == 0.0
    assert_array_equal(res.left, res.right)
    assert_array_equal(res.rectified[0].R, res.cameras[0].R)


def test_a_smaller_width_renders_the_same_extent_on_fewer_pixels(plane):
    col, prep = plane
    state = StereoState((0, 0), 0.2, 0.9)
    full = stereo_pair(prep, state)
    same = stereo_pair(prep, state, width=W)
    assert_array_equal(same.left, full.left)
    half = stereo_pair(prep, state, width=W // 2, layout="sbs")
    assert half.left.shape == (H // 2, W // 2) and half.packed.shape == (H // 2, W)
    cam_l, cam_r = half.rectified
    assert (cam_l.width, cam_l.height) == (W // 2, H // 2)
    xl, _ = cam_l.project(col.points)
    xr, _ = cam_r.project(col.points)
    assert_allclose(xl[:, 1], xr[:, 1], atol=1e-9)  # rows still agree
    # a point lands where the full-size pixel lands after a 2x resize: u' = (u + 1/2) / 2 - 1/2
    xf, _ = full.rectified[0].project(col.points)
    assert_allclose(xl, (xf + 0.5) / 2.0 - 0.5, atol=1e-9)
    # the slow reference: the full-size view averaged over 2 x 2 blocks (inside, where both are covered)
    ref = full.left.reshape(H // 2, 2, W // 2, 2).mean(axis=(1, 3))
    inner = (slice(3, -3), slice(3, -3))
    covered = (ref[inner] > 0) & (half.left[inner] > 0)
    assert covered.mean() > 0.5
    assert np.median(np.abs(ref[inner] - half.left[inner])[covered]) < 0.03


@pytest.mark.parametrize("width", [0, W + 1, 2.5, True])
def test_bad_width_is_refused(plane, width):
    _, prep = plane
    with pytest.raises(ValueError, match=r"width must be a whole number of pixels in \[1, 64\]"):
        stereo_pair(prep, StereoState((0, 0), 0.2, 0.9), width=width)


def _corners_in(novel, output):
    """The four corners of ``novel``'s image, through the world (rays at 5 m), in ``output``'s pixels."""
    corners = np.array([[-0.5, -0.5], [W - 0.5, -0.5], [-0.5, H - 0.5], [W - 0.5, H - 0.5]])
    xy, z = output.project(novel.backproject(corners, np.full(4, PLANE_Z)))
    assert (z > 0).all()
    return xy


# Pixels of slack for "inside the frame" (round-off) and for "reaches its edge" (rectify_cameras
# rounds each extent up to whole pixels: at most half a pixel each side).
EDGE_TOL = 1e-6
FIT_SLACK_PX = 0.5


@pytest.mark.parametrize("size", [(W, H), (50, 60), (120, 40)])
def test_fit_to_frame_keeps_both_whole_views_and_crop_cuts_them(plane, size):
    # A wide pair of the row, rolled 30 degrees from each other: the rectified extents outgrow the frame.
    col, _ = plane
    cams = (look_at([-0.6, 0, 0], [0, 0, PLANE_Z], [0, -1, 0], fov_deg=60, width=W, height=H),
            look_at([0.6, 0, 0], [0, 0, PLANE_Z], [0.5, -np.sqrt(0.75), 0], fov_deg=60, width=W, height=H))
    names = ("a.png", "b.png")
    rolled = Collection(names=names, cameras=cams, image_paths=tuple(col.image_paths[:2]), points=col.points)
    state = StereoState((0, 0), 0.0, 1.0)
    blank = lambda p, cam: np.zeros((cam.height, cam.width), np.float32)  # noqa: E731
    for framing in ("fit", "crop"):
        res = stereo_pair(PreparedCollection(rolled), state, method=blank, size=size, framing=framing)
        novel_l, novel_r = res.cameras[::-1] if res.swapped else res.cameras
        xy = np.concatenate([_corners_in(novel_l, res.rectified[0]), _corners_in(novel_r, res.rectified[1])])
        lo, hi = np.array([-0.5, -0.5]), np.array([size[0] - 0.5, size[1] - 0.5])
        inside = ((xy >= lo - EDGE_TOL) & (xy <= hi + EDGE_TOL)).all()
        if framing == "fit":
            assert inside and res.left.shape == (size[1], size[0])
            # as large as it can be: an extent reaches the frame's edge (within the rectified size's
            # rounding up to whole pixels, half a pixel each side before the scale)
            assert (np.isclose(xy, lo, atol=FIT_SLACK_PX) | np.isclose(xy, hi, atol=FIT_SLACK_PX)).any()
        else:
            assert not inside  # the tree before issue 27: centred at the collection's scale, cut off
        assert_allclose(*(c.project(col.points)[0][:, 1] for c in res.rectified), atol=1e-9)  # rows agree


def test_a_display_shifts_the_pair_into_the_zone(plane):
    # Against world positions: the points' disparities in the output cameras, converted independently.
    col, prep = plane
    display = Display.preset("desktop-24")
    res = stereo_pair(prep, StereoState((0, 1), 0.5, 0.5), display=display)
    xl, _ = res.rectified[0].project(col.points)
    xr, _ = res.rectified[1].project(col.points)
    seen = (np.abs(xl - [(W - 1) / 2, (H - 1) / 2]) <= [W / 2, H / 2]).all(1)
    seen &= (np.abs(xr - [(W - 1) / 2, (H - 1) / 2]) <= [W / 2, H / 2]).all(1)
    d = np.sort(xr[seen, 0] - xl[seen, 0])
    low, high = np.quantile(d, [0.01, 0.99])
    d = d[(d >= low) & (d <= high)]
    arcmin = arcmin_from_pixels(np.array([d.min(), d.max()]) * display.resolution / W, display)
    assert_allclose(arcmin, res.shift.after_arcmin, atol=1e-6)
    assert res.shift.fits and -60 < arcmin[0] < arcmin[1] < 60
    assert arcmin.mean() == pytest.approx(0.0, abs=0.05)  # centred in the ±60 arcmin zone
    plain = stereo_pair(prep, StereoState((0, 1), 0.5, 0.5))
    assert plain.shift is None
    gap = lambda r: r.rectified[1].K[0, 2] - r.rectified[0].K[0, 2]  # noqa: E731
    assert gap(res) - gap(plain) == pytest.approx(res.shift.shift_px)


def test_framing_and_shift_refuse_bad_input(plane):
    from vergence.stereospace import convergence_shift, frame_cameras

    col, _ = plane
    a, b = col.cameras[:2]
    display = Display.preset("desktop-24")
    for size in ((0, 10), (10,), (10.5, 10), (True, 10)):
        with pytest.raises(ValueError, match=r"size must be \(width, height\)"):
            frame_cameras(a, b, size)
    with pytest.raises(ValueError, match="framing must be one of fit, crop"):
        frame_cameras(a, b, (W, H), framing="stretch")
    with pytest.raises(TypeError, match="Camera"):
        frame_cameras(a, "b", (W, H))
    with pytest.raises(ValueError, match="points"):
        convergence_shift(a, b, np.full((3, 3), np.nan), display)
    with pytest.raises(ValueError, match=r"trim must be a fraction in \[0, 0.5\)"):
        convergence_shift(a, b, col.points, display, trim=0.5)
    with pytest.raises(TypeError, match="zone must be a ComfortZone"):
        convergence_shift(a, b, col.points, display, zone=(-60, 60))
    with pytest.raises(ValueError, match="resolution"):
        convergence_shift(a, b, col.points, Display(0.065, 0.6, 0.5))
    with pytest.raises(ValueError, match="framing must be one of"):
        stereo_pair(plane[1], StereoState((0, 1), 0.5, 0.5), framing="stretch")
    with pytest.raises(ValueError, match="give width or size, not both"):
        stereo_pair(plane[1], StereoState((0, 1), 0.5, 0.5), width=32, size=(32, 24))
