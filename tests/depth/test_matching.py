"""Matchers and the default pipeline: synthetic shifts, Middlebury targets, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vergence.depth import (
    MATCHERS,
    MAX_BLOCK_SIZE,
    compute_disparity,
    evaluate_disparity,
    match_blocks,
    match_bm,
    match_patchmatch,
    match_sgbm,
    middlebury_regions,
    read_middlebury_masks,
    sgbm_parameters,
)
from vergence.io import read_disparity, read_image

# A sub-pixel shift of a smooth random texture is recovered to 0.15 px (median over the image)
# by every matcher: SGBM/BM interpolate at 1/16 px, the window matchers by a parabola.
SUBPIXEL_TOL_PX = 0.15
# The issue's baseline: raw OpenCV SGBM 3-way scores 4.27 % (tsukuba) / 7.24 % (venus) bad nonocc
# (OpenCV's sample settings with speckle range 2, benchmarks/middlebury.py); the default pipeline
# must cut that by at least a third (measured: 2.18 % and 1.83 %).
ISSUE_RAW_NONOCC = {"tsukuba": 4.27, "venus": 7.24}
TARGET_NONOCC = {"tsukuba": 2.85, "venus": 4.83}
# The issue quotes the raw figures to two decimals.
ISSUE_DECIMALS = 2
# On the four scenes without official masks the pipeline must also cut the raw figure by a third
# (measured cuts 80-88 %).
MIN_CUT = 1.0 / 3.0


def _texture(h: int, w: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    small = rng.random((h // 3 + 2, w // 3 + 2, 3)).astype(np.float32)
    return cv2.resize(small, (w + 6, h + 6), interpolation=cv2.INTER_CUBIC)[3:h + 3, :w + 6].clip(0, 1)


def _shifted_pair(shift: float, h: int = 60, w: int = 120) -> tuple[np.ndarray, np.ndarray]:
    """left(x) = right(x - shift): disparity ``shift`` everywhere (bilinear resampling)."""
    right = _texture(h, w)[:, :w]
    xs, ys = np.meshgrid(np.arange(w, dtype=np.float32) - shift, np.arange(h, dtype=np.float32))
    left = cv2.remap(_texture(h, w)[:, :w], xs, ys, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT).clip(0, 1)
    return np.ascontiguousarray(left), np.ascontiguousarray(right)


@pytest.mark.parametrize("method", MATCHERS)
@pytest.mark.parametrize("shift", [6.0, 9.5])
def test_every_matcher_recovers_a_subpixel_shift(method, shift):
    left, right = _shifted_pair(shift)
    res = compute_disparity(left, right, max_disparity=20, method=method)
    assert np.isfinite(res.disparity).all() and res.disparity.dtype == np.float32
    assert abs(float(np.median(res.disparity[:, 30:])) - shift) < SUBPIXEL_TOL_PX
    # PatchMatch interpolates the matched view linearly, as PMS: half-way between pixels a 3-px texture
    # loses contrast, and about half its pixels fail the left-right check (see _UPSAMPLE in patchmatch.py)
    assert res.matched.mean() > (0.4 if method == "patchmatch" and shift % 1 else 0.5)


@pytest.mark.parametrize("min_disparity", [0, -8])
def test_opencv_matchers_match_the_columns_left_of_the_search_range(min_disparity):
    """OpenCV leaves the leftmost min + count columns blind; on mirrored margins they are matched."""
    left, right = _shifted_pair(6.0)
    for d in (match_sgbm(left, right, max_disparity=40, min_disparity=min_disparity),
              match_bm(left, right, max_disparity=40, min_disparity=min_disparity)):
        assert d.shape == left.shape[:2]
        # inside OpenCV's blind band, where the matches lie inside the right view (BM leaves its half
        # block of rows blank)
        band = d[5:-5, 10:48]
        assert np.isfinite(band).mean() > 0.9
        assert abs(float(np.nanmedian(band)) - 6.0) < SUBPIXEL_TOL_PX
        assert abs(float(np.nanmedian(d[:, 60:])) - 6.0) < SUBPIXEL_TOL_PX


def test_sgbm_gives_no_wrong_answer_in_its_last_columns():
    """StereoSGBM answers 0 in its last block // 2 columns whatever the scene: they are left unknown."""
    left, right = _shifted_pair(6.0)
    d = match_sgbm(left, right, max_disparity=20)
    last = d[:, -3:]
    assert (np.isnan(last) | (np.abs(last - 6.0) <= 1.0)).all()
    assert np.isnan(d[:, -2:]).all()


def test_opencv_matchers_leave_no_answer_where_the_match_is_outside_the_right_view():
    """A left band whose match lies left of the right view (true disparity 14 > x): the mirrored margin
    must not supply a match (any answer there with x - d < 0 is dropped)."""
    h, w = 60, 120
    right = _texture(h, w, 3)[:, :w]
    left = np.concatenate([_texture(h, w, 4)[:, :14], right[:, : w - 14]], axis=1)  # new content at x < 14
    for d in (match_sgbm(left, right, max_disparity=30), match_bm(left, right, max_disparity=30)):
        assert abs(float(np.nanmedian(d[:, 30:])) - 14.0) < SUBPIXEL_TOL_PX
        assert np.isfinite(d[:, :12]).mean() < 0.05
        x_right = np.arange(w) - d
        assert not (x_right < 0).any() and not (x_right > w - 1).any()


def test_block_matcher_left_right_check_finds_the_occlusion():
    """A foreground band at disparity 14 over a background at 4: a 10-px occluded strip left of it."""
    h, w = 50, 140
    bg, fg = _texture(h, w, 1)[:, :w], _texture(h, w, 2)[:, :w]
    right = bg.copy()
    right[:, 50:90] = fg[:, 64:104]  # the band seen 14 px to the left in the right image
    left = np.roll(bg, 4, axis=1)
    left[:, 64:104] = fg[:, 64:104]
    d = match_blocks(left, right, max_disparity=20, cost="sad")
    assert np.isnan(d[10:40, 56:62]).mean() > 0.8  # occluded: no left-right consistent match
    assert abs(np.nanmedian(d[10:40, 70:100]) - 14) < SUBPIXEL_TOL_PX
    assert abs(np.nanmedian(d[10:40, 20:50]) - 4) < SUBPIXEL_TOL_PX


def test_keep_invalid_keeps_nan():
    left, right = _shifted_pair(6.0)
    res = compute_disparity(left, right, max_disparity=20, keep_invalid=True)
    np.testing.assert_array_equal(np.isnan(res.disparity), ~res.matched)
    assert np.isnan(res.disparity[:, :3]).all()


def test_sgbm_parameters_by_hand():
    p = sgbm_parameters(288, 384, 16, 3)
    assert p == {"numDisparities": 16, "blockSize": 5, "P1": 600, "P2": 1200, "uniquenessRatio": 2,
                 "disp12MaxDiff": 1, "preFilterCap": 15, "speckleWindowSize": 0, "speckleRange": 0,
                 "mode": cv2.StereoSGBM_MODE_SGBM_3WAY}
    assert sgbm_parameters(1080, 1920, 128, 1)["blockSize"] == 5


def test_bm_settings_are_the_documented_ones(monkeypatch):
    """match_bm's docstring: texture threshold 10, uniqueness 15 %, left-right check at 1 px (and OpenCV's
    pre-filter cap 31); block 9 px up to 1000 px."""
    made = []
    create = cv2.StereoBM_create
    monkeypatch.setattr(cv2, "StereoBM_create", lambda **kw: made.append(create(**kw)) or made[-1])
    img = np.random.default_rng(0).random((40, 80)).astype(np.float32)
    match_bm(img, img, max_disparity=16, min_disparity=2)
    bm = made[0]
    assert (bm.getTextureThreshold(), bm.getUniquenessRatio(), bm.getDisp12MaxDiff(), bm.getPreFilterCap(),
            bm.getBlockSize(), bm.getMinDisparity(), bm.getNumDisparities()) == (10, 15, 1, 31, 9, 2, 16)


def test_matcher_table_is_the_dispatch():
    assert tuple(MATCHERS) == ("bm", "ncc", "patchmatch", "sad", "sgbm", "ssd")
    assert MATCHERS["sgbm"] is match_sgbm and MATCHERS["bm"] is match_bm and MATCHERS["patchmatch"] is match_patchmatch
    rng = np.random.default_rng(1)
    right = rng.random((24, 64)).astype(np.float32)
    left = np.roll(right, 4, axis=1)
    for cost in ("ncc", "sad", "ssd"):
        np.testing.assert_array_equal(MATCHERS[cost](left, right, max_disparity=16, min_disparity=0, block_size=None),
                                      match_blocks(left, right, max_disparity=16, cost=cost))
    with pytest.raises(ValueError, match="method must be one of bm, ncc, patchmatch, sad, sgbm, ssd; got 'census'"):
        compute_disparity(left, right, max_disparity=16, method="census")


def _middlebury(folder, names, scale):
    left, right, truth = (read_image(folder / names[0]), read_image(folder / names[1]),
                          read_disparity(folder / names[2], scale=scale))
    return left, right, truth


def _raw_opencv(left, right, ndisp):
    sgbm = cv2.StereoSGBM_create(0, ndisp, 5, P1=8 * 3 * 25, P2=32 * 3 * 25, disp12MaxDiff=1, uniquenessRatio=10,
                                 speckleWindowSize=100, speckleRange=2, mode=cv2.StereoSGBM_MODE_SGBM_3WAY)
    fixed = sgbm.compute(np.rint(left * 255).astype(np.uint8), np.rint(right * 255).astype(np.uint8))
    return np.where(fixed < 0, np.nan, fixed / 16.0)


@pytest.mark.parametrize(("scene", "names", "scale", "ndisp"),
                         [("tsukuba", ("im3.png", "im4.png", "groundtruth.png"), 16, 16),
                          ("venus", ("im2.ppm", "im6.ppm", "disp2.pgm"), 8, 32)])
def test_middlebury_targets_with_official_masks(shared_data, scene, names, scale, ndisp):
    folder = shared_data / "stereo" / scene
    left, right, truth = _middlebury(folder, names, scale)
    masks = read_middlebury_masks(folder)
    raw = evaluate_disparity(_raw_opencv(left, right, ndisp), truth, masks=masks)["nonocc"].bad
    assert round(raw, ISSUE_DECIMALS) == ISSUE_RAW_NONOCC[scene]  # the issue's baseline, reproduced
    ours = evaluate_disparity(compute_disparity(left, right, max_disparity=ndisp - 1).disparity, truth, masks=masks)
    assert ours["nonocc"].bad <= TARGET_NONOCC[scene] < raw
    assert ours["all"].bad < ours["disc"].bad


@pytest.mark.parametrize("scene", ["barn2", "bull", "poster", "sawtooth"])
def test_middlebury_computed_regions_cut_by_a_third(shared_data, scene):
    folder = shared_data / "stereo" / scene
    left, right, truth = _middlebury(folder, ("im2.png", "im6.png", "disp2.png"), 8)
    regions = middlebury_regions(truth, truth_right=read_disparity(folder / "disp6.png", scale=8))
    raw = evaluate_disparity(_raw_opencv(left, right, 32), truth, masks=regions)["nonocc"].bad
    ours = evaluate_disparity(compute_disparity(left, right, max_disparity=31).disparity, truth, masks=regions)
    assert ours["nonocc"].bad <= (1.0 - MIN_CUT) * raw


def test_bad_input():
    img = np.zeros((40, 60, 3), np.float32)
    with pytest.raises(ValueError, match=r"right must have the size of left \(40, 60\); got \(40, 59\)"):
        compute_disparity(img, img[:, :-1], max_disparity=10)
    with pytest.raises(ValueError, match="both be grey or both colour; got colour and grey"):
        compute_disparity(img, img[:, :, 0], max_disparity=10)
    with pytest.raises(ValueError, match=r"disparity range \[0, 70\] .* is wider than the image \(60 px\)"):
        compute_disparity(img, img, max_disparity=70)
    with pytest.raises(ValueError, match=r"range \[0, 50\] \(searched as 64 disparities from 0\) is wider"):
        compute_disparity(img, img, max_disparity=50)
    with pytest.raises(ValueError, match=r"max_disparity must exceed the smallest disparity searched \(5\); got 5"):
        compute_disparity(img, img, max_disparity=5, min_disparity=5)
    with pytest.raises(TypeError, match="max_disparity must be an integer number of pixels; got float"):
        compute_disparity(img, img, max_disparity=10.5)
    with pytest.raises(ValueError, match="method must be one of bm, ncc, patchmatch, sad, sgbm, ssd; got 'census'"):
        compute_disparity(img, img, max_disparity=10, method="census")
    with pytest.raises(ValueError, match="block_size must be odd; got 4"):
        match_sgbm(img, img, max_disparity=10, block_size=4)
    with pytest.raises(ValueError, match="block_size must be odd and >= 5 for StereoBM; got 3"):
        match_bm(img, img, max_disparity=10, block_size=3)
    with pytest.raises(ValueError, match="cost must be one of ncc, sad, ssd; got 'abs'"):
        match_blocks(img, img, max_disparity=10, cost="abs")
    with pytest.raises(ValueError, match=r"left must be finite \(no NaN or inf\)"):
        compute_disparity(np.full_like(img, np.nan), img, max_disparity=10)
    with pytest.raises(ValueError, match=r"left values must lie in \[0, 1\]"):
        compute_disparity(img + 2, img, max_disparity=10)


@pytest.mark.parametrize("method", MATCHERS)
def test_block_size_limits_are_refused_before_matching(method):
    """Issue 9: ``--block-size 1001`` said "no reliable disparity" (SGBM), was an internal error (BM),
    ``1e20`` an OverflowError; now MAX_BLOCK_SIZE and the image's smaller side bound every matcher."""
    left, right = _shifted_pair(6.0, h=60, w=300)
    with pytest.raises(ValueError, match=rf"block_size must be at most {MAX_BLOCK_SIZE} px \(MAX_BLOCK_SIZE\); got 1001"):
        compute_disparity(left, right, max_disparity=20, method=method, block_size=1001)
    with pytest.raises(ValueError, match=rf"block_size must be at most {MAX_BLOCK_SIZE} px"):
        compute_disparity(left, right, max_disparity=20, method=method, block_size=10**20 + 1)
    with pytest.raises(ValueError, match=r"block_size must not exceed the image's smaller side \(60 px\); got 61"):
        compute_disparity(left, right, max_disparity=20, method=method, block_size=61)
    assert np.isfinite(compute_disparity(left, right, max_disparity=20, method=method, block_size=21).disparity).all()


def test_a_validity_mask_leaves_the_black_borders_of_a_rectified_pair_unknown():
    """Issue 9: "match fills the black borders rectify adds with streaky values (rectify exports no
    validity mask, match takes none)"."""
    left, right = _shifted_pair(6.0, h=60, w=160)
    left[:, :24] = 0.0  # a rectification border: no image content
    left[:8] = 0.0
    valid = np.ones(left.shape[:2], bool)
    valid[:, :24] = False
    valid[:8] = False
    filled = compute_disparity(left, right, max_disparity=20)
    assert np.isfinite(filled.disparity[~valid]).all()  # without the mask the border gets extrapolated values
    for keep_invalid in (False, True):
        res = compute_disparity(left, right, max_disparity=20, valid=valid, keep_invalid=keep_invalid)
        assert np.isnan(res.disparity[~valid]).all() and (res.confidence[~valid] == 0).all()
        assert not res.matched[~valid].any()
        assert abs(float(np.nanmedian(res.disparity[valid])) - 6.0) < SUBPIXEL_TOL_PX
    assert np.isfinite(res.disparity[valid]).mean() > 0.5
    assert np.isfinite(compute_disparity(left, right, max_disparity=20, valid=valid).disparity[valid]).all()


def test_validity_mask_errors():
    left, right = _shifted_pair(6.0)
    with pytest.raises(TypeError, match="valid must be a boolean array; got dtype float64"):
        compute_disparity(left, right, max_disparity=20, valid=np.ones(left.shape[:2]))
    with pytest.raises(ValueError, match=r"valid must have the shape \(H, W\) of left \(60, 120\); got \(60, 119\)"):
        compute_disparity(left, right, max_disparity=20, valid=np.ones((60, 119), bool))
    with pytest.raises(ValueError, match="valid must select at least one pixel of left"):
        compute_disparity(left, right, max_disparity=20, valid=np.zeros((60, 120), bool))
