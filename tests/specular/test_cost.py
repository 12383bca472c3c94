"""The layered disparity cost (S3 §3.3, Eq. 2): against a pixel-by-pixel reference, its gradient
against finite differences, and what each term asks of the disparities."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from vergence.specular import COST_WEIGHTS, disparity_cost, disparity_cost_gradient

ZONE = (-70.0, 60.0)


def _random(n=3, h=4, w=5, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.normal(0, 80, (n, h, w, 2))
    o = rng.normal(0, 80, (n, h, w, 2))
    r = rng.uniform(0, 30, (n, h, w))
    imp = rng.uniform(0, 1, (n, h, w))
    d[1, 0, 0] = np.nan  # a layer without a match at one pixel
    r[1, 0, 0] = np.nan
    maps = {t: rng.uniform(0, 2, (n, h, w)) for t in ("absolute", "relative", "rivalry", "data")}
    return d, r, imp, o, maps


def _reference(d, r, imp, o, maps, alpha, variant, zone, lam):
    """The cost written out pixel by pixel, layer by layer, pair by pair."""
    n, h, w, _ = d.shape
    out = np.zeros((4, h, w))
    for y, x in itertools.product(range(h), range(w)):
        ok = [bool(np.isfinite(d[i, y, x]).all() and np.isfinite(r[i, y, x])) for i in range(n)]
        for i in range(n):
            if not ok[i]:
                continue
            wi2 = imp[i, y, x] ** 2
            ax = d[i, y, x, 0]
            if variant == "comfort":
                ax = ax - zone[1] if ax > zone[1] else (ax - zone[0] if ax < zone[0] else 0.0)
            out[0, y, x] += maps["absolute"][i, y, x] * wi2 * (ax**2 + d[i, y, x, 1] ** 2)
            out[2, y, x] += maps["rivalry"][i, y, x] * wi2 * r[i, y, x] ** 2
            out[3, y, x] += maps["data"][i, y, x] * wi2 * float(((d[i, y, x] - o[i, y, x]) ** 2).sum())
            for j in range(i + 1, n):
                if not ok[j]:
                    continue
                mp = (maps["relative"][i, y, x] + maps["relative"][j, y, x]) / 2
                ww = (imp[i, y, x] * imp[j, y, x]) ** 2
                for c in range(2):
                    now = d[j, y, x, c] - d[i, y, x, c]
                    phys = o[j, y, x, c] - o[i, y, x, c]
                    sigma = np.sign(phys) if phys != 0 else (1.0 if now >= 0 else -1.0)
                    out[1, y, x] += mp * ww * (sigma * now - lam[c]) ** 2
    total = sum(a * t for a, t in zip(alpha, out))
    return out, total


@pytest.mark.parametrize("variant", ["screen", "comfort"])
def test_cost_matches_the_pixel_by_pixel_reference(variant):
    d, r, imp, o, maps = _random()
    alpha, lam = (1.0, 2.0, 10.0, 0.1), (3.0, 0.0)
    got = disparity_cost(d, r, imp, o, alpha=alpha, variant=variant, zone=ZONE, maps=maps, lam=lam)
    terms, total = _reference(d, r, imp, o, maps, alpha, variant, ZONE, lam)
    for k, name in enumerate(("absolute", "relative", "rivalry", "data")):
        np.testing.assert_allclose(getattr(got, name), terms[k], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(got.total, total, rtol=1e-12)
    assert got.alpha == alpha and got.variant == variant


@pytest.mark.parametrize("variant", ["screen", "comfort"])
def test_gradient_matches_finite_differences(variant):
    d, r, imp, o, maps = _random(seed=1)
    d, r = np.nan_to_num(d), np.nan_to_num(r)  # every layer matched: the derivative is defined
    kw = dict(variant=variant, zone=ZONE, maps=maps)
    gd, gr = disparity_cost_gradient(d, r, imp, o, **kw)
    step = 1e-5
    for idx in [(0, 1, 2, 0), (1, 3, 4, 1), (2, 0, 0, 0), (2, 2, 3, 1)]:
        up, down = d.copy(), d.copy()
        up[idx] += step
        down[idx] -= step
        num = (disparity_cost(up, r, imp, o, **kw).total - disparity_cost(down, r, imp, o, **kw).total) / (2 * step)
        assert gd[idx] == pytest.approx(num[idx[1], idx[2]], rel=1e-5, abs=1e-6)
    for idx in [(0, 1, 2), (2, 3, 4)]:
        up, down = r.copy(), r.copy()
        up[idx] += step
        down[idx] -= step
        num = (disparity_cost(d, up, imp, o, **kw).total - disparity_cost(d, down, imp, o, **kw).total) / (2 * step)
        assert gr[idx] == pytest.approx(num[idx[1], idx[2]], rel=1e-5)


def _two_layers(mirror, reflection):
    """A mirror pixel and the reflection seen in it, both fully important, disparities in arcmin."""
    d = np.array([[[[mirror, 0.0]]], [[[reflection, 0.0]]]])
    return d, np.zeros((2, 1, 1)), np.ones((2, 1, 1))


def test_relative_term_keeps_a_reflection_lambda_behind_its_mirror():
    physical, r, imp = _two_layers(10.0, 200.0)  # the reflection far behind its mirror
    costs = {}
    for gap in (-3.0, 0.0, 1.5, 3.0, 6.0):
        d, _, _ = _two_layers(10.0, 10.0 + gap)
        costs[gap] = float(disparity_cost(d, r, imp, physical, alpha=(0, 1, 0, 0)).total[0, 0])
    assert costs[3.0] == 0.0 and costs[0.0] > costs[1.5] > 0 and costs[6.0] > 0
    assert costs[-3.0] > costs[0.0]  # in front of the mirror is worse than on it: the order is kept


def test_comfort_variant_costs_only_what_lies_outside_the_zone():
    inside, r, imp = _two_layers(-50.0, 40.0)
    assert disparity_cost(inside, r, imp, inside, alpha=(1, 0, 0, 0), variant="comfort", zone=ZONE).total[0, 0] == 0
    assert disparity_cost(inside, r, imp, inside, alpha=(1, 0, 0, 0)).total[0, 0] == 50.0**2 + 40.0**2
    outside, _, _ = _two_layers(-80.0, 100.0)
    got = disparity_cost(outside, r, imp, outside, alpha=(1, 0, 0, 0), variant="comfort", zone=ZONE).total[0, 0]
    assert got == pytest.approx(10.0**2 + 40.0**2)


def test_unmatched_layers_and_unimportant_pixels_add_nothing():
    d, r, imp = _two_layers(100.0, np.nan)
    r[1] = np.nan
    o = np.zeros_like(d)
    got = disparity_cost(d, r, imp, o)
    assert got.relative[0, 0] == 0 and got.absolute[0, 0] == 100.0**2
    gd, gr = disparity_cost_gradient(d, r, imp, o)
    assert (gd[1] == 0).all() and (gr[1] == 0).all()
    assert disparity_cost(d, r, np.zeros_like(imp), o).total[0, 0] == 0
    assert COST_WEIGHTS == (1.0, 1.0, 10.0, 0.1)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda a: a.update(disparity=np.zeros((2, 3, 2))), "disparity must have shape"),
        (lambda a: a.update(importance=np.full((1, 2, 2), 1.5)), "importance must be finite and in"),
        (lambda a: a.update(rivalry=np.zeros((1, 2, 3))), "rivalry must have shape"),
        (lambda a: a.update(disparity=np.full((1, 2, 2, 2), np.inf)), "must not hold inf"),
        (lambda a: a.update(alpha=(1, 1, 1)), "alpha must be four"),
        (lambda a: a.update(alpha=(1, -1, 1, 1)), "alpha must be four"),
        (lambda a: a.update(variant="flat"), "variant must be one of"),
        (lambda a: a.update(variant="comfort"), "comfort variant needs zone"),
        (lambda a: a.update(maps={"rivalry": -np.ones((1, 2, 2))}), "rivalry weight map must be finite and >= 0"),
        (lambda a: a.update(maps={"rivalry": np.ones((1, 3, 2))}), "rivalry weight map must have shape"),
        (lambda a: a.update(maps={"shine": np.ones((1, 2, 2))}), "unknown terms"),
    ],
)
def test_bad_input_is_one_clear_error(change, match):
    args = dict(disparity=np.zeros((1, 2, 2, 2)), rivalry=np.zeros((1, 2, 2)), importance=np.ones((1, 2, 2)),
                original=np.zeros((1, 2, 2, 2)))
    change(args)
    kw = {k: args.pop(k) for k in ("alpha", "variant", "maps") if k in args}
    with pytest.raises(ValueError, match=match):
        disparity_cost(args["disparity"], args["rivalry"], args["importance"], args["original"], **kw)
