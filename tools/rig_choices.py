"""Re-synthesise a rendered Quadri-Rig shot with the alternatives to ``render_ibr``'s defaults.

The figures behind the IBR defaults of ``docs/shots.md`` (chosen on the stadium): the proxy link
limit (``IBR_LINK_LIMIT_PX``: 1, 3, 10, 30 px), bicubic against bilinear sampling, and all 2N real
cameras per eye against the eye's own N. It reads what ``vergence rig render`` wrote (the real
cameras' images and depths, the truth), so the ray tracing is not repeated::

    vergence rig render examples/shots/stadium-quadri.json --out stadium-quadri
    python -m tools.rig_choices stadium-quadri examples/shots/stadium-quadri.json

Prints PSNR (dB), DSSIM and coverage of each variant per eye, over the covered pixels.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

# (weights, link limit px, interpolation, sources): the defaults first, then one change at a time.
VARIANTS = (
    ("ulr", 10.0, "cubic", "all"),
    ("ulr", 1.0, "cubic", "all"),
    ("ulr", 3.0, "cubic", "all"),
    ("ulr", 30.0, "cubic", "all"),
    ("ulr", 10.0, "linear", "all"),
    ("ulr", 10.0, "cubic", "eye"),
    ("bayesian", 10.0, "cubic", "all"),
)


def main(argv: list[str] | None = None) -> int:
    from vergence.io import read_image, read_pfm
    from vergence.metrics import dssim, psnr
    from vergence.rigs import load_shot
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
    print(f"{'weights':9s} {'link px':>7s} {'sampling':8s} {'sources':7s} {'eye':5s} {'PSNR':>6s} {'DSSIM':>8s} {'coverage':>8s}")
    for eye in ("left", "right"):
        truth = read_image(args.folder / "truth" / f"{eye}.png").astype(np.float32)
        for weights, limit, interp, which in VARIANTS:
            names = [rc.name for rc in (rig.cameras if which == "all" else rig.sources(eye))]
            res = render_ibr(rig.virtual(eye), [sources[n] for n in names], weights=weights, gradient_limit=limit,
                             interpolation=interp)  # fmt: skip
            c = res.coverage
            print(f"{weights:9s} {limit:7g} {interp:8s} {which:7s} {eye:5s} {psnr(res.image, truth, mask=c):6.2f} "
                  f"{dssim(res.image, truth, mask=c):8.4f} {100 * c.mean():7.1f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
