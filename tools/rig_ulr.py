"""Re-synthesise a rendered shot (Quadri-Rig or Tri-Rig) with ULR threshold and field-of-view variants.

The figures behind ``ULR_RELATIVE_THRESHOLD`` and ``ULR_GAMMA`` (``vergence.synthesis.ibr``): it reads
what ``vergence rig render`` wrote (the real cameras' images and depths, the truth), so the ray tracing
is not repeated::

    vergence rig render examples/shots/stadium-tri.json --out stadium-tri --weights ulr
    python -m tools.rig_ulr stadium-tri examples/shots/stadium-tri.json

Per variant and eye: PSNR (dB) over the covered pixels, the whole-image PSNR with the holes left black
(what the user receives), DSSIM over covered pixels, coverage, and the share of pixels seen by two or
more sources whose normalised weights are all equal (within 1e-3).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from vergence.synthesis.ibr import ULR_GAMMA, ULR_RELATIVE_THRESHOLD

# (label, k, gamma, relative threshold): "SIBR" is the rule before issue 27 (padding: equal weights
# with fewer than k sources; a hard field-of-view cut), "default" render_ibr's, then one change at a time.
VARIANTS = (
    ("SIBR k=4", 4, 0.0, math.inf),
    ("SIBR k=3", 3, 0.0, math.inf),
    ("SIBR k=2", 2, 0.0, math.inf),
    ("default", 4, ULR_GAMMA, ULR_RELATIVE_THRESHOLD),
    ("k=3 rel inf", 3, ULR_GAMMA, math.inf),  # Buehler's threshold alone, the last of three sources at weight 0
    ("rel 1.5", 4, ULR_GAMMA, 1.5),
    ("rel 3", 4, ULR_GAMMA, 3.0),
    ("rel 4", 4, ULR_GAMMA, 4.0),
    ("rel 10", 4, ULR_GAMMA, 10.0),
    ("rel 30", 4, ULR_GAMMA, 30.0),
    ("rel inf", 4, ULR_GAMMA, math.inf),
    ("gamma 0", 4, 0.0, ULR_RELATIVE_THRESHOLD),
    ("gamma .01", 4, 0.01, ULR_RELATIVE_THRESHOLD),
    ("gamma .1", 4, 0.1, ULR_RELATIVE_THRESHOLD),
    ("gamma 1", 4, 1.0, ULR_RELATIVE_THRESHOLD),
)


def main(argv: list[str] | None = None) -> int:
    from vergence.io import read_image, read_pfm
    from vergence.metrics import dssim, psnr
    from vergence.rigs import load_shot
    from vergence.synthesis import IBRSource, render_ibr

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the --out folder of `vergence rig render`")
    parser.add_argument("shot", type=Path, help="the shot file it rendered")
    parser.add_argument("--variants", default=None, help="comma-separated labels to run (default: all)")
    args = parser.parse_args(argv)
    shot = load_shot(args.shot)
    rig = shot.plan()
    sources = {rc.name: IBRSource(camera=rc.camera,
                                  image=read_image(args.folder / "cameras" / f"{rc.name}.png").astype(np.float32),
                                  depth=read_pfm(args.folder / "cameras" / f"{rc.name}_depth.pfm").astype(np.float64))
               for rc in rig.cameras}  # fmt: skip
    if shot.rig == "quadri":
        eyes = {eye: (rig.virtual(eye), None) for eye in ("left", "right")}
    else:
        eyes = {"right": (rig.reference_right, rig.distortion)}
    chosen = VARIANTS if args.variants is None else [v for v in VARIANTS if v[0] in args.variants.split(",")]
    print(f"{'variant':16s} {'eye':5s} {'PSNR cov':>8s} {'PSNR all':>8s} {'DSSIM':>8s} {'coverage':>8s} {'equal w':>7s}")
    for eye, (target, distortion) in eyes.items():
        truth = read_image(args.folder / "truth" / f"{eye}.png").astype(np.float32)
        for label, k, gamma, relative in chosen:
            res = render_ibr(target, list(sources.values()), weights="ulr", distortion=distortion, k=k, gamma=gamma,
                             relative_threshold=relative)  # fmt: skip
            c = res.coverage
            w = res.weights
            multi = (w > 0).sum(axis=0) >= 2
            used = np.where(w > 0, w, np.nan)
            equal = multi & (np.nanmax(used, axis=0, initial=0) - np.nanmin(np.where(w > 0, w, np.inf), axis=0) < 1e-3)
            print(f"{label:16s} {eye:5s} {psnr(res.image, truth, mask=c):8.2f} {psnr(res.image, truth):8.2f} "
                  f"{dssim(res.image, truth, mask=c):8.4f} {100 * c.mean():7.1f}% {100 * equal.sum() / max(1, multi.sum()):6.1f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
