"""S3's objective term by term (S3 Fig. 6's analogue) on scenes of large specular excess.

For each scene (``examples/scenes/specular/``: three development scenes and ``cabinet``, held out),
one :func:`vergence.specular.specular_stereo` run on S3's study display (``samsung-2233rz``) with the
image stretched to the screen's width (320 px over 1680 display px: 8.48' per image pixel), then
:meth:`~vergence.specular.SpecularResult.reoptimise` with each term of S3 Eq. 2 switched off in
turn (its alpha set to 0; the table is reused). Per configuration, measured on the final render
against the right eye (the pipeline's independent position match):

- ``in``: the share of the matched specular layer pixels (layers past the first, present in the
  physical left eye) whose horizontal disparity lies inside the comfort zone (+-60'), unweighted and
  weighted by the physical importance (the same weights before and after), before -> after;
- ``mirror``: the same, unweighted, on the pixels whose first hit is a mirror;
- ``med``: the median horizontal disparity of the mirror's important pixels (physical importance
  >= 0.5), before -> after, arcmin;
- ``behind``: of the mirror's reflection pixels (layer R), the share at least one image pixel behind
  the mirror's own surface (layer 1), before -> after;
- ``lost``: layer pixels present in the physical left eye and missing in the final render (and the
  rim pixels the repair of :func:`~vergence.specular.repair_render` fixed before that);
- the mean offset y of each specular layer (1: physical, 0: mono);
- ``comfortable``: of the specular layer pixels inside the zone before, how far they moved: the
  median and 90th percentile of ``|dx after - dx before|`` and the mean of ``1 - y``.

Run: ``.venv/bin/python benchmarks/specular_ablation.py [--width 320] [--k 16] [--fit screen|native]
[--variant comfort|screen] [--terms] [--scenes vanity ...]`` (``--variant screen``: S3 Eq. 2 as written).
A figure that sits on the zone's edge (a median within 1 px of +-60') is flagged ``(edge)``.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared cores: idle OpenMP threads must not spin

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "examples" / "scenes" / "specular"
DEV = ("vanity", "ball_lens", "bent_mirror")
HELD_OUT = ("cabinet",)
#: A mirror pixel's reflection counts as important at this physical importance or more.
IMPORTANT = 0.5


def _shares(state, weights, zone, layers_mask):  # noqa: ANN001
    dx = state.disparity[..., 0]
    ok = layers_mask & np.isfinite(dx)
    inside = ok & (dx >= zone.min_arcmin) & (dx <= zone.max_arcmin)
    n = ok.sum()
    w = np.where(ok, weights, 0.0)
    plain = inside.sum() / n if n else float("nan")
    weighted = (w * inside).sum() / w.sum() if w.sum() > 0 else float("nan")
    return plain, weighted


def measure(result, arcmin_per_px: float) -> dict:  # noqa: ANN001
    """The figures of one run (see the module text)."""
    zone, before, after = result.zone, result.before, result.after
    phys = result.physical_left
    present = np.isfinite(phys.position).all(axis=-1)
    n = present.shape[0]
    spec = present.copy()
    spec[0] = False
    # a mirror pixel: its first hit reflects and does not refract (glass always refracts from air)
    mirror = present[1] & ~present[2] if n > 2 else present[1]
    mirror_layers = spec & mirror[None]
    w = before.importance.astype(np.float64)
    out = {}
    for tag, state in (("before", before), ("after", after)):
        out[f"in_{tag}"] = _shares(state, w, zone, spec)
        out[f"mirror_{tag}"] = _shares(state, w, zone, mirror_layers)[0]
        imp = mirror & (w[1] >= IMPORTANT) & np.isfinite(state.disparity[1, ..., 0])
        out[f"med_{tag}"] = float(np.median(state.disparity[1, ..., 0][imp])) if imp.any() else float("nan")
    for tag, state in (("before", before), ("after", after)):
        refl = mirror & np.isfinite(state.disparity[1, ..., 0]) & np.isfinite(state.disparity[0, ..., 0])
        gap = state.disparity[1, ..., 0] - state.disparity[0, ..., 0]
        out[f"behind_{tag}"] = float((gap[refl] >= arcmin_per_px * 0.999).mean()) if refl.any() else float("nan")
    out["lost"] = [int((present[i] & ~np.isfinite(result.optimised_left.position[i]).all(axis=-1)).sum())
                   for i in range(n)]  # fmt: skip
    out["y"] = [float(result.y[i][present[i]].mean()) if present[i].any() else float("nan") for i in range(n)]
    out["present"] = [int(present[i].sum()) for i in range(n)]
    out["layer_in"] = [_shares(after, w, zone, spec & (np.arange(n) == i)[:, None, None])[0] for i in range(n)]
    # layers already comfortable: how far they moved (pixels inside the zone before, matched after)
    comfy = spec & np.isfinite(before.disparity[..., 0]) & np.isfinite(after.disparity[..., 0])
    comfy &= (before.disparity[..., 0] >= zone.min_arcmin) & (before.disparity[..., 0] <= zone.max_arcmin)
    shift = np.abs(after.disparity[..., 0] - before.disparity[..., 0])[comfy]
    out["comfy"] = (float(np.median(shift)) if shift.size else float("nan"),
                    float(np.percentile(shift, 90)) if shift.size else float("nan"),
                    float(np.mean(1.0 - result.y[comfy])) if shift.size else float("nan"))
    raw = getattr(result, "render_check_raw", None)
    out["raw_rim"] = raw.rim if raw is not None else -1
    out["seconds"] = {k: result.seconds.get(k, float("nan")) for k in ("plan_solve", "final_render")}
    return out


def _edge(v: float, zone, step: float) -> str:  # noqa: ANN001
    return " (edge)" if any(abs(abs(v) - b) < step for b in (zone.max_arcmin, -zone.min_arcmin)) else ""


def report(name: str, label: str, m: dict, zone, step: float) -> None:  # noqa: ANN001
    names = ["1", "R", "T", "RR", "RT", "TR", "TT"]
    ys = " ".join(f"{names[i]} {m['y'][i]:.2f}" for i in range(1, len(m["y"])) if m["present"][i])
    lost = sum(m["lost"][1:])
    print(f"  {label:14s} in {m['in_before'][0]:.3f}/{m['in_before'][1]:.3f} -> {m['in_after'][0]:.3f}/"
          f"{m['in_after'][1]:.3f}  mirror {m['mirror_before']:.3f} -> {m['mirror_after']:.3f}  "
          f"med {m['med_before']:6.1f} -> {m['med_after']:6.1f}{_edge(m['med_after'], zone, step)}  "
          f"behind {m['behind_before']:.3f} -> {m['behind_after']:.3f}  lost {lost:5d} "
          f"(repaired rim {m['raw_rim']})  y: {ys}")  # fmt: skip
    ins = " ".join(f"{names[i]} {m['layer_in'][i]:.2f}" for i in range(1, len(m["y"])) if m["present"][i])
    print(f"  {'':14s} comfortable before: |d after - d before| median {m['comfy'][0]:.1f}', 90th pct "
          f"{m['comfy'][1]:.1f}', mean 1 - y {m['comfy'][2]:.3f}")  # fmt: skip
    print(f"  {'':14s} per layer in after (unweighted): {ins}; solve {m['seconds']['plan_solve']:.1f} s, "
          f"final render {m['seconds']['final_render']:.1f} s")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--k", type=int, default=16)
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--display", default="samsung-2233rz")
    parser.add_argument("--scenes", nargs="+", default=[*DEV, *HELD_OUT])
    parser.add_argument("--fit", default="screen", choices=("screen", "native"))
    parser.add_argument("--variant", default="comfort", choices=("comfort", "screen"))
    parser.add_argument("--terms", action="store_true", help="also switch each term off in turn")
    args = parser.parse_args()

    from vergence.render import Tracer, open_scene
    from vergence.rigs import stereo_pair
    from vergence.specular import COST_TERMS, arcmin_per_pixel, fit_display, specular_stereo
    from vergence.viewing import Display

    display = Display.preset(args.display)
    for name in args.scenes:
        path = SCENES / f"{name}.json"
        scene = open_scene(path if path.is_file() else name, width=args.width)
        tracer = Tracer(scene)
        left, right = stereo_pair(scene.camera.build(), baseline=scene.stereo.baseline,
                                  convergence=scene.stereo.convergence)  # fmt: skip
        t0 = time.perf_counter()
        result = specular_stereo(tracer, left, right, display, k=args.k, samples=args.samples, fit=args.fit,
                                 variant=args.variant)  # fmt: skip
        tag = "held out" if name in HELD_OUT else "dev"
        px = arcmin_per_pixel(fit_display(display, left.width, fit=args.fit))  # arcmin of one image pixel
        print(f"\n{scene.name} ({tag}) {left.width}x{left.height}, k = {args.k}, {args.display} fit {args.fit} "
              f"variant {args.variant} "
              f"({px:.2f}'/px): {time.perf_counter() - t0:.1f} s")  # fmt: skip
        report(name, "all terms", measure(result, px), result.zone, px)
        if args.terms:
            alpha = list(result.settings["alpha"])
            for t, term in enumerate(COST_TERMS):
                a = list(alpha)
                a[t] = 0.0
                report(name, f"no {term}", measure(result.reoptimise(alpha=a), px), result.zone, px)
        del result


if __name__ == "__main__":
    main()
