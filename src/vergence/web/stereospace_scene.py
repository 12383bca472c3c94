"""What the StereoSpace page needs to draw any state itself in the browser (WebGL2, issue 30).

``GET /api/stereospace/{job_id}/scene`` (:func:`scene_of`) answers once, for a done ``stereospace``
job, everything :func:`vergence.stereospace.stereo_pair` reads when it renders a pair at the page's
working width (no display shift: the page's ``/pair`` asks none):

- the cameras (``K``, ``R``, ``t``, size; row-major), the camera index pair of each segment of the
  StereoSpace, the space's tolerance (coincident eyes) and the collection's up
  (:func:`~vergence.stereospace.collection_up`, the order of the eyes);
- the sparse points (the MLS handles are the points seen by a source and in front of the target,
  one per :data:`~vergence.stereospace.S2_HANDLE_CELL_PX` cell of the target, S2 §3.1) and the
  render parameters of S2's view: grid step, ``k`` sources, the angle floor, the ULR threshold
  scale, the negligible weight, the fewest handles of a map;
- the decoded images as PNG files, one a camera, written into the job's folder under names the
  server makes (``source-{k}.png``; 8-bit: the stored values of an 8-bit photo exactly) and served
  by ``GET /api/stereospace/{job_id}/scene/{name}``.

The page (``static/pages/stereospace_cams.js`` and ``stereospace_gl.js``) then interpolates the
eyes' cameras, rectifies and frames them, selects the handles, evaluates the MLS maps at the grid
nodes and blends the sources per pixel in a fragment shader as ``_mls_view_kernels.render_view``
does; ``tests/web/test_browser_stereospace_gl.py`` compares its pixels with ``stereo_pair``'s.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["SCENE_IMAGE", "scene_image", "scene_of"]

#: The names of the scene's image files: ``source-{k}.png``, ``k`` the camera's index.
SCENE_IMAGE = re.compile(r"source-(0|[1-9][0-9]{0,5})\.png")


def _camera(cam: Any) -> dict[str, Any]:
    return {"K": [float(v) for v in cam.K.ravel()], "R": [float(v) for v in cam.R.ravel()],
            "t": [float(v) for v in cam.t], "width": int(cam.width), "height": int(cam.height)}  # fmt: skip


def scene_of(prepared: Any, *, image_url: str, default_width: int, map_frame: np.ndarray) -> dict[str, Any]:
    """The scene of a :class:`~vergence.stereospace.PreparedCollection` as the page reads it (JSON-ready).

    ``image_url`` is the URL prefix of the images (``{image_url}/source-{k}.png``); ``map_frame`` the
    navigation map's frame (:func:`~vergence.stereospace.map_frame`): the page moves the map's eyes with
    each frame it draws, at ``frame[:2] @ (p - origin)``, ``origin`` the mean camera centre.
    """
    from vergence.stereospace import MLS_MIN_HANDLES, S2_HANDLE_CELL_PX, S2_MAX_SOURCES, S2_PENALTY_FLOOR
    from vergence.stereospace import S2_THRESHOLD_SCALE, UP_MIN_COSINE
    from vergence.stereospace.mls_view import NEGLIGIBLE_WEIGHT

    col = prepared.collection
    points = np.asarray(col.points, dtype=np.float64)
    return {
        "cameras": [_camera(c) for c in col.cameras],
        "segment_cameras": prepared.segment_cameras.tolist(),
        "tolerance": float(prepared.space.tolerance),
        "up": [float(v) for v in prepared.up],
        "points": [float(v) for v in points.ravel()],
        "images": [f"{image_url}/source-{k}.png" for k in range(len(col))],
        "map": {"frame": [[float(v) for v in r] for r in np.asarray(map_frame)[:2]],
                "origin": [float(v) for v in prepared.centers.mean(axis=0)]},
        "render": {"grid_step": int(prepared.grid_step), "k": S2_MAX_SOURCES, "sources": S2_MAX_SOURCES,
                   "alpha": 1.0, "penalty_floor": S2_PENALTY_FLOOR, "threshold_scale": S2_THRESHOLD_SCALE,
                   "negligible": NEGLIGIBLE_WEIGHT, "handle_cell_px": S2_HANDLE_CELL_PX,
                   "min_handles": MLS_MIN_HANDLES, "up_min_cosine": UP_MIN_COSINE, "framing": "fit", "default_width": int(default_width)},
    }  # fmt: skip


def scene_image(prepared: Any, folder: Path, name: str) -> Path | None:
    """The PNG of a scene image name (written into ``folder`` on first use); None for a name the
    server does not make (not ``source-{k}.png`` with ``k`` a camera of the collection)."""
    from vergence.io import write_image

    match = SCENE_IMAGE.fullmatch(name)
    if match is None or int(match.group(1)) >= len(prepared.collection):
        return None
    path = folder / f"source-{int(match.group(1))}.png"
    if not path.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        write_image(path, np.clip(prepared.image(int(match.group(1))), 0.0, 1.0))
    return path
