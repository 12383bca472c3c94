"""The camera graph of a collection and its capture paths (S2 §3, §4: the segments of the StereoSpace).

Nodes are the cameras of a :class:`~vergence.stereospace.collection.Collection`. Two cameras are
joined when they overlap, which S2 §3 takes from how collections are shot (cameras on arcs around
the object, looking at the same region). The rule, with its named thresholds:

1. similar viewing directions: the angle between the optical axes is at most
   :data:`MAX_AXIS_ANGLE_DEG`;
2. near centres: the baseline is at most :data:`NEAR_FACTOR` times the collection's spacing (the
   median over cameras of the distance to the nearest other camera), so the rule does not depend
   on the unit of the reconstruction;
3. shared points: when the collection has observations, at least :data:`MIN_SHARED_POINTS` points
   are seen by both cameras (a collection without observations skips this test).

The capture path (:func:`capture_paths`) is the minimum spanning forest of the graph by baseline,
cut into polylines; a component whose tree is one chain whose two ends are joined in the graph by
an edge at most :data:`RING_CLOSURE` times the chain's longest step is a ring and comes out closed
(its first node repeated at the end); a short straight walk, whose ends are also joined, stays open.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.stereospace.collection import Collection

__all__ = [
    "MAX_AXIS_ANGLE_DEG",
    "MIN_SHARED_POINTS",
    "NEAR_FACTOR",
    "RING_CLOSURE",
    "CameraGraph",
    "camera_graph",
    "capture_paths",
]

# Rectifying two views turns each by about half the angle between their axes (Fusiello et al. 2000):
# beyond 45° the rectified images are strongly sheared and the views share little of the object.
MAX_AXIS_ANGLE_DEG = 45.0
# A camera may be joined to cameras up to three spacings away: a ring or walk then gets its
# neighbours and the next ones (stereo pairs of a wider baseline), never the far side of the ring.
NEAR_FACTOR = 3.0
# Enough common points to place the two views against each other (a homography needs 4, MLS
# handles more; 10 leaves room for outliers), few enough for sparse SfM.
MIN_SHARED_POINTS = 10
# A chain closes into a ring when the edge between its ends is no longer than 1.5 of its steps: a
# ring's spanning tree leaves out one step (about as long as the others, a little longer at most),
# while the ends of a straight walk of n steps are n steps apart.
RING_CLOSURE = 1.5


@dataclass(frozen=True, slots=True, eq=False)
class CameraGraph:
    """Cameras joined where they overlap (see the module notes for the rule).

    Parameters
    ----------
    n_nodes : int
        Number of cameras.
    centers : (N, 3) float64
        Camera centres.
    edges : (E, 2) int64
        ``(i, j)`` with ``i < j``, sorted.
    axis_angle_deg : (E,) float64
        Angle between the two optical axes.
    baseline : (E,) float64
        Distance between the two centres (the reconstruction's unit).
    shared_points : (E,) int64
        Points seen by both cameras (0 when the collection has no observations).
    """

    n_nodes: int
    centers: np.ndarray
    edges: np.ndarray
    axis_angle_deg: np.ndarray
    baseline: np.ndarray
    shared_points: np.ndarray

    def neighbours(self, node: int) -> list[int]:
        """The nodes joined to ``node``, sorted."""
        if not isinstance(node, int | np.integer) or not 0 <= node < self.n_nodes:
            raise ValueError(f"node must be an index in [0, {self.n_nodes}); got {node!r}")
        e = self.edges
        return sorted(int(v) for v in np.concatenate([e[e[:, 0] == node, 1], e[e[:, 1] == node, 0]]))


def _shared_counts(collection: Collection) -> np.ndarray:
    """(N, N) number of points seen by both cameras."""
    n = len(collection)
    vis = np.zeros((collection.point_count, n), np.int64)
    obs = collection.observations
    vis[obs[:, 0], obs[:, 1]] = 1
    return vis.T @ vis


def camera_graph(
    collection: Collection,
    *,
    max_axis_angle_deg: float = MAX_AXIS_ANGLE_DEG,
    near_factor: float = NEAR_FACTOR,
    min_shared_points: int = MIN_SHARED_POINTS,
) -> CameraGraph:
    """The camera graph of ``collection`` (rule in the module notes).

    Raises
    ------
    ValueError
        If no pair of cameras overlaps by the rule (the message gives the closest miss), or a
        threshold is out of range.
    TypeError
        If ``collection`` is not a :class:`Collection`.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if not (isinstance(max_axis_angle_deg, int | float) and 0 < max_axis_angle_deg <= 180):
        raise ValueError(f"max_axis_angle_deg must be in (0, 180]; got {max_axis_angle_deg!r}")
    if not (isinstance(near_factor, int | float) and np.isfinite(near_factor) and near_factor > 0):
        raise ValueError(f"near_factor must be positive; got {near_factor!r}")
    if not isinstance(min_shared_points, int) or isinstance(min_shared_points, bool) or min_shared_points < 0:
        raise ValueError(f"min_shared_points must be an integer >= 0; got {min_shared_points!r}")
    n = len(collection)
    centers = collection.centers
    axes = np.array([c.R[2] for c in collection.cameras]).reshape(-1, 3)
    dist = np.linalg.norm(centers[:, None] - centers[None], axis=2)
    angle = np.degrees(np.arccos(np.clip(axes @ axes.T, -1.0, 1.0)))
    off = dist + np.diag(np.full(n, np.inf))
    spacing = float(np.median(off.min(axis=1)))
    shared = _shared_counts(collection)
    ok = (angle <= max_axis_angle_deg) & (dist <= near_factor * spacing)  # rules 1 and 2
    if len(collection.observations):
        ok &= shared >= min_shared_points  # rule 3
    i, j = np.nonzero(np.triu(ok, k=1))
    if len(i) == 0:
        raise ValueError(f"the collection has no overlapping pairs of cameras: none is within "
                         f"{max_axis_angle_deg:g}° in direction, {near_factor:g} spacings in position "
                         f"and sharing {min_shared_points} points")  # fmt: skip
    edges = np.stack([i, j], axis=1).astype(np.int64)
    out = {"edges": edges, "axis_angle_deg": angle[i, j], "baseline": dist[i, j],
           "shared_points": shared[i, j].astype(np.int64), "centers": centers}
    for value in out.values():
        value.flags.writeable = False
    return CameraGraph(n_nodes=n, **out)


def _spanning_forest(graph: CameraGraph) -> list[tuple[int, int]]:
    """Kruskal's minimum spanning forest by baseline (ties by node indices)."""
    parent = list(range(graph.n_nodes))

    def root(v: int) -> int:
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    order = np.lexsort((graph.edges[:, 1], graph.edges[:, 0], graph.baseline))
    tree = []
    for k in order:
        a, b = (int(v) for v in graph.edges[k])
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[ra] = rb
            tree.append((a, b))
    return tree


def _farthest(adj: dict[int, set[int]], start: int) -> tuple[int, dict[int, int]]:
    """The node farthest (in hops) from ``start`` and the BFS parents."""
    parents, frontier, last = {start: -1}, [start], start
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(adj[v]):
                if w not in parents:
                    parents[w] = v
                    nxt.append(w)
        if nxt:
            last = min(nxt)
        frontier = nxt
    return last, parents


def capture_paths(graph: CameraGraph) -> list[list[int]]:
    """The capture path of the collection as polylines of node indices.

    The minimum spanning forest of the graph (by baseline) is cut into chains, longest first
    (each chain is the longest path left in its tree; a branch shares the node it leaves from).
    A tree that is one chain whose ends are joined by a short graph edge (:data:`RING_CLOSURE`)
    is a ring: its polyline is closed, starting at its smallest node towards the smaller
    neighbour, and repeats that node at the end. An open polyline starts at its smaller end; a
    camera with no edge is a polyline of one node. Polylines are ordered by their first node.

    Examples
    --------
    A ring of 12 cameras gives ``[[0, 1, ..., 11, 0]]``; a walk of 5 gives ``[[0, 1, 2, 3, 4]]``.
    """
    if not isinstance(graph, CameraGraph):
        raise TypeError(f"graph must be a CameraGraph; got {type(graph).__name__}")
    joined = {(int(a), int(b)): float(d) for (a, b), d in zip(graph.edges, graph.baseline)}
    adj: dict[int, set[int]] = {v: set() for v in range(graph.n_nodes)}
    for a, b in _spanning_forest(graph):
        adj[a].add(b)
        adj[b].add(a)
    paths: list[list[int]] = []
    seen: set[int] = set()
    for v in range(graph.n_nodes):
        if v in seen:
            continue
        _, parents = _farthest(adj, v)
        component = set(parents)
        seen |= component
        if len(component) == 1:
            paths.append([v])
            continue
        is_chain = all(len(adj[u]) <= 2 for u in component)
        while any(adj[u] for u in component):
            start = min(u for u in component if adj[u])
            end, _ = _farthest(adj, start)
            far, par = _farthest(adj, end)
            chain = [far]
            while par[chain[-1]] != -1:
                chain.append(par[chain[-1]])
            for a, b in zip(chain, chain[1:]):
                adj[a].discard(b)
                adj[b].discard(a)
            step = max(joined[min(a, b), max(a, b)] for a, b in zip(chain, chain[1:]))
            closing = joined.get((min(chain[0], chain[-1]), max(chain[0], chain[-1])), np.inf)
            ring = is_chain and len(chain) >= 3 and closing <= RING_CLOSURE * step
            paths.append(_normalised(chain, ring))
            is_chain = False
    return sorted(paths, key=lambda p: (p[0], len(p)))


def _normalised(chain: list[int], closed: bool) -> list[int]:
    if not closed:
        return chain if chain[0] <= chain[-1] else chain[::-1]
    k = chain.index(min(chain))
    ring = chain[k:] + chain[:k]
    if ring[-1] < ring[1]:
        ring = [ring[0]] + ring[1:][::-1]
    return ring + [ring[0]]
