"""The dino collection, triangulated once for the whole session (about 3 s on one core)."""

from __future__ import annotations

import time

import pytest

from vergence.stereospace import load_collection


@pytest.fixture(scope="session")
def dino(shared_data):
    """``(collection, seconds)``: dino loaded and triangulated with the default settings."""
    folder = shared_data / "collections" / "dino"
    start = time.perf_counter()
    col = load_collection(folder / "dino_par.txt", images=folder)
    return col, time.perf_counter() - start


# --- a small synthetic collection on disk (camera file + images), for build and its commands --------
SYNTH_W, SYNTH_H = 64, 48
SYNTH_PLANE_Z = 5.0
SYNTH_XS = (-1.0, -0.5, 0.0, 0.5, 1.0)


def synthetic_camera(x: float):
    from vergence.camera import look_at

    return look_at([x, 0.0, 0.0], [0.0, 0.0, SYNTH_PLANE_Z], [0.0, -1.0, 0.0], fov_deg=60.0,
                   width=SYNTH_W, height=SYNTH_H)  # fmt: skip


SYNTH_NORMAL = (-0.4, -0.2, 1.0)  # the plane n . X = SYNTH_PLANE_Z, tilted: its disparities vary


def synthetic_render(cam):
    """A textured tilted plane ``SYNTH_NORMAL . X = SYNTH_PLANE_Z`` seen by ``cam`` (RGB, float32)."""
    import numpy as np

    n = np.array(SYNTH_NORMAL)
    d = cam.ray_directions()
    t = (SYNTH_PLANE_Z - cam.center @ n) / (d @ n)
    x, y = cam.center[0] + t * d[..., 0], cam.center[1] + t * d[..., 1]
    g = 0.5 + 0.4 * np.sin(2.1 * x) * np.cos(2.7 * y)
    return np.stack([g, 0.5 + 0.3 * np.sin(3.3 * x + 1.0), 1.0 - g], axis=-1).astype(np.float32)


def write_synthetic_collection(folder):
    """Five cameras on a row, toed in towards a textured plane, as ``cameras.json`` + ``v*.png``."""
    import numpy as np

    from vergence.io import CameraSet, write_cameras_json, write_image

    folder.mkdir(parents=True, exist_ok=True)
    cams = tuple(synthetic_camera(x) for x in SYNTH_XS)
    names = tuple(f"v{k}.png" for k in range(len(cams)))
    for name, cam in zip(names, cams):
        write_image(folder / name, synthetic_render(cam))
    rng = np.random.default_rng(7)
    x, y = rng.uniform(-2.5, 2.5, 150), rng.uniform(-1.5, 1.5, 150)
    n = SYNTH_NORMAL
    pts = np.column_stack([x, y, (SYNTH_PLANE_Z - n[0] * x - n[1] * y) / n[2]])
    obs, pixels = [], []
    for c, cam in enumerate(cams):  # each point seen where it projects inside, measured to ~0.1 px
        xy, z = cam.project(pts)
        seen = np.flatnonzero((z > 0) & (xy[:, 0] >= 0) & (xy[:, 0] <= SYNTH_W - 1) & (xy[:, 1] >= 0)
                              & (xy[:, 1] <= SYNTH_H - 1))  # fmt: skip
        obs += [(int(p), c, int(p)) for p in seen]
        pixels.append(xy[seen] + rng.normal(0.0, 0.1, (len(seen), 2)))
    cset = CameraSet(names=names, cameras=cams, points=pts, colors=np.full((len(pts), 3), 128, np.uint8),
                     observations=np.array(obs), observation_pixels=np.concatenate(pixels))
    write_cameras_json(folder / "cameras.json", cset)
    return folder / "cameras.json", folder


@pytest.fixture(scope="session")
def synthetic_space(tmp_path_factory):
    """``(cameras_path, images, built)``: the synthetic collection and its built space."""
    from vergence.stereospace import build_space

    cameras_path, images = write_synthetic_collection(tmp_path_factory.mktemp("synthetic"))
    return cameras_path, images, build_space(cameras_path, images=images)
