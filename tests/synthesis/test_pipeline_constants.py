"""Small hand-made cases that pin the pipeline constants and stages (each fails when one changes).

- the median tolerance of the rectified pipelines (``dibr._MEDIAN_TOLERANCE_PX`` = 0.5 px);
- the median refinement of the 3D path of ``synthesize_view`` (``refine_camera_warp``);
- the "nearer than the background" margin of background-only inpainting (1 px);
- importing a primitive does not import the pipelines.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from numpy.testing import assert_allclose

from vergence.camera import look_at
from vergence.synthesis import fill_holes, interpolate_view, synthesize_view

# Telea on 16-bit channels: a hole surrounded by one grey comes back as that grey to a few 16-bit
# levels (its gradient term works on integer levels); a foreground tint would be >= 0.05.
TELEA_TOL = 4.0 / 65535.0


def test_median_refinement_replaces_an_isolated_disparity_spike():
    # Plane at d = 2 seen by both references (right = left shifted 2 px). One pixel of the right
    # disparity is a spike (d = 6, a bright colour): warped to T = 0.5 it lands 3 px right of its
    # column, in front of the plane (nearest wins). Its 3x3 median there is 2 (|6 - 2| = 4 > 0.5 px
    # tolerance), so median refinement re-samples that pixel from the right reference at
    # x - 0.5 * 2 and the plane's colour comes back. With a tolerance above 4 px the spike stays.
    h, w = 5, 24
    plane = np.tile(np.linspace(0.1, 0.5, w + 2, dtype=np.float32), (h, 1))
    left, right = plane[:, :-2].copy(), plane[:, 2:].copy()  # right[x] = left[x + 2]: x_right = x_left - 2
    dl = np.full((h, w), 2.0)
    dr = np.full((h, w), 2.0)
    dr[2, 10] = 6.0
    right[2, 10] = 1.0
    res = interpolate_view(left, dl, right, dr, 0.5, edge_dilation=0)
    # Target pixel x = 10 + 0.5 * 6 = 13; the plane there is left[2, 13 + 1] (x_left = x_t + 0.5 d).
    assert res.image[2, 13] != 1.0
    assert_allclose(res.image[2, 13], left[2, 14], atol=1e-6)


def test_synthesize_view_3d_path_closes_the_cracks_of_point_splats():
    # gradient_limit = 0: no mesh facet links the pixels of a slanted surface, so they are point
    # splats; moving 0.4 m toward a plane 2.0-3.2 m away magnifies it m ~ 1.2 times and point
    # splats leave a share 1 - 1/m^2 ~ 30 % of cracks. The median refinement of the 3D path
    # (refine_camera_warp) closes them from the source by inverse warping, so hardly any hole is left.
    h, w = 40, 60
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    b = look_at([0.0, 0, 0.4], [0, 0, 2], [0, -1, 0], fov_deg=60, width=w, height=h)
    depth = 2.0 + 0.02 * np.arange(w)[None, :].repeat(h, 0)
    img = np.random.default_rng(0).random((h, w)).astype(np.float32)
    res = synthesize_view(img, depth, a, b, gradient_limit=0.0)
    assert res.holes.mean() < 0.05  # without refinement: ~0.30
    assert res.depth is not None and res.nearness_unit == "1/m"
    assert_allclose(res.nearness, 1.0 / res.depth, rtol=1e-6)


def test_inpaint_keeps_foreground_two_pixels_nearer_out_of_the_hole():
    # Background (grey 0.2, d = 1) | hole (4 px) | foreground (0.9, d = 3): the foreground is 2 px
    # nearer than the hole's background, more than the 1 px margin, so the band around the hole is
    # made background before Telea runs and the hole comes back pure background grey. A margin of
    # 2 px or more would let Telea read the foreground and tint the hole.
    h, w = 12, 20
    img = np.full((h, w), 0.2, np.float32)
    d = np.ones((h, w))
    img[:, 12:] = 0.9
    d[:, 12:] = 3.0
    holes = np.zeros((h, w), bool)
    holes[3:9, 8:12] = True
    out, filled_d = fill_holes(img, d, holes, method="inpaint")
    assert_allclose(out[holes], 0.2, atol=TELEA_TOL)
    assert_allclose(filled_d[holes], 1.0)  # the background disparity of each hole run


def test_importing_a_primitive_does_not_import_the_pipelines():
    code = (
        "import sys; from vergence.synthesis import forward_warp; import vergence.synthesis.warp; "
        "print('vergence.synthesis.dibr' in sys.modules); "
        "from vergence.synthesis import interpolate_view; print('vergence.synthesis.dibr' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True"]


def test_inpaint_keeps_the_scanline_fill_of_a_nearer_layer_hole():
    # Foreground (0.9, d = 3) on columns 0-9, background (0.2, d = 1) on 10-19; hole A (columns
    # 6-7) inside the foreground, hole B (11-12) inside the background. Column 7 has a hole pixel
    # of B within the inpainting band (4 px) that is farther by 2 px (> the 1 px margin): it belongs
    # to a nearer layer and keeps its scanline fill, exactly the foreground grey.
    h, w = 10, 20
    img = np.full((h, w), 0.2, np.float32)
    d = np.ones((h, w))
    img[:, :10] = 0.9
    d[:, :10] = 3.0
    holes = np.zeros((h, w), bool)
    holes[3:7, 6:8] = True
    holes[3:7, 11:13] = True
    out, _ = fill_holes(img, d, holes, method="inpaint")
    np.testing.assert_array_equal(out[3:7, 7], np.float32(0.9))


def test_synthesize_view_takes_the_3d_path_for_nearly_rectified_cameras():
    # A rotation of 1e-4 rad is far above the 1e-9 precision of the rectified-pair test: the 3D
    # path (nearness in 1/m) renders it; the exactly rectified pair takes the rectified one (px).
    h, w = 8, 12
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    b = look_at([0.1, 0, 0], [0.1, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    tilted = look_at([0.1, 0, 0], [0.1 + 1e-4, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    img = np.random.default_rng(1).random((h, w)).astype(np.float32)
    depth = np.full((h, w), 2.0)
    assert synthesize_view(img, depth, a, b).nearness_unit == "px"
    assert synthesize_view(img, depth, a, tilted).nearness_unit == "1/m"


def test_median_refine_needs_five_known_neighbours_and_half_a_pixel():
    # Disparity 0 (the source pixel is the target pixel). Hole (1, 2) has 4 known values in its
    # 3 x 3 window: no median (at least 5 needed), it stays a hole; hole (1, 1) has 5 and is filled.
    # The known pixel (1, 5) = 1 px differs from its median 0 by more than the 0.5 px tolerance:
    # it is re-sampled and takes the median.
    from vergence.synthesis import WarpedView, median_refine

    src = np.tile(np.linspace(0.1, 0.7, 7, dtype=np.float32), (3, 1))
    near = np.zeros((3, 7), np.float32)
    near[[1, 0, 0, 0, 1], [2, 1, 2, 3, 1]] = np.nan
    near[1, 5] = 1.0
    warped = WarpedView(np.where(np.isnan(near), 0.0, src).astype(np.float32), np.isnan(near), near)
    res = median_refine(warped, src, np.zeros((3, 7)), scale=1.0)
    assert res.holes[1, 2] and not res.holes[1, 1]
    assert res.image[1, 1] == src[1, 1]
    assert res.nearness[1, 5] == 0.0


def test_refine_camera_warp_needs_five_known_depths_and_agreeing_source_depth():
    # A rectified pair looking at a plane 2 m away, warped, then holes punched by hand. Hole
    # (3, 5) has 4 known depths in its window: it stays. Hole (3, 8) has 8 known neighbours at
    # 2.5 m: the median lifts it to 2.5 m, whose source pixel lies at 2.0 m, 20 % off (> 1 %): it
    # stays. Hole (6, 5), 8 neighbours on the plane: filled from the source.
    h, w = 10, 12
    a = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    b = look_at([0.05, 0, 0], [0.05, 0, 1], [0, -1, 0], fov_deg=60, width=w, height=h)
    img = np.random.default_rng(2).random((h, w)).astype(np.float32)
    depth = np.full((h, w), 2.0)
    from vergence.synthesis import WarpedView, refine_camera_warp, warp_to_camera

    full = warp_to_camera(img, depth, a, b)
    z = full.depth.copy()
    z[[3, 2, 2, 2, 3], [5, 4, 5, 6, 4]] = np.nan
    z[2:5, 7:10] = 2.5
    z[3, 8] = np.nan
    z[6, 5] = np.nan
    holes = np.isnan(z) | full.holes
    warped = WarpedView(np.where(holes, 0.0, full.image).astype(np.float32), holes, (1 / z).astype(np.float32), "1/m", z)
    res = refine_camera_warp(warped, img, depth, a, b, iterations=1)
    assert res.holes[3, 5] and res.holes[3, 8] and not res.holes[6, 5]


def test_a_warped_pixel_is_reliable_only_if_every_contributing_source_pixel_was():
    # Disparity 0.6 warped by 0.5: each source pixel moves 0.3 px left, so target x interpolates
    # sources x (weight 0.7) and x + 1 (weight 0.3). Source 5 unreliable: targets 4 and 5 used it.
    from vergence.synthesis import _stages

    w = 10
    unreliable = np.zeros((1, w, 1), np.float32)
    unreliable[0, 5, 0] = 1.0
    out, _, holes = _stages.forward_warp(unreliable, np.full((1, w), 0.6, np.float32), 0.5, 1.0)
    reliable = _stages.reliable_from_warped(out[:, :, 0], holes)
    expected = ~holes
    expected[0, 4:6] = False
    np.testing.assert_array_equal(reliable, expected)
