"""The fused wavefront: the default stages of :class:`~vergence.render.Tracer` in a few kernels per tree level.

The staged tracer (``Tracer(..., staged=True)``) runs ray generation, Mitsuba's cast, the float64 hit
refinement and the shading as separate numpy and Numba passes over every wavefront; it stays the
readable reference. With the default stages (``camera_rays``, ``Intersector``, ``WhittedShader``) the
tracer runs this module instead: per level one Mitsuba cast (its answers evaluated together), one
kernel that refines, scatters and shades every ray (``_wavefront_kernels.shade_level``) and one that
gathers the diffuse hits and the children in the same order as the staged path
(``compact_level``, which also writes the next cast in Mitsuba's float32 layout); then the ambient
occlusion of every diffuse hit of the tree as shadow rays (``Scene.ray_test``: any hit, no
shading), in chunks, finished by one kernel (``ao_finish``). The same maths in the same order: with
or without an ``rng`` the two paths agree to float rounding (``tests/render/test_wavefront.py``: bit
for bit on the test scenes). numpy's ``einsum`` sums the staged path's dot products in another order,
so a grazing secondary ray can, rarely, hit elsewhere: one layer-pixel of the 33 x 7 x 76,800 of S3's
table at 320 x 240 (``benchmarks/render.py --table``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence.render import _wavefront_kernels as wk
from vergence.render import surfaces
from vergence.render._kernels import ao_rays
from vergence.render.scene import Checker, Texture
from vergence.render.shader import AO_CHUNK, AO_PATTERNS, EPS_REL
from vergence.render.shading import ao_lattice

__all__ = ["ShadingPack", "pack_shading", "trace_wavefront"]

_EMPTY_MAP = np.zeros((0, 1, 3), dtype=np.float32)
# Rays shaded per kernel call within a level: bounds the scratch (21 float64 per ray: 350 MiB).
_LEVEL_CHUNK = 1 << 21
# Runs of rays per level chunk (each a parallel iteration of shade_level and compact_level, in order:
# a two-level scan places the diffuse hits and children) and the fewest rays in a run.
_BLOCKS, _RUN = 256, 512


@dataclass(frozen=True, slots=True, eq=False)
class ShadingPack:
    """Materials' albedo and the environment as arrays for the kernels (built once per tracer)."""

    alb_kind: np.ndarray  # (Nm,) 0 colour, 1 checker, 2 texture
    alb_color: np.ndarray  # (Nm, 2, 3) colour (twice) or the checker's two colours
    alb_squares: np.ndarray  # (Nm, 2) checker cells
    tex_base: np.ndarray  # (Nm,) first value of the texture in tex_data
    tex_h: np.ndarray
    tex_w: np.ndarray
    tex_data: np.ndarray  # every texture, flat, float64
    env_map: np.ndarray  # (h, w, 3) float32 radiance map, or (0, 1, 3): constant env_color
    env_color: np.ndarray  # (3,)
    irr_map: np.ndarray  # (h, w, 3) float32 irradiance table, or (0, 1, 3): constant irr_color
    irr_color: np.ndarray
    rotation: float


def pack_shading(packed: surfaces.PackedScene, lighting: object) -> ShadingPack:
    """The arrays of :class:`ShadingPack` from a scene's packed materials and a ``shading.Lighting``."""
    nm = len(packed.materials)
    kind = np.zeros(nm, dtype=np.int64)
    color = np.ones((nm, 2, 3))
    squares = np.ones((nm, 2), dtype=np.int64)
    base, th, tw = (np.zeros(nm, dtype=np.int64) for _ in range(3))
    data: list[np.ndarray] = []
    at = 0
    for k, m in enumerate(packed.materials):
        if isinstance(m, Checker):
            kind[k], color[k], squares[k] = 1, m.colors, m.squares
        elif isinstance(m, Texture):
            img = np.asarray(m.image, dtype=np.float64)
            kind[k], base[k], th[k], tw[k] = 2, at, img.shape[0], img.shape[1]
            data.append(img.ravel())
            at += img.size
        elif hasattr(m, "color") and packed.mat_kind[k] == surfaces.DIFFUSE:
            color[k] = m.color
    env = lighting.env
    const = irr_const = np.zeros(3)  # unused with a map
    if env.color is not None:
        const = np.asarray(env.color * env.intensity, dtype=np.float64)  # as Lighting.radiance
        irr_const = np.asarray(np.pi * env.color * env.intensity, dtype=np.float64)  # as Lighting.irradiance
    env_map = _EMPTY_MAP if lighting.radiance_map is None else np.ascontiguousarray(lighting.radiance_map)
    irr_map = _EMPTY_MAP if lighting.irradiance_table is None else np.ascontiguousarray(lighting.irradiance_table)
    return ShadingPack(kind, color, squares, base, th, tw, np.concatenate(data) if data else np.zeros(1), env_map,
                       const, irr_map, irr_const, float(lighting.rotation))  # fmt: skip


def trace_wavefront(tracer, origins, directions, pixels, starts, *, tmax, max_depth, samples, rng, ao_distance,
                    progress, geo_slots):  # noqa: ANN001, ANN201  # fmt: skip
    """Trace rays ``(M, 3)`` (unit directions) filling slots ``pixels`` into the tree's flat arrays.

    Returns ``(radiance, position, normal, first_point, first_t, tree_rays, ao_rays, object_id)`` as
    :func:`vergence.render.staged.trace_staged`, except that ``position`` and ``normal`` hold only the first
    ``geo_slots`` slots (sub-pixel rays keep only their radiance).
    """
    n_nodes = 2 ** (max_depth + 1) - 1
    n_slots, n_views = int(starts[-1]), len(starts) - 1
    view_of = lambda slots: np.searchsorted(starts[1:], slots, side="right")  # noqa: E731
    rad = np.zeros((n_nodes, n_slots, 3), dtype=np.float32)
    pos = np.empty((n_nodes, geo_slots, 3), dtype=np.float32)  # NaN where no hit: finish_layers
    nrm = np.empty((n_nodes, geo_slots, 3), dtype=np.float32)
    first_p = np.empty((n_slots, 3))
    first_t = np.empty(n_slots)
    oid = np.full((n_nodes, n_slots), -1, dtype=np.int32)
    pk, shader, sp = tracer.packed, tracer.shader, tracer.shading_pack()
    caster = tracer.intersector.caster
    node = np.ones(len(pixels), dtype=np.int64)
    slot = np.ascontiguousarray(pixels, dtype=np.int64)
    o = np.ascontiguousarray(origins, dtype=np.float64)
    d = np.ascontiguousarray(directions, dtype=np.float64)
    thr = np.zeros((0, 3))  # 1 at the first level
    o32, d32 = wk.start_rays(o, d)
    queue: list[tuple[np.ndarray, ...]] = []
    tree_rays = np.zeros(n_views, dtype=np.int64)
    no_tmax = np.zeros(0)
    for level in range(max_depth + 1):
        if progress is not None:
            progress(level / (max_depth + 2), f"level {level}: {len(slot):,} rays")
        m = len(slot)
        if not m:
            break
        bounded = level == 0 and tmax is not None
        registry, prim, t32 = caster.cast(o32, d32, tmax if bounded else None)
        tree_rays += m if n_views == 1 else np.bincount(view_of(slot), minlength=n_views)
        reflected, refracted = [], []
        for c0 in range(0, m, _LEVEL_CHUNK):  # bounded scratch; the order of the staged path is kept
            c1 = min(m, c0 + _LEVEL_CHUNK)
            q, children, r_part, t_part = _shade_chunk(slice(c0, c1), node, slot, o, d, thr, registry, prim, t32,
                                             tmax[c0:c1] if bounded else no_tmax, bounded, level == max_depth,
                                             level == 0, geo_slots, pk, sp, caster.lookup, rad, pos, nrm, first_p,
                                             first_t, oid, tracer.uv_objects())  # fmt: skip
            if len(q[0]):
                queue.append(q)
            reflected.append(r_part)
            refracted.append(t_part)
        if m <= _LEVEL_CHUNK:
            c_node, c_slot, c_o, c_d, c_thr, o32, d32 = children
        else:  # every reflection of the level, then every refraction (as staged)
            c_node, c_slot, c_o, c_d, c_thr, o32, d32 = (np.concatenate([p[k] for p in reflected + refracted],
                                                                        axis=1 if k >= 5 else 0) for k in range(7))  # fmt: skip
        node, slot, o, d, thr = c_node, c_slot, c_o, c_d, c_thr
    wk.finish_layers(oid, pos, nrm, first_p, first_t)
    if progress is not None:
        progress((max_depth + 1) / (max_depth + 2), "shading: image-based lighting x ambient occlusion")
    ao_count = np.zeros(n_views, dtype=np.int64)
    for q_node, q_slot, q_geo, q_alb in queue:  # in the staged order (an rng's draws continue block to block)
        _ambient_occlusion(shader, sp, q_node, q_slot, q_geo, q_alb, rad, samples=samples, rng=rng,
                           ao_distance=ao_distance)  # fmt: skip
        ao_count += (len(q_slot) if n_views == 1 else np.bincount(view_of(q_slot), minlength=n_views)) * samples
    if progress is not None:
        progress(1.0, "done")
    return rad, pos, nrm, first_p, first_t, tree_rays, ao_count, oid


def _shade_chunk(sl, node, slot, o, d, thr, registry, prim, t32, tmax, bounded, last, first, geo_slots, pk, sp, lookup,
                 rad, pos, nrm, first_p, first_t, oid, want_uv):  # noqa: ANN001, ANN202  # fmt: skip
    """``shade_level`` and ``compact_level`` on the rays ``sl`` of a level: their diffuse hits, their children
    (``(node, slot, origin, direction, throughput, o32, d32)``: the reflections then the refractions) and
    these two parts as views."""
    node, slot, o, d = node[sl], slot[sl], o[sl], d[sl]
    thr = thr[sl] if len(thr) else thr
    m = len(node)
    cls = np.empty(m, dtype=np.int8)
    h = np.empty((m, 21))
    blocks = max(1, min(m // _RUN, _BLOCKS))
    counts = wk.shade_level(node, slot, o, d, thr, registry[sl], lookup, prim[sl], t32[sl], tmax, bounded, pk.kind,
                            pk.center, pk.radius, pk.normal, pk.right, pk.up, pk.size, pk.tri_offset, pk.tri_v,
                            pk.tri_n, pk.tri_uv, pk.material, pk.mat_kind, pk.mat_color, pk.mat_ior, sp.alb_kind,
                            sp.alb_color, sp.alb_squares, sp.tex_base, sp.tex_h, sp.tex_w, sp.tex_data, sp.env_map,
                            sp.env_color, sp.rotation, last, first, geo_slots, rad, pos, nrm, first_p, first_t, oid,
                            cls, h, want_uv, blocks)  # fmt: skip
    starts = np.cumsum(counts, axis=0) - counts
    nq, nr, nt = (int(v) for v in counts.sum(axis=0))
    nc = nr + nt
    q = (np.empty(nq, np.int64), np.empty(nq, np.int64), np.empty((nq, 9)), np.empty((nq, 3)))
    c = (np.empty(nc, np.int64), np.empty(nc, np.int64), np.empty((nc, 3)), np.empty((nc, 3)), np.empty((nc, 3)),
         np.empty((3, nc), np.float32), np.empty((3, nc), np.float32))  # fmt: skip
    wk.compact_level(cls, h, node, slot, starts, nr, EPS_REL, *q, *c)
    cut = lambda part: tuple(a[:, part] if k >= 5 else a[part] for k, a in enumerate(c))  # noqa: E731
    return q, c, cut(slice(0, nr)), cut(slice(nr, nc))


def _ambient_occlusion(shader, sp, q_node, q_slot, q_geo, q_alb, rad, *, samples, rng, ao_distance) -> None:  # noqa: ANN001
    """``WhittedShader.diffuse`` of the queued diffuse hits, written into ``rad``: shadow rays, chunked as the shader."""
    lattice = ao_lattice(samples)
    step = max(1, AO_CHUNK // samples)
    pattern = AO_PATTERNS[shader.ao_pattern]
    n = len(q_slot)
    for s in range(0, n, step):
        e = min(n, s + step)
        geo = q_geo[s:e]
        if rng is not None:
            shifts = rng.random((e - s, 2))
        elif pattern is not None:
            shifts = pattern(np.ascontiguousarray(geo[:, 0:3]))
        else:
            shifts = np.empty((0, 2))
        orig, dirs = ao_rays(geo[:, 0:3], geo[:, 3:6], geo[:, 6:9], lattice, shifts, EPS_REL)
        maxt = None if ao_distance is None else np.full(dirs.shape[1], ao_distance)
        blocked = shader.occluders.occluded(orig, dirs, maxt)
        wk.ao_finish(blocked, samples, q_node[s:e], q_slot[s:e], geo, q_alb[s:e], sp.irr_map, sp.irr_color,
                     sp.rotation, rad)  # fmt: skip
