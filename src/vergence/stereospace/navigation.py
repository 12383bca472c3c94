"""Browsing the stereospace by zoom and pan, with jumps between regions (S2 §4.1).

``zoom`` moves the parameters ``(li, lj)`` along the gradient of the interocular distance s_w, ``pan``
along the tangent ``T`` (``T · ∇s_w = 0``), so that the view position moves at constant interocular
distance (S2 §4.1, Fig. 8). Steps are in metres of the space (the units of the camera centres), what a
viewer feels: ``zoom(v)`` changes s_w by ``v`` to first order, ``pan(v)`` moves the view position by
``v`` to first order. Where a move cannot continue inside its region, the view jumps to the closest
stereo point of another region inside a cone around the direction of movement (S2 §4.1).

Decisions (S2 leaves them open)
-------------------------------
- The cone of S2 §4.1 ("angle 40") is read as a half-angle: a candidate ``q`` qualifies when the angle
  between ``q - p`` and the direction of movement is at most :data:`JUMP_CONE_DEG`.
- The candidates are found as S2's implementation does, on a tessellation of every region
  (:data:`JUMP_SAMPLES` per side), then refined twice around each region's best sample, so the jump
  lands within about ``(2 / (JUMP_SAMPLES - 1))**3`` in parameter of the true closest point.
- A zoom whose gradient points out of the region slides along the border (the projected gradient):
  on a polyline of cameras one eye then keeps moving when the other reaches the end of its segment.
  It jumps only where the projected gradient vanishes (a corner). A pan never slides (that would change
  the interocular distance): it jumps, or stops, where its line leaves the region.
- Positive pan moves the view position along the baseline (from the first eye to the second).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vergence._validate import check_finite, check_in_range
from vergence.stereospace.space import JUMP_CONE_DEG, StereoSpace, StereoState

__all__ = ["JUMP_CONE_DEG", "JUMP_SAMPLES", "MAX_PAN_JUMPS", "MOVE_EVENTS", "Move", "pan", "pan_sign", "tangent",
           "zoom"]

JUMP_SAMPLES = 17
"""Samples per side of the tessellation of a region searched for a jump: 289 per region; with the two
refinements the landing point is within about 5e-4 in parameter of the closest point of the region."""

MAX_PAN_JUMPS = 8
"""Jumps one :func:`pan` may make while it spends its step (each jump lands at a region's closest
point in the cone, so a step longer than a few regions' widths ends after this many)."""

MOVE_EVENTS = ("moved", "jumped", "stopped")
"""What a move did: stayed in its region, jumped to another region, or stopped at the border (no
region in the cone)."""

_REFINEMENTS = 2


@dataclass(frozen=True, slots=True)
class Move:
    """The result of :func:`zoom` or :func:`pan`: the new state and what happened (:data:`MOVE_EVENTS`)."""

    state: StereoState
    event: str


def _frame(space: StereoSpace, state: StereoState):
    """Parameters, segment directions u_i, u_j (3,), the eyes (2, 3) and the gradient of s_w (2,)."""
    state = space.check_state(state)
    lam = np.array([state.li, state.lj])
    si, sj = space.segments[state.region[0]], space.segments[state.region[1]]
    return state, lam, si[1] - si[0], sj[1] - sj[0], space._eyes(state.region, *lam), space._jacobian(state.region, lam)[3]


def _vanishes(g: np.ndarray, ui: np.ndarray, uj: np.ndarray) -> bool:
    """True where the gradient is zero up to round-off on the scale of the segments."""
    return float(np.linalg.norm(g)) <= 1e-12 * max(float(np.linalg.norm(ui) + np.linalg.norm(uj)), 1e-300)


def tangent(space: StereoSpace, state: StereoState) -> np.ndarray:
    """The unit pan direction ``T`` in parameter space: ``T · ∇s_w = 0`` (S2 §4.1), shape (2,).

    ``T = (-g_j, g_i) / |g|``, signed so that the view position moves along the baseline. Where the
    gradient vanishes (s_w at its minimum over the region's plane) ``T`` is the direction of slowest
    growth of s_w, the last right singular vector of ``[u_i, -u_j]``.
    """
    state, lam, ui, uj, eyes, g = _frame(space, state)
    if _vanishes(g, ui, uj):
        T = np.linalg.svd(np.stack([ui, -uj], axis=1))[2][-1]
    else:
        T = np.array([-g[1], g[0]]) / np.linalg.norm(g)
    mid_rate = (ui * T[0] + uj * T[1]) / 2.0
    if float(mid_rate @ (eyes[1] - eyes[0])) < 0.0:
        T = -T
    return T


def pan_sign(space: StereoSpace, state: StereoState, *, forward: object, up: object) -> float:
    """The sign (1.0 or -1.0) of the :func:`pan` that moves the view position to the viewer's right.

    The viewer's right is the world direction ``forward x up`` (camera frame: x right, y down, z
    forward, so ``x = (-up) x forward``), ``forward`` the view's direction (e.g. the sum of the eyes'
    optical axes) and ``up`` the collection's (:func:`~vergence.stereospace.collection_up`); the
    sign is that of the view position's rate ``(u_i T_i + u_j T_j) / 2`` along it (:func:`tangent`).
    Unlike the order of the eyes (``eye_order``, which flips where the baseline turns past the
    view's axis inside a region, e.g. kermit's region (13, 15)), it depends only on where the view
    looks, so successive presses of one arrow key keep moving the same way in the world
    (issue 30). 1.0 where the rate has no component along the right (a forward along up).

    Raises
    ------
    ValueError
        A ``forward`` or ``up`` that is not 3 finite numbers; a state outside the space.
    """
    f = np.asarray(forward, dtype=np.float64)
    u = np.asarray(up, dtype=np.float64)
    for name, v in (("forward", f), ("up", u)):
        if v.shape != (3,) or not np.isfinite(v).all():
            raise ValueError(f"{name} must be 3 finite numbers; got {np.asarray(v).tolist()!r}")
    state, _, ui, uj, _, _ = _frame(space, state)
    T = tangent(space, state)
    rate = (ui * T[0] + uj * T[1]) / 2.0
    return -1.0 if float(rate @ np.cross(f, u)) < 0.0 else 1.0


def zoom(space: StereoSpace, state: StereoState, v: float, *, cone_deg: float = JUMP_CONE_DEG) -> Move:
    """Change the interocular distance by ``v`` (metres, to first order) along its gradient (S2 §4.1).

    ``[li, lj] += v ∇s_w / |∇s_w|²``; a component pushing out of the region is dropped (slide along the
    border). Where the gradient vanishes, the step follows the direction of fastest growth (the first
    right singular vector of ``[u_i, -u_j]``) with the length that grows s_w by ``v`` exactly.
    When no step is possible inside the region, the view jumps (see the module docstring).

    Returns
    -------
    Move
        The new state and ``"moved"``, ``"jumped"`` or ``"stopped"``.
    """
    state, lam, _, _, _, _ = _frame(space, state)
    v = check_finite("v", v)
    cone_deg = check_in_range("cone_deg", cone_deg, 0.0, 90.0)
    if v == 0.0:
        return Move(state, "moved")
    start, remaining = lam.copy(), v
    for _ in range(3):  # to a border, along it to a corner, and no further
        delta = _zoom_step(space, state, lam, remaining)
        if not np.any(delta):  # every component pushes out of the region
            break
        t = _exit_fraction(state, lam, delta)
        moved = _project(state, lam + t * delta)
        lam, remaining = np.array([moved.li, moved.lj]), remaining * (1.0 - t)
        if t >= 1.0:
            break
    if remaining != v:
        return Move(StereoState(state.region, float(lam[0]), float(lam[1])), "moved")
    delta = _zoom_step(space, state, lam, v, slide=False)
    direction = space._points(state.region, (lam + delta)[None])[0] - space._points(state.region, lam[None])[0]
    if not np.any(np.abs(direction) > 1e-12):
        direction = np.array([0.0, 0.0, 0.0, math.copysign(1.0, v)])  # s_w grows or shrinks, to no side
    return _jump_or_stop(space, state, lam, direction, cone_deg)


def _zoom_step(space: StereoSpace, state: StereoState, lam: np.ndarray, v: float, *, slide: bool = True) -> np.ndarray:
    """The parameter step of a zoom by ``v`` at ``lam`` (see :func:`zoom`), slid along the border."""
    state, _, ui, uj, eyes, g = _frame(space, StereoState(state.region, float(lam[0]), float(lam[1])))
    if not _vanishes(g, ui, uj):
        delta = v * g / float(g @ g)
    else:  # s_w at its minimum over the plane: it grows by sqrt(n0² + σ² t²) - n0 along w
        _, sv, vt = np.linalg.svd(np.stack([ui, -uj], axis=1))
        n0 = float(np.linalg.norm(eyes[1] - eyes[0]))
        if sv[0] == 0.0 or v < 0.0:
            return np.zeros(2)
        t = math.sqrt((n0 + v) ** 2 - n0 * n0) / sv[0]
        delta = max((t * vt[0], -t * vt[0]), key=lambda d: _exit_fraction(state, lam, d))
    if not slide:
        return delta
    slid = _slide(state, lam, delta)
    if not _vanishes(g, ui, uj) and float(g @ slid) * v > 0.0:
        slid *= v / float(g @ slid)  # along the border s_w still grows by v to first order
    return slid


def pan(space: StereoSpace, state: StereoState, v: float, *, cone_deg: float = JUMP_CONE_DEG) -> Move:
    """Move the view position by ``v`` (metres, to first order) at constant interocular distance (S2 §4.1).

    ``[li, lj] += v T / |M T|`` with ``T`` from :func:`tangent` and ``M = [u_i, u_j] / 2`` the rate of
    the view position; s_w is constant to first order. If the step leaves the region, the view jumps
    from the border, or stops there; after a jump the rest of the step (``v`` less the part taken in
    the region left) goes on in the region landed in, in the same world direction, through up to
    :data:`MAX_PAN_JUMPS` jumps. The event is ``"jumped"`` when any jump happened (even if the view
    then stopped at a border), ``"stopped"`` when it stopped without one.
    """
    state, lam, ui, uj, _, _ = _frame(space, state)
    v = check_finite("v", v)
    cone_deg = check_in_range("cone_deg", cone_deg, 0.0, 90.0)
    T = tangent(space, state)
    rate = float(np.linalg.norm(ui * T[0] + uj * T[1])) / 2.0
    if v == 0.0:
        return Move(state, "moved")
    if rate <= 1e-12 * max(float(np.linalg.norm(ui) + np.linalg.norm(uj)), 1e-300):
        return Move(state, "stopped")  # a region of zero-length segments: nothing to pan along
    event, remaining = "moved", v
    for _ in range(MAX_PAN_JUMPS + 1):
        delta = remaining * T / rate
        t = _exit_fraction(state, lam, delta)
        if t >= 1.0:
            return Move(_project(state, lam + delta), event)
        direction = space._points(state.region, (lam + delta)[None])[0] - space._points(state.region, lam[None])[0]
        border = _project(state, lam + t * delta)
        moved = _jump_or_stop(space, border, np.array([border.li, border.lj]), direction, cone_deg)
        if moved.event == "stopped":
            return moved if event == "moved" else Move(moved.state, event)
        # the rest of the pan goes on from where the view landed, the same way in the world
        event, remaining = "jumped", abs(remaining) * (1.0 - t)
        state, lam, ui, uj, _, _ = _frame(space, moved.state)
        T = tangent(space, state)
        rate = float(np.linalg.norm(ui * T[0] + uj * T[1])) / 2.0
        if rate <= 1e-12 * max(float(np.linalg.norm(ui) + np.linalg.norm(uj)), 1e-300) or remaining <= 0.0:
            return Move(state, event)
        onward = space._points(state.region, (lam + T)[None])[0, :3] - space._points(state.region, lam[None])[0, :3]
        if float(onward @ direction[:3]) < 0.0:
            remaining = -remaining
    return Move(state, event)


# -- the region's border ---------------------------------------------------------------------------
def _exit_fraction(state: StereoState, lam: np.ndarray, delta: np.ndarray) -> float:
    """Largest t in [0, 1] with lam + t delta in the region (the square, and li <= lj on a triangle)."""
    t = 1.0  # each ratio is taken only where the full step crosses: it lies in [0, 1], no overflow
    for k in range(2):
        if lam[k] + delta[k] > 1.0:
            t = min(t, (1.0 - lam[k]) / delta[k])
        elif lam[k] + delta[k] < 0.0:
            t = min(t, -lam[k] / delta[k])
    gap, rate = lam[1] - lam[0], delta[1] - delta[0]
    if state.region[0] == state.region[1] and gap + rate < 0.0:
        t = min(t, gap / -rate)
    return max(t, 0.0)


def _slide(state: StereoState, lam: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """``delta`` without its components that push out through a border that ``lam`` is on."""
    delta = delta.copy()
    out = ((lam <= 0.0) & (delta < 0.0)) | ((lam >= 1.0) & (delta > 0.0))
    delta[out] = 0.0
    if state.region[0] == state.region[1] and lam[0] >= lam[1] and delta[0] > delta[1]:
        delta[:] = delta.mean()  # along the diagonal li = lj of the triangle
        if (((lam <= 0.0) & (delta < 0.0)) | ((lam >= 1.0) & (delta > 0.0))).any():
            delta[:] = 0.0  # a corner of the triangle
    return delta


def _project(state: StereoState, lam: np.ndarray) -> StereoState:
    """The state of the closest parameters of the region to ``lam``."""
    lam = np.clip(lam, 0.0, 1.0)
    if state.region[0] == state.region[1] and lam[0] > lam[1]:
        lam[:] = lam.mean()
    return StereoState(state.region, float(lam[0]), float(lam[1]))


# -- the jump (S2 §4.1) ----------------------------------------------------------------------------
def _jump_or_stop(space: StereoSpace, state: StereoState, lam: np.ndarray, direction: np.ndarray, cone_deg: float) -> Move:
    """Jump to the closest stereo point of another region inside the cone, or stop at ``state``.

    Candidates whose baseline keeps the orientation of the current one (positive dot product) come
    first (S2 §4.2: the solution "more coherent with the rectified camera orientation"); among them the
    closest wins. Every region is searched on its coarse tessellation; only the regions whose coarse
    best could still win after refinement are refined.
    """
    p = space._points(state.region, lam[None])[0]
    eyes = space._eyes(state.region, *lam)
    baseline = eyes[1] - eyes[0]
    cos_max = math.cos(math.radians(cone_deg))
    length = float(np.linalg.norm(direction))
    if not length > 0.0:  # a step too small to point anywhere
        return Move(state, "stopped")
    unit = direction / length
    coarse = _coarse_candidates(space, state.region, p, unit, cos_max, baseline)
    if not coarse:
        return Move(state, "stopped")
    leader = min(coarse, key=_rank)
    cell = 1.0 / (JUMP_SAMPLES - 1)
    best = None
    for found in coarse:
        si, sj = space.segments[found.region[0]], space.segments[found.region[1]]
        # |d s / d λ| <= 1.5 (|u_i| + |u_j|): a finer tessellation gains at most that times a cell
        reach = 1.5 * (np.linalg.norm(si[1] - si[0]) + np.linalg.norm(sj[1] - sj[0])) * cell * math.sqrt(2.0)
        if found.agrees < leader.agrees or found.distance - reach > leader.distance:
            continue
        refined = _closest_in_cone(space, found.region, p, unit, cos_max, baseline, refinements=_REFINEMENTS)
        if best is None or _rank(refined) < _rank(best):
            best = refined
    return Move(StereoState(best.region, float(best.lam[0]), float(best.lam[1])), "jumped")


@dataclass(frozen=True, slots=True)
class _Candidate:
    region: tuple[int, int]
    lam: np.ndarray
    distance: float
    agrees: bool  # its baseline keeps the orientation of the current one


def _rank(found: _Candidate) -> tuple[bool, float]:
    return (not found.agrees, found.distance)


def _coarse_candidates(space, current, p, unit, cos_max, baseline) -> list[_Candidate]:
    """Each other region's best sample on the coarse tessellation, all regions at once: the compiled
    :func:`_closest_in_cone` without refinement (:mod:`vergence.stereospace._navigation_kernels`; the
    tests check they agree). dino's 4,371 regions take a few milliseconds (numpy arrays of every
    sample of every region took 0.3-0.8 s on two cores)."""
    from vergence.stereospace._navigation_kernels import coarse_candidates

    regions = np.array([r for r in space.regions if r != tuple(current)], dtype=np.int64).reshape(-1, 2)
    grid = np.linspace(0.0, 1.0, JUMP_SAMPLES)
    seg = space.segments
    s0 = np.ascontiguousarray(seg[:, 0], dtype=np.float64)
    u = np.ascontiguousarray(seg[:, 1] - seg[:, 0], dtype=np.float64)
    n = len(regions)
    found, agrees = np.zeros(n, np.bool_), np.zeros(n, np.bool_)
    best_k, best_dist = np.zeros(n, np.int64), np.zeros(n, np.float64)
    coarse_candidates(s0, u, regions, grid, np.ascontiguousarray(p, dtype=np.float64),
                      np.ascontiguousarray(unit, dtype=np.float64), float(cos_max),
                      np.ascontiguousarray(baseline, dtype=np.float64), float(space.tolerance),
                      found, best_k, best_dist, agrees)  # fmt: skip
    g = len(grid)
    return [_Candidate((int(regions[r, 0]), int(regions[r, 1])),
                       np.array([grid[best_k[r] // g], grid[best_k[r] % g]]), float(best_dist[r]), bool(agrees[r]))
            for r in np.flatnonzero(found)]  # fmt: skip


def _closest_in_cone(space, region, p, unit, cos_max, baseline, *, refinements: int) -> _Candidate | None:
    """The region's closest sample to ``p`` inside the cone, orientation first; None if none is in it."""
    axes = (np.linspace(0.0, 1.0, JUMP_SAMPLES),) * 2
    si, sj = space.segments[region[0]], space.segments[region[1]]
    best = None
    for _ in range(refinements + 1):
        lam = np.stack([x.ravel() for x in np.meshgrid(*axes, indexing="ij")], axis=1)
        if region[0] == region[1]:
            lam = lam[lam[:, 0] <= lam[:, 1]]
        if best is not None:
            lam = np.vstack([lam, best.lam])
        q = space._points(region, lam) - p
        dist = np.linalg.norm(q, axis=1)
        ok = (dist > space.tolerance) & (q @ unit >= cos_max * dist)
        base = (sj[0] + lam[:, 1:] * (sj[1] - sj[0])) - (si[0] + lam[:, :1] * (si[1] - si[0]))
        agree = base @ baseline >= 0.0
        agrees = bool((ok & agree).any())
        if agrees:
            ok &= agree
        if not ok.any() or (best is not None and best.agrees and not agrees):
            return best
        lam, dist, base = lam[ok], dist[ok], base[ok]
        near = dist <= dist.min() + space.tolerance  # ties: the pair closest to the current orientation
        k = np.flatnonzero(near)[np.argmax(base[near] @ baseline)]
        best = _Candidate(region, lam[k].copy(), float(dist[k]), agrees)
        h = (axes[0][1] - axes[0][0], axes[1][1] - axes[1][0])
        axes = tuple(np.linspace(max(0.0, lam[k, n] - h[n]), min(1.0, lam[k, n] + h[n]), JUMP_SAMPLES) for n in range(2))
    return best
