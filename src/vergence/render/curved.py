"""Curved rays: a pinhole camera of a distorted world, traced through the real scene (S0 §6).

S0 §6 renders the Tri-Rig's right image in a distorted world ``phi(scene)`` seen by straight rays,
and S0 §7 regrets that "we do not have a reference image to compare with". This module makes one:
the straight ray of pixel ``(x, y)`` of ``camera`` in the distorted world,

    q(z) = c + z r,    r = R^T K^-1 (x, y, 1)        (z: camera-frame depth, c the camera centre)

is, in the real scene, the curve ``P(z) = phi^-1(q(z))`` (``to_world = phi^-1``, e.g.
``WorldDistortion.inverse``, S0 §6 / Fig. 9). Its first intersection with the real scene is what
that pixel sees; lighting is computed in the real world only ("the distorted world should not be
used to compute ... illumination", S0 §7).

**Sampling rule** (:func:`sample_curves`). Each curve is first sampled at depths from ``near`` to
``far`` in geometric progression, each step at most :data:`MAX_DEPTH_RATIO` (an octave) and at
least :data:`INITIAL_SEGMENTS` steps; then every segment ``[u_a, u_b]`` (``u = 1/z``) is bisected
in inverse depth while the mapped midpoint ``P_m = P(2 / (u_a + u_b))`` lies more than
``tolerance_px`` pixels from the chord ``[P_a, P_b]``, at most :data:`MAX_SPLIT_LEVELS` times. The
distance is measured as the camera sees it: the real-world gap ``e = P_m - C`` (``C`` the point of
the chord nearest ``P_m``) is pulled back to the distorted world through the local Jacobian of
``to_world``, ``e = a J_x + b J_y + s (P_b - P_a)``, where ``J_x``, ``J_y`` are the real-world
displacements of a one-pixel step at depth ``z_m`` (finite differences of ``to_world``) and the
chord carries the along-ray part; the gap is ``hypot(a, b)`` pixels. Steps equal in ``u`` are
steps equal in disparity, in which the Tri-Rig's distortion is defined (``z' = D_r^-1(psi(D_r(z)))``,
S0 §6). A curve smooth in ``u`` is locally quadratic, its largest gap to a chord at the midpoint;
the quarter points are tested too, since a segment across an inflection of psi can have its
midpoint on the chord (measured on the stadium Tri-Rig: up to 0.94 px off at a 0.25 px tolerance
with the midpoint alone). Straight and affine maps need no split.

**Cost.** ``to_world`` is called once per bisection level for all the rays being sampled (up to
``_CHUNK_RAYS``), and maps each point once: a split segment's children have the parent's quarter
points as midpoints (the quarter points are computed as the children's midpoints, bit for bit), and
the one-pixel steps of ``J_x``, ``J_y`` are the midpoints of the neighbouring pixels' segments of the
same level where those exist (the same point, to rounding). On the stadium Tri-Rig at 320 x 180 this
maps 92 points per ray instead of 182, with the same polylines (issue 31).

**Far end.** ``far = inf`` cuts the sampling at :data:`CURVE_CUT_DEPTH`; the last segment then
continues without bound. Where ``to_world`` returns NaN (or inf) the curve is undefined: the ray
ends at the last defined sample before it (the boundary located by bisection) without a hit.

**Casting.** The rays are followed one first segment (octave) at a time, sampled then cast, so
nothing is sampled past a hit. Segments are cast in order, one Mitsuba call per round over the rays
still alive (first hit wins); segment ``k`` runs from sample ``k`` to sample ``k+1`` with ``tmax``
its length plus :data:`JOINT_OVERLAP` (``1 + |P|_inf``): a hit exactly at a joint is found by the
earlier segment, never missed between two casts nor counted twice (the ray stops at its first hit).
The hits are shaded once, by :meth:`~vergence.render.Tracer.trace_rays` from the hit segment's
origin along its direction (so reflections, refraction and AO see the real incoming direction).
A hit's distorted depth is that of the curve point it lies across from on its segment, found by
bisection (``_hit_depth``); a ray without a hit takes the environment along its last segment.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from vergence._validate import check_positive
from vergence.camera import Camera
from vergence.render.limits import MAX_RENDER_SIDE, render_cost
from vergence.render.raytree import Progress, Tracer, check_render_options
from vergence.render.results import RenderResult, RenderSettings
from vergence.render.scene import MAX_SCENE_EXTENT, Scene

__all__ = ["CURVE_CUT_DEPTH", "CurveSamples", "DEPTH_BISECTIONS", "INITIAL_SEGMENTS", "JOINT_OVERLAP",
           "MAX_DEPTH_RATIO", "MAX_MEAN_SEGMENTS", "MAX_SPLIT_LEVELS", "MIN_NEAR", "render_curved", "sample_curves",
           "trace_curved"]  # fmt: skip

#: Fewest segments per ray before any split: more than one so that a curve that bends one way then
#: the other (an inflection at the single midpoint) is still tested.
INITIAL_SEGMENTS = 4
#: Largest ratio of far to near depth of a first segment: the first samples are spaced by at most an
#: octave of depth, so a bend far from the camera is not hidden inside one segment whose midpoint in
#: ``1/z`` lies near the camera (from 0.5 m to CURVE_CUT_DEPTH: 20 segments).
MAX_DEPTH_RATIO = 2.0
#: Bisections of a segment at most: 2^-12 of a first segment's span in 1/z. A smooth curve
#: meets the tolerance far sooner (the gap falls 4x per split); the bound stops a curve that is not
#: smooth, and locates where ``to_world`` becomes undefined to that resolution.
MAX_SPLIT_LEVELS = 12
#: Mean segments per ray and first segment (an octave of depth) allowed while sampling: a map too
#: rough to follow is refused by name (MAX_SPLIT_LEVELS alone lets a first segment become 4096, and
#: 32,768 rays x 4096 segments x ~80 bytes is ~10 GiB).
MAX_MEAN_SEGMENTS = 64
#: Distorted depth (metres) where ``far = inf`` is cut, the last segment continuing without bound
#: (a larger finite ``far`` is cut there too): the diagonal of the scene's cube
#: (2 sqrt(3) MAX_SCENE_EXTENT), past which a straight ray from any camera in the scene has left
#: every object behind.
CURVE_CUT_DEPTH = 2.0 * np.sqrt(3.0) * MAX_SCENE_EXTENT
#: Smallest ``near``, metres (a micrometre): 39 octaves of depth to CURVE_CUT_DEPTH. Each octave is
#: a round of casts for every ray still alive; a smaller ``near`` only adds empty rounds.
MIN_NEAR = 1e-6
#: Overlap of consecutive segments, relative to ``1 + |P|_inf`` at the joint: 10x the float32
#: rounding of Mitsuba's cast (~1e-6 relative), so a hit at a joint is inside the earlier cast.
JOINT_OVERLAP = 1e-5
#: Bisections locating a hit's distorted depth on its segment (_hit_depth): 2^-26 of the segment's
#: span in inverse depth, far below the float32 precision of the depth map.
DEPTH_BISECTIONS = 26

# Share of progress given to sampling and casting the curves; shading the first hits takes the rest
# (the smaller part where to_world is costly, as the Tri-Rig distortion).
_SAMPLING_SHARE = 0.8
_CHUNK_RAYS = 1 << 16  # rays sampled and cast together: bounds the segment arrays (MAX_MEAN_SEGMENTS: < 0.5 GiB)


@dataclass(frozen=True, slots=True, eq=False)
class CurveSamples:
    """The polylines of curved rays, samples in order of increasing distorted depth.

    Attributes
    ----------
    points : (S, 3) float64
        Real-world samples ``P(z_j) = to_world(q(z_j))``, metres.
    depth : (S,) float64
        Their distorted camera-frame depths ``z_j``, metres.
    start : (n + 1,) int64
        Ray ``i`` owns ``points[start[i]:start[i + 1]]``: none (undefined from ``near`` on) or >= 2.
    open_end : (n,) bool
        The ray's last segment continues without bound (``far = inf`` and the curve reached the cut).
    """

    points: np.ndarray
    depth: np.ndarray
    start: np.ndarray
    open_end: np.ndarray

    @property
    def segments(self) -> np.ndarray:
        """Segments per ray ``(n,)``: samples minus one, 0 for a ray without samples."""
        return np.maximum(np.diff(self.start) - 1, 0)


def _check_curve_options(camera, to_world, near, far, tolerance_px) -> tuple[float, float, float]:  # noqa: ANN001
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pinhole vergence.camera.Camera; got {type(camera).__name__}")
    if not callable(to_world):
        raise TypeError(f"to_world must be a callable (points (..., 3) -> (..., 3)); got {type(to_world).__name__}")
    near = check_positive("near", near)
    if near < MIN_NEAR:
        raise ValueError(f"near must be >= {MIN_NEAR:g} m (MIN_NEAR); got {near:g}")
    if isinstance(far, bool) or not isinstance(far, int | float | np.integer | np.floating):
        raise TypeError(f"far must be a number (inf allowed); got {type(far).__name__}")
    far = float(far)
    if not far > near:  # NaN fails too
        raise ValueError(f"far must be > near = {near:g} (inf allowed); got {far:g}")
    return near, far, check_positive("tolerance_px", tolerance_px)


def _map(to_world, q: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """``to_world(q)`` as float64 of q's shape, non-finite rows set to NaN (undefined)."""
    out = to_world(q)
    try:
        p = np.asarray(out, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"to_world must return a numeric array; {err}") from None
    if p.shape != q.shape:
        raise ValueError(f"to_world must return an array of its input's shape {q.shape}; got {p.shape}")
    p[~np.isfinite(p).all(axis=-1)] = np.nan
    return p


def _gap_px(pa, pb, pm, jx, jy) -> np.ndarray:  # noqa: ANN001
    """Pixels between ``pm`` and the chord ``[pa, pb]``, pulled back through ``[J_x, J_y, pb - pa]`` (module notes)."""
    chord = pb - pa
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.clip(np.einsum("ij,ij->i", pm - pa, chord) / np.einsum("ij,ij->i", chord, chord), 0.0, 1.0)
        e = pm - (pa + s[:, None] * chord)
        yr = np.cross(jy, chord)
        det = np.einsum("ij,ij->i", jx, yr)
        a = np.einsum("ij,ij->i", e, yr) / det  # Cramer's rule for e = a J_x + b J_y + s' chord
        b = np.einsum("ij,ij->i", jx, np.cross(e, chord)) / det
        return np.hypot(a, b)  # NaN or inf where the frame is degenerate or a point undefined: split


def _initial_grid(u_near: float, u_far: float) -> np.ndarray:
    """Inverse depths of the first samples: depths in geometric progression of ratio <= MAX_DEPTH_RATIO.

    At least :data:`INITIAL_SEGMENTS` segments; the ends are exactly ``u_near`` and ``u_far``.
    """
    octaves = np.log(u_near / u_far) / np.log(MAX_DEPTH_RATIO)
    m = max(INITIAL_SEGMENTS, int(np.ceil(octaves - 1e-9)))  # a ratio of exactly 2^k needs no extra segment
    grid = u_near * (u_far / u_near) ** (np.arange(m + 1) / m)
    grid[0], grid[-1] = u_near, u_far
    return grid


def _neighbours(pixel: np.ndarray, path: np.ndarray, width: int, span: int) -> tuple[np.ndarray, np.ndarray]:
    """Index of the segment of the pixel to the right and of the pixel below with the same ``path``, -1 if absent.

    Segments of one level with the same path (the same bisections of the same first segment) span the
    same inverse depths bit for bit, so the midpoint of the right neighbour's segment is this
    midpoint moved one pixel in x, ``q_m + z_m (K^-1 e_x)``: the point the forward difference of
    ``J_x`` needs (``J_y`` likewise with the pixel below).
    """
    key = pixel * span + path
    order = np.argsort(key, kind="stable")
    sk = key[order]

    def find(q: np.ndarray, valid: np.ndarray) -> np.ndarray:
        i = np.minimum(np.searchsorted(sk, q), len(sk) - 1)
        return np.where(valid & (sk[i] == q), order[i], -1)

    return find(key + span, pixel % width != width - 1), find(key + width * span, np.ones(len(key), dtype=bool))


def _jacobian(to_world, pm, qm, step, mapped, nb) -> np.ndarray:  # noqa: ANN001
    """``J = P(q_m + step) - P_m``, the forward point from the neighbour ``nb`` (or ``mapped``, ``to_world(q_m +
    step)``, where it has none); backward, ``P_m - P(q_m - step)``, where the forward one is undefined; NaN where
    both are (the gap cannot be measured there and the segment is kept: the map is undefined within a pixel of
    the curve on both sides)."""
    from vergence.render._kernels import neighbour_steps

    j = neighbour_steps(pm, nb, np.ascontiguousarray(mapped))
    bad = np.isnan(j[:, 0]) & ~np.isnan(pm[:, 0])
    if bad.any():
        j[bad] = pm[bad] - _map(to_world, qm[bad] - step[bad])
    return j


def _sample_chunk(center, r, step_x, step_y, to_world, grid, open_far, tol, pixel=None, width=1):  # noqa: ANN001, ANN202
    """Adaptive polylines of rays ``q(z) = center + z r`` over the inverse depths ``grid`` (module notes).

    ``step_*``: one pixel at unit depth. Returns the :class:`CurveSamples` and, per ray, whether the
    curve became undefined within ``grid`` (the ray ends there).

    All rays advance one bisection level at a time, each level's points mapped by one call of
    ``to_world``. A point is mapped once: a split segment's children have the parent's quarter points
    as their midpoints, and the one-pixel steps of ``J_x``, ``J_y`` are the midpoints of the
    neighbouring pixels' segments of the same level where those exist (``pixel``: each ray's flat
    pixel index in an image ``width`` wide; :func:`_neighbours`). Without neighbours every step is mapped
    by ``to_world`` itself (the reference of this bookkeeping in the tests), and :func:`_gap_px` (numpy)
    is the reference of the gap kernel.
    """
    from vergence.render._kernels import segment_gaps_ok

    n, m = len(r), len(grid) - 1
    pixel = np.arange(n) if pixel is None else np.asarray(pixel, dtype=np.int64)
    span = m << (MAX_SPLIT_LEVELS + 1)
    ends = _map(to_world, center + r[:, None, :] / grid[None, :, None])
    undefined = np.isnan(ends[..., 0])
    u_end = np.where(undefined.any(axis=1), grid[np.argmax(undefined, axis=1)], -np.inf)  # first NaN's u
    ray = np.repeat(np.arange(n), m)
    path = np.tile(np.arange(m), n)
    ua, ub = np.tile(grid[:-1], n), np.tile(grid[1:], n)
    pa, pb = ends[:, :-1].reshape(-1, 3), ends[:, 1:].reshape(-1, 3)
    last = np.tile(np.arange(m) == m - 1, n) & open_far
    known = None  # the midpoints mapped at the level before (its quarter points)
    done: list[tuple[np.ndarray, ...]] = []
    total = 0
    for level in range(MAX_SPLIT_LEVELS + 1):
        keep = ua > u_end[ray]  # segments from the first undefined sample on are dropped
        ray, path, ua, ub, pa, pb, last = (v[keep] for v in (ray, path, ua, ub, pa, pb, last))
        known = None if known is None else known[keep]
        if not len(ray):
            break
        k = len(ray)
        um = 0.5 * (ua + ub)
        zm = (1.0 / um)[:, None]
        rr = r[ray]
        qm = center + zm * rr
        if level < MAX_SPLIT_LEVELS:
            # the quarter points too: a segment across an inflection of psi (where the curve turns from one
            # side of its chord to the other) can have its midpoint on the chord and bend by pixels elsewhere;
            # they are the midpoints of the children if the segment is split
            zq = 1.0 / np.concatenate([0.5 * (ua + um), 0.5 * (um + ub)])
            nx, ny = _neighbours(pixel[ray], path, width, span)
            sx, sy = zm * step_x, zm * step_y
            mx, my = nx < 0, ny < 0
            parts = [qm] if known is None else []
            parts += [qm[mx] + sx[mx], qm[my] + sy[my], center + zq[:, None] * np.concatenate([rr, rr])]
            out = _map(to_world, np.concatenate(parts))
            at = k if known is None else 0
            pm = out[:k] if known is None else known
            jx = _jacobian(to_world, pm, qm, sx, out[at : at + mx.sum()], nx)
            at += int(mx.sum())
            jy = _jacobian(to_world, pm, qm, sy, out[at : at + my.sum()], ny)
            at += int(my.sum())
            pq = out[at:]
            ok = segment_gaps_ok(pa, pb, pm, jx, jy, pq[:k], pq[k:], tol)
        else:
            pm = _map(to_world, qm) if known is None else known
            ok = ~np.isnan(pb[:, 0])
        np.maximum.at(u_end, ray[np.isnan(pm[:, 0])], um[np.isnan(pm[:, 0])])
        done.append((ray[ok], ua[ok], ub[ok], pa[ok], pb[ok], last[ok]))
        total += int(ok.sum())
        if level == MAX_SPLIT_LEVELS:
            break
        s = ~ok
        ray, path, ua, ub, pa, pb, last, um, pm = (v[s] for v in (ray, path, ua, ub, pa, pb, last, um, pm))
        known = np.concatenate([pq[:k][s], pq[k:][s]])
        ray, ua, ub = np.concatenate([ray, ray]), np.concatenate([ua, um]), np.concatenate([um, ub])
        path = np.concatenate([2 * path, 2 * path + 1])
        pa, pb = np.concatenate([pa, pm]), np.concatenate([pm, pb])
        last = np.concatenate([np.zeros_like(last), last])
        if total + len(ray) > MAX_MEAN_SEGMENTS * n * m:
            raise ValueError(f"to_world bends the rays too much to follow within tolerance_px = {tol:g}: more than "
                             f"{MAX_MEAN_SEGMENTS} segments per ray and octave of depth (MAX_MEAN_SEGMENTS); "
                             "raise tolerance_px")  # fmt: skip
    parts = [np.concatenate([d[k] for d in done]) for k in range(6)] if done else None
    return _polylines(n, parts, u_end), u_end > -np.inf


def _polylines(n: int, parts, u_end: np.ndarray) -> CurveSamples:  # noqa: ANN001
    """Accepted segments ``(ray, ua, ub, pa, pb, last)``, cut at each ray's first undefined ``u_end``, as polylines."""
    if parts is None:
        return CurveSamples(np.zeros((0, 3)), np.zeros(0), np.zeros(n + 1, dtype=np.int64), np.zeros(n, dtype=bool))
    ray, ua, ub, pa, pb, last = parts
    keep = ub > u_end[ray]
    order = np.lexsort((-ua[keep], ray[keep]))
    ray, ua, ub, pa, pb, last = (v[keep][order] for v in (ray, ua, ub, pa, pb, last))
    counts = np.bincount(ray, minlength=n)
    has = counts > 0
    rank = np.cumsum(has) - has  # index of each ray among the rays with segments
    size = len(ray) + int(has.sum())
    points, depth = np.empty((size, 3)), np.empty(size)
    pos = np.arange(len(ray)) + rank[ray]
    points[pos], depth[pos] = pa, 1.0 / ua
    final = np.cumsum(counts)[has] - 1  # each ray's last segment
    points[final + rank[has] + 1], depth[final + rank[has] + 1] = pb[final], 1.0 / ub[final]
    start = np.concatenate([[0], np.cumsum(counts + has)]).astype(np.int64)
    open_end = np.zeros(n, dtype=bool)
    open_end[has] = last[final]
    return CurveSamples(points=points, depth=depth, start=start, open_end=open_end)


def _pixel_rays(camera: Camera, pixels: np.ndarray):  # noqa: ANN202
    """``r = R^T K^-1 (x, y, 1)`` of flat pixel indices, and one-pixel steps in x and y at unit depth."""
    k_inv_rt = np.linalg.inv(camera.K).T @ camera.R  # row vectors: v K^-T R = (R^T K^-1 v^T)^T
    xy = np.stack([pixels % camera.width, pixels // camera.width, np.ones(len(pixels))], axis=1).astype(np.float64)
    return xy @ k_inv_rt, k_inv_rt[0], k_inv_rt[1]


def _far_grid(near: float, far: float) -> np.ndarray:
    """The first samples' inverse depths from ``near`` to ``far``, cut at CURVE_CUT_DEPTH (or 2 near)."""
    return _initial_grid(1.0 / near, 1.0 / min(far, max(CURVE_CUT_DEPTH, 2.0 * near)))


def sample_curves(camera: Camera, to_world: Callable, *, near: float, far: float,
                  tolerance_px: float = 0.25) -> CurveSamples:  # fmt: skip
    """The polylines followed by :func:`render_curved`, one per pixel of ``camera`` (row-major).

    Parameters
    ----------
    camera : Camera
        Pinhole camera of the distorted world.
    to_world : callable
        Vectorised map ``(..., 3) -> (..., 3)`` from the distorted to the real world (``phi^-1``
        of S0 §6); NaN or inf where undefined.
    near, far : float
        Distorted camera-frame depths where the rays start and end, metres,
        ``MIN_NEAR <= near < far``; ``far = inf`` allowed: cut at :data:`CURVE_CUT_DEPTH`, the last
        segment left open (a finite ``far`` beyond it is cut there, the segment closed).
    tolerance_px : float
        Largest gap between a segment's mapped midpoint and its chord, pixels (module notes).

    Returns
    -------
    CurveSamples

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> cam = look_at([0, 0, 0], [0, 0, 1], [0, -1, 0], fov_deg=60, width=4, height=3)
    >>> sample_curves(cam, lambda q: q, near=1.0, far=2.0).segments.tolist()  # straight: no split
    [4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4]
    """
    near, far, tol = _check_curve_options(camera, to_world, near, far, tolerance_px)
    r, step_x, step_y = _pixel_rays(camera, np.arange(camera.width * camera.height))
    grid = _far_grid(near, far)
    return _sample_chunk(camera.center, r, step_x, step_y, to_world, grid, not np.isfinite(far), tol,
                         np.arange(camera.width * camera.height), camera.width)[0]  # fmt: skip


def _cast_chunk(tracer: Tracer, curves: CurveSamples):  # noqa: ANN202
    """Cast each ray's segments in order, first hit wins.

    Returns per ray the sample index where its hit segment starts (-1: no hit) and the hit's ``t``,
    and the number of segments cast.
    """
    n = len(curves.open_end)
    nseg = curves.segments
    hit_seg, hit_t = np.full(n, -1, dtype=np.int64), np.full(n, np.nan)
    casts, k = 0, 0
    alive = np.flatnonzero(nseg > 0)
    while len(alive):
        i = curves.start[alive] + k
        pa, pb = curves.points[i], curves.points[i + 1]
        d = pb - pa
        length = np.linalg.norm(d, axis=1)
        go = length > 0.0  # a segment mapped to one point sees nothing
        tmax = length[go] + JOINT_OVERLAP * (1.0 + np.abs(pb[go]).max(axis=1))
        tmax[curves.open_end[alive[go]] & (k + 1 == nseg[alive[go]])] = np.inf
        hits = tracer.intersector(pa[go], d[go] / length[go, None], tmax=tmax)
        casts += int(go.sum())
        rays = alive[go][hits.rays]
        hit_seg[rays], hit_t[rays] = i[go][hits.rays], hits.t
        alive = alive[(hit_seg[alive] < 0) & (k + 1 < nseg[alive])]
        k += 1
    return hit_seg, hit_t, casts


def _hit_depth(to_world, center, r, za, zb, pa, unit, length, t) -> np.ndarray:  # noqa: ANN001
    """Distorted depth of hits at ``t`` along segments ``[P(za), P(zb)]``: the ``z`` in ``[za, zb]`` whose
    curve point ``P(z)`` projects onto the chord at the hit, ``(P(z) - P_a) . unit = t``, by
    :data:`DEPTH_BISECTIONS` bisections in ``1/z`` (exact for straight rays). Past the chord's end
    (the overlap, or the open last segment) the depth is extrapolated linearly in ``z``.
    """
    z = za + (t / length) * (zb - za)  # linear in z along the chord: exact for affine maps
    inside = t < length
    lo, hi = 1.0 / za[inside], 1.0 / zb[inside]  # phi(lo) <= 0 <= phi(hi)
    c, ri, pi, ui, ti = center, r[inside], pa[inside], unit[inside], t[inside]
    for _ in range(DEPTH_BISECTIONS):
        mid = 0.5 * (lo + hi)
        before = np.einsum("ij,ij->i", _map(to_world, c + ri / mid[:, None]) - pi, ui) < ti  # NaN: past the hit
        lo, hi = np.where(before, mid, lo), np.where(before, hi, mid)
    z[inside] = 2.0 / (lo + hi)
    return z


def _follow(tracer, camera, to_world, grid, open_far, tol, pix, out, report) -> int:  # noqa: ANN001
    """Sample and cast the curved rays of pixels ``pix``, one first segment (octave) at a time.

    Only the rays still alive are sampled further: nothing is sampled past a hit. Writes each hit's
    segment origin, unit direction, shading bound ``tmax`` and distorted depth into ``out``, and the
    direction of an escaping ray's last segment; returns the number of segments cast.
    """
    origin, direction, bound, depth, hit = out
    r, step_x, step_y = _pixel_rays(camera, pix)
    direction[pix] = r / np.linalg.norm(r, axis=1, keepdims=True)  # no segment at all: the straight ray
    alive = np.arange(len(pix))
    m, casts = len(grid) - 1, 0
    for j in range(m):
        if not len(alive):
            break
        if report is not None:
            report(j)
        curves, ended = _sample_chunk(camera.center, r[alive], step_x, step_y, to_world, grid[j : j + 2],
                                      open_far and j == m - 1, tol, pix[alive], camera.width)  # fmt: skip
        seg, t, c = _cast_chunk(tracer, curves)
        casts += c
        has = curves.segments > 0
        i = np.where(seg >= 0, seg, curves.start[1:] - 2)[has]  # the hit segment, or the last one
        a, got, t = alive[has], seg[has] >= 0, t[has]
        pa = curves.points[i]
        d = curves.points[i + 1] - pa
        length = np.linalg.norm(d, axis=1)
        moved = length > 0.0  # hit segments always have a length
        direction[pix[a[moved]]] = d[moved] / length[moved, None]
        g = pix[a[got]]
        hit[g], origin[g] = True, pa[got]
        depth[g] = _hit_depth(to_world, camera.center, r[a[got]], curves.depth[i[got]], curves.depth[i[got] + 1],
                              pa[got], direction[g], length[got], t[got])  # fmt: skip
        # Shading repeats the cast up to just past the hit (the same ray: the same first hit).
        bound[g] = t[got] + JOINT_OVERLAP * (1.0 + np.abs(pa[got] + t[got, None] * direction[g]).max(axis=1))
        alive = alive[has & (seg < 0) & ~ended]
    return casts


def trace_curved(tracer: Tracer, camera: Camera, to_world: Callable, *, near: float, far: float,
                 tolerance_px: float = 0.25, max_depth: int = 2, samples: int = 16,
                 rng: np.random.Generator | None = None, ao_distance: float | None = None,
                 progress: Progress | None = None) -> RenderResult:  # fmt: skip
    """:func:`render_curved` with a :class:`~vergence.render.Tracer` already made of the scene (a rig's
    renders share one); parameters as :func:`render_curved`."""
    near, far, tol = _check_curve_options(camera, to_world, near, far, tolerance_px)
    max_depth, samples, ao_distance = check_render_options(tracer.scene, camera, max_depth, samples, rng, ao_distance)
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable(fraction, message) or None; got {type(progress).__name__}")
    h, w = camera.height, camera.width
    if max(h, w) > MAX_RENDER_SIDE:
        raise ValueError(f"camera width and height must be <= {MAX_RENDER_SIDE} pixels (MAX_RENDER_SIDE); got {w}x{h}")
    problem = render_cost(w, h, max_depth=max_depth, samples=samples).problem()
    if problem is not None:
        raise ValueError(f"a curved render of {w}x{h} pixels with max_depth {max_depth}, samples {samples} {problem}")
    n = h * w
    origin, direction, bound, depth = np.empty((n, 3)), np.empty((n, 3)), np.empty(n), np.full(n, np.nan)
    hit = np.zeros(n, dtype=bool)
    grid = _far_grid(near, far)
    casts = 0
    for c0 in range(0, n, _CHUNK_RAYS):
        pix = np.arange(c0, min(n, c0 + _CHUNK_RAYS))
        report = None
        if progress is not None:
            report = lambda j, c0=c0, k=len(pix): progress(  # noqa: E731
                _SAMPLING_SHARE * (c0 + k * j / (len(grid) - 1)) / n, f"curved rays: pixels {c0:,}-{c0 + k - 1:,} of {n:,}, "
                f"octave {j + 1} of {len(grid) - 1}")  # fmt: skip
        casts += _follow(tracer, camera, to_world, grid, not np.isfinite(far), tol, pix,
                         (origin, direction, bound, depth, hit), report)  # fmt: skip
    if progress is not None:
        progress(_SAMPLING_SHARE, f"shading {int(hit.sum()):,} first hits (image-based lighting x ambient occlusion)")
    k = np.flatnonzero(hit)
    nodes = 2 ** (max_depth + 1) - 1
    rad = np.zeros((nodes, n, 3), dtype=np.float32)
    pos = np.full((nodes, n, 3), np.nan, dtype=np.float32)
    nrm = np.full((nodes, n, 3), np.nan, dtype=np.float32)
    settings = RenderSettings(scene=tracer.scene.name, max_depth=max_depth, samples=samples, deterministic=rng is None,
                              ao_distance=ao_distance, variant=tracer.intersector.variant,
                              environment=tracer.scene.environment.describe())  # fmt: skip
    shading = None
    if progress is not None:
        shading = lambda f, m: progress(_SAMPLING_SHARE + (1.0 - _SAMPLING_SHARE) * f, f"shading: {m}")  # noqa: E731
    if len(k):
        tree = tracer.trace_rays(origin[k], direction[k], tmax=bound[k], max_depth=max_depth, samples=samples,
                                 rng=rng, ao_distance=ao_distance, progress=shading)  # fmt: skip
        rad[:, k], pos[:, k], nrm[:, k] = tree.radiance, tree.position, tree.normal
        depth[k[~tree.hit]] = np.nan  # the shading cast repeats the segment cast; a miss here has no depth
        settings = tree.settings
    esc = np.flatnonzero(~hit)
    rad[0, esc] = tracer.shader.background(direction[esc])
    rad = rad.reshape(nodes, h, w, 3)
    settings = replace(settings, tree_rays=settings.tree_rays + casts)
    if progress is not None:
        progress(1.0, "done")
    return RenderResult(radiance=rad, position=pos.reshape(rad.shape), normal=nrm.reshape(rad.shape),
                        depth=depth.astype(np.float32).reshape(h, w), beauty=rad.sum(axis=0), camera=camera,
                        settings=settings)  # fmt: skip


def render_curved(scene: Scene, camera: Camera, to_world: Callable, *, near: float, far: float,
                  tolerance_px: float = 0.25, max_depth: int = 2, samples: int = 16,
                  rng: np.random.Generator | None = None, ao_distance: float | None = None,
                  progress: Progress | None = None) -> RenderResult:  # fmt: skip
    """Ray-trace ``scene`` through the curved rays of ``camera`` in a distorted world (S0 §6, module notes).

    The Tri-Rig's ground truth: with ``camera`` its reference right camera and ``to_world = phi^-1``
    (``WorldDistortion.inverse``), each pixel sees what the straight ray of the distorted world meets
    when followed in the real scene, shaded there (S0 §7: no lighting in the distorted world).

    Parameters
    ----------
    scene : Scene
    camera : Camera
        Pinhole camera of the distorted world.
    to_world : callable
        Vectorised ``(..., 3) -> (..., 3)``, distorted to real world; NaN (or inf) where undefined:
        the ray ends there without a hit.
    near, far : float
        Distorted camera-frame depths where the rays start and end, metres,
        ``MIN_NEAR <= near < far``; ``far = inf`` allowed (as :func:`sample_curves`).
    tolerance_px : float
        Largest gap, in pixels as ``camera`` sees it, between a segment and the curve (module notes).
    max_depth, samples, rng, ao_distance, progress
        As :func:`~vergence.render.render`.

    Returns
    -------
    RenderResult
        ``position``, ``normal`` and the radiance layers in the real world; ``depth`` is the distorted
        camera-frame depth of the first hit (what a straight ray of ``camera`` in the distorted world
        would report), NaN where the ray hits nothing. A ray without a hit takes the environment
        radiance along its last segment (the straight ray's direction when undefined from ``near`` on).
        ``settings.tree_rays`` counts the segment casts too.

    Raises
    ------
    TypeError
        If ``camera`` is not a pinhole Camera, ``to_world`` is not callable or returns non-numbers.
    ValueError
        If ``near < MIN_NEAR``, ``far <= near``, ``tolerance_px <= 0``, ``to_world`` returns another shape,
        or the curves need more than :data:`MAX_MEAN_SEGMENTS` segments per ray.
    """
    near, far, _ = _check_curve_options(camera, to_world, near, far, tolerance_px)
    check_render_options(scene, camera, max_depth, samples, rng, ao_distance)
    return trace_curved(Tracer(scene), camera, to_world, near=near, far=far, tolerance_px=tolerance_px,
                        max_depth=max_depth, samples=samples, rng=rng, ao_distance=ao_distance,
                        progress=progress)  # fmt: skip
