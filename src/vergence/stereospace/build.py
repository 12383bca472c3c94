"""A built StereoSpace: collection, graph, regions, a quality per region vertex and the map's frame.

:func:`build_space` runs the one-time work of S2 §3–4 on a camera file: the collection (points read
or triangulated), the camera graph and its capture paths, the StereoSpace of the graph's segments,
the leave-one-out PSNR of every camera's view by S2's method, and a quality for every stereo pair
at a region vertex. S2 §4.3.2 proposes storing "a quality value ... in each vertex of the
StereoSpace representation" and leaves its computation as future work; :func:`vertex_quality` is
ours (rule below). :mod:`vergence.stereospace.spacefile` saves and loads the result.

Region vertices
---------------
Region ``(i, j)`` has the four vertices ``(li, lj)`` in ``{0, 1}²``; vertex ``(li, lj)`` is the
stereo pair of the collection's cameras ``segment_cameras[i, li]`` and ``segment_cameras[j, lj]``
(at the ends of the segments the novel cameras are the real ones). A triangle ``(i, i)`` has
three (``li <= lj``), and its two diagonal vertices are coincident eyes (a mono view). Vertices of
different regions are often the same camera pair, so the quality is computed once per unordered
pair of cameras.

The quality rule
----------------
``quality = comfort * depth * rectification * interpolation``, each term in [0, 1]:

- ``comfort = min(1, w / r)`` and ``depth = min(1, r / w)``: ``r`` is the range of the pair's point
  disparities on the display in arcmin, from the 1st to the 99th percentile (:data:`DISPARITY_TRIM`),
  and ``w`` the width of the comfort zone
  (:func:`~vergence.stereospace.pair_quality`, :class:`vergence.viewing.ComfortZone`). A range
  wider than the zone cannot be fused whatever the image shift (comfort falls as ``w / r``); a
  range narrower than it fits with a shift but uses only ``r / w`` of the depth the display can
  show. The product is 1 when the range fills the zone exactly.
- ``rectification = max(0, 1 - δ / DISTORTION_LIMIT)`` with ``δ`` the larger of the two views'
  rectification distortion (RMS departure of Fusiello's homography from a similarity, a fraction
  of the image diagonal).
- ``interpolation = clip((p - PSNR_FLOOR_DB) / (PSNR_CEIL_DB - PSNR_FLOOR_DB), 0, 1)`` with ``p``
  the smaller leave-one-out PSNR of the two cameras (S2's ``"mls"`` view of the camera made from
  the others): how well the in-between views near these cameras can be synthesised (at the vertex
  itself the photos are shown).

Decisions: coincident eyes (interocular distance 0, a mono view) have nothing to fuse and no depth:
``comfort = 1``, ``depth = 0``, ``rectification = 1``, so their quality is 0 (a mono view is no
stereo pair). A pair that Fusiello's method cannot rectify (baseline along a viewing direction) or
whose views share no point scores 0, with the reason in ``note``.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vergence.stereospace.collection import Collection, load_collection
from vergence.stereospace.graph import CameraGraph, camera_graph, capture_paths
from vergence.stereospace.orientation import UP_AGREEMENT, collection_up
from vergence.stereospace.pair import PreparedCollection, space_from_graph
from vergence.stereospace.quality import DISPARITY_TRIM, pair_quality
from vergence.stereospace.space import StereoSpace, StereoState
from vergence.stereospace.views import leave_one_out
from vergence.viewing import ComfortZone, Display, check_display

__all__ = [
    "DEFAULT_DISPLAY",
    "DISPARITY_TRIM",
    "DISTORTION_LIMIT",
    "PSNR_CEIL_DB",
    "PSNR_FLOOR_DB",
    "UP_AGREEMENT",
    "BuiltSpace",
    "VertexQuality",
    "build_space",
    "map_frame",
    "vertex_pairs",
    "vertex_quality",
]

DEFAULT_DISPLAY = "desktop-24"
"""Display preset the quality is computed for unless told (:data:`vergence.viewing.DISPLAY_PRESETS`)."""
DISTORTION_LIMIT = 0.1
"""Rectification distortion (fraction of the image diagonal) at which the rectification term reaches 0:
homographies a tenth of the diagonal (80 px of a 640 x 480 image) away from a similarity keystone the
views beyond comfortable viewing. Measured: neighbouring dino cameras 0.0015, kermit pairs 0.016-0.14."""
PSNR_FLOOR_DB = 10.0
"""Leave-one-out PSNR at which the interpolation term is 0: about the score of an unrelated photo."""
PSNR_CEIL_DB = 30.0
"""Leave-one-out PSNR at which the interpolation term is 1: differences hard to see side by side."""

Progress = Callable[[float, str], None]


@dataclass(frozen=True, slots=True)
class VertexQuality:
    """The quality of the stereo pair of two cameras of the collection (see the module notes).

    Attributes
    ----------
    cameras : (int, int)
        The two camera indices, smaller first (equal for a mono vertex).
    quality : float
        ``comfort * depth * rectification * interpolation``, in [0, 1].
    comfort, depth, rectification, interpolation : float
        The four terms, each in [0, 1].
    range_arcmin : float or None
        Disparity range of the points seen by both views on the display (None: mono, or no point).
    fits_with_shift : bool
        The range fits the comfort zone's width (a horizontal shift can bring it inside).
    distortion : float or None
        The larger rectification distortion of the two views (None: mono or not rectifiable).
    psnr_db : (float, float)
        Leave-one-out PSNR of the two cameras' views (NaN where the view could not be made).
    points_seen : int
        Points seen by both views.
    note : str
        Why a term is 0 (``"mono"``, ``"not rectifiable: ..."``, ``"no shared points"``), else ``""``.
    """

    cameras: tuple[int, int]
    quality: float
    comfort: float
    depth: float
    rectification: float
    interpolation: float
    range_arcmin: float | None
    fits_with_shift: bool
    distortion: float | None
    psnr_db: tuple[float, float]
    points_seen: int
    note: str = ""

    def to_dict(self) -> dict:
        """JSON-ready fields (NaN PSNR as None)."""
        out = {k: getattr(self, k) for k in self.__slots__}
        out["cameras"] = list(self.cameras)
        out["psnr_db"] = [None if not math.isfinite(p) else p for p in self.psnr_db]
        return out

    @classmethod
    def from_dict(cls, data: Mapping) -> VertexQuality:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, Mapping) or set(data) != set(cls.__slots__):
            raise ValueError(f"a vertex quality record must have the fields {', '.join(cls.__slots__)}")
        values = dict(data)
        values["cameras"] = tuple(int(c) for c in data["cameras"])
        values["psnr_db"] = tuple(float("nan") if p is None else float(p) for p in data["psnr_db"])
        return cls(**values)


def _interpolation(psnr_db: tuple[float, float]) -> float:
    if any(math.isnan(p) for p in psnr_db):  # a view that could not be made
        return 0.0
    worst = min(psnr_db)  # inf (a perfect view) clips to 1
    return float(np.clip((worst - PSNR_FLOOR_DB) / (PSNR_CEIL_DB - PSNR_FLOOR_DB), 0.0, 1.0))


def vertex_quality(
    collection: Collection,
    cameras: tuple[int, int],
    display: Display,
    *,
    psnr_db: tuple[float, float],
    zone: ComfortZone | None = None,
) -> VertexQuality:
    """The quality of the stereo pair of cameras ``cameras`` of ``collection`` (rule in the module notes).

    Parameters
    ----------
    collection : Collection
    cameras : (int, int)
        Camera indices (either order; equal for coincident eyes).
    display : Display
        The display the pair is judged for (needs a resolution).
    psnr_db : (float, float)
        Leave-one-out PSNR of the two cameras' views, in the order of ``cameras`` (NaN: none).
    zone : ComfortZone, optional
        Default ``ComfortZone()`` (±60 arcmin).

    Examples
    --------
    A pair whose disparities span 240 arcmin, twice the default zone, with no distortion and
    views at 20 dB: ``0.5 * 1 * 1 * 0.5 = 0.25``.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    check_display(display, resolution=True)
    if not (isinstance(cameras, tuple | list) and len(cameras) == 2
            and all(isinstance(c, int | np.integer) and not isinstance(c, bool) for c in cameras)):  # fmt: skip
        raise TypeError(f"cameras must be a pair of camera indices; got {cameras!r}")
    a, b = (int(c) for c in cameras)
    if not (0 <= a < len(collection) and 0 <= b < len(collection)):
        raise ValueError(f"cameras must index the {len(collection)} cameras of collection; got {cameras!r}")
    try:
        psnr = (float(psnr_db[0]), float(psnr_db[1]))
        if len(psnr_db) != 2:
            raise ValueError
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"psnr_db must be two numbers (NaN for a view that could not be made); got {psnr_db!r}") from None
    zone = ComfortZone() if zone is None else zone
    if b < a:
        a, b, psnr = b, a, psnr[::-1]
    interp = _interpolation(psnr)
    common = {"cameras": (a, b), "interpolation": interp, "psnr_db": psnr}
    if a == b:
        n = len(collection.points)
        return VertexQuality(quality=0.0, comfort=1.0, depth=0.0, rectification=1.0, range_arcmin=None,
                             fits_with_shift=True, distortion=None, points_seen=n, note="mono", **common)
    try:
        q = pair_quality(collection, (collection.cameras[a], collection.cameras[b]), display, zone=zone,
                         trim=DISPARITY_TRIM)
    except ValueError as exc:  # the display was checked above: Fusiello's method refused the pair
        return VertexQuality(quality=0.0, comfort=0.0, depth=0.0, rectification=0.0, range_arcmin=None,
                             fits_with_shift=False, distortion=None, points_seen=0,
                             note=f"not rectifiable: {exc}", **common)  # fmt: skip
    delta = float(max(q["rectification_distortion"]))
    rect = max(0.0, 1.0 - delta / DISTORTION_LIMIT)
    if q["range_arcmin"] is None:
        return VertexQuality(quality=0.0, comfort=0.0, depth=0.0, rectification=rect, range_arcmin=None,
                             fits_with_shift=False, distortion=delta, points_seen=0, note="no shared points",
                             **common)  # fmt: skip
    span, width = float(q["range_arcmin"]), zone.max_arcmin - zone.min_arcmin
    comfort = 1.0 if span <= width else width / span
    depth = 1.0 if span >= width else span / width
    return VertexQuality(quality=comfort * depth * rect * interp, comfort=comfort, depth=depth, rectification=rect,
                         range_arcmin=span, fits_with_shift=bool(q["fits_with_shift"]), distortion=delta,
                         points_seen=int(q["points_seen"]), **common)  # fmt: skip


def map_frame(collection: Collection) -> np.ndarray:
    """The frame of the navigation map's top view (S2 §4.3.1): rows ``across``, ``along``, ``up``.

    S2 renders the space "with an orthogonal camera from above". Above is the collection's up
    (:func:`~vergence.stereospace.collection_up`: the direction perpendicular to the cameras'
    optical axes and centre directions, signed by a vote of their image-up axes), the up the pairs
    are rectified to: photos rolled about their optical axes no longer tilt the map into a side view
    (the mean image-up of a ring rolled in part has length 0.75 while pointing 90 degrees away from
    the ring's normal). ``across`` is the centres' largest principal axis made perpendicular to ``up``,
    ``along = up x across``. Map coordinates of a point ``p`` are ``frame[:2] @ (p - mean centre)``
    (:meth:`BuiltSpace.to_map`).

    Returns
    -------
    (3, 3) float64, orthonormal rows, right-handed.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    centers = collection.centers
    _, _, vt = np.linalg.svd(centers - centers.mean(axis=0))
    up = collection_up(collection.cameras)
    across = vt[0] - (vt[0] @ up) * up
    if np.linalg.norm(across) < 1e-9:  # the centres lie along "up": the mean right axis
        right = np.array([c.R[0] for c in collection.cameras]).mean(axis=0)
        across = right - (right @ up) * up
        if np.linalg.norm(across) < 1e-9:
            across = vt[1] - (vt[1] @ up) * up
    across /= np.linalg.norm(across)
    return np.stack([across, np.cross(up, across), up])


@dataclass(frozen=True, slots=True, eq=False)
class BuiltSpace:
    """Everything :func:`build_space` computed; saved by :func:`~vergence.stereospace.save_space`.

    Attributes
    ----------
    collection : Collection
    graph : CameraGraph
    space : StereoSpace
        One segment per graph edge (:func:`~vergence.stereospace.space_from_graph`).
    segment_cameras : (m, 2) int64
        The cameras at the ends of each segment.
    paths : tuple of tuple of int
        The capture paths (:func:`~vergence.stereospace.capture_paths`).
    display_name : str
        The display preset the quality was computed for.
    zone : ComfortZone
    psnr_db : (N,) float64
        Leave-one-out PSNR of each camera's ``"mls"`` view (NaN where it could not be made).
    vertex_qualities : dict
        ``(a, b) -> VertexQuality`` for every unordered camera pair at a region vertex (``a <= b``).
    cameras_path, images : Path
        Absolute paths the collection was read from.
    build_seconds : float
    """

    collection: Collection
    graph: CameraGraph
    space: StereoSpace
    segment_cameras: np.ndarray
    paths: tuple[tuple[int, ...], ...]
    display_name: str
    zone: ComfortZone
    psnr_db: np.ndarray
    vertex_qualities: Mapping[tuple[int, int], VertexQuality]
    cameras_path: Path
    images: Path
    build_seconds: float
    frame: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        if not isinstance(self.collection, Collection) or not isinstance(self.graph, CameraGraph):
            raise TypeError("collection and graph must be a Collection and its CameraGraph")
        if not isinstance(self.space, StereoSpace):
            raise TypeError(f"space must be a StereoSpace; got {type(self.space).__name__}")
        m, n = len(self.space.segments), len(self.collection)
        if np.shape(self.segment_cameras) != (m, 2):
            raise ValueError(f"segment_cameras must have shape ({m}, 2); got {np.shape(self.segment_cameras)}")
        if np.shape(self.psnr_db) != (n,):
            raise ValueError(f"psnr_db must have one value per camera ({n}); got shape {np.shape(self.psnr_db)}")
        Display.preset(self.display_name)  # an unknown preset is refused here
        object.__setattr__(self, "frame", map_frame(self.collection))

    @property
    def display(self) -> Display:
        """The display of :attr:`display_name`."""
        return Display.preset(self.display_name)

    def vertex(self, region: tuple[int, int], li: int, lj: int) -> VertexQuality:
        """The quality record of vertex ``(li, lj)`` (each 0 or 1) of ``region``."""
        i, j = self.space.check_region(region)
        if li not in (0, 1) or lj not in (0, 1) or (i == j and li > lj):
            raise ValueError(f"(li, lj) must be a vertex of region {(i, j)}: 0 or 1 each (li <= lj on a triangle); "
                             f"got {(li, lj)}")  # fmt: skip
        a, b = int(self.segment_cameras[i, li]), int(self.segment_cameras[j, lj])
        return self.vertex_qualities[min(a, b), max(a, b)]

    def region_quality(self, region: tuple[int, int]) -> np.ndarray:
        """(2, 2) quality of the region's vertices, ``[li, lj]``; NaN at ``(1, 0)`` of a triangle."""
        i, j = self.space.check_region(region)
        out = np.full((2, 2), np.nan)
        for li in (0, 1):
            for lj in (0, 1):
                if i != j or li <= lj:
                    out[li, lj] = self.vertex((i, j), li, lj).quality
        return out

    def quality_at(self, state: StereoState) -> float:
        """The vertex qualities interpolated at a state, as the navigation map shades them.

        Linear on the two triangles of the parameter square split along ``li = lj`` (a triangle
        region is one of them): ``(1 - li) q00 + (li - lj) q10 + lj q11`` where ``li > lj``, else
        ``(1 - lj) q00 + (lj - li) q01 + li q11``. The map of view positions is affine in
        ``(li, lj)``, so these are the weights of the map's Gouraud shading.
        """
        state = self.space.check_state(state)
        q, li, lj = self.region_quality(state.region), state.li, state.lj
        if li > lj:  # never on a triangle (li <= lj there)
            return float((1.0 - li) * q[0, 0] + (li - lj) * q[1, 0] + lj * q[1, 1])
        return float((1.0 - lj) * q[0, 0] + (lj - li) * q[0, 1] + li * q[1, 1])

    def prepared(self) -> PreparedCollection:
        """A :class:`PreparedCollection` of this space's collection and graph (decodes every image)."""
        return PreparedCollection(self.collection, graph=self.graph)

    def to_map(self, points: object) -> np.ndarray:
        """Map coordinates (..., 2) of world points (..., 3) in the top view of :func:`map_frame`."""
        p = np.asarray(points, dtype=np.float64)
        return (p - self.collection.centers.mean(axis=0)) @ self.frame[:2].T


def vertex_pairs(segment_cameras: np.ndarray) -> list[tuple[int, int]]:
    """The unordered camera pairs ``(a, b)``, ``a <= b``, at the vertices of every region, sorted."""
    ends = np.unique(np.asarray(segment_cameras).ravel())
    # every pair of segment ends is a vertex of some region: (i, j) with the ends on i and j, or i == j
    return [(int(a), int(b)) for k, a in enumerate(ends) for b in ends[k:]]


def build_space(
    cameras_path: str | os.PathLike[str],
    *,
    images: str | os.PathLike[str],
    display: str = DEFAULT_DISPLAY,
    zone: ComfortZone | None = None,
    progress: Progress | None = None,
    collection: Collection | None = None,
) -> BuiltSpace:
    """Build the StereoSpace of a camera file and its images, with a quality per region vertex.

    Steps: :func:`~vergence.stereospace.load_collection`, :func:`~vergence.stereospace.camera_graph`,
    :func:`~vergence.stereospace.capture_paths`, :func:`~vergence.stereospace.space_from_graph`,
    :func:`~vergence.stereospace.leave_one_out` (``"mls"``, one camera at a time: the slow part),
    then :func:`vertex_quality` for every camera pair at a region vertex.

    Parameters
    ----------
    cameras_path, images
        As :func:`~vergence.stereospace.load_collection`.
    display : str
        A preset of :data:`vergence.viewing.DISPLAY_PRESETS` (needs a resolution).
    zone : ComfortZone, optional
    progress : callable, optional
        ``progress(fraction, message)``: the triangulation, then once per leave-one-out view.
    collection : Collection, optional
        The collection already loaded from ``cameras_path`` and ``images`` (the load and its point
        triangulation are skipped; the paths are still recorded for :func:`load_space`).

    Raises
    ------
    ValueError
        Anything :func:`load_collection` or :func:`camera_graph` refuses; an unknown display.
    """
    start = time.perf_counter()
    shown = Display.preset(display)
    if shown.resolution is None:
        raise ValueError(f"display {display!r} has no resolution")
    zone = ComfortZone() if zone is None else zone
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    cam_path, img_dir = Path(os.fspath(cameras_path)).resolve(), Path(os.fspath(images)).resolve()
    if collection is None:
        collection = load_collection(cam_path, images=img_dir, progress=progress)
    elif not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    graph = camera_graph(collection)
    paths = tuple(tuple(p) for p in capture_paths(graph))
    space, pairs = space_from_graph(collection, graph)
    psnr = np.full(len(collection), np.nan)
    cache: dict = {}
    for k, name in enumerate(collection.names):
        try:
            ((value, _),) = leave_one_out(collection, method="mls", names=[name], images=cache).values()
            psnr[k] = value
        except ValueError:  # no source sees the points this camera sees: no view, term 0
            pass
        if progress is not None:
            progress((k + 1) / len(collection), f"leave-one-out view of {name}: {psnr[k]:.2f} dB")
    qualities = {}
    for a, b in vertex_pairs(pairs):
        qualities[a, b] = vertex_quality(collection, (a, b), shown, psnr_db=(psnr[a], psnr[b]), zone=zone)
    psnr.flags.writeable = False
    return BuiltSpace(collection=collection, graph=graph, space=space, segment_cameras=pairs, paths=paths,
                      display_name=display, zone=zone, psnr_db=psnr, vertex_qualities=qualities,
                      cameras_path=cam_path, images=img_dir, build_seconds=time.perf_counter() - start)
