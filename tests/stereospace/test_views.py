"""Novel views at a collection's cameras (S2 §3.1): the plane baseline, S2's MLS view, ours (depth).

Scene: a textured plane at z = 5 m seen by cameras with parallel optical axes; images are rendered
analytically, so the plane view (the exact homography of that plane) reproduces every view.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vergence.camera import look_at
from vergence.stereospace import Collection, leave_one_out, neighbours, novel_view, plane_view

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
    res = novel_view(plane, target, method=method, depths=depths)
    assert res.sources[0] == "v2.npy"
    err = np.abs(res.image - _render(target))[res.coverage]
    assert res.coverage.mean() > 0.95 and err.max() < 0.02


def test_leave_one_out_excludes_the_camera(plane):
    depths = {n: np.full((H, W), PLANE_Z) for n in plane.names}
    for method in ("plane", "mls", "depth"):
        out = leave_one_out(plane, method=method, names=["v2.npy"], depths=depths)
        score, view = out["v2.npy"]
        assert "v2.npy" not in view.sources and len(view.sources) >= 2
        assert score > 30.0  # a plane scene: every method is near exact


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
