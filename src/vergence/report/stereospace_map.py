"""The navigation map of a built StereoSpace (S2 §4.3.1, Fig. 11), as PNG.

A top view (the frame of :func:`vergence.stereospace.map_frame`, orthographic) of:

- the sparse points, small dark dots over the space: the impostor of the scene (S2 uses an image);
- the StereoSpace: every region drawn at its view positions (the mid-points ``(a + b) / 2`` of its
  pairs), a rhomboid as two triangles and a triangle as one, Gouraud-shaded from the quality of its
  vertices (:meth:`vergence.stereospace.BuiltSpace.region_quality`). Regions overlap on the map;
  they are drawn in order of increasing quality, so where they overlap the best shows: S2's "color
  per vertex corresponding to the maximum quality for that point". The colour scale runs from 0
  to 1 whatever the space (:data:`QUALITY_SCALE`; kermit's best vertex, 0.07, is dark, not the top
  colour), so that maps of different spaces compare (the colour bar gives the values);
- the capture paths as polylines, the cameras as dots with a short tick along their viewing
  direction;
- optionally a state: the two eyes (red left, blue right, as an anaglyph shows them) joined by the
  baseline, and the stereo camera at its mid-point (S2 Figs. 12-14).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.tri import Triangulation

from vergence.report._figures import new_figure, png_path, save_png

__all__ = ["MAP_FIGURE_SIZE", "QUALITY_SCALE", "navigation_map", "region_triangles"]

MAP_FIGURE_SIZE = (7.0, 6.0)  # inches, at 100 dpi
QUALITY_SCALE = (0.0, 1.0)
"""The colour scale of the region qualities: the range of :func:`vergence.stereospace.vertex_quality`."""
# Points drawn as the impostor at most: a random subset (fixed seed) beyond this keeps the PNG light.
_MAX_POINTS = 20000
# Camera ticks along the viewing direction, as a share of the cameras' extent on the map.
_TICK_SHARE = 0.06
# The view frames the cameras and the central points (this percentile range on each axis: SfM
# outliers far away would shrink the space to a corner), plus this margin as a share of the extent.
_POINT_PERCENTILES = (2.0, 98.0)
_MARGIN_SHARE = 0.08
_LEFT, _RIGHT, _STEREO = "tab:red", "tab:blue", "black"


def region_triangles(built) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The map's mesh of the StereoSpace: vertex positions, qualities and triangles.

    Returns
    -------
    xy : (V, 2) float64
        Map coordinates of each region vertex's view position (each region its own vertices).
    quality : (V,) float64
        Quality of each vertex.
    triangles : (T, 3) int64
        Vertex indices: rhomboid ``(0,0) (1,0) (1,1)`` and ``(0,0) (1,1) (0,1)``; triangle
        ``(0,0) (0,1) (1,1)``; sorted by increasing mean quality (drawing order).
    """
    seg = built.space.segments
    xy, quality, tris = [], [], []
    for region in built.space.regions:
        i, j = region
        q = built.region_quality(region)
        corners = [(0, 0), (1, 0), (1, 1), (0, 1)] if i != j else [(0, 0), (0, 1), (1, 1)]
        base = len(quality)
        for li, lj in corners:
            xy.append((seg[i, li] + seg[j, lj]) / 2.0)
            quality.append(q[li, lj])
        tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)] if i != j else [(base, base + 1, base + 2)]
    xy_map = built.to_map(np.array(xy).reshape(-1, 3))
    quality = np.array(quality, dtype=np.float64)
    triangles = np.array(tris, dtype=np.int64).reshape(-1, 3)
    order = np.argsort(quality[triangles].mean(axis=1), kind="stable")
    return xy_map, quality, triangles[order]


def navigation_map(built, path: str | os.PathLike[str], *, state=None, title: str | None = None) -> Path:
    """Draw the navigation map of ``built`` (a :class:`vergence.stereospace.BuiltSpace`) to a PNG.

    Parameters
    ----------
    built : BuiltSpace
    path : str or os.PathLike
        Output ``.png``, written atomically.
    state : StereoState, optional
        Draw its eyes and stereo camera ("you are here").
    title : str, optional
        Default: the collection's folder name, point and camera counts.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        ``path`` not ending in ``.png``, a state outside the space.
    """
    from vergence.stereospace import BuiltSpace

    if not isinstance(built, BuiltSpace):
        raise TypeError(f"built must be a BuiltSpace; got {type(built).__name__}")
    out = png_path(path)
    eyes = None if state is None else built.space.eyes(state)
    col = built.collection
    centers = built.to_map(col.centers)
    fig = new_figure(figsize=MAP_FIGURE_SIZE, dpi=100)
    ax = fig.add_subplot()
    pts = col.points
    if len(pts) > _MAX_POINTS:
        pts = pts[np.sort(np.random.default_rng(0).choice(len(pts), _MAX_POINTS, replace=False))]
    low, high = centers.min(axis=0), centers.max(axis=0)
    if len(pts):
        p2 = built.to_map(pts)
        ax.scatter(p2[:, 0], p2[:, 1], s=1.0, c="0.1", alpha=0.5, lw=0, zorder=3, label="sparse points")
        low = np.minimum(low, np.percentile(p2, _POINT_PERCENTILES[0], axis=0))
        high = np.maximum(high, np.percentile(p2, _POINT_PERCENTILES[1], axis=0))
    xy, quality, triangles = region_triangles(built)
    mesh = ax.tripcolor(Triangulation(xy[:, 0], xy[:, 1], triangles), quality, shading="gouraud",
                        cmap="viridis", vmin=0.0, vmax=QUALITY_SCALE[1], zorder=2, alpha=0.85)  # fmt: skip
    fig.colorbar(mesh, ax=ax, shrink=0.8, label="stereo pair quality (max at each point)")
    for k, p in enumerate(built.paths):
        line = centers[list(p)]
        ax.plot(line[:, 0], line[:, 1], color="0.15", lw=1.0, zorder=4, label="capture path" if k == 0 else None)
    extent = float(np.ptp(centers, axis=0).max()) or 1.0
    axes = built.to_map(col.centers + np.array([c.R[2] for c in col.cameras]) * 1.0) - centers
    norms = np.linalg.norm(axes, axis=1, keepdims=True)
    ticks = centers + _TICK_SHARE * extent * np.divide(axes, norms, out=np.zeros_like(axes), where=norms > 0)
    for c, t in zip(centers, ticks):
        ax.plot([c[0], t[0]], [c[1], t[1]], color="0.15", lw=0.8, zorder=4)
    ax.scatter(centers[:, 0], centers[:, 1], s=10, c="white", edgecolors="0.15", lw=0.8, zorder=5, label="cameras")
    if eyes is not None:
        from vergence.stereospace.orientation import collection_up, eye_order
        from vergence.stereospace.pair import pair_cameras

        first, second = pair_cameras(built.space, col, state, segment_cameras=built.segment_cameras)
        swapped = eye_order(first, second, collection_up(col.cameras))  # as stereo_pair orders them
        left, right = built.to_map(eyes[::-1] if swapped else eyes)
        mid = (left + right) / 2.0
        ax.plot([left[0], right[0]], [left[1], right[1]], color=_STEREO, lw=1.5, zorder=6)
        ax.scatter(*mid, s=60, marker="s", c=_STEREO, zorder=7, label="stereo camera")
        ax.scatter(*left, s=40, c=_LEFT, edgecolors="white", zorder=8, label="left eye")
        ax.scatter(*right, s=40, c=_RIGHT, edgecolors="white", zorder=8, label="right eye")
    pad = _MARGIN_SHARE * max(float((high - low).max()), 1e-9)
    ax.set_xlim(low[0] - pad, high[0] + pad)
    ax.set_ylim(low[1] - pad, high[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("across (collection units)")
    ax.set_ylabel("along (collection units)")
    if title is None:
        title = (f"{built.images.name}: {len(col)} cameras, {len(built.space.regions)} regions, "
                 f"quality on {built.display_name}")  # fmt: skip
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize=7, markerscale=1.5, framealpha=0.8)
    return save_png(fig, out)
