"""Truth against analyze's per-shot p50/p95 on the two synthetic plane clips of tests/support/stereo_planes.py, with
the search range found from the content (the default) and with the former default, +-width/8.

    .venv/bin/python benchmarks/video_search_range.py [FOLDER]

Writes the clips into FOLDER (default: a temporary folder): issue 28's (true 36-95 px at 480x272 per view, two
shots of 8 frames) and a second one (-110..-40 px, then -20..+120 px, at 640x352).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "support"))

from stereo_planes import HARD_SHOTS, OTHER_SHOTS, shot_truth, write_planes_clip  # noqa: E402

from vergence.video import open_stereo  # noqa: E402
from vergence.video._matching import default_search_px  # noqa: E402
from vergence.video.analysis import analyze_clip  # noqa: E402
from vergence.viewing import DISPLAY_PRESETS  # noqa: E402


def main(folder: Path) -> None:
    display = DISPLAY_PRESETS["tv-55"]
    for name, shots, width, height, seed in (("hard", HARD_SHOTS, 480, 272, 0), ("other", OTHER_SHOTS, 640, 352, 5)):
        path = folder / f"{name}_LRF_Full_SBS.mp4"
        truth = write_planes_clip(path, shots, width=width, height=height, frames_per_shot=8, seed=seed)
        search = default_search_px(width)
        for label, bounds in (("content", {}), (f"+-{search}", {"min_disparity": -search, "max_disparity": search})):
            t0 = time.perf_counter()
            result = analyze_clip(open_stereo(path), display, **bounds)
            seconds = time.perf_counter() - t0
            for k, shot in enumerate(result.shots):
                true = shot_truth(truth, shot.start, shot.end)
                got = shot.disparity_px
                figures = "  ".join(f"{p} {true[p]:+7.1f} / {got[p]:+7.1f}" for p in ("p1", "p50", "p95", "p99"))
                flags = f"searched {shot.search['search_px']}, on bound {list(shot.on_bound)}, saturated {shot.saturated}"
                print(f"{name} {label:>8} shot {k}: truth / reported  {figures}  ({flags})")
            for line in result.warnings:
                print(f"    warning: {line}")
            print(f"    {seconds:.1f} s")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        Path(sys.argv[1]).mkdir(parents=True, exist_ok=True)
        main(Path(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp))
