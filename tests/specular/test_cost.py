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
    r = rng.uniform(0, 300, (n, h, w))  # RMS 0-17 (ΔL*): both sides of rho_0 = 10
    imp = rng.uniform(0, 1, (n, h, w))
    d[1, 0, 0] = np.nan  # a layer without a match at one pixel
    r[1, 0, 0] = np.nan
    maps = {t: rng.uniform(0, 2, (n, h, w)) for t in ("absolute", "relative", "rivalry", "data")}
    return d, r, imp, o, maps


def _reference(d, r, imp, o, maps, alpha, variant, zone, lam, margin=15.0, vertical=15.0, rho0=10.0):
    """The cost written out pixel by pixel, layer by layer, pair by pair (the module text's formulas)."""
    n, h, w, _ = d.shape
    out = np.zeros((4, h, w))
    lo, hi = zone[0] + margin, zone[1] - margin
    for y, x in itertools.product(range(h), range(w)):
        ok = [bool(np.isfinite(d[i, y, x]).all() and np.isfinite(r[i, y, x])) for i in range(n)]
        for i in range(n):
            if not ok[i]:
                continue
            wi2 = imp[i, y, x] ** 2
            dx, dy = d[i, y, x]
            if variant == "comfort":
                ax = dx - hi if dx > hi else (dx - lo if dx < lo else 0.0)
                ay = abs(dy) - vertical if abs(dy) > vertical else 0.0
                target = (min(hi, max(lo, o[i, y, x, 0])), min(vertical, max(-vertical, o[i, y, x, 1])))
                riv = max(0.0, np.sqrt(r[i, y, x]) - rho0) ** 2
            else:
                ax, ay, target, riv = dx, dy, o[i, y, x], r[i, y, x] ** 2
            out[0, y, x] += maps["absolute"][i, y, x] * wi2 * (ax**2 + ay**2)
            out[2, y, x] += maps["rivalry"][i, y, x] * wi2 * riv
            out[3, y, x] += maps["data"][i, y, x] * wi2 * ((dx - target[0]) ** 2 + (dy - target[1]) ** 2)
            for j in range(i + 1, n):
                if not ok[j]:
                    continue
                mp = (maps["relative"][i, y, x] + maps["relative"][j, y, x]) / 2
                ww = (imp[i, y, x] * imp[j, y, x]) ** 2
                for c in range(2 if variant == "screen" else 1):
                    now = d[j, y, x, c] - d[i, y, x, c]
                    phys = o[j, y, x, c] - o[i, y, x, c]
                    sigma = np.sign(phys) if phys != 0 else (1.0 if now >= 0 else -1.0)
                    gap = sigma * now - lam[c]
                    if variant == "comfort":
                        gap = min(gap, 0.0)
                    out[1, y, x] += mp * ww * gap**2
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
    d[2, 0, 0, 0] = 20.0 + d[1, 0, 0, 0]  # a pair apart, one close: both branches of our relative term
    d[1, 3, 4, 1] = 40.0  # a vertical disparity beyond the tolerance
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
    costs, ours = {}, {}
    for gap in (-3.0, 0.0, 1.5, 3.0, 6.0, 40.0):
        d, _, _ = _two_layers(10.0, 10.0 + gap)
        costs[gap] = float(disparity_cost(d, r, imp, physical, alpha=(0, 1, 0, 0)).total[0, 0])
        ours[gap] = float(disparity_cost(d, r, imp, physical, alpha=(0, 1, 0, 0), variant="comfort",
                                         zone=ZONE).total[0, 0])  # fmt: skip
    # S3's (unordered, ordered by the physical pair): pulled to lambda = 3' behind from either side
    assert costs[3.0] == 0.0 and costs[0.0] > costs[1.5] > 0 and costs[6.0] > 0
    assert costs[-3.0] > costs[0.0]  # in front of the mirror is worse than on it: the order is kept
    # ours: no pull on a pair already apart, a floor at lambda, the order kept
    assert ours[3.0] == ours[6.0] == ours[40.0] == 0.0
    assert ours[-3.0] == 36.0 and ours[0.0] == 9.0 and ours[1.5] == 2.25


def test_comfort_variant_costs_only_what_lies_outside_the_target_zone():
    # the target zone is the comfort zone less the 15' margin: (-55, 45) for ZONE = (-70, 60)
    inside, r, imp = _two_layers(-50.0, 40.0)
    assert disparity_cost(inside, r, imp, inside, alpha=(1, 0, 0, 0), variant="comfort", zone=ZONE).total[0, 0] == 0
    assert disparity_cost(inside, r, imp, inside, alpha=(1, 0, 0, 0)).total[0, 0] == 50.0**2 + 40.0**2
    outside, _, _ = _two_layers(-80.0, 100.0)
    got = disparity_cost(outside, r, imp, outside, alpha=(1, 0, 0, 0), variant="comfort", zone=ZONE).total[0, 0]
    assert got == pytest.approx(25.0**2 + 55.0**2)
    no_margin = disparity_cost(outside, r, imp, outside, alpha=(1, 0, 0, 0), variant="comfort", zone=ZONE, margin=0)
    assert no_margin.total[0, 0] == pytest.approx(10.0**2 + 40.0**2)
    # vertical disparity up to 15' is tolerated, beyond it the excess costs
    d = np.array([[[[0.0, 10.0]]], [[[0.0, -25.0]]]])
    got = disparity_cost(d, r, imp, d, alpha=(1, 0, 0, 0), variant="comfort", zone=ZONE).total[0, 0]
    assert got == pytest.approx(10.0**2)


def test_the_data_term_pulls_to_the_nearest_comfortable_disparity_not_against_the_zone():
    """S3's data term pulls an excessive original back out of the zone; ours pulls to the target
    zone's edge, where the absolute term is 0 too: with the two, a reflection at 339' settles at
    45' whatever alpha_d, against (45 + 0.1 x 339) / 1.1 = 71.7' with S3's target."""
    physical, r, imp = _two_layers(0.0, 339.0)
    xs = np.linspace(0.0, 339.0, 679)  # 0.5' apart
    for variant, alpha_d, want in (("comfort", 0.1, 45.0), ("comfort", 10.0, 45.0)):
        costs = [float(disparity_cost(_two_layers(0.0, x)[0], r, imp, physical, alpha=(1, 0, 0, alpha_d),
                                      variant=variant, zone=(-60, 60)).total[0, 0]) for x in xs]  # fmt: skip
        assert xs[int(np.argmin(costs))] == pytest.approx(want, abs=0.26)
    # S3's data target with the same absolute term: the compromise of issue 26, between 45' and 339'
    costs = [float(disparity_cost(_two_layers(0.0, x)[0], r, imp, physical, alpha=(1, 0, 0, 0.1), variant="comfort",
                                  zone=(-60, 60)).absolute[0, 0] + 0.1 * (x - 339.0) ** 2) for x in xs]  # fmt: skip
    assert xs[int(np.argmin(costs))] == pytest.approx((45 + 0.1 * 339) / 1.1, abs=0.26)


def test_rivalry_is_costed_in_lightness_units_above_a_tolerance():
    d, _, imp = _two_layers(0.0, 20.0)
    r = np.array([[[0.0]], [[196.0]]])  # RMS difference of 14 (ΔL*)
    ours = disparity_cost(d, r, imp, d, alpha=(0, 0, 1, 0), variant="comfort", zone=ZONE)
    assert ours.rivalry[0, 0] == pytest.approx((14.0 - 10.0) ** 2)  # (ΔL*)^2 beyond rho_0 = 10
    assert disparity_cost(d, r * 0.25, imp, d, alpha=(0, 0, 1, 0), variant="comfort", zone=ZONE).total[0, 0] == 0.0
    assert disparity_cost(d, r, imp, d, alpha=(0, 0, 1, 0)).rivalry[0, 0] == 196.0**2  # S3's ||W r||^2


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
        (lambda a: a.update(rivalry=-np.ones((1, 2, 2))), "rivalry must be >= 0"),
    ],
)
def test_bad_input_is_one_clear_error(change, match):
    args = dict(disparity=np.zeros((1, 2, 2, 2)), rivalry=np.zeros((1, 2, 2)), importance=np.ones((1, 2, 2)),
                original=np.zeros((1, 2, 2, 2)))
    change(args)
    kw = {k: args.pop(k) for k in ("alpha", "variant", "maps") if k in args}
    with pytest.raises(ValueError, match=match):
        disparity_cost(args["disparity"], args["rivalry"], args["importance"], args["original"], **kw)
