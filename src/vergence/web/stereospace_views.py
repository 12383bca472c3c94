"""The StereoSpace page's views of a done job (S2 §4.3.1): what the job keeps for its follow-ups
(:class:`LiveSpace`), a state as the page shows it (:func:`view_of`: parameters, eyes and region on the
map, the pan direction, the disparity range) and the navigation map's data (:func:`map_data`, S2
Fig. 11: the top view of :func:`vergence.stereospace.map_frame`). Used by
:mod:`vergence.web.stereospace_page`.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MAX_MAP_POINTS", "LiveSpace", "map_data", "quality_of", "state_of", "view_of", "xy_of"]

#: Sparse points sent with the map at most (a fixed random subset beyond): the impostor of the scene.
MAX_MAP_POINTS = 2000
# The map frames the cameras and the central points (as vergence.report.stereospace_map does).
_POINT_PERCENTILES = (2.0, 98.0)


@dataclass(eq=False)
class LiveSpace:
    """What a done job keeps for its follow-ups: the prepared collection, the map frame, the pairs."""

    prepared: Any  # PreparedCollection
    frame: np.ndarray
    display: Any  # Display
    folder: Path
    extent: float
    lock: threading.Lock = field(default_factory=threading.Lock)
    pairs: OrderedDict = field(default_factory=OrderedDict)  # (region, li, lj, width) -> StereoPairResult
    files: OrderedDict = field(default_factory=OrderedDict)  # name -> (path, pair key, role), oldest first

    def to_map(self, points: object) -> np.ndarray:
        """Map coordinates of world points: :meth:`vergence.stereospace.BuiltSpace.to_map`'s frame."""
        return (np.asarray(points, dtype=np.float64) - self.prepared.centers.mean(axis=0)) @ self.frame[:2].T


def xy_of(p: np.ndarray) -> list[float]:
    return [float(p[0]), float(p[1])]


def state_of(state: Any) -> dict[str, Any]:
    return {"region": list(state.region), "li": state.li, "lj": state.lj}


def view_of(live: LiveSpace, state: Any) -> dict[str, Any]:
    """A state as the page shows it: parameters, stereo point, and on the map the eyes and the region."""
    from vergence.stereospace import eye_order, pair_cameras, pan_sign

    prepared = live.prepared
    space, cams, names = prepared.space, prepared.segment_cameras, prepared.collection.names
    i, j = state.region
    eyes = space.eyes(state)
    first, second = pair_cameras(space, prepared.collection, state, segment_cameras=cams)
    swapped = eye_order(first, second, prepared.up)  # the left eye as vergence.stereospace.stereo_pair orders it
    # the right arrow pans by pan_right * step: towards the view's world right, whatever the eyes' order
    pan_right = pan_sign(space, state, forward=first.R[2] + second.R[2], up=prepared.up)
    left, right = live.to_map(eyes[::-1] if swapped else eyes)
    point = space.point(i, state.li, j, state.lj)
    corners = [(0, 0), (1, 0), (1, 1), (0, 1)] if i != j else [(0, 0), (0, 1), (1, 1)]
    seg = space.segments
    outline = live.to_map(np.array([(seg[i, a] + seg[j, b]) / 2.0 for a, b in corners]))
    quality = quality_of(live, (first, second)) if float(point[3]) > space.tolerance else None
    return {**state_of(state), "stereo_point": [float(v) for v in point], "interocular": float(point[3]),
            "quality": quality,
            "swapped": swapped, "pan_right": pan_right, "centre_world": [float(v) for v in eyes.mean(axis=0)],
            "eyes": {"left": xy_of(left), "right": xy_of(right)},
            "stereo_camera": xy_of((left + right) / 2.0), "region_outline": [xy_of(p) for p in outline],
            "segments": [[names[cams[s, 0]], names[cams[s, 1]]] for s in (i, j)]}  # fmt: skip


def quality_of(live: LiveSpace, cameras: tuple) -> dict[str, Any] | None:
    """The disparity range of a pair's cameras on the job's display (None: the pair cannot be rectified)."""
    from vergence.stereospace import pair_quality

    try:
        q = pair_quality(live.prepared.collection, cameras, live.display, trim=0.01)
    except ValueError:
        return None
    return {k: q[k] for k in ("points_seen", "disparity_arcmin", "range_arcmin", "zone_arcmin", "inside",
                              "fits_with_shift")}  # fmt: skip


def map_data(live: LiveSpace, paths: list[list[int]]) -> dict[str, Any]:
    """The navigation map's data (S2 Fig. 11) in the top view's coordinates."""
    col = live.prepared.collection
    centers = live.to_map(col.centers)
    axes = live.to_map(col.centers + np.array([c.R[2] for c in col.cameras])) - centers
    norms = np.linalg.norm(axes, axis=1, keepdims=True)
    axes = np.divide(axes, norms, out=np.zeros_like(axes), where=norms > 0)
    pts = col.points
    if len(pts) > MAX_MAP_POINTS:
        pts = pts[np.sort(np.random.default_rng(0).choice(len(pts), MAX_MAP_POINTS, replace=False))]
    low, high = centers.min(axis=0), centers.max(axis=0)
    p2 = live.to_map(pts) if len(pts) else np.zeros((0, 2))
    if len(p2):
        low = np.minimum(low, np.percentile(p2, _POINT_PERCENTILES[0], axis=0))
        high = np.maximum(high, np.percentile(p2, _POINT_PERCENTILES[1], axis=0))
    return {"cameras": [{"name": n, "x": float(c[0]), "y": float(c[1]), "dx": float(a[0]), "dy": float(a[1])}
                        for n, c, a in zip(col.names, centers, axes)],
            "segments": live.prepared.segment_cameras.tolist(), "paths": paths,
            "points": [[round(float(x), 6), round(float(y), 6)] for x, y in p2],
            "bounds": [float(low[0]), float(low[1]), float(high[0]), float(high[1])]}  # fmt: skip
