"""The fused wavefront (vergence.render.wavefront) against the staged tracer, its slow reference.

``Tracer(scene)`` runs the default stages fused (a few kernels per tree level, AO as shadow rays);
``Tracer(scene, staged=True)`` runs them one by one (numpy between Mitsuba's casts). The same maths in
the same order: every layer, position, normal, depth and object id agrees to float64 rounding, with and
without an rng, supersampled or not, several cameras side by side, bounded rays (``tmax``). Also the new
kernels against plain loops: sub-pixel ray generation, the curved rays' gap test, the neighbour
bookkeeping of the curved sampling against the numpy steps it replaces.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.camera import look_at
from vergence.render import Tracer, builtin_scene, curved, wavefront
from vergence.render._kernels import segment_gaps_ok
from vergence.render.rays import subpixel_grid_rays, subpixel_rays

# float64 geometry stored as float32: identical but for a last-bit rounding of a refined coordinate
POS_ATOL = 1e-6
SIZE = (40, 30)


@pytest.fixture(scope="module", params=["glasses", "tabletop", "stadium"])
def pair(request):
    scene = builtin_scene(request.param, width=SIZE[0], height=SIZE[1])
    return Tracer(scene), Tracer(scene, staged=True)


def _same(a, b) -> None:
    assert_array_equal(a.radiance, b.radiance)
    assert_array_equal(a.depth, b.depth)
    assert_array_equal(np.isnan(a.position), np.isnan(b.position))
    assert_allclose(a.position, b.position, rtol=0, atol=POS_ATOL, equal_nan=True)
    assert_allclose(a.normal, b.normal, rtol=0, atol=POS_ATOL, equal_nan=True)
    if a.object_id is not None or b.object_id is not None:
        assert_array_equal(a.object_id, b.object_id)
    assert (a.settings.tree_rays, a.settings.ao_rays) == (b.settings.tree_rays, b.settings.ao_rays)


@pytest.mark.parametrize("options", [{}, {"supersample": 2}, {"rng": 7}, {"rng": 7, "supersample": 2},
                                     {"ao_distance": 0.5, "max_depth": 3}])  # fmt: skip
def test_fused_equals_staged(pair, options):
    fused, staged = pair
    assert fused.fused and not staged.fused
    kw = {"samples": 4, **options}
    if "rng" in kw:
        kw_a, kw_b = {**kw, "rng": np.random.default_rng(kw["rng"])}, {**kw, "rng": np.random.default_rng(kw["rng"])}
    else:
        kw_a = kw_b = kw
    _same(fused.render(**kw_a), staged.render(**kw_b))


def test_several_cameras_in_one_wavefront_equal_the_staged_path(pair):
    fused, staged = pair
    cam = fused.scene.camera.build()
    other = look_at(cam.center + 0.05 * cam.R[0], cam.center + cam.R[2], -cam.R[1], fov_deg=40.0, width=24, height=18)
    many = fused.render_many([cam, other], samples=2, supersample=2)
    ref = staged._render_many([cam, other], max_depth=2, samples=2, rng=None, ao_distance=None, progress=None,
                              supersample=2)  # fmt: skip
    for a, b in zip(many, ref):
        _same(a, b)
    _same(many[1], fused.render(other, samples=2, supersample=2))  # deterministic AO: as rendered alone


def test_render_many_splits_into_wavefronts_without_changing_results(pair, monkeypatch):
    from vergence.render import raytree

    fused, _ = pair
    cam = fused.scene.camera.build()
    whole = fused.render_many([cam, cam, cam], samples=2)
    monkeypatch.setattr(raytree, "WAVEFRONT_SLOTS", cam.width * cam.height)  # one camera per wavefront
    seen = []
    split = fused.render_many([cam, cam, cam], samples=2, progress=lambda f, m: seen.append(f))
    for a, b in zip(whole, split):
        _same(a, b)
    assert seen == sorted(seen) and seen[-1] == 1.0


def test_level_chunks_keep_the_staged_order(monkeypatch):
    scene = builtin_scene("glasses", width=24, height=20)
    ref = Tracer(scene, staged=True).render(samples=3, rng=np.random.default_rng(1))
    monkeypatch.setattr(wavefront, "_LEVEL_CHUNK", 97)  # many chunks per level: reflections, then refractions
    _same(Tracer(scene).render(samples=3, rng=np.random.default_rng(1)), ref)


def test_bounded_rays_equal_the_staged_path(pair):
    fused, staged = pair
    cam = fused.scene.camera.build()
    d = cam.ray_directions().reshape(-1, 3)
    o = np.broadcast_to(cam.center, d.shape)
    tmax = np.where(np.arange(len(d)) % 3 == 0, np.inf, 4.0)  # some unbounded, some cut at 4 m
    a = fused.trace_rays(o, d, tmax=tmax, samples=2, rng=np.random.default_rng(2))
    b = staged.trace_rays(o, d, tmax=tmax, samples=2, rng=np.random.default_rng(2))
    assert_array_equal(a.hit, b.hit)
    assert_array_equal(a.radiance, b.radiance)
    assert_allclose(a.position, b.position, rtol=0, atol=POS_ATOL, equal_nan=True)


def test_a_stage_of_its_own_runs_staged():
    from vergence.render.shader import WhittedShader

    class Shader(WhittedShader):
        pass

    scene = builtin_scene("tabletop", width=8, height=6)
    assert not Tracer(scene, shader=Shader(scene)).fused
    with pytest.raises(TypeError, match="staged must be a bool"):
        Tracer(scene, staged="yes")


def test_render_many_refuses_bad_cameras():
    tracer = Tracer(builtin_scene("tabletop", width=8, height=6))
    with pytest.raises(ValueError, match="cameras must be a non-empty list"):
        tracer.render_many([])
    with pytest.raises(TypeError, match="camera must be a Camera"):
        tracer.render_many([tracer.scene.camera.build(), "camera"])


def test_subpixel_grid_rays_against_subpixel_rays():
    cam = look_at([0.3, 1.0, -2.0], [0, 0.5, 3], [0, -1, 0], fov_deg=50, width=7, height=5)
    k = 3
    for rng_seed in (None, 5):
        batch = subpixel_grid_rays(cam, k, None if rng_seed is None else np.random.default_rng(rng_seed))
        rng = None if rng_seed is None else np.random.default_rng(rng_seed)
        cells = (np.arange(k) + 0.5) / k - 0.5
        expected = []
        for gy in cells:  # the staged path's loop, drawing its jitter in the same order
            for gx in cells:
                off = np.array([gx, gy])
                if rng is not None:
                    off = off + (rng.random((cam.height, cam.width, 2)) - 0.5) / k
                expected.append(subpixel_rays(cam, off).directions)
        assert_allclose(batch.directions, np.concatenate(expected), rtol=0, atol=1e-15)
        assert_array_equal(batch.pixels, np.arange(k * k * cam.width * cam.height))


def _gap_loop(pa, pb, p, jx, jy):
    """The gap of curved._gap_px written out: solve e = a J_x + b J_y + s chord by numpy's solver."""
    chord = pb - pa
    s = np.clip(np.dot(p - pa, chord) / np.dot(chord, chord), 0.0, 1.0)
    e = p - (pa + s * chord)
    a, b, _ = np.linalg.solve(np.stack([jx, jy, chord], axis=1), e)
    return math.hypot(a, b)


def test_segment_gap_kernel_against_a_solver_and_the_numpy_reference():
    rng = np.random.default_rng(3)
    n = 200
    pa, pb = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    pm, q1, q2 = (0.5 * (pa + pb) + 0.05 * rng.normal(size=(n, 3)) for _ in range(3))
    jx, jy = 0.01 * rng.normal(size=(n, 3)), 0.01 * rng.normal(size=(n, 3))
    jx[:5] = np.nan  # unmeasurable beside a defined midpoint: kept
    pb[5:10] = np.nan  # undefined end: never kept
    gaps = np.array([max(_gap_loop(pa[i], pb[i], p[i], jx[i], jy[i]) for p in (pm, q1, q2)) if i >= 10 else np.nan
                     for i in range(n)])  # fmt: skip
    tol = float(np.nanmedian(gaps))  # the threshold cuts through the sample
    ok = segment_gaps_ok(pa, pb, pm, jx, jy, q1, q2, tol)
    assert ok[:5].all() and not ok[5:10].any()
    assert_array_equal(ok[10:], gaps[10:] <= tol)
    ref = np.fmax(curved._gap_px(pa, pb, pm, jx, jy), np.fmax(curved._gap_px(pa, pb, q1, jx, jy),
                                                              curved._gap_px(pa, pb, q2, jx, jy)))  # fmt: skip
    ref[(np.isnan(jx[:, 0]) | np.isnan(jy[:, 0])) & ~np.isnan(pm[:, 0])] = 0.0
    assert_array_equal(ok, ~np.isnan(pb[:, 0]) & (ref <= tol))
    assert 50 < ok.sum() < n - 50


def _bend(q):
    z = q[..., 2:3]
    return q * (1.0 + z / 4.0) + np.concatenate([0.3 * np.sin(z), 0 * z, 0 * z], axis=-1)  # bends, then back


def test_neighbour_jacobians_equal_the_forward_differences(monkeypatch):
    """Sampling with the neighbours' midpoints as the one-pixel steps gives the polylines of the numpy
    forward differences (without neighbours: one to_world call per step) to rounding."""
    cam = look_at([0.4, 0.1, 0.0], [0.4, 0.1, 1.0], [0, -1, 0], fov_deg=60, width=9, height=7)
    fast = curved.sample_curves(cam, _bend, near=0.5, far=40.0, tolerance_px=0.05)

    def no_neighbours(pixel, path, width, span):
        return np.full(len(path), -1), np.full(len(path), -1)

    monkeypatch.setattr(curved, "_neighbours", no_neighbours)  # every step mapped by to_world itself
    slow = curved.sample_curves(cam, _bend, near=0.5, far=40.0, tolerance_px=0.05)
    assert_array_equal(fast.start, slow.start)
    assert_allclose(fast.points, slow.points, rtol=1e-12, atol=1e-12)
    assert fast.segments.min() > 7  # the map does bend: splits happen (7 octaves from 0.5 m to 40 m)


def test_each_point_is_mapped_once():
    """The curved sampling maps each point it tests once: a split segment's children reuse its quarter points."""
    cam = look_at([0.4, 0.1, 0.0], [0.4, 0.1, 1.0], [0, -1, 0], fov_deg=60, width=9, height=7)
    seen = []

    def counted(q):
        seen.append(np.asarray(q).reshape(-1, 3).copy())
        return _bend(q)

    curved.sample_curves(cam, counted, near=0.5, far=40.0, tolerance_px=0.05)
    points = np.concatenate(seen)
    _, counts = np.unique(points, axis=0, return_counts=True)
    assert counts.max() == 1


def test_neighbour_steps_kernel_against_a_loop():
    from vergence.render._kernels import neighbour_steps

    rng = np.random.default_rng(4)
    pm = rng.normal(size=(50, 3))
    nb = np.where(rng.random(50) < 0.6, rng.integers(0, 50, 50), -1)
    mapped = rng.normal(size=(int((nb < 0).sum()), 3))
    expected, k = [], 0
    for i in range(50):
        if nb[i] >= 0:
            expected.append(pm[nb[i]] - pm[i])
        else:
            expected.append(mapped[k] - pm[i])
            k += 1
    assert_array_equal(neighbour_steps(pm, nb, mapped), np.array(expected))
