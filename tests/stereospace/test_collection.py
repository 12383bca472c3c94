"""Collections: triangulation (synthetic, with known answers), loading dino and kermit, bad input."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from vergence.camera import look_at
from vergence.io import CameraSet, write_bundler, write_image
from vergence.stereospace import (
    MAX_REPROJECTION_ERROR_PX,
    Collection,
    load_collection,
    project_distorted,
    triangulate_points,
)

# Middlebury's README gives the dino's tight bounding box; triangulated points must fall inside it
# (with a 5 mm margin for the box's own tightness and sub-pixel noise at 0.66 m).
DINO_BOX = (np.array([-0.041897, 0.001126, -0.037845]), np.array([0.030897, 0.088227, 0.035495]))
DINO_BOX_MARGIN = 0.005
# SOURCES.md: the kermit bundle reprojects with a median error of about 0.2 px.
KERMIT_MEDIAN_PX = 0.2


def _pair():
    a = look_at([0, 0, 0], [0, 0, 4], [0, -1, 0], fov_deg=60, width=640, height=480)
    b = look_at([0.5, 0.1, 0], [0, 0, 4], [0, -1, 0], fov_deg=60, width=640, height=480)
    return a, b


# ------------------------------------------------------------------------------- triangulation
def test_triangulation_recovers_noise_free_points_exactly():
    a, b = _pair()
    X = np.random.default_rng(0).uniform([-1, -1, 3], [1, 1, 5], (50, 3))
    got = triangulate_points(a, b, a.project(X)[0], b.project(X)[0])
    np.testing.assert_allclose(got, X, atol=1e-9)


def test_triangulation_with_pixel_noise_recovers_points_and_agrees_with_opencv():
    a, b = _pair()
    rng = np.random.default_rng(1)
    X = rng.uniform([-1, -1, 3], [1, 1, 5], (200, 3))
    sigma = 0.3  # px
    pa = a.project(X)[0] + rng.normal(0, sigma, (200, 2))
    pb = b.project(X)[0] + rng.normal(0, sigma, (200, 2))
    got = triangulate_points(a, b, pa, pb)
    # Depth error ~ Z^2 sigma / (f b): 25 * 0.3 / (554 * 0.5) = 0.027 m at 5 m.
    err = np.linalg.norm(got - X, axis=1)
    assert np.median(err) < 0.03 and err.max() < 0.15
    Pa = a.K @ np.hstack([a.R, a.t[:, None]])
    Pb = b.K @ np.hstack([b.R, b.t[:, None]])
    h = cv2.triangulatePoints(Pa, Pb, pa.T, pb.T)
    ref = (h[:3] / h[3]).T
    # OpenCV's DLT leaves the rows unscaled; ours scales them to unit norm (H&Z §4.4.4), so with noise
    # the two least-squares answers differ by a small part of the noise error, and ours is no worse.
    assert np.abs(got - ref).max() < 0.005
    assert np.mean(err) <= 1.05 * np.mean(np.linalg.norm(ref - X, axis=1))


def test_triangulation_refuses_mismatched_inputs_in_one_line():
    a, b = _pair()
    with pytest.raises(ValueError, match=r"pixels_b must have the shape of pixels_a"):
        triangulate_points(a, b, np.zeros((3, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"pixels_a must be finite"):
        triangulate_points(a, b, [[np.nan, 0.0]], [[0.0, 0.0]])
    with pytest.raises(TypeError, match=r"camera_b must be a Camera"):
        triangulate_points(a, "b", np.zeros((1, 2)), np.zeros((1, 2)))


def test_project_distorted_matches_opencv_and_the_pinhole_without_distortion():
    a, _ = _pair()
    X = np.random.default_rng(2).uniform([-1, -1, 3], [1, 1, 5], (20, 3))
    np.testing.assert_allclose(project_distorted(a, np.zeros(4), X), a.project(X)[0], atol=1e-9)
    dist = np.array([-0.1, 0.02, 0.001, -0.002])
    rvec = cv2.Rodrigues(a.R)[0]
    ref = cv2.projectPoints(X, rvec, a.t, a.K, dist)[0][:, 0]
    np.testing.assert_allclose(project_distorted(a, dist, X), ref, atol=1e-6)
    assert np.isnan(project_distorted(a, dist, np.array([[0.0, 0.0, -1.0]]))).all()


# ------------------------------------------------------------------------------- the dataclass
def test_collection_reports_the_reprojection_error_of_each_observation():
    a, b = _pair()
    X = np.array([[0.2, 0.1, 4.0], [-0.3, 0.2, 3.5]])
    pix = np.concatenate([a.project(X)[0], b.project(X)[0]]) + [[3.0, 4.0], [0, 0], [0, 0], [0, 1.0]]
    obs = [[0, 0], [1, 0], [0, 1], [1, 1]]
    col = Collection(names=("a", "b"), cameras=(a, b), image_paths=("a.png", "b.png"), points=X,
                     observations=obs, observation_pixels=pix)  # fmt: skip
    np.testing.assert_allclose(col.reprojection_errors_px, [5.0, 0.0, 0.0, 1.0], atol=1e-9)
    assert col.point_count == 2 and col.median_reprojection_error_px == pytest.approx(0.5)
    with pytest.raises(ValueError, match="observations must index existing points and cameras"):
        Collection(names=("a", "b"), cameras=(a, b), image_paths=("a", "b"), points=X,
                   observations=[[2, 0]], observation_pixels=[[0.0, 0.0]])  # fmt: skip
    with pytest.raises(ValueError, match="one entry per camera"):
        Collection(names=("a",), cameras=(a, b), image_paths=("a", "b"))


# ------------------------------------------------------------------------------- bad input
def _linked(tmp_path: Path, source: Path, names: list[str]) -> Path:
    folder = tmp_path / "images"
    folder.mkdir()
    for n in names:
        (folder / n).symlink_to(source / n)
    return folder


def test_cameras_without_an_image_are_left_out_and_counted(shared_data, tmp_path):
    dino = shared_data / "collections" / "dino"
    names = [f"dino{k:04d}.png" for k in range(1, 9)]
    col = load_collection(dino / "dino_par.txt", images=_linked(tmp_path, dino, names), neighbours=2)
    assert col.names == tuple(names) and col.left_out == 363 - 8
    assert any("355 of the 363 cameras" in w for w in col.warnings)


def test_an_image_of_another_size_is_refused_naming_it(shared_data, tmp_path):
    dino = shared_data / "collections" / "dino"
    folder = _linked(tmp_path, dino, ["dino0001.png", "dino0002.png"])
    write_image(folder / "dino0003.png", np.zeros((240, 320), np.float32))
    want = r"^image dino0003\.png is 320 x 240 pixels; its camera in dino_par\.txt is 640 x 480$"
    with pytest.raises(ValueError, match=want):
        load_collection(dino / "dino_par.txt", images=folder)


def test_an_image_of_another_size_than_its_json_camera_is_refused(tmp_path):
    from vergence.io import write_cameras_json

    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=64, height=48)
    b = look_at([0.2, 0, 0], [0.2, 0, 1], [0, -1, 0], fov_deg=60, width=64, height=48)
    write_cameras_json(tmp_path / "cams.json", CameraSet(names=("a.png", "b.png"), cameras=(a, b)))
    write_image(tmp_path / "a.png", np.zeros((48, 64), np.float32))
    write_image(tmp_path / "b.png", np.zeros((48, 63), np.float32))
    with pytest.raises(ValueError, match=r"^image b\.png is 63 x 48 pixels; its camera in cams\.json is 64 x 48$"):
        load_collection(tmp_path / "cams.json", images=tmp_path)


def test_one_usable_camera_is_refused(shared_data, tmp_path):
    dino = shared_data / "collections" / "dino"
    with pytest.raises(ValueError, match=r"at least two cameras with an image; dino_par\.txt has 1"):
        load_collection(dino / "dino_par.txt", images=_linked(tmp_path, dino, ["dino0001.png"]))


def test_points_behind_every_camera_are_refused(tmp_path):
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=64, height=48)
    b = look_at([0.2, 0, 0], [0.2, 0, 1], [0, -1, 0], fov_deg=60, width=64, height=48)
    behind = np.array([[0.0, 0.0, -2.0], [0.1, 0.1, -3.0]])
    cset = CameraSet(names=("a.jpg", "b.jpg"), cameras=(a, b), points=behind,
                     colors=np.zeros((2, 3), np.uint8))  # fmt: skip
    write_bundler(tmp_path / "bundle.out", cset)
    (tmp_path / "list.txt").write_text("a.jpg\nb.jpg\n")
    for n in cset.names:
        write_image(tmp_path / n, np.full((48, 64), 0.5, np.float32))
    with pytest.raises(ValueError, match=r"^the points of bundle\.out are behind every camera$"):
        load_collection(tmp_path / "bundle.out", images=tmp_path)


def test_a_folder_without_images_and_bad_options_are_refused(tmp_path):
    with pytest.raises(ValueError, match="holds no image"):
        load_collection(tmp_path / "x_par.txt", images=tmp_path)
    with pytest.raises(ValueError, match="images must be a folder"):
        load_collection(tmp_path / "x_par.txt", images=tmp_path / "missing")
    with pytest.raises(ValueError, match="neighbours must be a positive integer"):
        load_collection(tmp_path / "x_par.txt", images=tmp_path, neighbours=0)


# ------------------------------------------------------------------------------- real collections
def test_dino_keeps_its_48_images_and_triangulates_hundreds_of_points(dino):
    col, seconds = dino
    assert len(col) == 48 and col.left_out == 363 - 48 and col.points_source == "triangulated"
    assert col.point_count > 500
    assert col.median_reprojection_error_px < 1.0  # measured 0.18 px
    assert np.nanmax(col.reprojection_errors_px) <= MAX_REPROJECTION_ERROR_PX + 1e-9
    lo, hi = DINO_BOX
    inside = ((col.points > lo - DINO_BOX_MARGIN) & (col.points < hi + DINO_BOX_MARGIN)).all(axis=1)
    assert inside.mean() > 0.99  # measured 99.8 %
    for p, c in col.observations:  # every point in front of the cameras that see it
        assert col.points[p] @ col.cameras[c].R[2] + col.cameras[c].t[2] > 0
    assert seconds < 60  # 3 s alone, 9 s on the shared 2 cores under load: catches all-pairs matching only


def test_kermit_has_11_cameras_9_registered_and_its_bundler_points(shared_data):
    folder = shared_data / "collections" / "kermit"
    col = load_collection(folder / "bundle.out", images=folder)
    assert len(col) == 9 and col.unregistered == 2 and col.left_out == 0
    assert col.points_source == "file" and col.point_count == 634 and len(col.observations) == 2039
    assert col.median_reprojection_error_px == pytest.approx(KERMIT_MEDIAN_PX, abs=0.05)
    assert any("not registered" in w for w in col.warnings)


# ------------------------------------------------------------------------------- matching, synthetic
PLANE_Z = 4.0  # the textured plane z = 4 m, seen by three cameras from 2.5 m apart at most


def _plane_views(xs=(-0.4, 0.0, 0.3), *, parallel=False):
    """320 x 240 views of a random-texture plane z = PLANE_Z from x in ``xs``, rendered by its homography."""
    rng = np.random.default_rng(5)
    texture = cv2.GaussianBlur(rng.uniform(0, 255, (400, 400)).astype(np.float32), (0, 0), 2.0)
    texture = cv2.normalize(texture, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    side = 4.0  # metres covered by the texture, centred on the axis
    A = np.array([[side / 400, 0, -side / 2], [0, side / 400, -side / 2], [0, 0, 1]])  # texel -> (x, y)
    cams, grays = [], []
    for x in xs:
        target = [x, 0.1 * x, PLANE_Z] if parallel else [0, 0, PLANE_Z]
        cam = look_at([x, 0.1 * x, 0], target, [0, -1, 0], fov_deg=50, width=320, height=240)
        Rt = np.column_stack([cam.R[:, 0], cam.R[:, 1], cam.R[:, 2] * PLANE_Z + cam.t])  # z = PLANE_Z
        H = cam.K @ Rt @ A
        grays.append(cv2.warpPerspective(texture, H, (320, 240), flags=cv2.INTER_LINEAR))
        cams.append(cam)
    return cams, grays


def test_matching_and_triangulating_a_textured_plane_puts_the_points_on_it():
    from vergence.stereospace.triangulation import triangulate_collection

    cams, grays = _plane_views()
    calls = []
    points, obs, pix, candidates = triangulate_collection(
        cams, np.zeros((3, 4)), lambda i: grays[i], neighbours=2, progress=lambda f, m: calls.append(f))
    assert len(points) > 200 and candidates >= len(points)
    assert np.median(np.abs(points[:, 2] - PLANE_Z)) < 0.01  # depth noise ~ Z^2 * 0.2 px / (f b) ~ 5 mm
    assert obs.shape == (2 * len(points), 2) and pix.shape == (2 * len(points), 2)
    assert calls == sorted(calls) and calls[-1] == pytest.approx(1.0)


def _write_par_collection(folder, cams, grays):
    from vergence.io import write_middlebury_par

    names = tuple(f"view{i}.png" for i in range(len(cams)))
    for n, g in zip(names, grays):
        write_image(folder / n, g.astype(np.float32) / 255.0)
    write_middlebury_par(folder / "plane_par.txt", CameraSet(names=names, cameras=tuple(cams)))
    return folder / "plane_par.txt"


def test_a_par_collection_is_triangulated_end_to_end_and_swapped_cameras_put_points_behind(tmp_path):
    cams, grays = _plane_views((0.0, 0.3), parallel=True)
    col = load_collection(_write_par_collection(tmp_path, cams, grays), images=tmp_path)
    assert col.points_source == "triangulated" and col.point_count > 200
    assert np.median(np.abs(col.points[:, 2] - PLANE_Z)) < 0.01
    assert col.median_reprojection_error_px < 0.5
    # The same images with the two cameras swapped: every match triangulates at z = -PLANE_Z,
    # reprojecting exactly, behind both cameras.
    other = tmp_path / "swapped"
    other.mkdir()
    path = _write_par_collection(other, cams[::-1], grays)
    with pytest.raises(ValueError, match=r"^the points triangulated for plane_par\.txt are behind every camera$"):
        load_collection(path, images=other)


def _line_of_views(folder: Path, names: tuple[str, ...]) -> None:
    """A Bundler collection of small textured views on a line, its points seen by every camera."""
    cams = tuple(look_at([0.2 * i, 0, 0], [0.3, 0, 4], [0, -1, 0], fov_deg=60, width=64, height=48)
                 for i in range(len(names)))  # fmt: skip
    rng = np.random.default_rng(0)
    points = rng.uniform([-0.5, -0.3, 3.5], [1.1, 0.3, 4.5], (20, 3))
    obs = [(p, c, p) for p in range(len(points)) for c in range(len(cams))]
    pixels = [cams[c].project(points[p:p + 1])[0][0] for p, c, _ in obs]
    folder.mkdir(parents=True)
    write_bundler(folder / "bundle.out", CameraSet(names=names, cameras=cams, points=points,
                                                   colors=np.zeros((len(points), 3), np.uint8),
                                                   observations=np.array(obs), observation_pixels=np.array(pixels)))
    (folder / "list.txt").write_text("".join(f"{n}\n" for n in names))
    for n in names:
        write_image(folder / n, rng.uniform(0, 1, (48, 64, 3)).astype(np.float32))


def test_images_that_lead_outside_within_are_left_out_unread(tmp_path, monkeypatch):
    import vergence.stereospace.collection as collection

    inside, outside = tmp_path / "inside", tmp_path / "outside"
    _line_of_views(inside, ("a.png", "b.png", "c.png", "d.png"))
    _line_of_views(outside, ("a.png", "b.png", "c.png", "d.png"))
    for name in ("a.png", "c.png"):  # the first image too: it would be the probe of the size
        (inside / name).unlink()
        (inside / name).symlink_to(outside / name)
    everywhere = load_collection(inside / "bundle.out", images=inside)
    assert everywhere.names == ("a.png", "b.png", "c.png", "d.png") and everywhere.left_out == 0
    opened = []
    real = collection._header_size
    monkeypatch.setattr(collection, "_header_size", lambda p: opened.append(Path(p).name) or real(p))
    kept = load_collection(inside / "bundle.out", images=inside, within=inside)
    assert kept.names == ("b.png", "d.png") and kept.left_out == 2
    assert kept.warnings == ("2 of the 4 cameras of bundle.out name an image that leads outside the allowed folder "
                             "(within): left out, unread",)
    assert set(opened) == {"b.png", "d.png"}  # nothing outside was opened, not even for its size
    (inside / "d.png").unlink()
    (inside / "d.png").symlink_to("d.png")  # a loop: unreadable, as missing
    with pytest.raises(ValueError, match=r"^a collection needs at least two cameras with an image; bundle\.out has 1 "
                                         r"with its image in .*inside \(2 more lead outside the allowed folder "
                                         r"\(within\)\)$"):
        load_collection(inside / "bundle.out", images=inside, within=inside)
    with pytest.raises(ValueError, match=r"^within must be a folder; .*nope is not a folder$"):
        load_collection(inside / "bundle.out", images=inside, within=tmp_path / "nope")
