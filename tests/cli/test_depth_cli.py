"""``vergence rectify``, ``match`` and ``evaluate-disparity``: outputs, JSON, and errors with exit code 2."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from vergence.cli import main
from vergence.io import read_disparity, read_image

# The JSON figures must equal what the library computes on the same files (same code path).
RTOL = 1e-12
# SIFT on the rectified dino0002/dino0001 pair: median |dy| 0.28 px measured; half a pixel is the bar.
MAX_MEDIAN_DY_PX = 0.5


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main([*args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.fixture
def dino(shared_data):
    return shared_data / "collections" / "dino"


@pytest.fixture
def tsukuba(shared_data):
    return shared_data / "stereo" / "tsukuba"


def test_rectify_writes_images_and_json(capsys, dino, tmp_path):
    out = tmp_path / "rect"
    code, stdout, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"),
                             "--cameras", str(dino / "dino_par.txt"), "--out", str(out), "--check", "--json")
    assert code == 0, err
    data = json.loads(stdout)
    assert data == json.loads((out / "rectification.json").read_text())
    left, right = read_image(out / "left.png"), read_image(out / "right.png")
    assert left.shape == right.shape == (data["left_camera"]["height"], data["left_camera"]["width"], 3)
    assert data["baseline"] > 0 and np.asarray(data["left_homography"]).shape == (3, 3)
    assert data["row_alignment"]["median_abs_dy_px"] < MAX_MEDIAN_DY_PX and data["row_alignment"]["matches"] > 50
    # the validity masks: 255 where the rectified pixel comes from the image, 0 in the black borders
    for side, image in (("left", left), ("right", right)):
        valid = read_image(out / f"{side}_valid.png")
        assert valid.shape == image.shape[:2] and set(np.unique(valid)) == {0.0, 1.0}
        border = image[valid == 0]  # black, but for a rim of pixels blended with it by the bilinear resampling
        assert (border == 0).all(axis=-1).mean() > 0.9 and 0.01 < (valid == 0).mean() < 0.5  # measured 1.7 %, 1.8 %
    assert sorted(p.name for p in out.iterdir()) == ["left.png", "left_valid.png", "rectification.json", "right.png",
                                                     "right_valid.png"]


def test_rectify_prints_a_summary_without_json(capsys, dino, tmp_path):
    code, stdout, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"),
                             "--cameras", str(dino / "dino_par.txt"), "--out", str(tmp_path / "r"), "--check")
    assert code == 0, err
    data = json.loads((tmp_path / "r" / "rectification.json").read_text())
    assert f"baseline {data['baseline']:.6g}" in stdout.replace("\n", " ")
    assert f"median |dy| = {data['row_alignment']['median_abs_dy_px']:.3f} px" in stdout.replace("\n", " ")


def test_rectify_a_bundler_pair_named_by_a_list(capsys, shared_data, tmp_path):
    kermit = shared_data / "collections" / "kermit"
    listing = tmp_path / "list.txt"
    listing.write_text("".join(f"{kermit / f'kermit{i:03d}.jpg'} 0 670\n" for i in range(11)))
    code, stdout, err = _run(capsys, "rectify", str(kermit / "kermit000.jpg"), str(kermit / "kermit001.jpg"), "--cameras",
                             str(kermit / "bundle.out"), "--image-list", str(listing), "--out", str(tmp_path / "o"),
                             "--check", "--json")
    assert code == 0, err
    assert json.loads(stdout)["row_alignment"]["median_abs_dy_px"] < MAX_MEDIAN_DY_PX
    code, _, err = _run(capsys, "rectify", str(kermit / "kermit004.jpg"), str(kermit / "kermit001.jpg"), "--cameras",
                        str(kermit / "bundle.out"), "--image-list", str(listing), "--out", str(tmp_path / "o2"))
    assert code == 2 and "'kermit004.jpg' is not registered" in err


def test_rectify_sizes_each_camera_by_its_image(capsys, shared_data, tmp_path):
    """bundle.out stores no image size and its K depends on it: a (centrally) cropped right image
    must get a camera built for its own size, not the left image's."""
    import cv2

    kermit = shared_data / "collections" / "kermit"
    crop = tmp_path / "kermit001.png"
    cv2.imwrite(str(crop), cv2.imread(str(kermit / "kermit001.jpg"))[8:-8, 8:-8])
    names = [crop if i == 1 else kermit / f"kermit{i:03d}.jpg" for i in range(11)]
    listing = tmp_path / "list.txt"
    listing.write_text("".join(f"{n} 0 670\n" for n in names))
    code, stdout, err = _run(capsys, "rectify", str(kermit / "kermit000.jpg"), str(crop), "--cameras",
                             str(kermit / "bundle.out"), "--image-list", str(listing), "--out", str(tmp_path / "o"),
                             "--check", "--json")
    assert code == 0, err
    assert json.loads(stdout)["row_alignment"]["median_abs_dy_px"] < MAX_MEDIAN_DY_PX
    # without a list, the cameras are paired with the sorted images of the folder, and the user is told
    # (issue 9: the shared kermit has no list.txt; the user had to write one)
    code, stdout, err = _run(capsys, "rectify", str(kermit / "kermit000.jpg"), str(kermit / "kermit001.jpg"),
                             "--cameras", str(kermit / "bundle.out"), "--out", str(tmp_path / "o2"), "--json")
    assert code == 0, err
    assert "note: bundle.out has no list.txt: its 11 cameras were paired with the 11 JPEG images" in " ".join(err.split())
    assert json.loads(stdout)["notes"][0].startswith("bundle.out has no list.txt")
    # a bundle whose folder does not hold its images: say what to pass
    (tmp_path / "x" / "b").mkdir(parents=True)
    (tmp_path / "x" / "b" / "bundle.out").write_bytes((kermit / "bundle.out").read_bytes())
    code, _, err = _run(capsys, "rectify", str(kermit / "kermit000.jpg"), str(kermit / "kermit001.jpg"), "--cameras",
                        str(tmp_path / "x" / "b" / "bundle.out"), "--out", str(tmp_path / "o3"))
    assert code == 2 and "pass --image-list" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--out", "d.pfm", "--preview", "d.pfm"], "--out, --preview and --confidence must name different files"),
        (["--out", "d.png"], "--out d.png stores integers: give --scale"),
        (["--out", "d.npy", "--scale", "16"], "--scale applies to .png/.pgm outputs only"),
        (["--out", "d.tif"], "--out must be a .pfm, .npy, or .png/.pgm"),
        (["--out", "d.png", "--scale", "0"], "--scale must be a finite number > 0; got 0"),
        (["--out", "d.png", "--scale", "16", "--min-disparity", "-2"],
         "--out d.png stores disparities >= 0 only, and --min-disparity -2 searches negative ones"),
        (["--out", "d.png", "--scale", "5000"], "--max-disparity 15 x --scale 5000 exceeds 65535"),
        (["--out", "d.pfm", "--block-size", "257"], "--block-size must be an odd number of pixels in [1, 255]"),
        (["--out", "d.png", "--scale", "1e-300"], "--scale 1e-300 stores the whole range up to --max-disparity 15 in "
         "less than one step"),
        (["--out", "d.pfm", "--preview", "p.txt"], "--preview must be a .png, .jpg, .jpeg, .ppm, .pfm, .npy, .hdr file"),
        (["--out", "d.pfm", "--confidence", "c.ppm"], "--confidence must be a .png, .pgm, .jpg, .jpeg, .pfm, .npy file"),
        (["--out", "d.pfm", "--confidence", "no/c.png"], "cannot write no/c.png: folder no does not exist"),
    ],
)
def test_match_refuses_bad_outputs_before_matching(capsys, tsukuba, tmp_path, monkeypatch, options, message):
    import vergence.commands.match as match_work

    def no_matching(*args, **kwargs):
        raise AssertionError("matching ran before the outputs were checked")

    monkeypatch.setattr(match_work, "compute_disparity", no_matching)
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15",
                        *options)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_match_never_overwrites_an_input(capsys, tsukuba, tmp_path):
    left = tmp_path / "im3.png"
    shutil.copy(tsukuba / "im3.png", left)
    before = left.read_bytes()
    code, _, err = _run(capsys, "match", str(left), str(tsukuba / "im4.png"), "--max-disparity", "15",
                        "--out", str(tmp_path / "." / "im3.png"), "--scale", "16")
    assert code == 2 and f"would overwrite input {left}" in err and len(err.strip().splitlines()) == 1
    assert left.read_bytes() == before


def test_match_then_evaluate(capsys, tsukuba, tmp_path):
    out = tmp_path / "d.pfm"
    code, stdout, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15",
                             "--min-disparity", "1", "--out", str(out), "--preview", str(tmp_path / "p.png"),
                             "--confidence", str(tmp_path / "c.png"), "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["known_percent"] == 100.0 and summary["width"] == 384
    preview = read_image(tmp_path / "p.png")  # the map, then its colour bar and labels
    assert preview.shape[1:] == (384, 3) and 288 + 14 < preview.shape[0] < 288 + 60
    assert read_image(tmp_path / "c.png").shape == (288, 384)
    code, stdout, err = _run(capsys, "evaluate-disparity", str(out), str(tsukuba / "groundtruth.png"),
                             "--truth-scale", "16", "--masks", str(tsukuba), "--json")
    assert code == 0, err
    scores = json.loads(stdout)
    assert list(scores) == ["nonocc", "all", "disc"] and set(scores["nonocc"]) == {"bad", "rms", "pixels"}
    assert scores["nonocc"]["bad"] < 2.85 and scores["nonocc"]["pixels"] == 85438
    code, stdout, _ = _run(capsys, "evaluate-disparity", str(out), str(tsukuba / "groundtruth.png"), "--truth-scale",
                           "16", "--image", str(tsukuba / "im3.png"), "--json")
    assert code == 0 and list(json.loads(stdout)) == ["nonocc", "all", "disc", "textureless"]
    code, stdout, _ = _run(capsys, "evaluate-disparity", str(out), str(tsukuba / "groundtruth.png"), "--truth-scale", "16")
    assert code == 0 and "nonocc" in stdout and "computed" in stdout


def test_match_png_with_scale_and_keep_invalid(capsys, tsukuba, tmp_path):
    out = tmp_path / "d.png"
    code, _, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15",
                        "--min-disparity", "1", "--keep-invalid", "--method", "bm", "--out", str(out), "--scale", "16")
    assert code == 0, err
    d = read_disparity(out, scale=16)
    assert np.isnan(d).any() and np.nanmax(d) <= 15.0


@pytest.mark.parametrize("keep_invalid", [False, True])
def test_match_keeps_zero_disparities_in_pfm_and_tells_them_from_unknown_in_png(capsys, tsukuba, tmp_path, keep_invalid):
    """Issue 9: "match --keep-invalid into a 16-bit PNG when a true zero disparity exists" was refused
    (after the matching), although the help said invalid pixels become 0 there."""
    args = ("match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15",
            *(["--keep-invalid"] if keep_invalid else []))
    code, _, err = _run(capsys, *args, "--out", str(tmp_path / "d.pfm"))
    assert code == 0, err
    d = read_disparity(tmp_path / "d.pfm")
    zero = d == 0
    assert zero.any() and np.isnan(d).any() == keep_invalid  # 0 is a real value in PFM, unknown is inf
    code, stdout, err = _run(capsys, *args, "--out", str(tmp_path / "d.png"), "--scale", "16", "--json")
    assert code == 0, err
    warning = f"{int(zero.sum())} pixels of disparity 0 (below 0.03125 px) are stored as 1/16 px"
    # (a pair whose content sits at disparity 0, the search's lower bound, is also said to sit there)
    assert f"warning: {warning}" in err and json.loads(stdout)["warnings"][-1].startswith(warning)
    stored = read_disparity(tmp_path / "d.png", scale=16)
    np.testing.assert_array_equal(np.isnan(stored), np.isnan(d))  # unknown stays unknown, zero stays known
    assert (stored[zero] == 1 / 16).all()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["stereo/tsukuba/im3.png", "stereo/venus/im6.ppm"], "error: RIGHT must have the size of left"),
        (["stereo/tsukuba/im3.png", "GREY", "--max-disparity", "15"], "error: LEFT and RIGHT must both be grey or both colour"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--max-disparity", "400"], "wider than the image"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--method", "census"], "--method must be one of"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--smoothing", "x"], "--smoothing must be one of"),
        # issue 9: "--smoothing wls scores worse than no smoothing": dropped (benchmarks/smoothing.py)
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--smoothing", "wls"],
         "--smoothing must be one of median, none; got 'wls'"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--max-disparity", "3", "--min-disparity", "3"],
         "--max-disparity must exceed the smallest disparity searched (3); got 3"),
        # issue 9: "--block-size 1001" said "no reliable disparity" (SGBM), an internal error (BM), 1e20 overflowed
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--block-size", "1001"],
         "--block-size must be an odd number of pixels in [1, 255]; got 1001"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--block-size", "1001", "--method", "bm"],
         "--block-size must be an odd number of pixels in [1, 255]; got 1001"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--block-size", str(10**20)],
         f"--block-size must be an odd number of pixels in [1, 255]; got {10**20}"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--block-size", "3", "--method", "bm"],
         "--block-size must be odd and >= 5 for StereoBM; got 3"),
        # ranges OpenCV cannot allocate (overflows inside StereoSGBM): refused against the width first
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--max-disparity", "15", "--min-disparity", "-10000"],
         "leaves no column to match"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--max-disparity", "0", "--min-disparity", "-383"],
         "leaves no column to match"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--max-disparity", "-900", "--min-disparity", "-1000"],
         "leaves no column to match"),
    ],
)
def test_match_errors(capsys, shared_data, tmp_path, args, message):
    import cv2

    grey = tmp_path / "grey.png"
    cv2.imwrite(str(grey), cv2.imread(str(shared_data / "stereo/tsukuba/im4.png"), cv2.IMREAD_GRAYSCALE))
    paths = [str(grey) if a == "GREY" else (str(shared_data / a) if a.startswith("stereo/") else a) for a in args]
    if "--max-disparity" not in paths:
        paths += ["--max-disparity", "15"]
    code, _, err = _run(capsys, "match", *paths, "--out", str(tmp_path / "d.pfm"))
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "d.pfm").exists()


def test_rectify_errors(capsys, dino, tmp_path):
    par = dino / "dino_par.txt"
    base = ["--cameras", str(par), "--out", str(tmp_path / "o")]
    # a camera file without the image
    stray = tmp_path / "stray.png"
    shutil.copy(dino / "dino0001.png", stray)
    code, _, err = _run(capsys, "rectify", str(stray), str(dino / "dino0002.png"), *base)
    assert code == 2 and "no camera named 'stray.png'" in err
    # a degenerate (zero) baseline: the same camera twice
    code, _, err = _run(capsys, "rectify", str(dino / "dino0001.png"), str(dino / "dino0001.png"), *base)
    assert code == 2 and "baseline > 0" in err
    # a truncated camera file
    trunc = tmp_path / "cut_par.txt"
    trunc.write_text(par.read_text()[:2000])
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras", str(trunc),
                        "--out", str(tmp_path / "o"))
    assert code == 2 and ("truncated" in err or "expected 22 fields" in err)
    # the pair in the wrong order
    code, _, err = _run(capsys, "rectify", str(dino / "dino0001.png"), str(dino / "dino0002.png"), *base)
    assert code == 2 and "swap the two images" in err
    # an unknown camera format
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                        str(dino / "README.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and "no known format" in err
    # a grey right image beside a colour left one: the arguments by name, not left_image/right_image
    import cv2

    (tmp_path / "grey").mkdir()
    cv2.imwrite(str(tmp_path / "grey" / "dino0001.png"), cv2.imread(str(dino / "dino0001.png"), cv2.IMREAD_GRAYSCALE))
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(tmp_path / "grey" / "dino0001.png"), *base)
    assert code == 2 and err.startswith("error: LEFT and RIGHT must both be grey or both colour")
    assert not (tmp_path / "o").exists()


def test_evaluate_errors(capsys, tsukuba, tmp_path):
    gt = str(tsukuba / "groundtruth.png")
    code, _, err = _run(capsys, "evaluate-disparity", gt, gt)
    assert code == 2 and err.startswith("error: --estimate-scale is required for a .png disparity map")
    # issue 9, "the CLI speaks Python": every message names the option the user typed
    scaled = ["evaluate-disparity", gt, gt, "--estimate-scale", "16", "--truth-scale", "16"]
    np.save(tmp_path / "small.npy", np.ones((10, 10), np.float32))
    for extra, message in ((["--threshold", "-1"], "--threshold must be > 0; got -1"),
                           (["--truth-scale", "0"], "--truth-scale must be > 0; got 0"),
                           (["--estimate-scale", "0"], "--estimate-scale must be > 0; got 0"),
                           (["--truth-right", str(tmp_path / "small.npy")],
                            "--truth-right must have shape (H, W) matching truth (288, 384); got (10, 10)")):
        code, _, err = _run(capsys, *scaled, *extra)
        assert code == 2 and err.strip() == f"error: {message}"
    np.save(tmp_path / "small.npy", np.ones((10, 10), np.float32))
    code, _, err = _run(capsys, "evaluate-disparity", str(tmp_path / "small.npy"), gt, "--truth-scale", "16")
    assert code == 2 and err.startswith("error: ESTIMATE must have shape (288, 384) matching truth")
    code, _, err = _run(capsys, "evaluate-disparity", gt, gt, "--estimate-scale", "16", "--truth-scale", "16",
                        "--masks", str(tmp_path))
    assert code == 2 and "no Middlebury masks" in err
    code, _, err = _run(capsys, "evaluate-disparity", gt, gt, "--estimate-scale", "16", "--truth-scale", "16",
                        "--masks", str(tsukuba), "--image", str(tsukuba / "im3.png"))
    assert code == 2 and "--masks replaces the computed regions; do not combine it with --truth-right, --image or --border" in err


def test_match_refuses_a_uniform_pair_and_warns_on_a_mostly_flat_one(capsys, tmp_path):
    """Issue 9: "match on a black or uniform-grey pair: matched_percent 75, an all-zero map", exit 0."""
    import cv2

    for level in (0, 128):
        flat = tmp_path / f"flat{level}.png"
        cv2.imwrite(str(flat), np.full((100, 200), level, np.uint8))
        code, stdout, err = _run(capsys, "match", str(flat), str(flat), "--max-disparity", "15", "--out",
                                 str(tmp_path / "d.pfm"), "--json")
        assert code == 2 and stdout == "" and len(err.strip().splitlines()) == 1
        assert err.startswith("error: LEFT has no texture to match: 0 % of its pixels")  # the argument, not `left`
        assert not (tmp_path / "d.pfm").exists()
    spot = np.full((100, 200), 128, np.uint8)
    spot[30:60, 60:110] = np.random.default_rng(0).integers(0, 256, (30, 50))
    cv2.imwrite(str(tmp_path / "spot.png"), spot)
    code, stdout, err = _run(capsys, "match", str(tmp_path / "spot.png"), str(tmp_path / "spot.png"), "--max-disparity",
                             "15", "--out", str(tmp_path / "d.pfm"), "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    assert len(summary["warnings"]) == 3 and summary["textured_percent"] < 10.0
    assert "sit at the search's lower bound (0 px)" in summary["warnings"][2]  # a pair matched against itself
    assert err.splitlines() == [f"warning: {w}" for w in summary["warnings"]]


def test_compare_flat_tiny_and_identical_images(capsys, tmp_path):
    """Issue 9: compare refused flat images (PSNR and SSIM are defined), wrote PSNR as the string "inf",
    and on a 2x2 image spoke of "win_size", a parameter the user never gave."""
    from vergence.io import write_image
    from vergence.metrics import SSIM_WINDOW

    write_image(tmp_path / "grey.png", np.full((20, 30), 0.4))
    write_image(tmp_path / "grey2.png", np.full((20, 30), 0.6))  # 102 and 153 of 255: a difference of 0.2
    code, stdout, err = _run(capsys, "compare", str(tmp_path / "grey.png"), str(tmp_path / "grey2.png"), "--json")
    assert code == 0 and err == ""
    data = json.loads(stdout)
    assert data["psnr_db"] == pytest.approx(20 * np.log10(5)) and data["identical"] is False and data["ssim"] > 0.9
    assert data["registration_pixels"] == 0 and data["registration_rms_px"] is None
    code, stdout, _ = _run(capsys, "compare", str(tmp_path / "grey.png"), str(tmp_path / "grey.png"), "--json")
    assert code == 0 and '"psnr_db": null' in stdout and json.loads(stdout)["identical"] is True
    write_image(tmp_path / "rgb.png", np.zeros((20, 30, 3)))
    code, _, err = _run(capsys, "compare", str(tmp_path / "grey.png"), str(tmp_path / "grey2.png"), "--mask",
                        str(tmp_path / "rgb.png"))
    assert code == 2 and err.startswith(f"error: --mask {tmp_path / 'rgb.png'} must be a single-channel (grey) image")
    write_image(tmp_path / "tiny.png", np.random.default_rng(0).random((2, 2)))
    code, stdout, err = _run(capsys, "compare", str(tmp_path / "tiny.png"), str(tmp_path / "tiny.png"))
    assert code == 2 and stdout == "" and "win_size" not in err
    # sweep case cli/compare/issue9-17: the message led with the Python name "image", not IMAGE
    assert err.strip() == (f"error: IMAGE must be at least {SSIM_WINDOW} px on each side for SSIM's {SSIM_WINDOW} x "
                           f"{SSIM_WINDOW} window (SSIM_WINDOW); got 2 x 2 px")


def test_rectify_refuses_an_image_of_another_size_than_its_cameras(capsys, dino, tmp_path):
    """Issue 9: "rectify accepts an image whose size differs from its camera's (garbage out)"."""
    import cv2

    from vergence.io import read_cameras, write_cameras

    for name in ("dino0001.png", "dino0002.png"):
        cv2.imwrite(str(tmp_path / name), cv2.resize(cv2.imread(str(dino / name)), (320, 240)))
    code, stdout, err = _run(capsys, "rectify", str(tmp_path / "dino0002.png"), str(tmp_path / "dino0001.png"),
                             "--cameras", str(dino / "dino_par.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and stdout == "" and len(err.strip().splitlines()) == 1
    assert err.startswith("error: LEFT dino0002.png is 320x240 px, but its camera in dino_par.txt belongs to the "
                          f"640x480 image {dino / 'dino0002.png'}")
    # a camera file that stores the size (ours, COLMAP)
    (tmp_path / "cams").mkdir()
    write_cameras(tmp_path / "cams" / "cams.json", read_cameras(dino / "dino_par.txt", image_size=(640, 480)))
    code, _, err = _run(capsys, "rectify", str(tmp_path / "dino0002.png"), str(tmp_path / "dino0001.png"),
                        "--cameras", str(tmp_path / "cams" / "cams.json"), "--out", str(tmp_path / "o"))
    assert code == 2 and err.strip() == "error: LEFT must have shape (480, 640) to match its camera; got (240, 320)"
    assert not (tmp_path / "o").exists()


def test_rectify_writes_all_or_nothing(capsys, dino, tmp_path, monkeypatch):
    import vergence.commands.rectify as rectify_work

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(rectify_work, "write_json", fail)  # the last file of five
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                        str(dino / "dino_par.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and "disk full" in err
    assert list(tmp_path.iterdir()) == []  # no output folder, no hidden staging folder


def test_match_mask_leaves_the_rectification_borders_unknown(capsys, tsukuba, tmp_path):
    """Issue 9: match filled the black borders rectify adds with streaky values; --mask takes left_valid.png."""
    from vergence.io import write_image

    left = read_image(tsukuba / "im3.png")
    left[:, :40] = 0.0  # a black rectification border and its mask
    write_image(tmp_path / "left.png", left)
    valid = np.ones(left.shape[:2])
    valid[:, :40] = 0.0
    write_image(tmp_path / "left_valid.png", valid)
    args = ["match", str(tmp_path / "left.png"), str(tsukuba / "im4.png"), "--max-disparity", "15"]
    code, _, err = _run(capsys, *args, "--out", str(tmp_path / "plain.pfm"))
    assert code == 0, err
    assert np.isfinite(read_disparity(tmp_path / "plain.pfm")[:, :40]).all()  # the border got extrapolated values
    code, stdout, err = _run(capsys, *args, "--mask", str(tmp_path / "left_valid.png"), "--out", str(tmp_path / "d.pfm"),
                             "--json")
    assert code == 0, err
    d = read_disparity(tmp_path / "d.pfm")
    assert np.isnan(d[:, :40]).all() and np.isfinite(d[:, 40:]).all()
    summary = json.loads(stdout)
    assert summary["mask"] == str(tmp_path / "left_valid.png")
    assert summary["known_percent"] == pytest.approx(100.0 * (384 - 40) / 384)
    # a mask of another size, a colour one, an empty one
    write_image(tmp_path / "small.png", valid[:, :-1])
    write_image(tmp_path / "colour.png", np.dstack([valid] * 3))
    write_image(tmp_path / "empty.png", np.zeros_like(valid))
    for name, message in (("small.png", "--mask small.png must have the size of LEFT (384x288); got 383x288"),
                          ("colour.png", "--mask colour.png must be a grey image; got 3 channels"),
                          ("empty.png", "--mask empty.png selects no pixel")):
        code, _, err = _run(capsys, *args, "--mask", str(tmp_path / name), "--out", str(tmp_path / "e.pfm"))
        assert code == 2 and err.startswith(f"error: {message}") and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "e.pfm").exists()


def test_match_writes_all_or_nothing(capsys, tsukuba, tmp_path, monkeypatch):
    """The disparity, preview and confidence files appear together or not at all."""
    import vergence.commands.match as match_work

    real = match_work.write_image

    def fail_on_confidence(path, image, **kwargs):
        if image.ndim == 2:  # the confidence map, written last
            raise OSError("disk full")
        real(path, image, **kwargs)

    monkeypatch.setattr(match_work, "write_image", fail_on_confidence)
    assert ".tmp-" not in str(tmp_path)
    code, _, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15",
                        "--out", str(tmp_path / "d.pfm"), "--preview", str(tmp_path / "p.png"), "--confidence",
                        str(tmp_path / "c.png"))
    assert code == 2 and "disk full" in err and ".tmp-" not in err
    assert list(tmp_path.iterdir()) == []


def test_match_bm_default_block_on_a_tiny_image_is_refused_by_name(capsys, tmp_path):
    """Found by our sweep: StereoBM's default 9 px block on an 8-row pair was an internal error (exit 1)."""
    import cv2

    cv2.imwrite(str(tmp_path / "small.png"), np.random.default_rng(0).integers(0, 256, (8, 40), np.uint8))
    code, _, err = _run(capsys, "match", str(tmp_path / "small.png"), str(tmp_path / "small.png"), "--max-disparity",
                        "7", "--method", "bm", "--out", str(tmp_path / "d.pfm"))
    assert code == 2 and err.strip() == ("error: --block-size (default 9 px for StereoBM) must not exceed the image's "
                                         "smaller side (8 px): give a smaller one")


def test_rectify_writes_all_files_or_none(capsys, shared_data, tmp_path, monkeypatch):
    import vergence.commands.rectify as rectify_work

    dino = shared_data / "collections" / "dino"

    def full_disk(path, obj):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(rectify_work, "write_json", full_disk)
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                        str(dino / "dino_par.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and "no space left on device" in err.lower()
    assert list(tmp_path.iterdir()) == []  # neither left.png nor an empty folder
    (tmp_path / "o").write_text("a file")
    monkeypatch.undo()
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                        str(dino / "dino_par.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and "it exists and is not a folder" in err and "Errno" not in err
