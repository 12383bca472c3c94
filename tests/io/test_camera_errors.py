"""Camera files a user can get wrong: every refusal names the file, the line and what was expected."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.io import (
    CAMERA_FORMATS,
    CameraSet,
    cameras_for_images,
    read_bundler,
    read_cameras,
    read_cameras_json,
    read_colmap,
    read_middlebury_par,
    write_bundler,
    write_cameras,
    write_colmap,
    write_middlebury_par,
)

PAR_LINE = "a.png 1 0 0 0 1 0 0 0 1 1 0 0 0 1 0 0 0 1 0 0 0\n"


def _cam(width: int = 64, height: int = 48, **kw):
    return look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=width, height=height, **kw)


# ------------------------------------------------------------------------------ the format table
def test_format_table_dispatches_both_ways(tmp_path):
    s = CameraSet(names=("a.png",), cameras=(_cam(),))
    for name, path in (("json", tmp_path / "c.json"), ("middlebury", tmp_path / "c_par.txt"),
                       ("colmap", tmp_path), ("json", tmp_path / "named.cams")):
        fmt = name if path.suffix == ".cams" else None
        write_cameras(path, s, format=fmt)
        back = read_cameras(path, format=fmt, image_size=(64, 48))
        assert back.names == ("a.png",)
        np.testing.assert_allclose(back.cameras[0].K, s.cameras[0].K, rtol=0, atol=1e-12)
    assert tuple(CAMERA_FORMATS) == ("middlebury", "bundler", "colmap", "json")
    with pytest.raises(ValueError, match="format must be one of middlebury, bundler, colmap, json; got 'yaml'"):
        read_cameras(tmp_path / "c.json", format="yaml")
    with pytest.raises(ValueError, match=r"no known format by its name or content; expected \*_par.txt \(middlebury\), \*.out \(bundler\)"):
        write_cameras(tmp_path / "c.yaml", s)
    with pytest.raises(TypeError, match="path must be a str or os.PathLike; got int"):
        read_cameras(3)
    with pytest.raises(TypeError, match="cameras must be a CameraSet; got list"):
        write_cameras(tmp_path / "c.json", [])


def test_cameras_for_images_reads_once_per_size_and_names_the_missing(tmp_path):
    s = CameraSet(names=("a.png", "b.png"), cameras=(_cam(), _cam()))
    write_middlebury_par(tmp_path / "c_par.txt", s)
    (cam_a, dist_a), (cam_b, _) = cameras_for_images(tmp_path / "c_par.txt", [("x/a.png", (64, 48)), ("b.png", (32, 24))])
    assert (cam_a.width, cam_b.width) == (64, 32) and dist_a.shape == (4,)
    with pytest.raises(ValueError, match="no camera named 'c.png'"):
        cameras_for_images(tmp_path / "c_par.txt", [("c.png", (64, 48))])
    (tmp_path / "b.out").write_text("# Bundle file v0.3\n1 0\n100 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n")
    with pytest.raises(ValueError, match="does not name its images: no list.txt was found beside it and its folder does not hold one JPEG image per camera; pass image_list"):
        cameras_for_images(tmp_path / "b.out", [("a.png", (64, 48))])


# ------------------------------------------------------------------------------------ Middlebury
@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", r"the file is empty"),
        ("\n\n", r":1: expected the number of cameras on the first line"),
        ("1.5\n" + PAR_LINE, r":1: expected the number of cameras"),
        ("1\n" + PAR_LINE.replace(" 0 0 0\n", " 0 0 inf\n"), r":2: numbers must be finite"),
        ("1\n" + PAR_LINE.replace("a.png 1", "a.png 0", 1), r":2: K"),
    ],
)
def test_middlebury_more_bad_files(tmp_path, text, message):
    p = tmp_path / "bad_par.txt"
    p.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_middlebury_par(p, image_size=(8, 8))


def test_middlebury_bad_size_encoding_and_writer(tmp_path):
    p = tmp_path / "c_par.txt"
    p.write_text("1\n" + PAR_LINE)
    for size in ((8,), (0, 8), (8.0, 8), (True, 8), "8x8"):
        with pytest.raises(ValueError, match="image_size must be \\(width, height\\) with positive integers"):
            read_middlebury_par(p, image_size=size)
    p.write_bytes(b"\xff\xfe1\n")
    with pytest.raises(ValueError, match="not a UTF-8 text file"):
        read_middlebury_par(p, image_size=(8, 8))
    (tmp_path / "a.png").write_bytes(b"not an image")
    p.write_text("1\n" + PAR_LINE)
    with pytest.raises(ValueError, match="cannot read the size of image"):
        read_middlebury_par(p)
    distorted = CameraSet(names=("a.png",), cameras=(_cam(),), distortion=[[0.1, 0, 0, 0]])
    with pytest.raises(ValueError, match="registered and distortion-free for a Middlebury par file"):
        write_middlebury_par(tmp_path / "d_par.txt", distorted)


# --------------------------------------------------------------------------------------- Bundler
BUNDLE_ONE = "# Bundle file v0.3\n1 1\n100 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 -5\n0 0 0\n9 9 9\n1 {cam} 0 1.0 2.0\n"


def test_bundler_observation_of_an_unknown_or_unregistered_camera(tmp_path):
    for cam in ("1", "0.5", "-1"):
        (tmp_path / "bundle.out").write_text(BUNDLE_ONE.format(cam=cam))
        with pytest.raises(ValueError, match="point 0 is observed by camera .*, which is not registered"):
            read_bundler(tmp_path / "bundle.out", image_size=(8, 8))
    (tmp_path / "bundle.out").write_text(BUNDLE_ONE.replace("100 0 0", "0 0 0").format(cam="0"))
    with pytest.raises(ValueError, match="observed by camera 0, which is not registered"):
        read_bundler(tmp_path / "bundle.out", image_size=(8, 8))


def test_bundler_image_list_errors(tmp_path):
    (tmp_path / "bundle.out").write_text(BUNDLE_ONE.format(cam="0"))
    with pytest.raises(ValueError, match=r"image_list must name one image per camera \(1\); got 2"):
        read_bundler(tmp_path / "bundle.out", image_size=(8, 8), image_list=["a.jpg", "b.jpg"])
    with pytest.raises(TypeError, match="image_list must be a path to list.txt or a sequence of names; got int"):
        read_bundler(tmp_path / "bundle.out", image_size=(8, 8), image_list=3)
    (tmp_path / "list.txt").write_text("a.jpg 0 100\nb.jpg\n")
    with pytest.raises(ValueError, match=r"image_list must name one image per camera \(1\); got 2"):
        read_bundler(tmp_path / "bundle.out", image_size=(8, 8))
    (tmp_path / "list.txt").write_text("missing.jpg\n")
    with pytest.raises(FileNotFoundError, match="missing.jpg to read its size; pass image_size"):
        read_bundler(tmp_path / "bundle.out")
    s = read_bundler(tmp_path / "bundle.out", image_size=(9, 7))
    assert s.names == ("missing.jpg",) and s.observation_pixels.tolist() == [[5.0, 1.0]]  # (9-1)/2 + 1, (7-1)/2 - 2


def test_bundler_writer_refuses_tangential_distortion(tmp_path):
    s = CameraSet(names=("a",), cameras=(_cam(65, 49),), distortion=[[0.1, 0.0, 0.01, 0.0]])
    with pytest.raises(ValueError, match="radial distortion only"):
        write_bundler(tmp_path / "b.out", s)


# ---------------------------------------------------------------------------------------- COLMAP
@pytest.mark.parametrize(
    ("cameras", "images", "message"),
    [
        ("1\n", "", "camera model must be one of"),
        ("x PINHOLE 10 10 5 5 5 5\n", "", "CAMERA_ID must be an integer; got 'x'"),
        ("1 PINHOLE ten 10 5 5 5 5\n", "", "WIDTH must be an integer; got 'ten'"),
        ("1 PINHOLE 10 0 5 5 5 5\n", "", "the image size must be positive; got 10x0"),
        ("1 PINHOLE 10 10 5 5 5 nan\n", "", ":1: numbers must be finite"),
        ("1 PINHOLE 10 10 5 5 5 5\n", "1 1 0 0 0 0 0 0 one a.png\n\n", "CAMERA_ID must be an integer; got 'one'"),
        ("1 PINHOLE 10 10 5 5 5 5\n", "1 0 0 0 0 0 0 0 1 a.png\n\n", ":1: the quaternion must be non-zero"),
        ("1 PINHOLE 10 10 5 5 5 5\n", "1 1 0 0 x 0 0 0 1 a.png\n\n", ":1: expected numbers"),
    ],
)
def test_colmap_more_bad_files(tmp_path, cameras, images, message):
    (tmp_path / "cameras.txt").write_text(cameras)
    (tmp_path / "images.txt").write_text(images)
    with pytest.raises(ValueError, match=message):
        read_colmap(tmp_path)


def test_colmap_missing_files_and_writer_errors(tmp_path):
    (tmp_path / "cameras.txt").write_text("1 PINHOLE 10 10 5 5 5 5\n")
    with pytest.raises(FileNotFoundError, match="images.txt"):
        read_colmap(tmp_path / "cameras.txt")
    with pytest.raises(TypeError, match="path must be a str or os.PathLike; got NoneType"):
        read_colmap(None)
    s = CameraSet(names=("a", "b"), cameras=(_cam(), None))
    with pytest.raises(FileNotFoundError, match="no such folder"):
        write_colmap(tmp_path / "nope", s)
    with pytest.raises(ValueError, match="cameras must all be registered for a COLMAP model"):
        write_colmap(tmp_path, s)
    skewed = _cam()
    K = skewed.K.copy()
    K[0, 1] = 0.5
    skewed = type(skewed)(K=K, R=skewed.R, t=skewed.t, width=64, height=48)
    with pytest.raises(ValueError, match="has skew 0.5; COLMAP models have none"):
        write_colmap(tmp_path, CameraSet(names=("a",), cameras=(skewed,)))


# ------------------------------------------------------------------------------------------ JSON
@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"format": "other", "cameras": []}', "is not a vergence camera file"),
        ('[1, 2]', "is not a vergence camera file"),
        ('{"format": "vergence-cameras", "cameras": [{"name": "a"}]}', "camera entry 0 must have 'name' and 'camera'"),
    ],
)
def test_json_bad_files(tmp_path, text, message):
    (tmp_path / "c.json").write_text(text)
    with pytest.raises(ValueError, match=message):
        read_cameras_json(tmp_path / "c.json")


def test_camera_set_more_validation():
    a = _cam()
    with pytest.raises(ValueError, match="names must be non-empty strings without whitespace"):
        CameraSet(names=("a b",), cameras=(a,))
    with pytest.raises(TypeError, match="cameras must hold Camera instances or None"):
        CameraSet(names=("a",), cameras=("cam",))
    with pytest.raises(ValueError, match=r"colors must have one row per point \(1\); got 0"):
        CameraSet(names=("a",), cameras=(a,), points=[[0, 0, 1]])
    with pytest.raises(ValueError, match=r"observation_pixels must have one row per observation \(1\); got 0"):
        CameraSet(names=("a",), cameras=(a,), points=[[0, 0, 1]], colors=[[1, 2, 3]], observations=[[0, 0, 0]])
    with pytest.raises(ValueError, match="camera 'b' is not registered in the reconstruction"):
        CameraSet(names=("a", "b"), cameras=(a, None)).camera("b")


# Issue 9: a valid Middlebury par file not named *_par.txt was refused (the name alone decided).
def test_camera_files_are_recognised_by_content_when_the_name_says_nothing(tmp_path):
    s = CameraSet(names=("a.png", "b.png"), cameras=(_cam(), _cam()))
    write_middlebury_par(tmp_path / "c_par.txt", s)
    (tmp_path / "cameras.txt.bak").write_bytes((tmp_path / "c_par.txt").read_bytes())
    got = read_cameras(tmp_path / "cameras.txt.bak", image_size=(64, 48))
    assert got.names == s.names
    np.testing.assert_allclose(got.cameras[1].K, s.cameras[1].K)
    (cam, _), = cameras_for_images(tmp_path / "cameras.txt.bak", [("b.png", (64, 48))])
    np.testing.assert_allclose(cam.R, s.cameras[1].R)
    write_bundler(tmp_path / "b.out", s)
    (tmp_path / "reconstruction").write_bytes((tmp_path / "b.out").read_bytes())
    assert len(read_cameras(tmp_path / "reconstruction", image_size=(64, 48))) == 2
    (tmp_path / "notes.txt").write_text("2\nthis is not a camera line\n")
    with pytest.raises(ValueError, match="camera file 'notes.txt' has no known format by its name or content"):
        read_cameras(tmp_path / "notes.txt")


# Issue 9 sweep (api/read_cameras/image_list=missing, and any file as image_list in the full sweep): the
# readers that take no image list or size dropped them unseen, so a missing list.txt or a malformed size
# passed with a Middlebury, JSON or COLMAP file. A malformed one is refused whatever the format; a
# well-formed image list with a format that has no use for it too.
@pytest.mark.parametrize("fmt", ["middlebury", "json", "colmap"])
@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"image_list": "MISSING"}, FileNotFoundError, r"cannot read .*missing_list.txt: no such file"),
        ({"image_list": ""}, ValueError, r"image_list must name a file \(Bundler's list.txt\); got ''"),
        ({"image_list": 1.5}, TypeError, "image_list must be a path to list.txt or a sequence of names; got float"),
        ({"image_list": ["a.jpg", None]}, TypeError, r"image_list\[1\] must be an image name \(a non-empty str\); got None"),
        ({"image_size": (64, 0)}, ValueError, r"image_size must be \(width, height\) with positive integers"),
        ({"image_size": "64x48"}, ValueError, r"image_size must be \(width, height\) with positive integers"),
    ],
)
def test_read_cameras_refuses_bad_options_whatever_the_format(tmp_path, fmt, options, error, match):
    path = {"middlebury": tmp_path / "c_par.txt", "json": tmp_path / "c.json", "colmap": tmp_path}[fmt]
    write_cameras(path, CameraSet(names=("a.png",), cameras=(_cam(),)))
    if options.get("image_list") == "MISSING":
        options = {"image_list": tmp_path / "missing_list.txt"}
    read_cameras(path, image_size=(64, 48))  # the file itself is fine
    with pytest.raises(error, match=match):
        read_cameras(path, **options)
    (tmp_path / "list.txt").write_text("a.png\n")
    with pytest.raises(ValueError, match=rf"^image_list applies to Bundler cameras \(\*.out\) only; .* is a {fmt} camera"):
        read_cameras(path, image_list=tmp_path / "list.txt")


@pytest.mark.parametrize("fmt", [["json"], {"json": 1}])
def test_a_format_of_a_wrong_type_is_named(tmp_path, fmt):
    # was "unhashable type" from the format table, naming nothing
    with pytest.raises(ValueError, match=r"^format must be one of middlebury, bundler, colmap, json; got "):
        read_cameras(tmp_path / "c.json", format=fmt)
