"""Where browsing starts: a state between three consecutive cameras of a capture path (S2 §4).

:func:`start_state` picks, among the states whose eyes sit at the middles of two consecutive
segments ``p-q`` and ``q-r`` of a capture path, the one whose pair has the smallest disparity range
on the display (:func:`~vergence.stereospace.pair_quality`): a comfortable first view. The demo's
sequences and the workbench's browser start there.
"""

from __future__ import annotations

import numpy as np

from vergence.stereospace.graph import capture_paths
from vergence.stereospace.pair import PreparedCollection, pair_cameras
from vergence.stereospace.quality import pair_quality
from vergence.stereospace.space import StereoState
from vergence.viewing.geometry import Display

__all__ = ["start_state", "state_near"]


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
