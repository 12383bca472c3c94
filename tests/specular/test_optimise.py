"""Per-pixel offsets (S3 §3.4): the descent against a brute-force search on the same table, its
cost against the numpy cost, the kernel's fill of unmatched rows against numpy's interpolation, and
what the objective does on simple layered pixels (issue 26)."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.specular import disparity_cost, optimise_offsets

ZONE = (-70.0, 60.0)


def _interp(table, y):
    """The table (K + 1, N, H, W[, 2]) at per-layer, per-pixel offsets y (N, H, W), linearly."""
    k = table.shape[0] - 1
    pos = y * k
    m = np.minimum(pos.astype(int), k - 1)
    t = pos - m
    lo = np.take_along_axis(table, m[None, ..., None] if table.ndim == 5 else m[None], 0)[0]
    hi = np.take_along_axis(table, (m + 1)[None, ..., None] if table.ndim == 5 else (m + 1)[None], 0)[0]
    t = t[..., None] if table.ndim == 5 else t
    return lo + t * (hi - lo)


def _table(k=8, n=3, h=3, w=4, seed=0):
    """Layer disparities that scale with the offset (d_i(y) = y * physical, as moving the shading
    camera towards the other eye does), rivalry that grows away from y = 1, random importance."""
    rng = np.random.default_rng(seed)
    ys = np.linspace(0, 1, k + 1)
    physical = rng.normal(0, 90, (n, h, w, 2))
    physical[..., 1] *= 0.05
    disp = ys[:, None, None, None, None] * physical[None]
    riv = (1 - ys)[:, None, None, None] * rng.uniform(0, 60, (n, h, w))[None]
    imp = rng.uniform(0.2, 1, (n, h, w))  # the physical pair's, held fixed
    return disp, riv, imp, physical


@pytest.mark.parametrize("variant", ["screen", "comfort"])
def test_descent_reaches_the_brute_force_minimum_of_one_free_layer(variant):
    disp, riv, imp, physical = _table(n=2)
    kw = dict(variant=variant, zone=ZONE)
    sol = optimise_offsets(disp, riv, imp, physical, **kw)
    assert (sol.y[0] == 1).all()  # the diffuse layer stays
    grid = np.linspace(0, 1, 801)
    for yy in range(disp.shape[2]):
        for xx in range(disp.shape[3]):
            best = np.inf
            for g in grid:
                y = np.ones((2, 1, 1))
                y[1] = g
                at = lambda tab: _interp(tab[:, :, yy : yy + 1, xx : xx + 1], y)  # noqa: E731
                c = disparity_cost(at(disp), at(riv), imp[:, yy : yy + 1, xx : xx + 1],
                                   physical[:, yy : yy + 1, xx : xx + 1], **kw).total[0, 0]  # fmt: skip
                best = min(best, c)
            assert sol.cost[yy, xx] <= best * (1 + 1e-3) + 1e-6, (yy, xx, sol.cost[yy, xx], best)


@pytest.mark.parametrize("variant", ["screen", "comfort"])
def test_reported_cost_is_the_numpy_cost_at_the_offsets(variant):
    disp, riv, imp, physical = _table(n=3, seed=2)
    maps = {"relative": np.full(physical.shape[:3], 2.0)}
    sol = optimise_offsets(disp, riv, imp, physical, variant=variant, zone=ZONE, maps=maps)
    at = lambda tab: _interp(tab, sol.y)  # noqa: E731
    ref = disparity_cost(at(disp).astype(np.float32), at(riv).astype(np.float32), imp, physical, variant=variant,
                         zone=ZONE, maps=maps)  # fmt: skip
    np.testing.assert_allclose(sol.cost, ref.total, rtol=1e-4)
    # never worse than the physical stereo (one of the starts is y = 1)
    phys = disparity_cost(disp[-1], riv[-1], imp, physical, variant=variant, zone=ZONE, maps=maps).total
    assert (sol.cost <= phys * (1 + 1e-5) + 1e-6).all()


def _line(physical, k=32, rivalry=None):
    """A two-layer pixel: the first layer fixed at ``physical[0]``, the second ``y x physical[1]``."""
    ys = np.linspace(0, 1, k + 1)
    phys = np.array([[[[physical[0], 0.0]]], [[[physical[1], 0.0]]]])
    disp = ys[:, None, None, None, None] * phys[None]
    disp[:, 0] = phys[0]  # the diffuse layer does not move
    riv = np.zeros((k + 1, 2, 1, 1)) if rivalry is None else rivalry(ys)[:, None, None, None] * np.ones((1, 2, 1, 1))
    return disp, riv, np.ones((2, 1, 1)), phys


def test_a_comfortable_layer_keeps_its_physical_stereo():
    """A reflection 40' behind the screen, rivalry falling towards mono but below the tolerance
    (RMS 9.5 ΔL* at y = 1): ours leaves it where it is; S3 Eq. 2 as written pulls it to the screen."""
    disp, riv, imp, phys = _line((5.0, 40.0), rivalry=lambda y: 90.0 * y)
    ours = optimise_offsets(disp, riv, imp, phys, variant="comfort", zone=ZONE)
    assert ours.y[1, 0, 0] == 1.0
    s3 = optimise_offsets(disp, riv, imp, phys, variant="screen")
    assert s3.y[1, 0, 0] < 0.5


def test_a_far_reflection_comes_into_the_zone_and_stays_behind_its_mirror():
    """A reflection at 300' on a mirror at 10': the absolute and data terms agree on the target
    zone's edge, 60 - 15 = 45'; S3's data target (the original) would stop it at
    (60 + 0.1 x 300) / 1.1 = 81.8' (issue 26's 85' for 339')."""
    disp, riv, imp, phys = _line((10.0, 300.0))
    for alpha in ((1, 1, 10, 0.1), (1, 0, 10, 0.1), (1, 1, 10, 1.0)):
        sol = optimise_offsets(disp, riv, imp, phys, variant="comfort", zone=ZONE, alpha=alpha)
        assert abs(sol.y[1, 0, 0] * 300.0 - 45.0) < 0.5, alpha
    # with the absolute term off, the data term alone takes it there too
    sol = optimise_offsets(disp, riv, imp, phys, variant="comfort", zone=ZONE, alpha=(0, 0, 0, 1))
    assert abs(sol.y[1, 0, 0] * 300.0 - 45.0) < 0.5


def test_losing_the_match_is_no_escape_from_the_cost():
    """The far reflection again, without a match for 0.25 < y < 0.9: those rows take the disparity
    interpolated between the matched ones (here exactly 300 y), so the answer does not change; the
    kernel's fill against numpy's interpolation of the same table."""
    disp, riv, imp, phys = _line((10.0, 300.0))
    ys = np.linspace(0, 1, disp.shape[0])
    holes = disp.copy()
    holes[(ys > 0.25) & (ys < 0.9), 1] = np.nan
    sol = optimise_offsets(holes, riv, imp, phys, variant="comfort", zone=ZONE)
    assert abs(sol.y[1, 0, 0] * 300.0 - 45.0) < 0.5
    holes[(ys < 0.2), 1] = np.nan  # the starts, too, lose their match: held at the nearest matched row
    filled = holes.copy()
    ok = np.isfinite(holes[:, 1, 0, 0, 0])
    for c in range(2):
        filled[:, 1, 0, 0, c] = np.interp(ys, ys[ok], holes[ok, 1, 0, 0, c])
    a = optimise_offsets(holes, riv, imp, phys, variant="comfort", zone=ZONE)
    b = optimise_offsets(filled, riv, imp, phys, variant="comfort", zone=ZONE)
    np.testing.assert_array_equal(a.y, b.y)
    np.testing.assert_array_equal(a.cost, b.cost)


def test_a_layer_painted_out_of_every_term_is_frozen():
    disp, riv, imp, physical = _table(n=3, h=2, w=3, seed=4)
    maps = {t: np.ones((3, 2, 3)) for t in ("absolute", "relative", "rivalry", "data")}
    for t in maps:
        maps[t][2, 0] = 0.0  # layer 3, top row: frozen
    sol = optimise_offsets(disp, riv, imp, physical, variant="comfort", zone=ZONE, maps=maps)
    assert np.all(sol.y[2, 0] == 1.0)
    free = optimise_offsets(disp, riv, imp, physical, variant="comfort", zone=ZONE)
    assert np.any(free.y[2, 0] < 1.0)  # it would move otherwise
    np.testing.assert_array_equal(sol.y[2, 1], free.y[2, 1])


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda a: a.update(disparity=np.zeros((2, 1, 2, 2, 2))), "K >= 2"),
        (lambda a: a.update(rivalry=np.zeros((3, 1, 2, 3))), "rivalry must have shape"),
        (lambda a: a.update(importance=np.full((1, 2, 2), 2.0)), "importance must be finite"),
        (lambda a: a.update(importance=np.ones((3, 1, 2, 2))), "the physical pair's, held fixed"),
        (lambda a: a.update(rivalry=-np.ones((3, 1, 2, 2))), "rivalry must be >= 0"),
        (lambda a: a.update(original=np.zeros((1, 2, 2))), "original must have shape"),
        (lambda a: a.update(steps=0), "steps must be"),
        (lambda a: a.update(restarts=1.5), "restarts must be"),
        (lambda a: a.update(fixed=(3,)), "fixed must list"),
        (lambda a: a.update(variant="comfort"), "comfort variant needs zone"),
    ],
)
def test_bad_input_is_one_clear_error(change, match):
    args = dict(disparity=np.zeros((3, 1, 2, 2, 2)), rivalry=np.zeros((3, 1, 2, 2)), importance=np.ones((1, 2, 2)),
                original=np.zeros((1, 2, 2, 2)))
    change(args)
    with pytest.raises(ValueError, match=match):
        optimise_offsets(args.pop("disparity"), args.pop("rivalry"), args.pop("importance"), args.pop("original"),
                         **args)  # fmt: skip
