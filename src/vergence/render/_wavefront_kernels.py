"""Numba kernels of the fused wavefront (:mod:`vergence.render.wavefront`): one level of the ray tree per call.

Each kernel does, for every ray of a wavefront at once, what the staged tracer
(:meth:`vergence.render.Tracer._trace` with ``staged=True``) does in a dozen numpy passes: the same
maths in the same order (``surfaces.refine_hits``, ``shading.schlick``/``reflect``/``refract``,
``shader.offset``, ``surfaces.albedo``, ``Lighting``), so the staged path is their reference
(``tests/render/test_wavefront.py``). Materials and textures come packed by ``wavefront.pack_shading``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from vergence.render._kernels import equirect_one, refine_one

__all__ = ["ao_finish", "compact_level", "finish_layers", "shade_level", "start_rays"]

# Classes of a hit in ``shade_level``'s ``cls``.
NONE, DIFFUSE_HIT, REFLECT, REFLECT_REFRACT = 0, 1, 2, 3


@numba.njit(cache=True, inline="always")
def _texel(data: np.ndarray, base: int, h: int, w: int, x: float, y: float, c: int) -> float:
    """Bilinear lookup with periodic wrap of channel ``c`` of an ``(h, w, 3)`` image stored flat from ``base``."""
    xf, yf = math.floor(x), math.floor(y)
    fx, fy = x - xf, y - yf
    x0, y0 = int(xf) % w, int(yf) % h
    x1, y1 = (x0 + 1) % w, (y0 + 1) % h
    top = data[base + (y0 * w + x0) * 3 + c] * (1 - fx) + data[base + (y0 * w + x1) * 3 + c] * fx
    bottom = data[base + (y1 * w + x0) * 3 + c] * (1 - fx) + data[base + (y1 * w + x1) * 3 + c] * fx
    return top * (1 - fy) + bottom * fy


@numba.njit(cache=True, inline="always")
def _albedo(mat: int, u: float, v: float, alb_kind: np.ndarray, alb_color: np.ndarray, alb_squares: np.ndarray,
            tex_base: np.ndarray, tex_h: np.ndarray, tex_w: np.ndarray, tex_data: np.ndarray) -> tuple:  # fmt: skip
    """``surfaces.albedo`` of one hit: a colour (kind 0), a checker (1), a texture (2)."""
    k = alb_kind[mat]
    if k == 0:
        return alb_color[mat, 0, 0], alb_color[mat, 0, 1], alb_color[mat, 0, 2]
    if k == 1:
        cell = int(math.floor(u * alb_squares[mat, 0]) + math.floor(v * alb_squares[mat, 1])) % 2
        return alb_color[mat, cell, 0], alb_color[mat, cell, 1], alb_color[mat, cell, 2]
    h, w, base = tex_h[mat], tex_w[mat], tex_base[mat]
    x, y = u * w - 0.5, (1.0 - v) * h - 0.5
    return (_texel(tex_data, base, h, w, x, y, 0), _texel(tex_data, base, h, w, x, y, 1),
            _texel(tex_data, base, h, w, x, y, 2))  # fmt: skip


@numba.njit(parallel=True, cache=True)
def start_rays(origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mitsuba's layout ``(3, M)`` float32 of origins and directions ``(M, 3)`` float64."""
    m = origins.shape[0]
    o32 = np.empty((3, m), dtype=np.float32)
    d32 = np.empty((3, m), dtype=np.float32)
    for i in numba.prange(m):
        for c in range(3):
            o32[c, i] = origins[i, c]
            d32[c, i] = dirs[i, c]
    return o32, d32


@numba.njit(parallel=True, cache=True)
def shade_level(
    node: np.ndarray, slot: np.ndarray, o: np.ndarray, d: np.ndarray, thr: np.ndarray,
    registry: np.ndarray, lookup: np.ndarray, prim: np.ndarray, t32: np.ndarray, tmax: np.ndarray, bounded: bool,
    kind: np.ndarray, center: np.ndarray, radius: np.ndarray, normal: np.ndarray, right: np.ndarray, up: np.ndarray,
    size: np.ndarray, tri_offset: np.ndarray, tri_v: np.ndarray, tri_n: np.ndarray, tri_uv: np.ndarray,
    material: np.ndarray, mat_kind: np.ndarray, mat_color: np.ndarray, mat_ior: np.ndarray,
    alb_kind: np.ndarray, alb_color: np.ndarray, alb_squares: np.ndarray, tex_base: np.ndarray, tex_h: np.ndarray,
    tex_w: np.ndarray, tex_data: np.ndarray, env_map: np.ndarray, env_color: np.ndarray, env_rotation: float,
    last: bool, first: bool, geo_slots: int,
    rad: np.ndarray, pos: np.ndarray, nrm: np.ndarray, first_p: np.ndarray, first_t: np.ndarray, oid: np.ndarray,
    cls: np.ndarray, h: np.ndarray, want_uv: np.ndarray, blocks: int,
) -> np.ndarray:  # fmt: skip
    """One level of the tree for every ray of the wavefront (the staged ``Tracer._trace``'s loop body).

    Ray ``i`` (tree ``node[i]``, slot ``slot[i]``, exact origin ``o``, unit direction ``d``, throughput
    ``thr``; ``thr`` empty: 1, the first level) with Mitsuba's answer (``lookup[registry]`` the object,
    -1 for none; ``prim``; ``t32``):

    - no hit (or, when ``bounded``, a refined distance past ``tmax``): ``rad = thr x environment(d)``,
      unless bounded by a finite ``tmax`` (an unfinished segment: nothing); ``cls = 0``;
    - a hit: refined in float64 (texture coordinates only where ``want_uv[obj]``), normals turned to
      face the ray, ``pos``/``nrm`` written for slots below ``geo_slots``, ``oid`` (the object) for
      every slot, ``first_p``/``first_t`` at the first level; then per material kind (``mat_kind``:
      0 diffuse, 1 mirror, 2 glass): diffuse ``cls = 1`` with ``h[i, 9:12] = thr x albedo``; specular
      (not at the ``last`` level) ``cls = 2`` (reflection: direction ``h[12:15]``, throughput
      ``h[9:12]``) or 3 (and refraction: ``h[15:18]``, ``h[18:21]``), Schlick's split for glass.
      ``h[i, 0:9]`` holds the point, geometric and shading normals.

    The rays go in ``blocks`` consecutive runs, one per parallel iteration; returns each run's count of
    diffuse hits, reflections and refractions ``(blocks, 3)``, from which :func:`compact_level`
    places them (a two-level scan).
    """
    m = node.shape[0]
    has_thr = thr.shape[0] == m
    counts = np.zeros((blocks, 3), dtype=np.int64)
    run = (m + blocks - 1) // blocks
    for b in numba.prange(blocks):
        nq = nr = nt = 0
        for i in range(b * run, min(m, (b + 1) * run)):
            t0, t1, t2 = 1.0, 1.0, 1.0
            if has_thr:
                t0, t1, t2 = thr[i, 0], thr[i, 1], thr[i, 2]
            c = NONE
            while True:  # one pass; each outcome sets c and leaves
                n_, s_ = node[i] - 1, slot[i]
                ox, oy, oz = o[i, 0], o[i, 1], o[i, 2]
                dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
                obj = lookup[min(registry[i], lookup.shape[0] - 1)]
                hit = obj >= 0 and math.isfinite(t32[i])
                ti = gx = gy = gz = sx = sy = sz = u = v = 0.0
                if hit:
                    ti, gx, gy, gz, sx, sy, sz, u, v = refine_one(
                        kind, center, radius, normal, right, up, size, tri_offset, tri_v, tri_n, tri_uv, obj, prim[i],
                        ox, oy, oz, dx, dy, dz, np.float64(t32[i]), want_uv[obj])  # fmt: skip
                    if bounded and not ti <= tmax[i]:
                        hit = False
                if not hit:
                    if bounded and not math.isinf(tmax[i]):
                        c = NONE  # a bounded segment without a hit is unfinished, not escaped
                        break
                    if env_map.shape[0] > 0:
                        er, eg, eb = equirect_one(env_map, env_rotation, dx, dy, dz)
                    else:
                        er, eg, eb = env_color[0], env_color[1], env_color[2]
                    rad[n_, s_, 0] = t0 * er
                    rad[n_, s_, 1] = t1 * eg
                    rad[n_, s_, 2] = t2 * eb
                    c = NONE
                    break
                px, py, pz = ox + ti * dx, oy + ti * dy, oz + ti * dz
                entering = dx * gx + dy * gy + dz * gz < 0.0
                if not entering:
                    gx, gy, gz, sx, sy, sz = -gx, -gy, -gz, -sx, -sy, -sz
                if s_ < geo_slots:
                    pos[n_, s_, 0], pos[n_, s_, 1], pos[n_, s_, 2] = px, py, pz
                    nrm[n_, s_, 0], nrm[n_, s_, 1], nrm[n_, s_, 2] = sx, sy, sz
                oid[n_, s_] = obj
                if first:
                    first_p[s_, 0], first_p[s_, 1], first_p[s_, 2] = px, py, pz
                    first_t[s_] = ti
                h[i, 0], h[i, 1], h[i, 2] = px, py, pz
                h[i, 3], h[i, 4], h[i, 5] = gx, gy, gz
                h[i, 6], h[i, 7], h[i, 8] = sx, sy, sz
                mat = material[obj]
                mk = mat_kind[mat]
                if mk == 0:
                    a0, a1, a2 = _albedo(mat, u, v, alb_kind, alb_color, alb_squares, tex_base, tex_h, tex_w,
                                         tex_data)  # fmt: skip
                    h[i, 9], h[i, 10], h[i, 11] = t0 * a0, t1 * a1, t2 * a2
                    c = DIFFUSE_HIT
                    break
                if last:
                    c = NONE  # specular hits at the last level are cut off
                    break
                dn = dx * sx + dy * sy + dz * sz
                h[i, 12], h[i, 13], h[i, 14] = dx - 2.0 * dn * sx, dy - 2.0 * dn * sy, dz - 2.0 * dn * sz  # reflect
                if mk == 1:  # a mirror reflects everything, tinted
                    h[i, 9], h[i, 10], h[i, 11] = (t0 * mat_color[mat, 0], t1 * mat_color[mat, 1],
                                                   t2 * mat_color[mat, 2])  # fmt: skip
                    c = REFLECT
                    break
                cos_i = min(max(-dn, 0.0), 1.0)
                ior = mat_ior[mat]
                n1, n2 = (1.0, ior) if entering else (ior, 1.0)
                r0 = ((n1 - n2) / (n1 + n2)) ** 2  # shading.schlick (Schlick 1994)
                sin2_t = (n1 / n2) ** 2 * (1.0 - cos_i**2)
                if n1 > n2 and sin2_t > 1.0:
                    rr = 1.0
                else:
                    cos_t = math.sqrt(min(max(1.0 - sin2_t, 0.0), 1.0)) if n1 > n2 else cos_i
                    rr = r0 + (1.0 - r0) * (1.0 - cos_t) ** 5
                h[i, 9], h[i, 10], h[i, 11] = t0 * rr, t1 * rr, t2 * rr
                eta = n1 / n2  # shading.refract
                cc = -dn
                k = 1.0 - eta**2 * (1.0 - cc**2)
                if k < 0.0 or not rr < 1.0:
                    c = REFLECT  # total internal reflection: no refracted child
                    break
                sk = math.sqrt(k)
                h[i, 15] = eta * dx + (eta * cc - sk) * sx
                h[i, 16] = eta * dy + (eta * cc - sk) * sy
                h[i, 17] = eta * dz + (eta * cc - sk) * sz
                f0, f1, f2 = 1.0 - rr, 1.0 - rr, 1.0 - rr
                if entering:  # the glass's colour on the way in
                    f0, f1, f2 = f0 * mat_color[mat, 0], f1 * mat_color[mat, 1], f2 * mat_color[mat, 2]
                h[i, 18], h[i, 19], h[i, 20] = t0 * f0, t1 * f1, t2 * f2
                c = REFLECT_REFRACT
                break
            cls[i] = c
            nq += c == DIFFUSE_HIT
            nr += c >= REFLECT
            nt += c == REFLECT_REFRACT
        counts[b, 0], counts[b, 1], counts[b, 2] = nq, nr, nt
    return counts


@numba.njit(parallel=True, cache=True)
def compact_level(
    cls: np.ndarray, h: np.ndarray, node: np.ndarray, slot: np.ndarray, starts: np.ndarray, n_reflect: int,
    eps_rel: float, q_node: np.ndarray, q_slot: np.ndarray, q_geo: np.ndarray, q_alb: np.ndarray,
    c_node: np.ndarray, c_slot: np.ndarray, c_o: np.ndarray, c_d: np.ndarray, c_thr: np.ndarray,
    c_o32: np.ndarray, c_d32: np.ndarray,
) -> None:  # fmt: skip
    """Gather a level's diffuse hits (``q_*``, in ray order) and children (reflections in ray order, then
    refractions from ``n_reflect``), each child's cast origin moved off the surface,
    ``p +- eps_rel (1 + |p|_inf) n_geo`` (``shader.offset``), written in Mitsuba's float32 layout too.

    ``starts (blocks, 3)``: where each of :func:`shade_level`'s runs puts its first diffuse hit,
    reflection and refraction (exclusive prefix sums of its counts). ``q_geo`` rows: point, geometric
    normal, shading normal.
    """
    m = cls.shape[0]
    blocks = starts.shape[0]
    run = (m + blocks - 1) // blocks
    for b in numba.prange(blocks):
        jq, jr, jt = starts[b, 0], starts[b, 1], n_reflect + starts[b, 2]
        for i in range(b * run, min(m, (b + 1) * run)):
            c = cls[i]
            if c == NONE:
                continue
            if c == DIFFUSE_HIT:
                q_node[jq], q_slot[jq] = node[i], slot[i]
                for k in range(9):
                    q_geo[jq, k] = h[i, k]
                for k in range(3):
                    q_alb[jq, k] = h[i, 9 + k]
                jq += 1
                continue
            px, py, pz = h[i, 0], h[i, 1], h[i, 2]
            e = eps_rel * (1.0 + max(abs(px), abs(py), abs(pz)))
            for which in range(2):
                if which == 1 and c != REFLECT_REFRACT:
                    break
                j = jr if which == 0 else jt
                sign = 1.0 if which == 0 else -1.0
                c_node[j], c_slot[j] = 2 * node[i] + which, slot[i]
                for k in range(3):
                    p = h[i, k]
                    c_o[j, k] = p
                    c_o32[k, j] = p + (sign * e) * h[i, 3 + k]
                    c_d[j, k] = h[i, 12 + 3 * which + k]
                    c_d32[k, j] = c_d[j, k]
                    c_thr[j, k] = h[i, 9 + 9 * which + k]
            jr += 1
            jt += c == REFLECT_REFRACT


@numba.njit(parallel=True, cache=True)
def finish_layers(oid: np.ndarray, pos: np.ndarray, nrm: np.ndarray, first_p: np.ndarray, first_t: np.ndarray) -> None:
    """NaN in ``pos``, ``nrm`` (the first ``pos.shape[1]`` slots) and ``first_p``/``first_t`` where a node has no
    hit (``oid == -1``): the arrays start uninitialised and the hits write the rest."""
    n_nodes, n_slots = oid.shape
    geo = pos.shape[1]
    for s in numba.prange(n_slots):
        if oid[0, s] < 0:
            first_p[s, 0], first_p[s, 1], first_p[s, 2] = np.nan, np.nan, np.nan
            first_t[s] = np.nan
        if s < geo:
            for n in range(n_nodes):
                if oid[n, s] < 0:
                    for c in range(3):
                        pos[n, s, c] = np.nan
                        nrm[n, s, c] = np.nan


@numba.njit(parallel=True, cache=True)
def ao_finish(blocked: np.ndarray, samples: int, q_node: np.ndarray, q_slot: np.ndarray, q_geo: np.ndarray,
              q_alb: np.ndarray, irr_map: np.ndarray, irr_color: np.ndarray, rotation: float, rad: np.ndarray) -> None:  # fmt: skip
    """``rad[node - 1, slot] = (thr albedo) E(n_shade) AO / pi`` with ``AO = 1 - blocked / samples`` (``shader.diffuse``).

    ``blocked`` holds ``samples`` consecutive answers per point; ``irr_map`` the irradiance table
    (empty: the constant ``irr_color``).
    """
    m = q_node.shape[0]
    has_map = irr_map.shape[0] > 0
    for i in numba.prange(m):
        count = 0
        for k in range(samples):
            if blocked[i * samples + k]:
                count += 1
        ao = 1.0 - count / samples
        if has_map:
            e0, e1, e2 = equirect_one(irr_map, rotation, q_geo[i, 6], q_geo[i, 7], q_geo[i, 8])
        else:
            e0, e1, e2 = irr_color[0], irr_color[1], irr_color[2]
        f = ao / np.pi
        n_, s_ = q_node[i] - 1, q_slot[i]
        rad[n_, s_, 0] = q_alb[i, 0] * (e0 * f)
        rad[n_, s_, 1] = q_alb[i, 1] * (e1 * f)
        rad[n_, s_, 2] = q_alb[i, 2] * (e2 * f)
