"""Camera-set readers and writers: real files (dino, kermit), conventions, round trips, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vergence.camera import Camera, look_at
from vergence.io import (
    CameraSet,
    read_bundler,
    read_cameras,
    read_cameras_json,
    read_colmap,
    read_middlebury_par,
    write_bundler,
    write_cameras_json,
    write_colmap,
    write_middlebury_par,
)

# Text round trips print repr(float): exact. Rotation matrices through quaternions (COLMAP) lose a
# few ulps: 1e-12 absolute is loose for that and still far below any meaningful difference.
ROUND_TRIP_ATOL = 1e-12
# The rotations printed in dino_par.txt and bundle.out are orthonormal only to ~1e-6; a quaternion
# (COLMAP) stores the nearest rotation, so a round trip through it moves R by up to that much.
FILE_ROTATION_ATOL = 1e-5
# SOURCES.md: the kermit bundle reprojects its points with a median error of about 0.2 px.
KERMIT_MEDIAN_REPROJECTION_PX = 0.2
KERMIT_TOL_PX = 0.02
# OpenCV's projectPoints and Bundler's formula on the same numbers: measured 7e-9 px apart (float
# rounding over pixel values in the hundreds); 1e-6 px leaves room and still tests every convention.
KERMIT_OPENCV_ATOL_PX = 1e-6


def _cams_equal(a: Camera, b: Camera, atol: float = 0.0) -> None:
    assert (a.width, a.height) == (b.width, b.height)
    for x, y in ((a.K, b.K), (a.R, b.R), (a.t, b.t)):
        np.testing.assert_allclose(x, y, rtol=0, atol=atol)


def _sets_equal(a: CameraSet, b: CameraSet, atol: float = 0.0) -> None:
    assert a.names == b.names
    for ca, cb in zip(a.cameras, b.cameras):
        assert (ca is None) == (cb is None)
        if ca is not None:
            _cams_equal(ca, cb, atol)
    np.testing.assert_allclose(a.distortion, b.distortion, rtol=0, atol=atol)
    np.testing.assert_allclose(a.points, b.points, rtol=0, atol=atol)
    np.testing.assert_array_equal(a.colors, b.colors)
    np.testing.assert_array_equal(a.observations, b.observations)
    np.testing.assert_allclose(a.observation_pixels, b.observation_pixels, rtol=0, atol=atol)


def _toy_set() -> CameraSet:
    a = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    b = look_at([0.3, 0.1, -0.2], [0, 0, 5], [0, -1, 0], fov_deg=50, width=64, height=48)
    return CameraSet(names=("a.png", "b.png"), cameras=(a, b))


@pytest.fixture(scope="module")
def dino(shared_data):
    return read_middlebury_par(shared_data / "collections" / "dino" / "dino_par.txt", image_size=(640, 480))


@pytest.fixture(scope="module")
def kermit(shared_data):
    # cameras named by their index (the folder's images would name them kermit000.jpg, ...)
    return read_bundler(shared_data / "collections" / "kermit" / "bundle.out", image_size=(640, 480),
                        image_list=[str(i) for i in range(11)])  # fmt: skip


# ------------------------------------------------------------------------------------- Middlebury
def test_dino_par_file_values_and_projection(dino):
    assert len(dino) == 363 and dino.names[0] == "dino0001.png"
    cam = dino.camera("dino0001.png")
    np.testing.assert_array_equal(cam.K, [[3310.4, 0.0, 316.73], [0.0, 3325.5, 200.55], [0.0, 0.0, 1.0]])
    assert cam.t[2] == 0.66025659732745012
    # the dino's bounding box centre (README) projects inside every image that sees the object
    centre = np.array([(-0.041897 + 0.030897) / 2, (0.001126 + 0.088227) / 2, (-0.037845 + 0.035495) / 2])
    for name in ("dino0001.png", "dino0024.png", "dino0048.png"):
        pix, depth = dino.camera(name).project(centre)
        assert depth > 0 and 0 <= pix[0] < 640 and 0 <= pix[1] < 480


def test_middlebury_sizes_from_the_images_and_missing_image(shared_data, tmp_path):
    src = shared_data / "collections" / "dino" / "dino_par.txt"
    lines = src.read_text().splitlines()
    (tmp_path / "two_par.txt").write_text("\n".join(["2", lines[1], lines[2]]) + "\n")
    for n in ("dino0001.png", "dino0002.png"):
        (tmp_path / n).write_bytes((shared_data / "collections" / "dino" / n).read_bytes())
    cams = read_middlebury_par(tmp_path / "two_par.txt")
    assert [(c.width, c.height) for c in cams.cameras] == [(640, 480), (640, 480)]
    (tmp_path / "dino0002.png").unlink()
    with pytest.raises(FileNotFoundError, match=r"dino0002.png.*image_size"):
        read_middlebury_par(tmp_path / "two_par.txt")


def test_middlebury_round_trip(dino, tmp_path):
    few = CameraSet(names=dino.names[:5], cameras=dino.cameras[:5])
    write_middlebury_par(tmp_path / "x_par.txt", few)
    _sets_equal(read_middlebury_par(tmp_path / "x_par.txt", image_size=(640, 480)), few)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("3\na.png 1 0 0 0 1 0 0 0 1 1 0 0 0 1 0 0 0 1 0 0 0\n", r"truncated: the header announces 3 cameras, the file has 1"),
        ("1\na.png 1 0 0 0 1 0 0 0 1 1 0 0\n", r":2: expected 22 fields"),
        ("1\na.png 1 0 0 0 1 0 0 0 1 1 0 0 0 1 0 0 0 x 0 0 0\n", r":2: expected numbers"),
        ("1\na.png 1 0 0 0 1 0 0 0 1 2 0 0 0 1 0 0 0 1 0 0 0\n", r":2: R must be a rotation"),
        ("many\n", r":1: expected the number of cameras"),
        ("-1\n", r"the number of cameras must be an integer >= 0; got -1"),
    ],
)
def test_middlebury_bad_files(tmp_path, text, message):
    p = tmp_path / "bad_par.txt"
    p.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_middlebury_par(p, image_size=(8, 8))


# ---------------------------------------------------------------------------------------- Bundler
def test_kermit_unregistered_cameras_are_reported(kermit):
    assert len(kermit) == 11 and kermit.unregistered == (4, 6)  # SOURCES.md: 2 cameras with f = 0
    assert kermit.cameras[4] is None and kermit.points.shape == (634, 3) and len(kermit.observations) == 2039
    with pytest.raises(ValueError, match="'4' is not registered"):
        kermit.camera("4")


def test_kermit_reprojection_matches_the_published_error(kermit):
    """Our converted cameras + (k1, k2) reproject the SfM points onto their observations (~0.2 px)."""
    errs = []
    for (p, c, _), obs in zip(kermit.observations, kermit.observation_pixels):
        cam = kermit.cameras[c]
        x = cam.R @ kermit.points[p] + cam.t
        assert x[2] > 0  # in front of the camera: z forward
        n = x[:2] / x[2]
        k1, k2 = kermit.distortion[c, :2]
        r2 = n @ n
        pix = cam.K[:2, :2] @ (n * (1 + k1 * r2 + k2 * r2 * r2)) + cam.K[:2, 2]
        errs.append(np.linalg.norm(pix - obs))
    assert abs(np.median(errs) - KERMIT_MEDIAN_REPROJECTION_PX) < KERMIT_TOL_PX


def _bundler_native_reprojection(path) -> np.ndarray:
    """Bundler's own model straight from the file's numbers (y up, -z forward, centre origin, k1 k2):
    the projected minus the stored key position of every observation, in Bundler's pixel frame."""
    tokens = path.read_text().split("\n", 1)[1].split()
    vals = iter(tokens)
    n_cams, n_pts = int(next(vals)), int(next(vals))
    cams = []
    for _ in range(n_cams):
        f, k1, k2, *rest = (float(next(vals)) for _ in range(15))
        cams.append((f, k1, k2, np.reshape(rest[:9], (3, 3)), np.array(rest[9:])))
    residuals = []
    for _ in range(n_pts):
        X = np.array([float(next(vals)) for _ in range(3)])
        [next(vals) for _ in range(3)]  # colour
        for _ in range(int(next(vals))):
            c, _key, xb, yb = int(next(vals)), next(vals), float(next(vals)), float(next(vals))
            f, k1, k2, R, t = cams[c]
            x = R @ X + t
            p = -x[:2] / x[2]
            r2 = p @ p
            residuals.append(f * (1 + k1 * r2 + k2 * r2 * r2) * p - (xb, yb))
    return np.array(residuals)


def test_kermit_converted_cameras_reproject_like_bundler_through_opencv(shared_data, kermit):
    """Our K, R, t and OpenCV (k1, k2, 0, 0) reproduce Bundler's own residual of every observation
    (x unchanged, y flipped by the y-up -> y-down origin change)."""
    native = _bundler_native_reprojection(shared_data / "collections" / "kermit" / "bundle.out")
    ours = np.empty_like(native)
    for k, ((p, c, _), obs) in enumerate(zip(kermit.observations, kermit.observation_pixels)):
        cam = kermit.cameras[c]
        pix, _ = cv2.projectPoints(kermit.points[p][None], cv2.Rodrigues(cam.R)[0], cam.t, cam.K, kermit.distortion[c])
        ours[k] = pix.ravel() - obs
    np.testing.assert_allclose(ours * (1, -1), native, rtol=0, atol=KERMIT_OPENCV_ATOL_PX)


def test_bundler_conversion_by_hand(tmp_path):
    """One camera at the origin, identity Bundler rotation: a point at z = -2 is straight ahead."""
    text = "# Bundle file v0.3\n1 1\n100 0.1 0.01\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n0.5 0.25 -2\n255 0 10\n1 0 7 25 12.5\n"
    (tmp_path / "bundle.out").write_text(text)
    s = read_bundler(tmp_path / "bundle.out", image_size=(101, 51))
    cam = s.cameras[0]
    np.testing.assert_array_equal(cam.K, [[100, 0, 50], [0, 100, 25], [0, 0, 1]])
    np.testing.assert_array_equal(cam.R, np.diag([1.0, -1.0, -1.0]))
    np.testing.assert_array_equal(s.distortion[0], [0.1, 0.01, 0, 0])
    # Bundler pixel (25, 12.5) with y up, centre origin -> ours (50 + 25, 25 - 12.5)
    np.testing.assert_array_equal(s.observation_pixels[0], [75.0, 12.5])
    np.testing.assert_array_equal(s.observations[0], [0, 0, 7])
    pix, depth = cam.project([0.5, 0.25, -2.0])
    assert depth[()] == 2.0
    np.testing.assert_allclose(pix, [50 + 100 * 0.25, 25 - 100 * 0.125])  # undistorted projection


def test_bundler_round_trip(kermit, tmp_path):
    write_bundler(tmp_path / "bundle.out", kermit)
    _sets_equal(read_bundler(tmp_path / "bundle.out", image_size=(640, 480)), kermit)


def test_bundler_names_from_list_and_image_sizes(shared_data, tmp_path):
    src = shared_data / "collections" / "kermit"
    names = [f"kermit{i:03d}.jpg" for i in range(11)]
    (tmp_path / "list.txt").write_text("".join(f"{src / n} 0 670\n" for n in names))
    (tmp_path / "bundle.out").write_bytes((src / "bundle.out").read_bytes())
    s = read_bundler(tmp_path / "bundle.out")
    assert s.names == tuple(names) and s.cameras[0].width == 640
    assert s.index(src / "kermit003.jpg") == 3


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("# Bundle file v0.2\n", "expected the header"),
        ("# Bundle file v0.3\n2 0\n100 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n", "truncated: ran out of numbers while reading camera 1"),
        ("# Bundle file v0.3\n1 0\n100 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 zero\n", "expected numbers"),
        ("# Bundle file v0.3\n-2 0\n", r"the number of cameras must be an integer >= 0; got -2"),
        ("# Bundle file v0.3\n0 1.5\n", r"the number of points must be an integer >= 0; got 1.5"),
        ("# Bundle file v0.3\n0 1\n0 0 0\n9 9 9\n-1\n", r"the number of views of point 0 must be an integer >= 0"),
    ],
)
def test_bundler_bad_files(tmp_path, text, message):
    (tmp_path / "bundle.out").write_text(text)
    with pytest.raises(ValueError, match=message):
        read_bundler(tmp_path / "bundle.out", image_size=(8, 8))


def test_bundler_needs_a_size(tmp_path):
    (tmp_path / "bundle.out").write_text("# Bundle file v0.3\n0 0\n")
    with pytest.raises(ValueError, match="image_size is required"):
        read_bundler(tmp_path / "bundle.out")


def test_bundler_writer_refuses_what_bundler_cannot_hold(tmp_path):
    cam = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48, principal_point=(30.0, 20.0))
    with pytest.raises(ValueError, match="does not fit Bundler's model"):
        write_bundler(tmp_path / "b.out", CameraSet(names=("x",), cameras=(cam,)))


# ----------------------------------------------------------------------------------------- COLMAP
def test_colmap_models_by_hand(tmp_path):
    (tmp_path / "cameras.txt").write_text(
        "# comment\n1 SIMPLE_PINHOLE 100 80 50 50.5 40.5\n2 OPENCV 100 80 60 70 50 40 0.1 -0.02 0.001 0.002\n"
        "3 RADIAL 100 80 55 50 40 0.2 0.03\n")
    (tmp_path / "images.txt").write_text(
        "# header\n1 1 0 0 0 0.1 0.2 0.3 1 a.png\n10 20 -1 100 200 -1\n"
        "2 0.7071067811865476 0 0.7071067811865476 0 0 0 1 2 b.png\n\n3 1 0 0 0 0 0 0 3 c.png\n")
    s = read_colmap(tmp_path)
    assert s.names == ("a.png", "b.png", "c.png")
    np.testing.assert_array_equal(s.cameras[0].K, [[50, 0, 50], [0, 50, 40], [0, 0, 1]])  # cx - 0.5
    np.testing.assert_array_equal(s.cameras[0].t, [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(s.cameras[1].K, [[60, 0, 49.5], [0, 70, 39.5], [0, 0, 1]])
    np.testing.assert_allclose(s.cameras[1].R, [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-15)  # 90 deg about y
    np.testing.assert_array_equal(s.distortion, [[0, 0, 0, 0], [0.1, -0.02, 0.001, 0.002], [0.2, 0.03, 0, 0]])


def test_colmap_round_trip(kermit, tmp_path):
    registered = [i for i, c in enumerate(kermit.cameras) if c is not None]
    s = CameraSet(names=tuple(kermit.names[i] for i in registered), cameras=tuple(kermit.cameras[i] for i in registered),
                  distortion=kermit.distortion[registered])
    write_colmap(tmp_path, s)
    assert "RADIAL" in (tmp_path / "cameras.txt").read_text()
    _sets_equal(read_colmap(tmp_path / "images.txt"), s, atol=FILE_ROTATION_ATOL)
    toy = _toy_set()
    write_colmap(tmp_path, toy)
    assert "SIMPLE_PINHOLE" in (tmp_path / "cameras.txt").read_text()
    _sets_equal(read_colmap(tmp_path), toy, atol=ROUND_TRIP_ATOL)


@pytest.mark.parametrize(
    ("cameras", "images", "message"),
    [
        ("1 FISHEYE 10 10 1 2 3\n", "1 1 0 0 0 0 0 0 1 a.png\n\n", "model must be one of OPENCV, PINHOLE"),
        ("1 PINHOLE 10 10 1 2 3\n", "1 1 0 0 0 0 0 0 1 a.png\n\n", "PINHOLE takes 4 parameters; got 3"),
        ("1 PINHOLE 10 10 5 5 5 5\n", "1 1 0 0 0 0 0 0 2 a.png\n\n", "uses camera 2, which cameras.txt does not define"),
        ("1 PINHOLE 10 10 5 5 5 5\n", "1 1 0 0 0 0 0\n", "expected IMAGE_ID QW"),
    ],
)
def test_colmap_bad_files(tmp_path, cameras, images, message):
    (tmp_path / "cameras.txt").write_text(cameras)
    (tmp_path / "images.txt").write_text(images)
    with pytest.raises(ValueError, match=message):
        read_colmap(tmp_path)


# ------------------------------------------------------------------------------------- JSON, misc
def test_json_round_trip_keeps_unregistered_points_and_distortion(kermit, tmp_path):
    write_cameras_json(tmp_path / "k.json", kermit)
    _sets_equal(read_cameras_json(tmp_path / "k.json"), kermit)


def test_dispatcher_picks_the_format(dino, kermit, tmp_path):
    few = CameraSet(names=dino.names[:2], cameras=dino.cameras[:2])
    write_cameras_json(tmp_path / "c.json", few)
    write_colmap(tmp_path, few)
    write_middlebury_par(tmp_path / "c_par.txt", few)
    write_bundler(tmp_path / "c.out", _toy_bundler_set())
    _sets_equal(read_cameras(tmp_path / "c.json"), few)
    _sets_equal(read_cameras(tmp_path / "cameras.txt"), few, atol=FILE_ROTATION_ATOL)
    _sets_equal(read_cameras(tmp_path / "c_par.txt", image_size=(640, 480)), few)
    assert read_cameras(tmp_path / "c.out", image_size=(65, 49)).names == ("0",)
    with pytest.raises(ValueError, match=r"no known format by its name or content; expected \*_par.txt"):
        read_cameras(tmp_path / "cams.yaml")


def _toy_bundler_set() -> CameraSet:
    cam = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=65, height=49)
    return CameraSet(names=("0",), cameras=(cam,))


def test_camera_set_validation():
    a, _ = _toy_set().cameras
    with pytest.raises(ValueError, match="names must be unique; repeated: x"):
        CameraSet(names=("x", "x"), cameras=(a, a))
    with pytest.raises(ValueError, match=r"names must have one entry per camera \(2\); got 1"):
        CameraSet(names=("x",), cameras=(a, a))
    with pytest.raises(ValueError, match=r"distortion must be finite with shape \(1, 4\)"):
        CameraSet(names=("x",), cameras=(a,), distortion=[[0.1, 0.2]])
    with pytest.raises(ValueError, match="observations must index existing points and cameras"):
        CameraSet(names=("x",), cameras=(a,), points=[[0, 0, 1]], colors=[[1, 2, 3]], observations=[[0, 1, 0]],
                  observation_pixels=[[1.0, 2.0]])
    with pytest.raises(ValueError, match="no camera named 'nope.png'; it has 2: a.png, b.png"):
        _toy_set().camera("nope.png")


def test_truncated_json(tmp_path):
    (tmp_path / "c.json").write_text('{"format": "vergence-cameras", "cameras": [')
    with pytest.raises(ValueError, match="not valid JSON"):
        read_cameras_json(tmp_path / "c.json")


def test_camera_image_size_of_a_huge_jpeg_is_an_error_naming_the_limit(shared_data, tmp_path, huge_image):
    src = shared_data / "collections" / "dino" / "dino_par.txt"
    lines = src.read_text().splitlines()
    (tmp_path / "one_par.txt").write_text("\n".join(["1", lines[1].replace("dino0001.png", "big.jpg")]) + "\n")
    (tmp_path / "big.jpg").write_bytes(huge_image("big.jpg"))
    with pytest.raises(ValueError, match=r"big.jpg.*declares.*limit of 80,000,000"):
        read_middlebury_par(tmp_path / "one_par.txt")


def test_disparity_png_declaring_too_many_pixels_is_refused(tmp_path, huge_image):
    from vergence.io import read_disparity  # noqa: PLC0415

    (tmp_path / "d.png").write_bytes(huge_image("d.png"))
    with pytest.raises(ValueError, match=r"declares 100000 x 100000"):
        read_disparity(tmp_path / "d.png", scale=1)


def test_deeply_nested_camera_json_is_one_line_error(tmp_path):
    (tmp_path / "c.json").write_text("[" * 50_000 + "]" * 50_000)
    with pytest.raises(ValueError, match="camera file .*c.json nests arrays/objects more than 64 levels deep"):
        read_cameras_json(tmp_path / "c.json")


# Issue 9: a _par.txt with a byte-order mark and CRLF line ends was refused.
@pytest.mark.parametrize("newline", [b"\r\n", b"\r"])
def test_middlebury_par_with_bom_and_crlf_reads_like_the_plain_file(tmp_path, newline):
    few = CameraSet(names=("a.png", "b.png"), cameras=(
        look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=640, height=480),
        look_at([0.1, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=640, height=480)))  # fmt: skip
    write_middlebury_par(tmp_path / "x_par.txt", few)
    plain = (tmp_path / "x_par.txt").read_bytes()
    (tmp_path / "bom_par.txt").write_bytes(b"\xef\xbb\xbf" + plain.replace(b"\n", newline))
    _sets_equal(read_middlebury_par(tmp_path / "bom_par.txt", image_size=(640, 480)), few)


# Issue 9: Bundler output without its list.txt (the shared kermit has none): the user had to write one.
def test_bundler_without_list_pairs_cameras_with_the_sorted_images_of_its_folder(shared_data, tmp_path):
    src = shared_data / "collections" / "kermit"
    names = [f"kermit{i:03d}.jpg" for i in range(11)]
    got = read_bundler(src / "bundle.out")
    assert got.names == tuple(names) and got.cameras[0].width == 640
    assert len(got.notes) == 1 and "has no list.txt: its 11 cameras were paired with the 11 JPEG images of" in got.notes[0]
    assert "kermit000.jpg .. kermit010.jpg" in got.notes[0]
    (tmp_path / "list.txt").write_text("".join(f"{src / n} 0 670\n" for n in names))
    (tmp_path / "bundle.out").write_bytes((src / "bundle.out").read_bytes())
    listed = read_bundler(tmp_path / "bundle.out")
    _sets_equal(got, listed)
    assert listed.notes == ()
    # Bundler's layout: bundle/bundle.out below the images; images in reverse creation order still sort by name
    (tmp_path / "list.txt").unlink()
    (tmp_path / "bundle").mkdir()
    (tmp_path / "bundle.out").rename(tmp_path / "bundle" / "bundle.out")
    for n in reversed(names):
        (tmp_path / n).write_bytes((src / n).read_bytes())
    _sets_equal(read_bundler(tmp_path / "bundle" / "bundle.out"), listed)
    # a folder whose JPEG count differs from the camera count is not guessed at
    (tmp_path / names[0]).unlink()
    assert read_bundler(tmp_path / "bundle" / "bundle.out", image_size=(640, 480)).names[:2] == ("0", "1")
