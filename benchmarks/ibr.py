"""Speed of multi-view IBR at 1920 x 1080: ``render_ibr`` (ULR) vs its staged path and plain numpy, 4 sources.

1. ``render_ibr(weights="ulr")`` with a given proxy depth, bilinear and bicubic (the default): the
   fused kernel (one pass over the target's rows: projection, field of view, visibility, ULR
   weights, sampling, blend) against the staged path it replaced (issue 31: per-source full-frame
   slopes, projection, visibility and colour, then ULR weights, then the blend;
   ``_ibr_stages.ulr_staged`` swapped in for ``ulr_fused``) and, bilinear, against a plain numpy
   implementation of the same ULR (``numpy_ulr`` below: same formulas, same visibility rule,
   whole-image array operations). Same process, same inputs, interleaved runs; medians, their
   ratios, and the largest differences between the images and weights.
2. ``render_ibr`` with the proxy forward-warped from the 4 sources' depths (mesh z-buffer).
3. ``render_ibr(weights="bayesian")``: the one-pass sampling of all sources against the staged
   per-source sampling (``_ibr_stages.sample_sources_staged``).

The scene is analytic: a textured wall 10 m away and 12 textured spheres in front of it, seen by
4 cameras 1920 x 1080 on a 0.6 m x 0.3 m grid around the target. Timings are wall-clock medians of
``--repeats`` runs after a warm-up that compiles the kernels; the CPU time of the process and the
load average are printed too, since the cores may be shared. Run:
``.venv/bin/python benchmarks/ibr.py [--repeats N] [--threads N]``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Iterator

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before Numba starts its OpenMP threads

import numba  # noqa: E402
import numpy as np  # noqa: E402

from _timing import report, timed  # noqa: E402
from vergence.camera import Camera, look_at  # noqa: E402
from vergence.synthesis import IBRSource, render_ibr  # noqa: E402
from vergence.synthesis import _ibr_stages  # noqa: E402
from vergence.synthesis._ibr_stages import FOV_MARGIN_PX, surface_slopes  # noqa: E402
from vergence.synthesis.ibr import (  # noqa: E402
    IBR_OCCLUSION_SLOPE_CAP,
    IBR_OCCLUSION_TOLERANCE,
    ULR_ALPHA,
    ULR_BETA,
    ULR_FOV_BAND,
    ULR_GAMMA,
    ULR_K,
    ULR_PENALTY_FLOOR,
    ULR_RELATIVE_THRESHOLD,
    ULR_THRESHOLD_SCALE,
)

WIDTH, HEIGHT = 1920, 1080
WALL_Z = 10.0


def _camera(x: float, y: float) -> Camera:
    return look_at([x, y, 0.0], [0.0, 0.0, WALL_Z], [0.0, -1.0, 0.0], fov_deg=60.0, width=WIDTH, height=HEIGHT)


def _texture(p: np.ndarray) -> np.ndarray:
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    out = np.stack([0.5 + 0.4 * np.sin(7 * x + z), 0.5 + 0.4 * np.cos(5 * y - z), 0.5 + 0.3 * np.sin(3 * (x + y))], axis=-1)
    return out.astype(np.float32)


def render_scene(cam: Camera, spheres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray-cast image and camera-frame depth of the wall and the spheres (rows: centre xyz, radius)."""
    d = cam.ray_directions()
    c = cam.center
    t = (WALL_Z - c[2]) / d[..., 2]
    for sx, sy, sz, r in spheres:
        oc = c - np.array([sx, sy, sz])
        b = d @ oc
        disc = b * b - (oc @ oc - r * r)
        with np.errstate(invalid="ignore"):
            hit = -b - np.sqrt(disc)
        t = np.where((disc > 0) & (hit > 0) & (hit < t), hit, t)
    p = c + t[..., None] * d
    return _texture(p), (p - c) @ cam.R[2]


def numpy_ulr(target: Camera, sources: list[IBRSource], proxy_depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference: ULR with a given proxy in whole-image numpy operations (image, normalised weights)."""
    points = target.backproject_depth(proxy_depth)
    n, (h, w) = len(sources), proxy_depth.shape
    pens = np.full((n, h, w), np.inf)
    colours = np.zeros((n, h, w, 3), dtype=np.float32)
    r = points - target.center
    dn = np.linalg.norm(r, axis=-1)
    for i, src in enumerate(sources):
        cam, img, dep = src.camera, src.image, src.depth
        hs, ws = dep.shape
        q = points @ cam.R.T + cam.t
        z = q[..., 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            u = (cam.K[0, 0] * q[..., 0] + cam.K[0, 1] * q[..., 1]) / z + cam.K[0, 2]
            v = cam.K[1, 1] * q[..., 1] / z + cam.K[1, 2]
            m = FOV_MARGIN_PX
            inside = (z > 0) & (u >= -m) & (u <= ws - 1 + m) & (v >= -m) & (v <= hs - 1 + m)
        uc = np.clip(np.where(inside, u, 0.0), 0, ws - 1)
        vc = np.clip(np.where(inside, v, 0.0), 0, hs - 1)
        x0 = np.minimum(np.floor(uc).astype(np.intp), ws - 1)
        y0 = np.minimum(np.floor(vc).astype(np.intp), hs - 1)
        fx, fy = uc - x0, vc - y0
        tol = IBR_OCCLUSION_TOLERANCE * z
        slopes = surface_slopes(dep, IBR_OCCLUSION_SLOPE_CAP)  # towards -x, +x, -y, +y (tested against a loop)

        def allowed(xj: np.ndarray, yj: np.ndarray) -> np.ndarray:
            """The visibility test's tolerance at source pixel (xj, yj): relative plus its slope on the
            projection's side times the distance."""
            sx = np.where(uc > xj, slopes[1][yj, xj], slopes[0][yj, xj])
            sy = np.where(vc > yj, slopes[3][yj, xj], slopes[2][yj, xj])
            return tol + sx * np.abs(uc - xj) + sy * np.abs(vc - yj)

        xn = np.minimum(np.floor(uc + 0.5).astype(np.intp), ws - 1)
        yn = np.minimum(np.floor(vc + 0.5).astype(np.intp), hs - 1)
        with np.errstate(invalid="ignore"):
            near = np.abs(dep[yn, xn] - z) <= allowed(xn, yn)
        vis = inside & near
        total = np.zeros((h, w))
        acc = np.zeros((h, w, 3))
        for dx, dy, b in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
            xj, yj = np.minimum(x0 + dx, ws - 1), np.minimum(y0 + dy, hs - 1)
            with np.errstate(invalid="ignore"):
                ok = (b > 0) & (x0 + dx < ws) & (y0 + dy < hs) & (np.abs(dep[yj, xj] - z) <= allowed(xj, yj))
            bb = np.where(ok, b, 0.0)
            total += bb
            acc += bb[..., None] * img[yj, xj]
        with np.errstate(invalid="ignore", divide="ignore"):
            colours[i] = np.where(vis[..., None], acc / total[..., None], 0.0)
        vi = points - cam.center
        di = np.linalg.norm(vi, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            ang = np.arccos(np.clip(np.einsum("hwc,hwc->hw", vi, r) / (di * dn), -1.0, 1.0))
            res = (di - dn) / di
            edge = np.minimum(np.minimum(u + 0.5, ws - 0.5 - u), np.minimum(v + 0.5, hs - 0.5 - v))
            band = ULR_FOV_BAND * min(ws, hs)
            fov = np.where(edge < band, ULR_GAMMA * (band / edge - 1.0) ** 2, 0.0)
        pen = ULR_ALPHA * np.maximum(ULR_PENALTY_FLOOR, ang) + ULR_BETA * np.maximum(ULR_PENALTY_FLOOR, res) + fov
        pens[i] = np.where(vis, pen, np.inf)
    order = np.argsort(pens, axis=0, kind="stable")  # ties to the lower index
    rank = np.argsort(order, axis=0, kind="stable")
    count = np.isfinite(pens).sum(axis=0)
    ranked = np.sort(pens, axis=0)
    kth = ranked[ULR_K - 1] if n >= ULR_K else np.full((h, w), np.inf)  # inf with fewer than k visible
    thresh = ULR_THRESHOLD_SCALE * np.minimum(kth, ULR_RELATIVE_THRESHOLD * ranked[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        wt = np.where((rank < ULR_K) & np.isfinite(pens) & (count > 0), np.maximum(0.0, 1.0 - pens / thresh), 0.0)
    wt = wt.astype(np.float32)
    total = wt.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        wt = np.where(total > 0, wt / total, 0.0).astype(np.float32)
    image = np.einsum("shw,shwc->hwc", wt, colours).astype(np.float32)
    return image, wt


@contextlib.contextmanager
def staged() -> Iterator[None]:
    """``render_ibr`` as before the fused kernels (issue 31): the staged ULR path and the staged
    per-source sampling swapped in for the fused ones."""
    fused, sample = _ibr_stages.ulr_fused, _ibr_stages.sample_sources
    _ibr_stages.ulr_fused, _ibr_stages.sample_sources = _ibr_stages.ulr_staged, _ibr_stages.sample_sources_staged
    try:
        yield
    finally:
        _ibr_stages.ulr_fused, _ibr_stages.sample_sources = fused, sample


def load() -> str:
    return "load average " + " ".join(open("/proc/loadavg").read().split()[:3])  # noqa: SIM115


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--threads", type=int, default=None, help="Numba threads (default: all cores)")
    args = parser.parse_args(argv)
    if args.threads is not None:
        numba.set_num_threads(args.threads)
    rng = np.random.default_rng(20261125)
    spheres = np.column_stack([rng.uniform(-3, 3, 12), rng.uniform(-1.5, 1.5, 12), rng.uniform(4, 8, 12), rng.uniform(0.3, 0.8, 12)])
    sources = [IBRSource(_camera(x, y), *render_scene(_camera(x, y), spheres)) for x, y in ((-0.3, -0.15), (0.3, -0.15), (-0.3, 0.15), (0.3, 0.15))]
    target = _camera(0.1, 0.05)
    proxy = render_scene(target, spheres)[1]
    print(f"{WIDTH}x{HEIGHT} target, 4 sources {WIDTH}x{HEIGHT}; cores: {os.cpu_count()}, Numba threads: "
          f"{numba.get_num_threads()}, layer: {numba.threading_layer()}, OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}; "
          f"{load()}")

    def ulr(interpolation: str) -> object:
        return render_ibr(target, sources, proxy_depth=proxy, interpolation=interpolation)

    def ulr_staged(interpolation: str) -> object:
        with staged():
            return ulr(interpolation)

    # Warm-up (compiles or loads the kernels) and agreement.
    for interp in ("linear", "cubic"):
        fast, slow = ulr(interp), ulr_staged(interp)
        print(f"fused vs staged, {interp}: max |image diff| {np.abs(fast.image - slow.image).max():.2e}, max |weight diff| "
              f"{np.abs(fast.weights - slow.weights).max():.2e}, coverage equal: {bool((fast.coverage == slow.coverage).all())}")
    fast = ulr("linear")
    ref_image, ref_w = numpy_ulr(target, sources, proxy)
    print(f"numpy vs render_ibr, linear: max |image diff| {np.abs(fast.image - ref_image).max():.2e}, "
          f"max |weight diff| {np.abs(fast.weights - ref_w).max():.2e}, coverage {fast.coverage.mean():.3f}")
    runs: dict[str, list] = {name: [] for name in ("fused cubic", "fused linear", "staged cubic", "staged linear", "numpy")}
    for _ in range(args.repeats):  # interleaved, so all see the same machine load
        runs["fused cubic"].append(timed(lambda: ulr("cubic")))
        runs["staged cubic"].append(timed(lambda: ulr_staged("cubic")))
        runs["fused linear"].append(timed(lambda: ulr("linear")))
        runs["staged linear"].append(timed(lambda: ulr_staged("linear")))
        runs["numpy"].append(timed(lambda: numpy_ulr(target, sources, proxy)))
    t = {}
    t["fused cubic"] = report("render_ibr ulr bicubic (default), given proxy", runs["fused cubic"], "  goal < 150 ms", width=50)
    t["fused linear"] = report("render_ibr ulr bilinear, given proxy", runs["fused linear"], "  goal < 150 ms", width=50)
    t["staged cubic"] = report("staged (before issue 31) bicubic", runs["staged cubic"], width=50)
    t["staged linear"] = report("staged (before issue 31) bilinear", runs["staged linear"], width=50)
    t["numpy"] = report("plain numpy ULR bilinear, given proxy", runs["numpy"], width=50)
    print(f"fusing: bicubic {t['staged cubic'] / t['fused cubic']:.1f}x, bilinear {t['staged linear'] / t['fused linear']:.1f}x "
          f"faster; numpy / render_ibr bilinear: {t['numpy'] / t['fused linear']:.1f}x (staged: "
          f"{t['numpy'] / t['staged linear']:.1f}x); {load()}")
    render_ibr(target, sources)
    report("render_ibr ulr, forward-warped proxy", [timed(lambda: render_ibr(target, sources)) for _ in range(args.repeats)],
           width=50)

    def bayes() -> object:
        return render_ibr(target, sources, proxy_depth=proxy, weights="bayesian")

    def bayes_staged() -> object:
        with staged():
            return bayes()

    fast, slow = bayes(), bayes_staged()
    print(f"bayesian, fused vs staged sampling: max |image diff| {np.abs(fast.image - slow.image).max():.2e}")
    b_runs: dict[str, list] = {"fused": [], "staged": []}
    for _ in range(max(1, args.repeats // 2)):
        b_runs["fused"].append(timed(bayes))
        b_runs["staged"].append(timed(bayes_staged))
    tb = report("render_ibr bayesian (4 passes), given proxy", b_runs["fused"], width=50)
    tbs = report("staged sampling (before issue 31) bayesian", b_runs["staged"], width=50)
    print(f"bayesian: {tbs / tb:.1f}x; {load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
