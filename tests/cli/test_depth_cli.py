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
    ],
)
def test_match_refuses_bad_outputs_before_matching(capsys, tsukuba, tmp_path, monkeypatch, options, message):
    import vergence.cli.match as match_cli

    def no_matching(*args, **kwargs):
        raise AssertionError("matching ran before the outputs were checked")

    monkeypatch.setattr(match_cli, "compute_disparity", no_matching)
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
    assert read_image(tmp_path / "p.png").shape == (288, 384, 3) and read_image(tmp_path / "c.png").shape == (288, 384)
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


def test_match_keeps_zero_disparities_in_pfm_and_refuses_them_in_png(capsys, tsukuba, tmp_path):
    args = ("match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15")
    code, _, err = _run(capsys, *args, "--out", str(tmp_path / "d.pfm"))
    assert code == 0, err
    d = read_disparity(tmp_path / "d.pfm")
    assert np.isfinite(d).all() and (d == 0).any()  # every pixel gets a disparity; 0 is a real value in PFM
    code, _, err = _run(capsys, *args, "--out", str(tmp_path / "d.png"), "--scale", "16")
    assert code == 2 and "0 means unknown there; use .pfm or .npy" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["stereo/tsukuba/im3.png", "stereo/venus/im6.ppm"], "right must have the size of left"),
        (["stereo/tsukuba/im3.png", "GREY", "--max-disparity", "15"], "both be grey or both colour"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--max-disparity", "400"], "wider than the image"),
        (["stereo/tsukuba/im3.png", "stereo/tsukuba/im4.png", "--method", "census"], "method must be one of"),
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
    assert code == 2 and message in err and "Traceback" not in err
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
    assert not (tmp_path / "o").exists()


def test_evaluate_errors(capsys, tsukuba, tmp_path):
    gt = str(tsukuba / "groundtruth.png")
    code, _, err = _run(capsys, "evaluate-disparity", gt, gt)
    assert code == 2 and "scale is required" in err
    np.save(tmp_path / "small.npy", np.ones((10, 10), np.float32))
    code, _, err = _run(capsys, "evaluate-disparity", str(tmp_path / "small.npy"), gt, "--truth-scale", "16")
    assert code == 2 and "estimate must have shape (288, 384) matching truth" in err
    code, _, err = _run(capsys, "evaluate-disparity", gt, gt, "--estimate-scale", "16", "--truth-scale", "16",
                        "--masks", str(tmp_path))
    assert code == 2 and "no Middlebury masks" in err
    code, _, err = _run(capsys, "evaluate-disparity", gt, gt, "--estimate-scale", "16", "--truth-scale", "16",
                        "--masks", str(tsukuba), "--image", str(tsukuba / "im3.png"))
    assert code == 2 and "--masks replaces the computed regions; do not combine it with --truth-right or --image" in err


def test_rectify_writes_all_files_or_none(capsys, shared_data, tmp_path, monkeypatch):
    import vergence.cli.rectify as cli_rectify

    dino = shared_data / "collections" / "dino"

    def full_disk(path, obj):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cli_rectify, "write_json", full_disk)
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                        str(dino / "dino_par.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and "No space left on device" in err
    assert list(tmp_path.iterdir()) == []  # neither left.png nor an empty folder
    (tmp_path / "o").write_text("a file")
    monkeypatch.undo()
    code, _, err = _run(capsys, "rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                        str(dino / "dino_par.txt"), "--out", str(tmp_path / "o"))
    assert code == 2 and "it exists and is not a folder" in err and "Errno" not in err
