"""View-interpolation quality on Middlebury 2005 "Dolls" (half size): view3 from view1 + view5.

Reads ``../shared/data/multiview/dolls`` (see ``shared/data/SOURCES.md``; Scharstein & Pal 2007,
Hirschmüller & Scharstein 2007): view k sits at (k - 1)/4 of the way from view1 to view5, the
ground-truth disparities (PNG value / 2, 0 = unknown) are on the view1-view5 baseline. View3 is
synthesized at T = 0.5 and compared with the real view3 (PSNR, SSIM, registration error of S1
Eq. 11-13); the baselines of the issue (nearest-pixel warp + Telea inpainting, then gap filling)
are computed the same way, an ablation shows what each post-processing step brings, and T = 0 / 1
are checked against view1 / view5. With ``--out DIR`` it writes the synthesized views, the error
image (4 x |synthesized - real|) and the figures as JSON. The registration error is evaluated where
the synthesized view's 5 x 5 patches have a contrast of at least ``--min-contrast`` (default
``vergence.metrics.MIN_CONTRAST`` = 3/255; 0 evaluates every pixel, as S1's plain Eq. 11); the
"reg %" column gives the share of pixels evaluated.

Run: ``.venv/bin/python benchmarks/dolls.py [--out DIR] [--min-contrast C]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from vergence.io import read_disparity, read_image, write_image, write_json
from vergence.metrics import MIN_CONTRAST, psnr, registration_error, ssim
from vergence.synthesis import WarpedView, blend_views, error_image, forward_warp, interpolate_view

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "multiview" / "dolls"
DISPARITY_SCALE = 2.0  # Dolls PNG disparities: value / 2 (SOURCES.md)
ERROR_GAIN = 4.0  # the error image shows 4 x |synthesized - real|, mean over the channels


def _nearest_warp(image: np.ndarray, disparity: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The issue's plain baseline: each pixel to its nearest target pixel, z-buffer, no gap filling."""
    h, w = disparity.shape
    out = np.zeros_like(image)
    zbuf = np.full((h, w), -np.inf)
    ys, xs = np.nonzero(~np.isnan(disparity))
    d = disparity[ys, xs]
    xt = np.rint(xs - scale * d).astype(np.intp)
    keep = (xt >= 0) & (xt < w)
    ys, xs, xt, d = ys[keep], xs[keep], xt[keep], d[keep]
    order = np.argsort(d, kind="stable")  # far first: the nearest surface is written last
    out[ys[order], xt[order]] = image[ys[order], xs[order]]
    zbuf[ys[order], xt[order]] = d[order]
    holes = ~np.isfinite(zbuf)
    return out, np.where(holes, np.nan, zbuf).astype(np.float32), holes


def _telea(image: np.ndarray, holes: np.ndarray) -> np.ndarray:
    u8 = np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)
    return cv2.inpaint(u8, holes.astype(np.uint8), 3, cv2.INPAINT_TELEA).astype(np.float32) / 255.0


def _nearest_view(image: np.ndarray, disparity: np.ndarray, scale: float) -> WarpedView:
    out, zbuf, holes = _nearest_warp(image, disparity, scale)
    return WarpedView(image=out, holes=holes, nearness=zbuf.astype(np.float32))


def _two_reference_baseline(v1, d1, v5, d5, t, *, gap_filling: bool) -> np.ndarray:
    """Warp both references (nearest pixel, or forward_warp's gap filling), blend, Telea."""
    if gap_filling:
        warps = [forward_warp(v1, d1, scale=t), forward_warp(v5, d5, scale=-(1.0 - t))]
    else:
        warps = [_nearest_view(v1, d1, t), _nearest_view(v5, d5, -(1.0 - t))]
    blended = blend_views(warps, [1.0 - t, t])
    return _telea(blended.image, blended.holes)


def _scores(image: np.ndarray, reference: np.ndarray, *, min_contrast: float) -> dict:
    reg = registration_error(image, reference, min_contrast=min_contrast)
    value = psnr(image, reference)
    return {
        # Identical images have infinite PSNR, which JSON cannot hold: written as the string "inf".
        "psnr_db": round(value, 3) if np.isfinite(value) else "inf",
        "ssim": round(ssim(image, reference), 4),
        "registration_rms_px": round(reg.rms, 3),
        "registration_median_px": round(reg.median, 3),
        "registration_k80_px": round(reg.ranked[0.8], 3),
        "registration_k95_px": round(reg.ranked[0.95], 3),
        "registration_evaluated_percent": round(100.0 * reg.evaluated_fraction, 1),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="Folder for the images and JSON (none by default).")
    parser.add_argument(
        "--min-contrast", type=float, default=MIN_CONTRAST,
        help="Registration error: evaluate pixels whose patch contrast is at least this ([0, 1] units).",
    )
    args = parser.parse_args(argv)

    def score(image: np.ndarray, reference: np.ndarray) -> dict:
        return _scores(image, reference, min_contrast=args.min_contrast)

    if not DATA.is_dir():
        print(f"Dolls data not found at {DATA} (see shared/data/SOURCES.md)", file=sys.stderr)
        return 1
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    v1, v3, v5 = (read_image(DATA / f"view{k}.png") for k in (1, 3, 5))
    d1 = read_disparity(DATA / "disp1.png", scale=DISPARITY_SCALE)
    d5 = read_disparity(DATA / "disp5.png", scale=DISPARITY_SCALE)

    interpolate_view(v1, d1, v5, d5, 0.5)  # compile the kernels outside the timing
    t0 = time.perf_counter()
    result = interpolate_view(v1, d1, v5, d5, 0.5)
    elapsed = time.perf_counter() - t0
    scores = score(result.image, v3)
    if args.out is not None:
        error = error_image(result.image, v3, gain=ERROR_GAIN)
        write_image(args.out / "view3_synthesized.png", result.image)
        write_image(args.out / "view3_error_x4.png", error)

    rows = {
        "nearest warp + Telea (issue baseline)": score(_two_reference_baseline(v1, d1, v5, d5, 0.5, gap_filling=False), v3),
        "gap filling + Telea": score(_two_reference_baseline(v1, d1, v5, d5, 0.5, gap_filling=True), v3),
        "pipeline, no edge dilation": score(interpolate_view(v1, d1, v5, d5, 0.5, edge_dilation=0).image, v3),
        "pipeline, contour removal, no dilation": score(
            interpolate_view(v1, d1, v5, d5, 0.5, edge_dilation=0, contour_width=1).image, v3
        ),
        "pipeline + contour removal": score(interpolate_view(v1, d1, v5, d5, 0.5, contour_width=1).image, v3),
        "pipeline, no median refinement": score(interpolate_view(v1, d1, v5, d5, 0.5, median=False).image, v3),
        "pipeline, fill=mirror": score(interpolate_view(v1, d1, v5, d5, 0.5, fill="mirror").image, v3),
        "pipeline, fill=inpaint": score(interpolate_view(v1, d1, v5, d5, 0.5, fill="inpaint").image, v3),
        "pipeline (defaults)": scores,
    }
    sanity = {
        "T=0 vs view1": score(interpolate_view(v1, d1, v5, d5, 0.0).image, v1),
        "T=1 vs view5": score(interpolate_view(v1, d1, v5, d5, 1.0).image, v5),
    }
    # T = 0.25 / 0.75 have no ground truth here. Check them by re-warping each synthesized view, with
    # its own synthesized disparity, to T = 0.5 and comparing with the real view3 over the pixels it
    # reaches; for scale, a real reference (view1 alone) warped the same way scores "view1 alone".
    quarter = {}
    for t in (0.25, 0.75):
        res = interpolate_view(v1, d1, v5, d5, t)
        back = forward_warp(res.image, res.nearness, scale=0.5 - t)
        quarter[f"T={t} re-warped to view3"] = round(psnr(back.image, v3, mask=~back.holes), 3)
        if args.out is not None:
            write_image(args.out / f"view_T{t}.png", res.image)
    alone = forward_warp(v1, d1, scale=0.5)
    quarter["view1 alone warped to view3"] = round(psnr(alone.image, v3, mask=~alone.holes), 3)
    report = {
        "data": str(DATA),
        "target": "view3 (T = 0.5) from view1 + view5 with ground-truth disparities",
        "holes_percent": round(100.0 * float(result.holes.mean()), 3),
        "seconds": round(elapsed, 3),
        "registration_min_contrast": args.min_contrast,
        "results": rows,
        "sanity": sanity,
        "quarter_positions": quarter,
    }
    if args.out is not None:
        write_json(args.out / "dolls.json", report)
    width = max(len(k) for k in [*rows, *sanity])
    print(f"registration error over the pixels with patch contrast >= {args.min_contrast * 255:g}/255 (reg %)")
    print(f"{'method':<{width}}  PSNR dB   SSIM   reg RMS  reg med  reg k80  reg k95  reg %")
    for name, s in [*rows.items(), *sanity.items()]:
        print(
            f"{name:<{width}}  {s['psnr_db']:>7}  {s['ssim']:.4f}  {s['registration_rms_px']:7.3f}"
            f"  {s['registration_median_px']:7.3f}  {s['registration_k80_px']:7.3f}  {s['registration_k95_px']:7.3f}"
            f"  {s['registration_evaluated_percent']:5.1f}"
        )
    for name, q in quarter.items():
        print(f"{name}: PSNR {q} dB over the pixels reached")
    print(f"holes filled: {report['holes_percent']} %; interpolate_view took {elapsed * 1000:.0f} ms")
    if args.out is not None:
        print(f"wrote {args.out}/view3_synthesized.png, view3_error_x4.png, view_T0.25.png, view_T0.75.png, dolls.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
