"""Re-synthesise a rendered Quadri-Rig shot with the alternatives to ``render_ibr``'s defaults.

The figures behind the IBR defaults of ``docs/shots.md`` (chosen on the stadium): the proxy link
limit (``IBR_LINK_LIMIT_PX``: 1, 3, 10, 30 px), bicubic against bilinear sampling, all 2N real
cameras per eye against the eye's own N, and the visibility test's slope allowance
(``IBR_OCCLUSION_SLOPE_CAP``: 0, the relative 1 % alone, against 0.05, 0.1, 0.2). It reads what ``vergence rig render`` wrote (the real
cameras' images and depths, the truth), so the ray tracing is not repeated::

    vergence rig render examples/shots/stadium-quadri.json --out stadium-quadri
    python -m tools.rig_choices stadium-quadri examples/shots/stadium-quadri.json

Prints per variant and eye: PSNR (dB) and DSSIM over the covered pixels, DSSIM from the 7x7 windows
wholly inside the covered area, PSNR of the whole image with its holes filled (S1's background fill),
and the coverage.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

# (weights, link limit px, interpolation, sources, visibility slope cap): the defaults first, then one
# change at a time.
VARIANTS = (
    ("ulr", 10.0, "cubic", "all", 0.1),
    ("ulr", 1.0, "cubic", "all", 0.1),
    ("ulr", 3.0, "cubic", "all", 0.1),
    ("ulr", 30.0, "cubic", "all", 0.1),
    ("ulr", 10.0, "linear", "all", 0.1),
    ("ulr", 10.0, "cubic", "eye", 0.1),
    ("ulr", 10.0, "cubic", "all", 0.0),
    ("ulr", 10.0, "cubic", "all", 0.05),
    ("ulr", 10.0, "cubic", "all", 0.2),
    ("bayesian", 10.0, "cubic", "all", 0.1),
)


def main(argv: list[str] | None = None) -> int:
    from vergence.io import read_image, read_pfm
    from vergence.rigs import load_shot
    from vergence.rigs.shoot import measure_against_truth as measure
    from vergence.synthesis import IBRSource, render_ibr

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the --out folder of `vergence rig render`")
    parser.add_argument("shot", type=Path, help="the shot file it rendered (a Quadri-Rig)")
    args = parser.parse_args(argv)
    shot = load_shot(args.shot)
    if shot.rig != "quadri":
        parser.error("the shot must be a Quadri-Rig")
    rig = shot.plan()
    sources = {rc.name: IBRSource(camera=rc.camera,
                                  image=read_image(args.folder / "cameras" / f"{rc.name}.png").astype(np.float32),
                                  depth=read_pfm(args.folder / "cameras" / f"{rc.name}_depth.pfm").astype(np.float64))
               for rc in rig.cameras}  # fmt: skip
    print(f"{'weights':9s} {'link px':>7s} {'sampling':8s} {'sources':7s} {'slope':>5s} {'eye':5s} {'PSNR':>6s} "
          f"{'DSSIM':>8s} {'inside':>8s} {'filled':>6s} {'coverage':>8s}")
    for eye in ("left", "right"):
        truth = read_image(args.folder / "truth" / f"{eye}.png").astype(np.float32)
        for weights, limit, interp, which, slope in VARIANTS:
            names = [rc.name for rc in (rig.cameras if which == "all" else rig.sources(eye))]
            res = render_ibr(rig.virtual(eye), [sources[n] for n in names], weights=weights, gradient_limit=limit,
                             interpolation=interp, occlusion_slope_cap=slope)  # fmt: skip
            m = measure(res.image, truth, res.coverage, res.proxy_depth)
            print(f"{weights:9s} {limit:7g} {interp:8s} {which:7s} {slope:5g} {eye:5s} {m['psnr']:6.2f} "
                  f"{m['dssim']:8.4f} {m['dssim_inside']:8.4f} {m['psnr_filled']:6.2f} {100 * m['coverage']:7.1f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
