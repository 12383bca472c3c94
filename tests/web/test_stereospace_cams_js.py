"""The browser's StereoSpace cameras and view plan (``static/pages/stereospace_cams.js``, issue 30) run in Node
against the library: the rectified, framed cameras of :func:`vergence.stereospace.stereo_pair` and, for S2's
view of the left one, a plain numpy reference of the plan (the 4 nearest sources, the proxy depth, one
handle per 4 px cell of the target, :func:`vergence.stereospace.mls_similarity` and the angle ``P_ANG`` at
each grid node, S2 §3.1 Eq. (4)). The built-in tabletop collection is ray-traced into a temporary folder.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

NODE = shutil.which("node")
CAMS_JS = Path(__file__).resolve().parents[2] / "src" / "vergence" / "web" / "static" / "pages" / "stereospace_cams.js"
WIDTH = 320
# Cameras: float64 in both, the same formulas (slerp by quaternions here, by rotation vectors in scipy)
CAMERA_ATOL = 1e-7
# Node maps: the page stores float32 (about 3e-5 px at 600 px); the reference is float64
MAP_ATOL_PX = 1e-3
ANGLE_ATOL = 1e-6

pytestmark = pytest.mark.skipif(NODE is None, reason="node (Node.js) is not installed: the page's JavaScript "
                                                     "cannot run outside the browser here")

DRIVER = """
const fs = require("fs"), vm = require("vm");
vm.runInThisContext(fs.readFileSync(process.argv[2], "utf8") + "\\nglobalThis.SSCams = SSCams;");
const raw = JSON.parse(fs.readFileSync(process.argv[3], "utf8"));
const scene = SSCams.prepare(raw);
const cam = (c) => ({ K: c.K, R: c.R, t: c.t, width: c.width, height: c.height });
const out = raw.states.map((state) => {
  const [a, b] = SSCams.eyeCameras(scene, state);
  const pair = SSCams.pairCameras(scene, a, b, raw.width);
  const plan = SSCams.viewPlan(scene, pair.left);
  return { left: cam(pair.left), right: cam(pair.right), swapped: pair.swapped, ids: plan.ids, counts: plan.counts,
           proxy: plan.proxy, xs: plan.xs, ys: plan.ys, nodes: Array.from(plan.nodes) };
});
process.stdout.write(JSON.stringify(out));
"""


@pytest.fixture(scope="module")
def tabletop(tmp_path_factory):
    from vergence.render import builtin_scene
    from vergence.stereospace import PreparedCollection, load_collection, render_collection

    folder = tmp_path_factory.mktemp("tabletop")
    cameras = render_collection(builtin_scene("tabletop"), folder)
    return PreparedCollection(load_collection(cameras, images=folder), grid_step=16)


def _states(prepared) -> list:
    """Rhomboid and triangle states spread over the regions, those stereo_pair can draw."""
    from vergence.stereospace import StereoState, stereo_pair

    regions = prepared.space.regions
    out = []
    for region in regions[:: max(1, len(regions) // 6)]:
        li, lj = (0.3, 0.7) if region[0] == region[1] else (0.4, 0.65)
        state = StereoState(region, li, lj)
        try:
            stereo_pair(prepared, state, method=lambda p, cam: np.zeros((cam.height, cam.width, 3)), width=WIDTH)
        except ValueError:
            continue
        out.append(state)
    return out


def _run(prepared, states, tmp_path) -> list[dict]:
    from vergence.stereospace import map_frame
    from vergence.web.stereospace_scene import scene_of

    scene = scene_of(prepared, image_url="/x", default_width=WIDTH, map_frame=map_frame(prepared.collection))
    scene["states"] = [{"region": list(s.region), "li": s.li, "lj": s.lj} for s in states]
    scene["width"] = WIDTH
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    (tmp_path / "driver.js").write_text(DRIVER)
    done = subprocess.run([NODE, str(tmp_path / "driver.js"), str(CAMS_JS), str(tmp_path / "scene.json")],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def _plan_reference(prepared, target):
    """The plan of S2's view of ``target`` in plain numpy: sources, handle counts, proxy depth, node values."""
    from vergence.stereospace import S2_HANDLE_CELL_PX, mls_similarity

    col = prepared.collection
    distance = np.linalg.norm(prepared.centers - target.center, axis=1)
    ids = sorted(range(len(distance)), key=lambda k: (distance[k], k))[:4]
    q, z = target.project(col.points)
    proxy = float(np.median(z[z > 0]))
    xs = np.unique(np.append(np.arange(0, target.width, 16), target.width - 1)).astype(float)
    ys = np.unique(np.append(np.arange(0, target.height, 16), target.height - 1)).astype(float)
    gx, gy = np.meshgrid(xs, ys)
    nodes = np.stack([gx.ravel(), gy.ravel()], axis=1)
    counts, maps, angles = [], [], []
    for n in ids:
        cam = col.cameras[n]
        p, zs = cam.project(col.points)
        chosen, cells = [], set()
        for k in range(len(col.points)):  # the first point of each 4 px cell of the target, in order
            seen = zs[k] > 0 and -0.5 <= p[k, 0] <= cam.width - 0.5 and -0.5 <= p[k, 1] <= cam.height - 0.5
            if not (seen and z[k] > 0):
                continue
            cell = (int(np.floor(q[k, 0] / S2_HANDLE_CELL_PX)), int(np.floor(q[k, 1] / S2_HANDLE_CELL_PX)))
            if cell not in cells:
                cells.add(cell)
                chosen.append(k)
        counts.append(len(chosen))
        maps.append(mls_similarity(nodes, q[chosen], p[chosen]))
        rays = np.c_[nodes, np.ones(len(nodes))] @ np.linalg.inv(target.K).T
        P = target.center + proxy * rays @ target.R  # R^T ray, row by row
        a, b = target.center - P, cam.center - P
        angles.append(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b)))
    return ids, counts, proxy, xs, ys, np.array(maps), np.array(angles)


def test_the_pages_cameras_are_stereo_pairs(tabletop, tmp_path):
    from vergence.stereospace import stereo_pair

    states = _states(tabletop)
    assert len(states) >= 4
    got = _run(tabletop, states, tmp_path)
    for state, js in zip(states, got):
        res = stereo_pair(tabletop, state, method=lambda p, cam: np.zeros((cam.height, cam.width, 3)), width=WIDTH)
        assert js["swapped"] == res.swapped, state
        for side, cam in (("left", res.rectified[0]), ("right", res.rectified[1])):
            assert (js[side]["width"], js[side]["height"]) == (cam.width, cam.height)
            assert_allclose(np.reshape(js[side]["K"], (3, 3)), cam.K, atol=CAMERA_ATOL * cam.width, err_msg=str(state))
            assert_allclose(np.reshape(js[side]["R"], (3, 3)), cam.R, atol=CAMERA_ATOL, err_msg=str(state))
            assert_allclose(js[side]["t"], cam.t, atol=CAMERA_ATOL, err_msg=str(state))


def test_the_pages_view_plan_is_s2s(tabletop, tmp_path):
    from vergence.camera import Camera

    states = _states(tabletop)[:3]
    for js in _run(tabletop, states, tmp_path):
        left = js["left"]
        target = Camera(K=np.reshape(left["K"], (3, 3)), R=np.reshape(left["R"], (3, 3)), t=np.array(left["t"]),
                        width=left["width"], height=left["height"])
        ids, counts, proxy, xs, ys, maps, angles = _plan_reference(tabletop, target)
        assert js["ids"] == ids and js["counts"] == counts
        assert js["proxy"] == pytest.approx(proxy, rel=1e-12)
        assert_allclose(js["xs"], xs) and assert_allclose(js["ys"], ys)
        nodes = np.reshape(js["nodes"], (len(ids), len(ys) * len(xs), 4))
        assert_allclose(nodes[..., :2], maps, atol=MAP_ATOL_PX)
        assert_allclose(nodes[..., 2], angles, atol=ANGLE_ATOL)
