"""A built StereoSpace: the quality rule per region vertex, the map's frame, the space folder, the map.

Most tests use the synthetic collection of ``conftest.py`` (five cameras toed in towards a tilted
textured plane, 64 x 48); dino and kermit tests skip without the shared data.
"""

from __future__ import annotations

import json
import math
import shutil
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import look_at
from vergence.io import CameraSet, write_cameras_json
from vergence.report.stereospace_map import navigation_map, region_triangles
from vergence.stereospace import (
    DISPARITY_TRIM,
    DISTORTION_LIMIT,
    PSNR_CEIL_DB,
    PSNR_FLOOR_DB,
    BuiltSpace,
    Collection,
    StereoState,
    VertexQuality,
    build_space,
    load_space,
    map_frame,
    pair_quality,
    save_space,
    vertex_pairs,
    vertex_quality,
)
from vergence.viewing import ComfortZone, Display

DESKTOP = Display.preset("desktop-24")


# -- the quality rule --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def col(synthetic_space):
    return synthetic_space[2].collection


def _range_and_distortion(col, a, b):
    q = pair_quality(col, (col.cameras[a], col.cameras[b]), DESKTOP, trim=DISPARITY_TRIM)
    return q["range_arcmin"], max(q["rectification_distortion"])


def test_comfort_falls_as_the_zone_over_the_range(col):
    span, delta = _range_and_distortion(col, 0, 2)
    zone = ComfortZone(crossed_arcmin=span / 4, uncrossed_arcmin=span / 4)  # half the range wide
    q = vertex_quality(col, (0, 2), DESKTOP, psnr_db=(20.0, 25.0), zone=zone)
    assert q.comfort == pytest.approx(0.5) and q.depth == 1.0 and not q.fits_with_shift
    assert q.rectification == pytest.approx(1.0 - delta / DISTORTION_LIMIT)
    assert q.interpolation == pytest.approx((20.0 - PSNR_FLOOR_DB) / (PSNR_CEIL_DB - PSNR_FLOOR_DB))  # the worse view
    assert q.quality == pytest.approx(0.5 * q.rectification * 0.5)
    assert q.range_arcmin == pytest.approx(span)


def test_depth_falls_as_the_range_over_the_zone(col):
    span, _ = _range_and_distortion(col, 1, 3)
    zone = ComfortZone(crossed_arcmin=span, uncrossed_arcmin=span)  # twice the range wide
    q = vertex_quality(col, (1, 3), DESKTOP, psnr_db=(PSNR_CEIL_DB + 5, math.inf), zone=zone)
    assert q.comfort == 1.0 and q.depth == pytest.approx(0.5) and q.fits_with_shift
    assert q.interpolation == 1.0  # above the ceiling, and a perfect view, clip to 1
    assert q.quality == pytest.approx(0.5 * q.rectification)


def test_the_range_is_trimmed(col):
    full = pair_quality(col, (col.cameras[0], col.cameras[4]), DESKTOP)["range_arcmin"]
    trimmed = pair_quality(col, (col.cameras[0], col.cameras[4]), DESKTOP, trim=0.1)["range_arcmin"]
    assert 0.5 * full < trimmed < full  # a plane's disparities are uniform-ish: 10 % off each end
    with pytest.raises(ValueError, match="trim must be a fraction"):
        pair_quality(col, (col.cameras[0], col.cameras[4]), DESKTOP, trim=0.5)


def test_vertex_quality_ignores_the_order_of_the_cameras(col):
    a = vertex_quality(col, (3, 1), DESKTOP, psnr_db=(18.0, 22.0))
    b = vertex_quality(col, (1, 3), DESKTOP, psnr_db=(22.0, 18.0))
    assert a == b and a.cameras == (1, 3) and a.psnr_db == (22.0, 18.0)


def test_mono_vertex_has_no_stereo_quality(col):
    q = vertex_quality(col, (2, 2), DESKTOP, psnr_db=(30.0, 30.0))
    assert (q.quality, q.comfort, q.depth, q.rectification, q.interpolation) == (0.0, 1.0, 0.0, 1.0, 1.0)
    assert q.note == "mono" and q.range_arcmin is None


def test_a_view_that_could_not_be_made_scores_zero(col):
    q = vertex_quality(col, (0, 1), DESKTOP, psnr_db=(math.nan, 30.0))
    assert q.interpolation == 0.0 and q.quality == 0.0
    q = vertex_quality(col, (0, 1), DESKTOP, psnr_db=(30.0, math.nan))
    assert q.interpolation == 0.0


def test_a_pair_along_the_viewing_direction_is_not_rectifiable(tmp_path):
    cams = tuple(look_at([0, 0, z], [0, 0, 10], [0, -1, 0], fov_deg=60, width=32, height=24) for z in (0.0, 1.0))
    pts = np.array([[0.5, 0.2, 5.0], [-0.4, 0.1, 6.0], [0.1, -0.3, 7.0]])
    col = Collection(names=("a", "b"), cameras=cams, image_paths=(tmp_path / "a", tmp_path / "b"), points=pts)
    q = vertex_quality(col, (0, 1), DESKTOP, psnr_db=(30.0, 30.0))
    assert q.quality == 0.0 and q.note.startswith("not rectifiable")


def test_vertex_quality_refuses_bad_input(col):
    with pytest.raises(ValueError, match="cameras must index"):
        vertex_quality(col, (0, 9), DESKTOP, psnr_db=(20.0, 20.0))
    with pytest.raises(TypeError, match="collection must be a Collection"):
        vertex_quality("col", (0, 1), DESKTOP, psnr_db=(20.0, 20.0))


def test_record_round_trips_through_a_dict(col):
    q = vertex_quality(col, (0, 1), DESKTOP, psnr_db=(math.nan, 21.0))
    back = VertexQuality.from_dict(json.loads(json.dumps(q.to_dict())))
    assert back.cameras == q.cameras and math.isnan(back.psnr_db[0]) and back.psnr_db[1] == 21.0
    assert back.quality == q.quality and back.note == q.note
    with pytest.raises(ValueError, match="fields"):
        VertexQuality.from_dict({"cameras": [0, 1]})


# -- the map's frame ----------------------------------------------------------------------------------
def _ring(n, *, roll):
    """Cameras on a circle of radius 2 in the plane y = 0.5, looking at the centre; rolled by 90° every other."""
    cams = []
    for k in range(n):
        a = 2 * math.pi * k / n
        up = [0, -1, 0] if not roll else ([0, -1, 0] if k % 2 else [0, 1, 0])
        cams.append(look_at([2 * math.cos(a), 0.5, 2 * math.sin(a)], [0, 0.5, 0], up, fov_deg=50, width=32, height=24))
    return Collection(names=tuple(f"c{k}" for k in range(n)), cameras=tuple(cams),
                      image_paths=tuple(f"c{k}" for k in range(n)))  # fmt: skip


def _check_frame(frame):
    assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(frame) == pytest.approx(1.0)


def test_frame_looks_along_the_mean_up_axis_when_the_cameras_agree():
    frame = map_frame(_ring(8, roll=False))
    _check_frame(frame)
    assert_allclose(frame[2], [0, -1, 0], atol=1e-12)  # look_at's image up is -y here


def test_frame_looks_along_the_plane_normal_when_the_up_axes_cancel():
    col = _ring(8, roll=True)
    ups = np.array([-c.R[1] for c in col.cameras]).mean(axis=0)
    assert np.linalg.norm(ups) < 1e-12  # they cancel exactly
    frame = map_frame(col)
    _check_frame(frame)
    assert abs(frame[2] @ [0, 1, 0]) == pytest.approx(1.0)  # the ring's normal, either sign
    assert_allclose(frame[:2] @ [0, 1, 0], 0.0, atol=1e-12)


def test_frame_looks_down_the_arc_normal_when_the_photos_are_rolled():
    # Issue 27: an arc of 8 cameras over 90 degrees around the world's +y axis, every photo rolled 90
    # degrees (its image up along the arc's tangent): the mean image up is long (they agree) but lies
    # in the arc's plane; the top view must look along the arc's normal, the world's y.
    cams = []
    for k in range(8):
        a = math.radians(90.0 * k / 7)
        centre = np.array([2 * math.cos(a), 0.5, 2 * math.sin(a)])
        tangent = [-math.sin(a), 0.0, math.cos(a)]
        cams.append(look_at(centre, [0, 0.5, 0], tangent, fov_deg=50, width=32, height=24))
    col = Collection(names=tuple(f"c{k}" for k in range(8)), cameras=tuple(cams),
                     image_paths=tuple(f"c{k}" for k in range(8)))  # fmt: skip
    ups = np.array([-c.R[1] for c in col.cameras]).mean(axis=0)
    assert np.linalg.norm(ups) > 0.5 and abs(ups[1]) < 1e-12  # they agree, on a horizontal direction
    frame = map_frame(col)
    _check_frame(frame)
    assert abs(frame[2] @ [0, 1, 0]) == pytest.approx(1.0)


def test_frame_of_cameras_on_a_line(col):
    frame = map_frame(col)  # the synthetic row: centres on the x axis
    _check_frame(frame)
    assert_allclose(abs(frame[0] @ [1, 0, 0]), 1.0)  # across the row


# -- build, save, load ------------------------------------------------------------------------------
def test_build_gives_a_record_for_every_region_vertex(synthetic_space):
    _, _, built = synthetic_space
    space, pairs = built.space, built.segment_cameras
    assert len(space.regions) == len(space.segments) * (len(space.segments) + 1) // 2
    assert sorted(built.vertex_qualities) == vertex_pairs(pairs)
    for i, j in space.regions:
        q = built.region_quality((i, j))
        for li in (0, 1):
            for lj in (0, 1):
                if i == j and li > lj:
                    assert math.isnan(q[li, lj])
                    continue
                rec = built.vertex((i, j), li, lj)
                assert set(rec.cameras) == {int(pairs[i, li]), int(pairs[j, lj])}
                assert q[li, lj] == rec.quality
        if i == j:
            assert q[0, 0] == q[1, 1] == 0.0  # coincident eyes on the triangle's diagonal
    assert np.isfinite(built.psnr_db).all() and (built.psnr_db > 20).all()  # measured 24.4-32.6 dB
    best = max(built.vertex_qualities.values(), key=lambda v: v.quality)
    assert best.quality > 0.5 and abs(best.cameras[1] - best.cameras[0]) == 1  # neighbours fill the zone best
    with pytest.raises(ValueError, match="vertex of region"):
        built.vertex((0, 0), 1, 0)


def test_build_of_a_loaded_collection_is_the_same_space(synthetic_space):
    cameras_path, images, built = synthetic_space
    again = build_space(cameras_path, images=images, collection=built.collection)
    assert again.collection is built.collection and again.cameras_path == built.cameras_path
    assert np.array_equal(again.graph.edges, built.graph.edges)
    assert_allclose(again.psnr_db, built.psnr_db)
    assert {k: v.quality for k, v in again.vertex_qualities.items()} == {
        k: v.quality for k, v in built.vertex_qualities.items()}
    with pytest.raises(TypeError, match="collection must be a Collection"):
        build_space(cameras_path, images=images, collection="dino")


def test_space_folder_round_trip(synthetic_space, tmp_path):
    _, _, built = synthetic_space
    out = save_space(built, tmp_path / "space")
    assert sorted(p.name for p in out.iterdir()) == ["points.npz", "space.json"]
    back = load_space(out)
    assert isinstance(back, BuiltSpace)
    assert back.collection.names == built.collection.names
    assert_array_equal(back.graph.edges, built.graph.edges)
    assert_array_equal(back.space.segments, built.space.segments)
    assert back.paths == built.paths
    assert_array_equal(back.psnr_db, built.psnr_db)
    assert back.vertex_qualities == built.vertex_qualities
    assert back.display_name == built.display_name and back.zone == built.zone
    assert back.collection.median_reprojection_error_px == built.collection.median_reprojection_error_px
    assert_array_equal(back.collection.points, built.collection.points)
    record = json.loads((out / "space.json").read_text())
    assert record["version"] == 1 and record["cameras_path"] == str(built.cameras_path)
    assert record["point_count"] == 150 and record["regions"] == len(built.space.regions)


@pytest.fixture
def saved(synthetic_space, tmp_path):
    """A copy of the synthetic collection and a space folder built from it (mutable per test)."""
    cameras_path, images, built = synthetic_space
    data = shutil.copytree(images, tmp_path / "data")
    moved = BuiltSpace(collection=built.collection, graph=built.graph, space=built.space,
                       segment_cameras=built.segment_cameras, paths=built.paths, display_name=built.display_name,
                       zone=built.zone, psnr_db=built.psnr_db, vertex_qualities=built.vertex_qualities,
                       cameras_path=data / cameras_path.name, images=data, build_seconds=1.0)  # fmt: skip
    return save_space(moved, tmp_path / "space"), data


def _edit(path, **changes):
    record = json.loads(path.read_text())
    record.update(changes)
    path.write_text(json.dumps(record))


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        (lambda s, d: shutil.rmtree(s), "does not exist"),
        (lambda s, d: (s / "space.json").unlink(), "no space.json"),
        (lambda s, d: (s / "space.json").write_text("{ not json"), "not valid JSON"),
        (lambda s, d: _edit(s / "space.json", format="other"), "not a vergence space file"),
        (lambda s, d: _edit(s / "space.json", version=99), "format version 99"),
        (lambda s, d: (d / "cameras.json").unlink(), "camera file .* is missing"),
        (lambda s, d: (d / "v3.png").unlink(), "image .*v3.png .* is missing"),
        (lambda s, d: (s / "points.npz").unlink(), "no points.npz"),
        (lambda s, d: (s / "points.npz").write_bytes(b"garbage"), "points.npz is damaged"),
        (lambda s, d: _edit(s / "space.json", names=["v0.png", "v1.png", "v9.png"]), "no longer has the camera v9"),
        (lambda s, d: _edit(s / "space.json", vertex_quality=[]), "do not match the regions"),
        (lambda s, d: _edit(s / "space.json", display={"preset": "imax"}), "unknown display preset"),
    ],
)
def test_load_refuses_a_moved_or_damaged_space(saved, damage, words):
    space, data = saved
    damage(space, data)
    with pytest.raises(ValueError, match=words):
        load_space(space)


def test_load_refuses_an_edited_camera_file(saved):
    space, data = saved
    record = json.loads((data / "cameras.json").read_text())
    record["cameras"][2]["camera"]["t"][0] += 0.01  # camera 2 moved by 1 cm
    (data / "cameras.json").write_text(json.dumps(record))
    with pytest.raises(ValueError, match="differ from those the space"):
        load_space(space)


def test_build_refuses_an_unknown_display(synthetic_space):
    cameras_path, images, _ = synthetic_space
    with pytest.raises(ValueError, match="unknown display preset 'imax'"):
        build_space(cameras_path, images=images, display="imax")


# -- the navigation map -------------------------------------------------------------------------------
def test_region_triangles_sit_at_the_view_positions(synthetic_space):
    _, _, built = synthetic_space
    xy, quality, triangles = region_triangles(built)
    m = len(built.space.segments)
    assert len(triangles) == 2 * (m * (m - 1) // 2) + m  # two per rhomboid, one per triangle
    means = quality[triangles].mean(axis=1)
    assert (np.diff(means) >= 0).all()  # drawn in order of quality: the best shows where they overlap
    # every vertex is the map image of the mid-point of its region's eyes
    seg = built.space.segments
    mids = np.array([(seg[i, a] + seg[j, b]) / 2 for i, j in built.space.regions
                     for a, b in ([(0, 0), (1, 0), (1, 1), (0, 1)] if i != j else [(0, 0), (0, 1), (1, 1)])])  # fmt: skip
    assert_allclose(xy, (mids - built.collection.centers.mean(axis=0)) @ built.frame[:2].T, atol=1e-12)
    assert quality.max() == max(q.quality for q in built.vertex_qualities.values())


def test_navigation_map_writes_a_png(synthetic_space, tmp_path):
    from vergence.io import read_image

    _, _, built = synthetic_space
    out = navigation_map(built, tmp_path / "map.png", state=StereoState((0, 1), 0.25, 0.75))
    img = read_image(out)
    assert img.shape[:2] == (600, 700) and img.std() > 0.05
    with pytest.raises(ValueError, match="end in .png"):
        navigation_map(built, tmp_path / "map.jpg")
    with pytest.raises(ValueError, match="li must lie in"):
        navigation_map(built, tmp_path / "bad.png", state=StereoState((0, 1), 1.5, 0.2))
    assert not (tmp_path / "bad.png").exists()


def test_the_map_colours_quality_on_a_fixed_0_to_1_scale(synthetic_space, tmp_path, monkeypatch):
    # Kermit's best vertex, 0.07, was drawn in the top colour (the scale ran 0..max): a space's colours
    # must mean the same quality whatever its best.
    from matplotlib.axes import Axes

    _, _, built = synthetic_space
    seen = []
    original = Axes.tripcolor

    def spy(self, *args, **kwargs):
        seen.append((kwargs.get("vmin"), kwargs.get("vmax"), float(np.max(args[1]))))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Axes, "tripcolor", spy)
    navigation_map(built, tmp_path / "map.png")
    (vmin, vmax, best), = seen
    assert (vmin, vmax) == (0.0, 1.0) and best < 1.0


# -- the shared collections ----------------------------------------------------------------------------
@pytest.mark.slow
def test_build_kermit(shared_data, tmp_path):
    folder = shared_data / "collections" / "kermit"
    start = time.perf_counter()
    built = build_space(folder / "bundle.out", images=folder)
    seconds = time.perf_counter() - start
    assert len(built.collection) == 9 and built.collection.point_count == 634
    assert built.paths == ((3, 2, 1, 0, 4), (6, 5, 1, 7, 8))  # two walks meeting at camera 1
    assert 14.0 < np.nanmin(built.psnr_db) and np.nanmax(built.psnr_db) < 19.0  # measured 14.45-18.16 dB
    back = load_space(save_space(built, tmp_path / "kermit"))
    assert back.vertex_qualities == built.vertex_qualities
    assert seconds < 60


def test_vertex_quality_checks_its_arguments(col):
    with pytest.raises(TypeError, match="display must be a vergence.viewing.Display"):
        vertex_quality(col, (0, 1), "desktop-24", psnr_db=(20.0, 20.0))
    with pytest.raises(ValueError, match="^display resolution is unknown: give the screen width in pixels$"):
        vertex_quality(col, (0, 1), Display(0.065, 0.6, 0.5), psnr_db=(20.0, 20.0))
    with pytest.raises(TypeError, match="pair of camera indices"):
        vertex_quality(col, (0, 1.0), DESKTOP, psnr_db=(20.0, 20.0))
    with pytest.raises(ValueError, match="psnr_db must be two numbers"):
        vertex_quality(col, (0, 1), DESKTOP, psnr_db=(20.0,))


def test_quality_at_interpolates_the_vertices(synthetic_space):
    _, _, built = synthetic_space
    q = built.region_quality((0, 1))
    for li in (0, 1):
        for lj in (0, 1):
            assert built.quality_at(StereoState((0, 1), li, lj)) == pytest.approx(q[li, lj])
    # the centre lies on the split li = lj: the mean of the diagonal's ends, from either side
    assert built.quality_at(StereoState((0, 1), 0.5, 0.5)) == pytest.approx((q[0, 0] + q[1, 1]) / 2)
    assert built.quality_at(StereoState((0, 1), 0.75, 0.25)) == pytest.approx(0.25 * q[0, 0] + 0.5 * q[1, 0] + 0.25 * q[1, 1])
    t = built.region_quality((2, 2))
    assert built.quality_at(StereoState((2, 2), 0.0, 1.0)) == pytest.approx(t[0, 1])
    assert built.quality_at(StereoState((2, 2), 0.25, 0.75)) == pytest.approx(0.5 * t[0, 1])  # diagonal is 0


@pytest.mark.slow
def test_build_dino(shared_data, tmp_path):
    """About 70 s: 48 leave-one-out views (docs/stereospace.md has the timings)."""
    folder = shared_data / "collections" / "dino"
    built = build_space(folder / "dino_par.txt", images=folder)
    col = built.collection
    assert len(col) == 48 and col.left_out == 315 and col.points_source == "triangulated"
    assert len(built.paths) == 1 and built.paths[0][0] == built.paths[0][-1] and len(built.paths[0]) == 49  # a ring
    assert 20.0 < np.nanmin(built.psnr_db) and np.nanmax(built.psnr_db) < 34.0  # measured 20.6-33.0 dB
    best = max(built.vertex_qualities.values(), key=lambda v: v.quality)
    assert best.quality > 0.9  # measured 0.98 on desktop-24
    b = (best.cameras[1] - best.cameras[0]) % 48
    assert b in (1, 47)  # ring neighbours
    frame = map_frame(col)
    _, s, vt = np.linalg.svd(col.centers - col.centers.mean(axis=0))
    assert abs(frame[2] @ vt[2]) == pytest.approx(1.0)  # the up axes cancel: the ring's normal
    back = load_space(save_space(built, tmp_path / "dino"))
    assert back.vertex_qualities == built.vertex_qualities
