"""`vergence convert` against the truth: the converted right view vs a direct render with the retargeted rig.

Renders the test clips (``make_test_clips``: tabletop, a cut, stadium; H.264 at ``--crf``), converts the
2D + depth clip and the stereo clip into ``--budget-arcmin`` on ``--display`` with ``origin="left"`` as PNG
frames (full SBS: the left view is the input's, the right one synthesised), then per shot derives the
shifted-sensor rig whose parallax is the shot's psi (``retargeted_rig``: the RGBD clip's near/far for 2D +
depth, the shot's own rig for stereo), renders the shot through it (``render_retargeted``, the left camera
the clip's) and prints:

- PSNR (dB, mean over frames) and mean absolute error (8-bit levels) of the converted right view against
  the direct render's right view (8-bit), over all pixels and over the pixels the left view sees
  (``RetargetedViews.visible``: not disoccluded, not beyond the left view's border);
- the same for the input's right view (the unretargeted one: what the conversion starts from), for
  ``synthesize_stereo`` of the input's left view with the rig's true parallax (the best this synthesis
  can do: what the conversion's depth and psi cost beyond it), and for the converted left view against
  the direct render's left view (the floor: the input's H.264 and 4:2:0 round trip, which the
  synthesised view inherits);
- the output parallax ``P = x_r - x_l`` (px of the views, 1st-99th percentile): the plan (``range_px``),
  the rig's (from the rendered geometry), and the one ``analyze_clip`` matches in the output.

Run: ``.venv/bin/python benchmarks/video_retarget_truth.py [--frames-per-shot 24] [--width 160 --height 90]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from vergence.metrics import psnr
from vergence.render import builtin_scene
from vergence.video import (
    CLIP_SHOTS,
    analyze_clip,
    convert_clip,
    make_test_clips,
    open_depth_clip,
    open_frames,
    open_stereo,
    render_retargeted,
    retargeted_rig,
)
from vergence.synthesis import synthesize_stereo
from vergence.viewing import Display, LinearMapping

# psi(p) = p: synthesize_stereo given the parallax itself (as a "disparity" map q = -P).
IDENTITY = LinearMapping(0.0, 1.0, 0.0, 1.0)


def _as_8bit(image: np.ndarray) -> np.ndarray:
    """The direct render as 8 bits, as the clips store their views."""
    return np.rint(image * 255.0) / 255.0


def _scores(image: np.ndarray, truth: np.ndarray, visible: np.ndarray) -> tuple[float, float, float, float]:
    """Mean PSNR (all, visible) over frames and mean absolute error in levels (all, visible)."""
    diff = np.abs(image - truth).mean(axis=3) * 255.0
    return (float(np.mean([psnr(a, b) for a, b in zip(image, truth)])),
            float(np.mean([psnr(a, b, mask=m) for a, b, m in zip(image, truth, visible)])),
            float(diff.mean()), float(diff[visible].mean()))  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames-per-shot", type=int, default=24)
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=90)
    parser.add_argument("--crf", type=int, default=12)
    parser.add_argument("--display", default="tv-55")
    parser.add_argument("--budget-arcmin", type=float, default=30.0)
    parser.add_argument("--out", type=Path, help="keep the clips and conversions here (default: a temporary folder)")
    args = parser.parse_args()
    folder = args.out or Path(tempfile.mkdtemp(prefix="retarget_truth_"))
    folder.mkdir(parents=True, exist_ok=True)
    display = Display.preset(args.display)
    w, h, n = args.width, args.height, args.frames_per_shot
    start = time.perf_counter()
    clips = make_test_clips(folder, frames_per_shot=n, width=w, height=h, crf=args.crf)
    with np.load(clips.truth) as data:
        near, far = data["near"], data["far"]
    print(f"test clips: {clips.frames} frames, {w}x{h} per view, crf {args.crf}, in {time.perf_counter() - start:.1f} s; "
          f"{args.display}, +-{args.budget_arcmin:g} arcmin, origin left, PNG frames")  # fmt: skip
    inputs = np.stack(list(open_frames(clips.stereo).frames()))
    for kind, clip in (("2d+depth", open_depth_clip(clips.rgbd)), ("stereo", open_stereo(clips.stereo))):
        out = folder / f"{kind.replace('+', '_')}_LRF_Full_SBS"
        conversion = convert_clip(clip, out, display, budget_arcmin=args.budget_arcmin, origin="left", force=True)
        frames = np.stack(list(open_frames(out).frames()))
        analysis = analyze_clip(open_stereo(out), display, vertical=False)
        for s, (shot, conv) in enumerate(zip(CLIP_SHOTS, conversion.shots)):
            focal = builtin_scene(shot.scene, width=w, height=h).camera.build().focal_px
            if kind == "2d+depth":
                rig = retargeted_rig(shot, conv.mapping, focal_px=focal, kind="inverse", near=near[s], far=far[s])
            else:
                rig = retargeted_rig(shot, conv.mapping, focal_px=focal, kind="disparity")
            views = render_retargeted(shot, rig, frames_per_shot=n, width=w, height=h)
            a, b = conv.start, conv.end
            left, right = _as_8bit(views.left), _as_8bit(views.right)
            converted = _scores(frames[a:b, :, w:], right, views.visible)
            unretargeted = _scores(inputs[a:b, :, w:], right, views.visible)
            floor = _scores(frames[a:b, :, :w], left, np.ones_like(views.visible))
            ideal = np.stack([synthesize_stereo(image, -p, kind="disparity", mapping=IDENTITY, origin="left").right
                              for image, p in zip(frames[a:b, :, :w], views.parallax_px)])  # fmt: skip
            best = _scores(np.clip(ideal, 0.0, 1.0), right, views.visible)
            p_rig = np.percentile(views.parallax_px, [1, 99])
            matched = analysis.shots[s].disparity_px if s < len(analysis.shots) else None
            print(f"{kind:8s} {shot.scene:8s}: rig b {shot.baseline:g} -> {rig.baseline:.4f} m, convergence "
                  f"{shot.convergence:g} -> {rig.convergence:.3f} m; visible {views.visible.mean():.1%} of the right view")  # fmt: skip
            print(f"    converted right vs direct: PSNR {converted[0]:.2f} dB (visible {converted[1]:.2f}), "
                  f"MAE {converted[2]:.2f} levels (visible {converted[3]:.2f})")
            print(f"    input right (unretargeted): PSNR {unretargeted[0]:.2f} dB (visible {unretargeted[1]:.2f}), "
                  f"MAE {unretargeted[2]:.2f} levels (visible {unretargeted[3]:.2f})")
            print(f"    synthesis with the true parallax: PSNR {best[0]:.2f} dB (visible {best[1]:.2f}), "
                  f"MAE {best[2]:.2f} levels (visible {best[3]:.2f})")
            print(f"    floor, converted left vs direct left: PSNR {floor[0]:.2f} dB, MAE {floor[2]:.2f} levels")
            print(f"    P = x_r - x_l, px (1-99 %): plan {conv.range_px[0]:+.2f} .. {conv.range_px[1]:+.2f}, "
                  f"rig {p_rig[0]:+.2f} .. {p_rig[1]:+.2f}, matched in the output "
                  + ("-" if matched is None else f"{-matched['p99']:+.2f} .. {-matched['p1']:+.2f}"))
    print(f"total {time.perf_counter() - start:.1f} s; files in {folder}")


if __name__ == "__main__":
    main()
