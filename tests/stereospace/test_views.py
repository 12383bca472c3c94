"""Novel views at a collection's cameras (S2 §3.1): the plane baseline, S2's MLS view, ours (depth).

Scene: a textured plane at z = 5 m seen by cameras with parallel optical axes; images are rendered
analytically, so the plane view (the exact homography of that plane) reproduces every view.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vergence.camera import look_at
from vergence.stereospace import Collection, leave_one_out, neighbours, novel_view, plane_view, source_depths

PLANE_Z = 5.0
W, H = 64, 48


def _camera(x, y=0.0):
    return look_at([x, y, 0.0], [x, y, PLANE_Z], [0.0, -1.0, 0.0], fov_deg=60.0, width=W, height=H)


def _render(cam):
    d = cam.ray_directions()
    t = (PLANE_Z - cam.center[2]) / d[..., 2]
    x, y = cam.center[0] + t * d[..., 0], cam.center[1] + t * d[..., 1]
    g = 0.5 + 0.4 * np.sin(1.3 * x) * np.cos(1.7 * y)
    return np.stack([g, 1.0 - g, 0.5 + 0.2 * np.cos(2.1 * x)], axis=-1).astype(np.float32)


@pytest.fixture(scope="module")
def plane(tmp_path_factory):
    """A collection of 5 cameras on a line in front of the plane, images as float npy files."""
    folder = tmp_path_factory.mktemp("plane")
    xs = (-0.4, -0.2, 0.0, 0.2, 0.4)
    cams, paths = [], []
    for n, x in enumerate(xs):
        cam = _camera(x)
        path = Path(folder) / f"v{n}.npy"
        np.save(path, _render(cam))
        cams.append(cam)
        paths.append(path)
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-2, 2, 80), rng.uniform(-1.5, 1.5, 80), np.full(80, PLANE_Z)])
    return Collection(tuple(p.name for p in paths), tuple(cams), tuple(paths), points=points)


def test_neighbours_are_the_nearest_and_never_excluded(plane):
    assert neighbours(plane, _camera(0.05), k=2) == [2, 3]
    assert neighbours(plane, _camera(0.0), k=3, exclude=["v2.npy"]) == [1, 3, 0] or \
        neighbours(plane, _camera(0.0), k=3, exclude=["v2.npy"]) == [3, 1, 0]  # fmt: skip


def test_plane_view_of_a_plane_is_exact(plane):
    target = _camera(0.1, 0.05)
    res = plane_view(plane, target)
    assert res.method == "plane" and set(res.sources) == {"v2.npy", "v3.npy"}
    assert res.coverage.mean() > 0.9
    err = np.abs(res.image - _render(target))[res.coverage]
    assert err.max() < 0.02  # bilinear resampling of a smooth texture only


@pytest.mark.parametrize("method", ["mls", "depth"])
def test_novel_view_at_a_source_reproduces_it(plane, method):
    target = plane.cameras[2]
    depths = {n: np.full((H, W), PLANE_Z) for n in plane.names}
    res = novel_view(plane, target, method=method, depths=depths, k=5)  # S2 takes its 4 best of the 5
    assert res.sources[0] == "v2.npy" and len(res.sources) == (4 if method == "mls" else 5)
    err = np.abs(res.image - _render(target))[res.coverage]
    assert res.coverage.mean() > 0.95 and err.max() < 0.02


def test_leave_one_out_excludes_the_camera(plane):
    depths = {n: np.full((H, W), PLANE_Z) for n in plane.names}
    for method in ("plane", "mls", "depth"):
        out = leave_one_out(plane, method=method, names=["v2.npy"], depths=depths)
        score, view = out["v2.npy"]
        assert "v2.npy" not in view.sources and len(view.sources) >= 2
        assert score > 30.0  # a plane scene: every method is near exact


def test_grid_step_reaches_s2_view_in_both_methods(plane):
    """``grid_step`` is S2's MLS grid: the mls view is s2_view's at that step; leave_one_out passes it on."""
    from vergence.stereospace import s2_view

    target = _camera(0.1, 0.05)
    sources = [(plane.cameras[i], np.load(plane.image_paths[i])) for i in neighbours(plane, target)]
    for step in (3, 16):
        res = novel_view(plane, target, method="mls", grid_step=step)
        assert np.array_equal(res.image, s2_view(target, sources, points=plane.points, grid_step=step).image)
    coarse = leave_one_out(plane, method="mls", names=["v2.npy"], grid_step=3)["v2.npy"][1].image
    assert np.array_equal(coarse, novel_view(plane, plane.cameras[2], method="mls", exclude=["v2.npy"], grid_step=3).image)
    assert not np.array_equal(coarse, leave_one_out(plane, method="mls", names=["v2.npy"])["v2.npy"][1].image)
    for bad, error in ((0, ValueError), (2.5, TypeError), (True, TypeError)):
        with pytest.raises(error, match="grid_step must be"):
            novel_view(plane, target, method="depth", grid_step=bad)  # refused before any depth is computed
        with pytest.raises(error, match="grid_step must be"):
            leave_one_out(plane, method="plane", grid_step=bad)


def test_bad_input(plane):
    with pytest.raises(ValueError, match="method"):
        novel_view(plane, _camera(0.0), method="nerf")
    with pytest.raises(ValueError, match="exclude"):
        neighbours(plane, _camera(0.0), exclude=list(plane.names))
    with pytest.raises(TypeError, match="target"):
        plane_view(plane, "v0.npy")
    with pytest.raises(ValueError, match="exclude"):
        novel_view(plane, _camera(0.0), exclude=["nope.png"])
    with pytest.raises(ValueError, match="method"):
        leave_one_out(plane, method="nerf")


def test_source_depth_of_kermit_agrees_with_its_points(shared_data):
    """A view's matched depth (rectified with its partner; the right one of the pair through the
    mirrored matching) agrees with the bundle's points at their projections."""
    from vergence.stereospace import load_collection
    from vergence.stereospace.depths import _pair_depth, _partners

    folder = shared_data / "collections" / "kermit"
    col = load_collection(folder / "bundle.out", images=folder)
    partners = _partners(col)
    for name in ("kermit000.jpg", "kermit001.jpg"):  # 000 is left of 001: one direct, one mirrored
        i, j = col.names.index(name), col.names.index(partners[name])
        depth = _pair_depth(col, i, j, None)
        cam = col.cameras[i]
        pix, z = cam.project(col.points)
        ok = (z > 0) & (pix[:, 0] >= 0) & (pix[:, 0] <= cam.width - 1) & (pix[:, 1] >= 0) & (pix[:, 1] <= cam.height - 1)
        at = depth[np.rint(pix[ok, 1]).astype(int), np.rint(pix[ok, 0]).astype(int)]
        rel = np.abs(at - z[ok]) / z[ok]
        assert np.isfinite(at).mean() > 0.5
        rel = rel[np.isfinite(rel)]
        assert np.median(rel) < 0.01 and np.mean(rel < 0.05) > 0.85  # measured: 0.1-0.3 %, 93-97 %


def test_more_bad_input(plane):
    with pytest.raises(TypeError, match="collection"):
        source_depths("dino")
    with pytest.raises(ValueError, match="k must"):
        neighbours(plane, _camera(0.0), k=0)
    with pytest.raises(ValueError, match="names"):
        leave_one_out(plane, method="plane", names=["nope.png"])
    with pytest.raises(TypeError, match="exclude"):
        novel_view(plane, _camera(0.0), exclude="v0.npy")


def _fine(cam, backdrop=False):
    """A finely textured plane at PLANE_Z (period about 9 px), black on the left half if ``backdrop``."""
    d = cam.ray_directions()
    t = (PLANE_Z - cam.center[2]) / d[..., 2]
    x, y = cam.center[0] + t * d[..., 0], cam.center[1] + t * d[..., 1]
    g = 0.5 + 0.4 * np.sin(8.0 * x) * np.cos(9.0 * y)
    img = np.stack([g, 1.0 - g, 0.5 + 0.3 * np.cos(7.0 * x)], axis=-1).astype(np.float32)
    if backdrop:
        img[:, : W // 2] = 0.0
    return img


def _fine_collection(folder, backdrop=False):
    cams = [_camera(x) for x in (-0.2, 0.0, 0.2)]
    paths = []
    for n, cam in enumerate(cams):
        paths.append(folder / f"v{n}.npy")
        np.save(paths[-1], _fine(cam, backdrop))
    return Collection(tuple(p.name for p in paths), tuple(cams), tuple(paths), points=np.zeros((0, 3)))


def test_check_depth_keeps_the_true_depth_and_drops_a_wrong_one(tmp_path):
    from vergence.stereospace import check_depth

    col = _fine_collection(tmp_path)
    true = np.full((H, W), PLANE_Z)
    kept = np.isfinite(check_depth(col, 1, true)).mean()
    wrong = np.isfinite(check_depth(col, 1, np.full((H, W), 0.6 * PLANE_Z))).mean()
    assert kept > 0.85 and wrong < 0.2, (kept, wrong)
    # an excluded camera never checks: with both others excluded nothing can be checked, all is kept
    assert np.isfinite(check_depth(col, 1, true, exclude=["v0.npy", "v2.npy"])).all()


def test_check_depth_drops_textureless_pixels(tmp_path):
    from vergence.stereospace import check_depth

    col = _fine_collection(tmp_path, backdrop=True)
    depth = check_depth(col, 1, np.full((H, W), PLANE_Z))
    assert not np.isfinite(depth[:, : W // 2 - 4]).any()
    assert np.isfinite(depth[:, W // 2 + 4 :]).mean() > 0.8
    with pytest.raises(ValueError, match="depth must be"):
        check_depth(col, 1, np.ones((3, 3)))


def test_depth_functions_refuse_a_bad_camera_index(plane):
    from vergence.stereospace import check_depth, source_depth

    with pytest.raises(ValueError, match="camera index"):
        check_depth(plane, 5, np.ones((H, W)))
    with pytest.raises(ValueError, match="camera index"):
        source_depth(plane, -1)
    with pytest.raises(TypeError, match="collection"):
        source_depth("dino", 0)
