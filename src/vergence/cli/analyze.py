"""``vergence analyze``: comfort of a stereo or 2D + depth clip (or image) on a display, per frame and per shot."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import (
    SYNTHESIS_BUDGET_ARCMIN,
    app,
    check_output_path,
    console,
    err_console,
    options_named,
    preset_display,
    print_json,
)
from vergence.cli._video import (
    DEPTH_KIND_OPTION,
    DEPTH_SCALE_OPTION,
    FPS_OPTION,
    INPUT_KIND_OPTION,
    LAYOUT_OPTION,
    MAX_DISPARITY_OPTION,
    METHOD_OPTION,
    MIN_DISPARITY_OPTION,
    check_input_kind,
    open_input,
)

__all__ = ["analyze"]

_OPTIONS = {"every": "--every", "min_disparity": "--min-disparity", "max_disparity": "--max-disparity",
            "method": "--method", "budget_arcmin": "--budget-arcmin", "crossed_arcmin": "--comfort-arcmin",
            "uncrossed_arcmin": "--comfort-arcmin"}


@app.command("analyze")
def analyze(
    input_path: Path = typer.Argument(..., metavar="INPUT", help="A stereo video, image folder or image (SBS or TB, "
                                      "full or half), or a 2D + depth one (iw3's _RGBD, or colour with --depth)."),
    display_preset: str = typer.Option(..., "--display", help="Display preset (vergence budget --help lists them)."),
    depth: Path | None = typer.Option(None, "--depth", help="The depth clip of a colour INPUT (video, folder or "
                                      "image, same length and size)."),
    kind: str | None = INPUT_KIND_OPTION,
    layout: str | None = LAYOUT_OPTION,
    depth_kind: str | None = DEPTH_KIND_OPTION,
    depth_scale: float | None = DEPTH_SCALE_OPTION,
    budget_arcmin: float | None = typer.Option(None, "--budget-arcmin", help="2D + depth: the parallax budget of "
                                               "vergence synthesize, fitted per shot (+-A arcmin); default "
                                               f"{SYNTHESIS_BUDGET_ARCMIN:g}."),
    comfort_arcmin: float = typer.Option(60.0, "--comfort-arcmin", help="The comfort zone, +-C arcmin of vergence."),
    every: int = typer.Option(1, "--every", help="Analyse every Nth frame (matching is slow); cuts use all frames."),
    min_disparity: int | None = MIN_DISPARITY_OPTION,
    max_disparity: int | None = MAX_DISPARITY_OPTION,
    method: str | None = METHOD_OPTION,
    no_vertical: bool = typer.Option(False, "--no-vertical", help="Stereo: skip the vertical disparity of feature "
                                     "matches (SIFT on views at most 960 px wide)."),
    fps: float | None = FPS_OPTION,
    report: Path | None = typer.Option(None, "--report", help="Write analysis.json, disparity.png, a thumbnail per "
                                       "shot and index.html into this folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the analysis as JSON."),
) -> None:
    """Comfort of a stereo or 2D + depth clip on a display: disparity percentiles, comfort, divergence,
    stereo window, vertical disparity and a suggested retargeting, per frame and per shot."""
    from vergence.video.analysis import analyze_clip
    from vergence.viewing import ComfortZone

    display = preset_display(display_preset)
    check_input_kind(kind)
    if not input_path.exists():
        raise FileNotFoundError(f"INPUT {input_path} does not exist")
    clip, kind = open_input(input_path, kind, depth=depth, layout=layout, depth_kind=depth_kind,
                            depth_scale=depth_scale, fps=fps, depth_only={"--budget-arcmin": budget_arcmin},
                            stereo_only={"--method": method, "--min-disparity": min_disparity,
                                         "--max-disparity": max_disparity, "--no-vertical": no_vertical or None})
    if report is not None:
        check_output_path(report, input_path, *([depth] if depth is not None else []))
        if report.exists() and not report.is_dir():
            raise ValueError(f"--report {report} is a file; give a folder")
    with options_named(**_OPTIONS):
        zone = ComfortZone(crossed_arcmin=comfort_arcmin, uncrossed_arcmin=comfort_arcmin)
        with err_console.status(f"analysing {clip.frames} frames", spinner="dots") as status:
            def progress(done: int, total: int) -> None:
                status.update(f"analysing frame {done} of {total}")

            result = analyze_clip(clip, display, zone=zone, every=every, min_disparity=min_disparity,
                                  max_disparity=max_disparity, method=method or "sgbm",
                                  budget_arcmin=SYNTHESIS_BUDGET_ARCMIN if budget_arcmin is None else budget_arcmin,
                                  vertical=not no_vertical, progress=progress)  # fmt: skip
    data = {"input": str(input_path), "depth": None if depth is None else str(depth),
            **({"layout": clip.layout} if kind == "stereo" else {}), **result.to_dict()}  # fmt: skip
    data["display"] = {"preset": display_preset, **dataclasses.asdict(display)}
    if report is not None:
        from vergence.io import atomic_folder
        from vergence.report.video_analysis import write_analysis_report

        with atomic_folder(report) as tmp:
            write_analysis_report(result, tmp, data=data, title=f"Comfort of {input_path.name} on {display_preset}")
            raise_if_interrupted()
    if as_json:
        print_json(data)
        return
    for k, shot in enumerate(result.shots):
        d, a, s = shot.disparity_px, shot.disparity_arcmin, shot.suggestion
        console.print(f"shot {k}: frames {shot.start}-{shot.end - 1}, disparity {d['p1']:+.2f} .. {d['p99']:+.2f} px "
                      f"(1-99 %) = {a['p1']:+.1f} .. {a['p99']:+.1f} arcmin, {100 * shot.outside_comfort:.1f} % outside "
                      f"comfort, {100 * shot.diverging:.1f} % diverging, {shot.window_violations} window violations; "
                      f"suggestion: {s['action']} (scale {s['scale']:.3f}, shift {s['shift_px']:+.2f} px)")
    if report is not None:
        console.print(f"report: {report / 'index.html'}")
