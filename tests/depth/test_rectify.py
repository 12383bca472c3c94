"""FTV rectification (Fusiello et al. 2000): exact geometry on synthetic cameras, row alignment on real pairs, errors."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vergence.camera import Camera, look_at
from vergence.depth import measure_row_alignment, rectify_cameras, rectify_pair
from vergence.io import read_bundler, read_image, read_middlebury_par

# Projections through 3x3 double-precision products: rows agree to ~1e-12 px; 1e-8 leaves room.
ROW_ATOL_PX = 1e-8
# SIFT on the dino (untextured, 640x480) localises matches to ~0.2-0.3 px: the calibrated epipolar
# distance of the raw matches is 0.2-0.35 px. A rectified pair must stay well under half a pixel.
DINO_MEDIAN_DY_MAX_PX = 0.35
# kermit pair 0-1 (Bundler, with its k1 k2): 0.12 px measured with distortion, 0.14 without.
KERMIT_MEDIAN_DY_MAX_PX = 0.2
# Before rectification the same dino matches are 6-18 px apart vertically.
DINO_UNRECTIFIED_DY_MIN_PX = 3.0
# Bilinear resampling here and in cv2.warpPerspective: same weights, float32 rounding.
RESAMPLE_ATOL = 1e-4


def _camera(K, axis, angle, centre, width=640, height=480) -> Camera:
    R = Rotation.from_rotvec(np.asarray(axis, float) / np.linalg.norm(axis) * angle).as_matrix()
    return Camera(K=K, R=R, t=-R @ np.asarray(centre, float), width=width, height=height)


@pytest.fixture
def verged_pair() -> tuple[Camera, Camera]:
    """A hard pair: different intrinsics (one skewed), rotations and a baseline off the x axis."""
    K1 = np.array([[1000, 2, 320], [0, 990, 240], [0, 0, 1.0]])
    K2 = np.array([[1100, 0, 300], [0, 1080, 250], [0, 0, 1.0]])
    return _camera(K1, [0.2, 1, 0.1], 0.1, [0, 0, 0]), _camera(K2, [-0.1, 1, 0.3], -0.15, [0.5, 0.05, 0.03])


def test_conjugate_points_share_rows_and_homographies_match_the_new_cameras(verged_pair):
    left, right = verged_pair
    rect = rectify_cameras(left, right)
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-2, 2, (50, 2)), rng.uniform(4, 10, 50)])
    nl, _ = rect.left_camera.project(pts)
    nr, _ = rect.right_camera.project(pts)
    np.testing.assert_allclose(nl[:, 1], nr[:, 1], rtol=0, atol=ROW_ATOL_PX)  # Fusiello et al. 2000: conjugate rows equal
    for cam, new, T in ((left, nl, rect.left_homography), (right, nr, rect.right_homography)):
        old, _ = cam.project(pts)
        h = np.column_stack([old, np.ones(len(old))]) @ T.T
        np.testing.assert_allclose(h[:, :2] / h[:, 2:], new, rtol=0, atol=ROW_ATOL_PX)
    d = nl[:, 0] - nr[:, 0] + rect.doffs_px
    assert (d > 0).all()  # points in front: positive disparity once the principal points are aligned
    assert rect.baseline == pytest.approx(np.linalg.norm([0.5, 0.05, 0.03]), rel=1e-15)


def test_centres_kept_orientation_upright_and_extents_in_view(verged_pair):
    left, right = verged_pair
    rect = rectify_cameras(left, right)
    np.testing.assert_allclose(rect.left_camera.center, left.center, atol=1e-15)
    np.testing.assert_allclose(rect.right_camera.center, right.center, atol=1e-12)
    np.testing.assert_array_equal(rect.left_camera.R, rect.right_camera.R)
    assert rect.left_camera.R[1] @ left.R[1] > 0.9  # c_right - c_left: rows still grow downwards
    corners = np.array([[-0.5, -0.5, 1], [639.5, -0.5, 1], [-0.5, 479.5, 1], [639.5, 479.5, 1]])
    for T, cam in ((rect.left_homography, rect.left_camera), (rect.right_homography, rect.right_camera)):
        h = corners @ T.T
        xy = h[:, :2] / h[:, 2:]
        assert (xy[:, 0] >= -0.5 - 1e-9).all() and (xy[:, 0] <= cam.width - 0.5 + 1e-9).all()
        assert (xy[:, 1] >= -0.5 - 1e-9).all() and (xy[:, 1] <= cam.height - 0.5 + 1e-9).all()


def test_common_principal_point_gives_zero_doffs(verged_pair):
    rect = rectify_cameras(*verged_pair, common_principal_point=True)
    assert rect.doffs_px == 0.0
    np.testing.assert_array_equal(rect.left_camera.K, rect.right_camera.K)


def test_resampling_matches_opencv_warp_perspective():
    rng = np.random.default_rng(1)
    image = cv2.GaussianBlur(rng.random((120, 160)).astype(np.float32), (0, 0), 1.5)
    a = look_at([0, 0, 0], [0.2, 0, 5], [0, -1, 0], fov_deg=60, width=160, height=120)
    b = look_at([0.3, 0.02, 0], [0.1, 0, 5], [0, -1, 0], fov_deg=60, width=160, height=120)
    pair = rectify_pair(image, image, a, b)
    cam = pair.rectification.left_camera
    ref = cv2.warpPerspective(image, pair.rectification.left_homography, (cam.width, cam.height), flags=cv2.INTER_LINEAR)
    inner = cv2.erode(pair.left_valid.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert inner.mean() > 0.5
    np.testing.assert_allclose(pair.left[inner], ref[inner], rtol=0, atol=RESAMPLE_ATOL)
    outside = cv2.dilate(pair.left_valid.astype(np.uint8), np.ones((5, 5), np.uint8)) == 0
    assert pair.left.dtype == np.float32 and outside.any() and not pair.left[outside].any()  # black outside


@pytest.mark.parametrize(("a", "b"), [(2, 1), (11, 10), (27, 26)])
def test_dino_pairs_end_on_the_same_rows(shared_data, a, b):
    folder = shared_data / "collections" / "dino"
    cams = read_middlebury_par(folder / "dino_par.txt", image_size=(640, 480))
    na, nb = f"dino{a:04d}.png", f"dino{b:04d}.png"
    left, right = read_image(folder / na), read_image(folder / nb)
    before = measure_row_alignment(left, right)
    pair = rectify_pair(left, right, cams.camera(na), cams.camera(nb))
    after = measure_row_alignment(pair.left, pair.right)
    assert after.matches >= 50
    assert after.median_abs_dy_px < DINO_MEDIAN_DY_MAX_PX < DINO_UNRECTIFIED_DY_MIN_PX < before.median_abs_dy_px


def test_kermit_pair_with_lens_distortion(shared_data):
    folder = shared_data / "collections" / "kermit"
    cams = read_bundler(folder / "bundle.out", image_size=(640, 480))
    pair = rectify_pair(read_image(folder / "kermit000.jpg"), read_image(folder / "kermit001.jpg"), cams.cameras[0],
                        cams.cameras[1], left_distortion=cams.distortion[0], right_distortion=cams.distortion[1])
    rows = measure_row_alignment(pair.left, pair.right)
    assert rows.matches >= 100 and rows.median_abs_dy_px < KERMIT_MEDIAN_DY_MAX_PX


def test_measure_is_reproducible(shared_data):
    folder = shared_data / "collections" / "dino"
    a, b = read_image(folder / "dino0002.png"), read_image(folder / "dino0001.png")
    np.testing.assert_array_equal(measure_row_alignment(a, b).abs_dy_px, measure_row_alignment(a, b).abs_dy_px)


def test_new_axes_and_common_intrinsics_by_the_construction(verged_pair):
    """Fusiello et al. 2000: r1 along c_right - c_left, r2 = k x r1 with k the old LEFT optical axis,
    r3 = r1 x r2; A = (A_1 + A_2) / 2 with zero skew (the skew of K1 must not survive)."""
    left, right = verged_pair
    rect = rectify_cameras(left, right)
    r1 = (right.center - left.center) / np.linalg.norm(right.center - left.center)
    r2 = np.cross(left.R[2], r1)
    r2 /= np.linalg.norm(r2)
    np.testing.assert_allclose(rect.left_camera.R, np.stack([r1, r2, np.cross(r1, r2)]), rtol=0, atol=1e-15)
    for cam in (rect.left_camera, rect.right_camera):
        assert cam.K[0, 1] == 0.0
        assert (cam.K[0, 0], cam.K[1, 1]) == ((1000 + 1100) / 2, (990 + 1080) / 2)


def test_output_growth_limit_is_16_times_the_input_area():
    origin = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    steep = look_at([0.8, 0, 1.0], [0.8, 0, 6], [0, -1, 0], fov_deg=60, width=64, height=48)  # 31 times
    with pytest.raises(ValueError, match="over 16 times the input area"):
        rectify_cameras(origin, steep)
    wide = look_at([1.0, 0, 1.0], [1.0, 0, 6], [0, -1, 0], fov_deg=60, width=64, height=48)
    rect = rectify_cameras(origin, wide)  # 10 times: accepted
    assert 9 * 64 * 48 < rect.left_camera.width * rect.left_camera.height <= 16 * 64 * 48


def test_bad_geometry(verged_pair):
    left, right = verged_pair
    with pytest.raises(ValueError, match=r"distinct centres \(baseline > 0\); got baseline 0"):
        rectify_cameras(left, left)
    with pytest.raises(ValueError, match="right camera lies to the left of the left camera"):
        rectify_cameras(right, left)
    ahead = look_at([0, 0, 1.0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    origin = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    with pytest.raises(ValueError, match="the right camera lies to the left"):
        rectify_cameras(origin, ahead)  # straight ahead: no step to the right at all
    nearly_ahead = look_at([1e-7, 0, 1.0], [1e-7, 0, 6], [0, -1, 0], fov_deg=60, width=64, height=48)
    with pytest.raises(ValueError, match="the baseline is along the left optical axis"):
        rectify_cameras(origin, nearly_ahead)  # to the right, but at a sine of 1e-7 from the axis
    slanted = look_at([0.2, 0, 1.0], [0.2, 0, 6], [0, -1, 0], fov_deg=60, width=64, height=48)
    with pytest.raises(ValueError, match="epipole"):
        rectify_cameras(origin, slanted)
    with pytest.raises(TypeError, match="must be Camera instances"):
        rectify_cameras(left, "right")
    with pytest.raises(ValueError, match=r"left_distortion must hold OpenCV coefficients"):
        rectify_cameras(left, right, left_distortion=[0.1, 0.2])


def test_bad_images(verged_pair):
    left, right = verged_pair
    img = np.zeros((480, 640, 3), np.float32)
    with pytest.raises(ValueError, match=r"right_image must have shape \(480, 640\) to match its camera; got \(479, 640\)"):
        rectify_pair(img, img[:-1], left, right)
    with pytest.raises(ValueError, match="both be grey or both colour"):
        rectify_pair(img, img[:, :, 0], left, right)
    with pytest.raises(ValueError, match=r"too few SIFT features to measure the row alignment"):
        measure_row_alignment(img, img)
    with pytest.raises(TypeError, match="right_camera must be a Camera; got str"):
        rectify_pair(img, img, left, "right")


def test_rectify_with_a_world_up_accepts_rolled_cameras_and_refuses_upside_down_pairs():
    """``up``: the order is checked against the world, not the left camera's x axis. A left camera
    rolled by 180 degrees sees its partner at negative x (refused without ``up``); with ``up`` the
    rectified rows run down the world. The reversed order would turn them upside down: refused."""
    up = np.array([0.0, -1.0, 0.0])  # look_at's image up of a level camera here
    left = look_at([0, 0, 0], [0, 0, 5], [0, 1, 0], fov_deg=60, width=64, height=48)  # rolled 180 degrees
    right = look_at([0.1, 0, 0], [0.1, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    with pytest.raises(ValueError, match="lies to the left"):
        rectify_cameras(left, right)
    rect = rectify_cameras(left, right, up=up)
    assert rect.left_camera.R[1] @ up < -0.99 and rect.right_camera.R[1] @ up < -0.99
    with pytest.raises(ValueError, match="upside down"):
        rectify_cameras(right, left, up=up)
    with pytest.raises(ValueError, match="up"):
        rectify_cameras(left, right, up=[0.0, 0.0, 0.0])
