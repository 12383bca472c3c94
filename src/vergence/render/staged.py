"""The ray tree traced stage by stage (S3 §3.1): the readable reference of :mod:`vergence.render.wavefront`.

Each tree level is one intersection call of the tracer's ``intersector``, then numpy and small kernels:
escaped rays take the ``shader``'s background, hits store their node's position, normal and object,
diffuse hits are queued for shading, specular hits spawn their reflection (node ``2i``) and refraction
(node ``2i + 1``) children (Whitted 1980). The queued diffuse hits are shaded together at the end
(image-based lighting x ambient occlusion). A :class:`~vergence.render.Tracer` with a stage of its own,
or built with ``staged=True``, runs this path; the fused default agrees with it to float rounding.
"""

from __future__ import annotations

import numpy as np

from vergence.render import _kernels, surfaces
from vergence.render.shader import offset

__all__ = ["trace_staged"]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _take(a: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``a[rows]`` for ``(M, k)`` float64 arrays, gathered by a parallel kernel."""
    return _kernels.take_rows(np.ascontiguousarray(a, dtype=np.float64), rows)


def trace_staged(tracer, batches, starts, *, tmax, max_depth, samples, rng, ao_distance, progress):  # noqa: ANN001, ANN201
    """Trace the rays of ``batches`` (:class:`~vergence.render.rays.RayBatch`, filling slots ``pixels``;
    ``starts``: the first slot of each view, then the slot count) through ``tracer``'s stages.

    Returns ``(radiance, position, normal, first_point, first_t, tree_rays, ao_rays, object_id)``:
    the flat ``(N, n_slots, ...)`` layers (N = 2^(D+1) - 1 nodes), the first hit's point and ray
    parameter per slot (NaN without a hit), and the tree and AO rays cast per view.
    """
    n_nodes = 2 ** (max_depth + 1) - 1
    n_slots, n_views = int(starts[-1]), len(starts) - 1
    view_of = lambda slots: np.searchsorted(starts[1:], slots, side="right")  # noqa: E731
    rad = np.zeros((n_nodes, n_slots, 3), dtype=np.float32)
    pos = np.full((n_nodes, n_slots, 3), np.nan, dtype=np.float32)
    nrm = np.full((n_nodes, n_slots, 3), np.nan, dtype=np.float32)
    first_p = np.full((n_slots, 3), np.nan)
    first_t = np.full(n_slots, np.nan)
    oid = np.full((n_nodes, n_slots), -1, dtype=np.int32)
    pix = np.concatenate([b.pixels for b in batches])
    o = np.concatenate([b.origins for b in batches])  # exact origins (float64 geometry)
    d = np.concatenate([b.directions for b in batches])
    node = np.ones(len(pix), dtype=np.int64)
    oc = o  # origins handed to Mitsuba: moved off the surface they leave
    thr = np.ones((len(pix), 3))
    queue: list[tuple[np.ndarray, ...]] = []  # diffuse hits: node, pixel, p, n_geo, n_shade, albedo x throughput
    pk = tracer.packed
    tree_rays = np.zeros(n_views, dtype=np.int64)
    for level in range(max_depth + 1):
        if progress is not None:
            progress(level / (max_depth + 2), f"level {level}: {len(pix):,} rays")
        if not len(pix):
            break
        hits = tracer.intersector(o, d, cast_from=oc, tmax=tmax if level == 0 else None)
        tree_rays += np.bincount(view_of(pix), minlength=n_views)
        esc = np.ones(len(pix), dtype=bool)
        esc[hits.rays] = False
        if level == 0 and tmax is not None:
            esc &= np.isinf(tmax)  # a bounded segment without a hit is unfinished, not escaped
        _kernels.scatter_weighted(rad, node[esc], pix[esc], thr[esc], tracer.shader.background(d[esc]))
        hit = hits.rays
        node, pix, d, thr, obj = node[hit], pix[hit], _take(d, hit), _take(thr, hit), hits.obj
        p, ng, ns, uv = hits.points, hits.n_geo, hits.n_shade, hits.uv
        entering = _dot(d, ng) < 0.0
        side = np.where(entering, 1.0, -1.0)[:, None]
        ng, ns = ng * side, ns * side  # both face the arriving ray now
        _kernels.scatter_nodes(pos, node, pix, p)
        _kernels.scatter_nodes(nrm, node, pix, ns)
        oid[node - 1, pix] = obj  # each (node, pixel) is reached by one ray of a level
        if level == 0:
            first_p[pix] = p
            first_t[pix] = hits.t
        mat = pk.material[obj]
        kind = pk.mat_kind[mat]
        s = np.flatnonzero(kind == surfaces.DIFFUSE)
        queue.append((node[s], pix[s], _take(p, s), _take(ng, s), _take(ns, s),
                      _take(thr, s) * surfaces.albedo(pk, mat[s], _take(uv, s))))  # fmt: skip
        if level == max_depth:
            break  # specular hits at the last level are cut off
        s = np.flatnonzero(kind != surfaces.DIFFUSE)
        rdir, rw, g, tdir, tw = tracer.shader.specular(_take(d, s), _take(ns, s), entering[s], mat[s])
        ps, ngs, ts = _take(p, s), _take(ng, s), _take(thr, s)
        pg = _take(ps, g)
        children = [(2 * node[s], pix[s], ps, offset(ps, ngs), rdir, ts * rw),
                    (2 * node[s][g] + 1, pix[s][g], pg, offset(pg, _take(ngs, g), -1.0), tdir, _take(ts, g) * tw)]  # fmt: skip
        node, pix, o, oc, d, thr = (np.concatenate([c[k] for c in children]) for k in range(6))
    if progress is not None:
        progress((max_depth + 1) / (max_depth + 2), "shading: image-based lighting x ambient occlusion")
    ao_rays = np.zeros(n_views, dtype=np.int64)
    if queue:
        qn, qpix, qp, qng, qns, qalb = (np.concatenate([q[k] for q in queue]) for k in range(6))
        light = tracer.shader.diffuse(qp, qng, qns, samples=samples, rng=rng, ao_distance=ao_distance)
        _kernels.scatter_weighted(rad, qn, qpix, qalb, np.ascontiguousarray(light, dtype=np.float64))
        ao_rays = np.bincount(view_of(qpix), minlength=n_views) * samples
    if progress is not None:
        progress(1.0, "done")
    return rad, pos, nrm, first_p, first_t, tree_rays, ao_rays, oid
