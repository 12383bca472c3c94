"""Per-pixel offsets (S3 §3.4): the descent against a brute-force search on the same table, its
cost against the numpy cost, and what it does on simple layered pixels."""

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
    riv = (1 - ys)[:, None, None, None] * rng.uniform(0, 5, (n, h, w))[None]
    imp = np.broadcast_to(rng.uniform(0.2, 1, (n, h, w)), (k + 1, n, h, w)).copy()
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
                c = disparity_cost(at(disp), at(riv), at(imp), physical[:, yy : yy + 1, xx : xx + 1], **kw).total[0, 0]
                best = min(best, c)
            assert sol.cost[yy, xx] <= best * (1 + 1e-3) + 1e-6, (yy, xx, sol.cost[yy, xx], best)


@pytest.mark.parametrize("variant", ["screen", "comfort"])
def test_reported_cost_is_the_numpy_cost_at_the_offsets(variant):
    disp, riv, imp, physical = _table(n=3, seed=2)
    maps = {"relative": np.full(physical.shape[:3], 2.0)}
    sol = optimise_offsets(disp, riv, imp, physical, variant=variant, zone=ZONE, maps=maps)
    at = lambda tab: _interp(tab, sol.y)  # noqa: E731
    ref = disparity_cost(at(disp).astype(np.float32), at(riv).astype(np.float32), at(imp).astype(np.float32),
                         physical, variant=variant, zone=ZONE, maps=maps)  # fmt: skip
    np.testing.assert_allclose(sol.cost, ref.total, rtol=1e-4)
    # never worse than the physical stereo (one of the starts is y = 1)
    phys = disparity_cost(disp[-1], riv[-1], imp[-1], physical, variant=variant, zone=ZONE, maps=maps).total
    assert (sol.cost <= phys * (1 + 1e-5) + 1e-6).all()


def test_a_comfortable_pixel_keeps_its_physical_stereo():
    disp, riv, imp, physical = _table(n=2)
    inside = np.clip(physical, -40, 40)
    inside[..., 1] = 0.0  # vertical disparity is never comfortable: the absolute term would shrink it
    disp = np.linspace(0, 1, disp.shape[0])[:, None, None, None, None] * inside[None]
    sol = optimise_offsets(disp, riv, imp, inside, variant="comfort", zone=ZONE, alpha=(1, 0, 10, 0.1))
    assert np.allclose(sol.y, 1.0)  # inside the zone only the data, rivalry and relative terms act: y = 1 is best
    # the relative term is off here (alpha_p = 0): layers 3' apart or more would want to keep their gap


def test_a_far_reflection_comes_into_the_zone_and_stays_behind_its_mirror():
    """A reflection at 300 arcmin (far behind the screen) on a mirror at 10. With S3's weights the
    relative term (pulling it to 3' behind the mirror, its physical order kept) and the data term
    (pulling it back to 300) meet at 2 (x - 13) + 0.2 (x - 300) = 0, x = 39.1', inside the zone;
    without the relative term the comfort variant pulls it only to the zone's far edge."""
    k = 32
    ys = np.linspace(0, 1, k + 1)
    physical = np.array([[[[10.0, 0.0]]], [[[300.0, 0.0]]]])
    disp = ys[:, None, None, None, None] * physical[None]
    disp[:, 0] = physical[0]  # the diffuse layer does not move
    riv = np.zeros((k + 1, 2, 1, 1))
    imp = np.ones((k + 1, 2, 1, 1))
    s3 = optimise_offsets(disp, riv, imp, physical, variant="comfort", zone=ZONE)
    assert abs(s3.y[1, 0, 0] * 300.0 - 86.0 / 2.2) < 0.5
    edge = optimise_offsets(disp, riv, imp, physical, variant="comfort", zone=ZONE, alpha=(1, 0, 10, 0.1))
    # the zone's edge against the data term: 2 (x - 60) + 0.2 (x - 300) = 0, x = 81.8'
    assert abs(edge.y[1, 0, 0] * 300.0 - 180.0 / 2.2) < 0.5


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda a: a.update(disparity=np.zeros((2, 1, 2, 2, 2))), "K >= 2"),
        (lambda a: a.update(rivalry=np.zeros((3, 1, 2, 3))), "rivalry must have shape"),
        (lambda a: a.update(importance=np.full((3, 1, 2, 2), 2.0)), "importance must be finite"),
        (lambda a: a.update(original=np.zeros((1, 2, 2))), "original must have shape"),
        (lambda a: a.update(steps=0), "steps must be"),
        (lambda a: a.update(restarts=1.5), "restarts must be"),
        (lambda a: a.update(fixed=(3,)), "fixed must list"),
        (lambda a: a.update(variant="comfort"), "comfort variant needs zone"),
    ],
)
def test_bad_input_is_one_clear_error(change, match):
    args = dict(disparity=np.zeros((3, 1, 2, 2, 2)), rivalry=np.zeros((3, 1, 2, 2)), importance=np.ones((3, 1, 2, 2)),
                original=np.zeros((1, 2, 2, 2)))
    change(args)
    with pytest.raises(ValueError, match=match):
        optimise_offsets(args.pop("disparity"), args.pop("rivalry"), args.pop("importance"), args.pop("original"),
                         **args)  # fmt: skip
