"""Where browsing starts, and finding a good state (S2 §4).

:func:`start_state` picks, among the states whose eyes sit at the middles of two consecutive
segments ``p-q`` and ``q-r`` of a capture path, the one whose pair has the smallest disparity range
on the display (:func:`~vergence.stereospace.pair_quality`): a comfortable first view. The demo's
sequences and the workbench's browser start there.

A built space is searched by its region vertices' qualities (S2 §4.3.2): :func:`best_states` ranks
the camera pairs at region vertices and gives a state for each (:func:`vertex_state`: the eyes at the
two cameras); :func:`state_at_camera` places the stereo camera at a named camera, the eyes half-way
to two of its graph neighbours (the most comfortable such pair), or on its one segment.
"""

from __future__ import annotations

import numpy as np

from dataclasses import dataclass

from vergence.stereospace.build import BuiltSpace, VertexQuality
from vergence.stereospace.graph import capture_paths
from vergence.stereospace.pair import PreparedCollection, pair_cameras
from vergence.stereospace.quality import pair_quality
from vergence.stereospace.space import StereoState
from vergence.viewing.geometry import Display

__all__ = ["RankedState", "best_states", "start_state", "state_at_camera", "state_near", "vertex_state"]


def _segment(prepared: PreparedCollection, a: int, b: int) -> int:
    """Index of the segment joining cameras ``a`` and ``b``."""
    hits = np.flatnonzero(((prepared.segment_cameras[:, 0] == a) & (prepared.segment_cameras[:, 1] == b))
                          | ((prepared.segment_cameras[:, 0] == b) & (prepared.segment_cameras[:, 1] == a)))  # fmt: skip
    if hits.size == 0:
        raise ValueError(f"cameras {a} and {b} are not joined by a segment of the graph")
    return int(hits[0])


def _near(prepared: PreparedCollection, segment: int, camera: int, fraction: float) -> float:
    """The parameter of the point ``fraction`` of the way along ``segment`` from its end ``camera``."""
    return fraction if int(prepared.segment_cameras[segment, 0]) == camera else 1.0 - fraction


def state_near(prepared: PreparedCollection, p: int, q: int, r: int, fraction: float) -> StereoState:
    """The state with the eyes ``fraction`` of a segment from camera ``q``, on segments ``p-q`` and ``q-r``
    of the camera graph (each eye on one; ``fraction`` 0.5: at their middles).

    Raises
    ------
    ValueError
        If ``p-q`` or ``q-r`` is not a segment of the graph.
    """
    i, j = _segment(prepared, p, q), _segment(prepared, q, r)
    li, lj = _near(prepared, i, q, fraction), _near(prepared, j, q, fraction)
    if i > j:
        i, j, li, lj = j, i, lj, li
    return StereoState((i, j), li, lj)


def start_state(prepared: PreparedCollection, display: Display) -> tuple[StereoState, tuple[int, int, int], float]:
    """The start of the sequences: the state, its cameras ``(p, q, r)`` and its disparity range (arcmin).

    Every three consecutive cameras ``p, q, r`` of a capture path give the state with the eyes at the
    middles of segments ``p-q`` and ``q-r``; the one whose pair has the smallest disparity range on
    ``display`` (:func:`~vergence.stereospace.pair_quality`) wins, the first on a tie.

    Raises
    ------
    ValueError
        If no capture path has three cameras, or no candidate pair sees a point of the collection.
    """
    best = None
    for path in capture_paths(prepared.graph):
        for p, q, r in zip(path, path[1:], path[2:]):
            if len({p, q, r}) < 3:
                continue
            state = state_near(prepared, p, q, r, 0.5)
            cams = pair_cameras(prepared.space, prepared.collection, state, segment_cameras=prepared.segment_cameras)
            quality = pair_quality(prepared.collection, cams, display)
            if quality["range_arcmin"] is not None and (best is None or quality["range_arcmin"] < best[2]):
                best = (state, (int(p), int(q), int(r)), float(quality["range_arcmin"]))
    if best is None:
        raise ValueError("no three consecutive cameras of a capture path see a common point")
    return best


@dataclass(frozen=True, slots=True)
class RankedState:
    """A state at a region vertex and the quality record of its camera pair (:func:`best_states`)."""

    state: StereoState
    vertex: VertexQuality


def _ends(segment_cameras: np.ndarray, camera: int) -> list[tuple[int, int]]:
    """``(segment, end)`` of every segment end that is ``camera``."""
    return [(int(k), int(e)) for k, e in zip(*np.nonzero(np.asarray(segment_cameras) == camera))]


def vertex_state(segment_cameras: np.ndarray, a: int, b: int) -> StereoState:
    """A state whose first eye is camera ``a`` and second eye camera ``b`` (a region vertex).

    ``segment_cameras`` is the ``(m, 2)`` camera index of each segment end
    (:func:`~vergence.stereospace.space_from_graph`). With ``a`` on segment ``i`` (end ``li``) and
    ``b`` on segment ``j`` (end ``lj``), the first such ends, the state is region ``(i, j)`` at
    ``(li, lj)``, its eyes swapped into ``i <= j`` (and ``li <= lj`` on a triangle) as regions require.

    Raises
    ------
    ValueError
        If ``a`` or ``b`` is at no segment end.
    """
    ends_a, ends_b = _ends(segment_cameras, a), _ends(segment_cameras, b)
    if not ends_a or not ends_b:
        raise ValueError(f"camera {a if not ends_a else b} is at no segment end of the space (not in the camera graph)")
    shared = [(ia, ea, eb) for ia, ea in ends_a for ib, eb in ends_b if ia == ib]
    if shared:  # the two ends of one segment: its triangle, from end 0 to end 1
        i, _, _ = shared[0]
        return StereoState((i, i), 0.0, 1.0)
    (i, li), (j, lj) = ends_a[0], ends_b[0]
    if i > j:
        i, j, li, lj = j, i, lj, li
    return StereoState((i, j), float(li), float(lj))


def best_states(built: BuiltSpace, *, count: int = 10) -> list[RankedState]:
    """The ``count`` best camera pairs at region vertices by quality (mono vertices left out), best first.

    Ties keep the order of the camera pairs (smaller indices first). Each comes with the state of
    :func:`vertex_state` (the eyes at the two cameras).
    """
    if not isinstance(built, BuiltSpace):
        raise TypeError(f"built must be a BuiltSpace; got {type(built).__name__}")
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
        raise ValueError(f"count must be a positive whole number; got {count!r}")
    stereo = [q for _, q in sorted(built.vertex_qualities.items()) if q.cameras[0] != q.cameras[1]]
    ranked = sorted(stereo, key=lambda q: -q.quality)[: int(count)]
    return [RankedState(vertex_state(built.segment_cameras, *q.cameras), q) for q in ranked]


def state_at_camera(prepared: PreparedCollection, camera: int, display: Display) -> StereoState:
    """A state whose stereo camera stands at (or nearest to) ``camera``, the eyes on two of its segments.

    For each pair of graph neighbours ``(p, r)`` of ``camera`` the eyes go on the segments to them
    at one distance ``d`` from the camera, half the shorter segment's length; the pair whose view
    position (the eyes' mid-point) lies nearest the camera's centre wins (neighbours on opposite
    sides: on a row, exactly at it), the smaller disparity range on ``display``
    (:func:`~vergence.stereospace.pair_quality`) breaking ties within 1 % of ``d``. A camera with one
    neighbour ``p`` gets the triangle of segment ``camera-p`` with the eyes at the camera and half-way to ``p``.

    Raises
    ------
    ValueError
        If ``camera`` is no index of the collection or has no neighbour in the graph.
    """
    n = len(prepared.collection)
    if isinstance(camera, bool) or not isinstance(camera, int | np.integer) or not 0 <= camera < n:
        raise ValueError(f"camera must be an index in [0, {n}); got {camera!r}")
    q = int(camera)
    around = prepared.graph.neighbours(q)
    if not around:
        raise ValueError(f"camera {prepared.collection.names[q]} has no neighbour in the camera graph")
    if len(around) == 1:
        i = _segment(prepared, q, around[0])
        at = float(prepared.segment_cameras[i, 1] == q)
        li, lj = sorted((at, 0.5))
        return StereoState((i, i), li, lj)
    centres = prepared.centers
    candidates = []
    for k, p in enumerate(around):
        for r in around[k + 1:]:
            lengths = np.linalg.norm(centres[[p, r]] - centres[q], axis=1)
            d = lengths.min() / 2.0
            i, j = _segment(prepared, p, q), _segment(prepared, q, r)
            li, lj = _near(prepared, i, q, d / lengths[0]), _near(prepared, j, q, d / lengths[1])
            state = StereoState((i, j), li, lj) if i <= j else StereoState((j, i), lj, li)
            off = float(np.linalg.norm(prepared.space.point(state.region[0], state.li, state.region[1],
                                                            state.lj)[:3] - centres[q]))  # fmt: skip
            candidates.append((off / d, state))
    nearest = min(c[0] for c in candidates)
    best = None
    for off, state in candidates:
        if off > nearest + 0.01:
            continue
        cams = pair_cameras(prepared.space, prepared.collection, state, segment_cameras=prepared.segment_cameras)
        try:
            span = pair_quality(prepared.collection, cams, display)["range_arcmin"]
        except ValueError:  # a pair that cannot be rectified
            continue
        key = np.inf if span is None else float(span)
        if best is None or key < best[0]:
            best = (key, state)
    if best is None:
        raise ValueError(f"no pair of neighbours of camera {prepared.collection.names[q]} can be rectified")
    return best[1]
