"""``vergence analyze``'s work: the comfort of a stereo or 2D + depth clip (or image) on a display, per frame
and per shot (:func:`vergence.video.analysis.analyze_clip`), with its report folder."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from vergence.commands._naming import literal
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.commands._video import (DEPTH_KIND, DEPTH_SCALE, FPS, INPUT_KIND, LAYOUT, MAX_DISPARITY, METHOD,
                                      MIN_DISPARITY, check_input_kind, open_input)  # fmt: skip

if TYPE_CHECKING:
    from vergence.video.analysis import ClipAnalysis
    from vergence.viewing.geometry import Display

__all__ = ["ANALYZE", "DEFAULT_BUDGET_ARCMIN", "AnalysisReport", "analyze"]

#: The budget a 2D + depth clip is fitted to when none is given: ``vergence synthesize``'s
#: (:data:`vergence.commands.synthesize.SYNTHESIS_BUDGET_ARCMIN`), written out here so that
#: ``vergence analyze --help`` does not load the synthesis (a test checks that the two agree).
DEFAULT_BUDGET_ARCMIN = 30.0


@dataclass(frozen=True, slots=True)
class AnalysisReport:
    """The analysis of a clip and what ``--json`` prints beside it: the input, its kind and the display."""

    analysis: ClipAnalysis
    input_path: Path
    depth: Path | None
    kind: str
    layout: str | None
    display_name: str
    display: Display
    report: Path | None = None

    def to_dict(self) -> dict[str, object]:
        """What ``vergence analyze --json`` prints and the report's ``analysis.json`` holds."""
        data = {"input": str(self.input_path), "depth": None if self.depth is None else str(self.depth),
                **({"layout": self.layout} if self.kind == "stereo" else {}), **self.analysis.to_dict()}  # fmt: skip
        data["display"] = {"preset": self.display_name, **dataclasses.asdict(self.display)}
        return data


def analyze(*, input_path: Path, display: str, depth: Path | None = None, input_kind: str | None = None,
            layout: str | None = None, depth_kind: str | None = None, depth_scale: float | None = None,
            budget_arcmin: float | None = None, comfort_arcmin: float = 60.0, every: int = 1,
            min_disparity: int | None = None, max_disparity: int | None = None, method: str | None = None,
            no_vertical: bool = False, fps: float | None = None, report: Path | None = None, force: bool = False,
            progress: Callable[[float, str], None] | None = None,
            before_commit: Callable[[], None] | None = None) -> AnalysisReport:  # fmt: skip
    """The comfort of the clip ``input_path`` holds on the display preset ``display``
    (:func:`vergence.video.analysis.analyze_clip`); with ``report``, its folder of files, all or none
    (:func:`vergence.report.video_analysis.write_analysis_report`).

    ``progress(fraction, message)`` is told as the frames are analysed; ``before_commit()`` is called
    once the report's files are written, before they appear (raise there to leave none). A ``report``
    folder that already holds a file of the report's names is refused unless ``force`` (nothing is
    replaced then: the check comes before any file appears); its other files are kept either way.

    Raises
    ------
    ParameterError
        A value the display, the input, its opening or the analysis refuse, naming its parameter.
    OSError
        A file that cannot be read or written.
    """
    from vergence.commands._display import display_from  # vergence.viewing: not for --help
    from vergence.io.atomic import check_output_path
    from vergence.video.analysis import analyze_clip
    from vergence.viewing import ComfortZone

    chosen = display_from(display, None, None, None)
    check_input_kind(input_kind)
    if not input_path.exists():
        raise ParameterError("{input_path} " + literal(input_path) + " does not exist")
    clip, kind = open_input(input_path, input_kind, depth=depth, layout=layout, depth_kind=depth_kind,
                            depth_scale=depth_scale, fps=fps, stereo_only={"method": method, "min_disparity": min_disparity,
                                         "max_disparity": max_disparity, "no_vertical": no_vertical or None})
    if report is not None:
        check_output_path(report, input_path, *([depth] if depth is not None else []))
        if report.exists() and not report.is_dir():
            raise ParameterError("{report} " + literal(report) + " is a file; give a folder")

    def frames(done: int, total: int) -> None:
        if progress is not None:  # the shots' summaries after the last frame are the last step
            progress(done / (total + 1), f"analysing frame {done} of {total}")

    with naming(every="every", min_disparity="min_disparity", max_disparity="max_disparity", method="method",
                budget_arcmin="budget_arcmin", crossed_arcmin="comfort_arcmin", uncrossed_arcmin="comfort_arcmin"):
        zone = ComfortZone(crossed_arcmin=comfort_arcmin, uncrossed_arcmin=comfort_arcmin)
        if progress is not None:
            progress(0.0, f"analysing {clip.frames} frames")
        result = analyze_clip(clip, chosen, zone=zone, every=every, min_disparity=min_disparity,
                              max_disparity=max_disparity, method=method or "sgbm",
                              budget_arcmin=DEFAULT_BUDGET_ARCMIN if budget_arcmin is None else budget_arcmin,
                              vertical=not no_vertical, progress=frames)  # fmt: skip
    if progress is not None:
        progress(1.0, f"analysed {clip.frames} frames")
    done = AnalysisReport(result, input_path, depth, kind, clip.layout if kind == "stereo" else None, display,
                          chosen, report)  # fmt: skip
    if report is not None:
        from vergence.io import atomic_folder
        from vergence.report.video_analysis import write_analysis_report

        with atomic_folder(report) as tmp:
            write_analysis_report(result, tmp, data=done.to_dict(), title=f"Comfort of {input_path.name} on {display}")
            clash = sorted(str(f.relative_to(tmp)) for f in tmp.rglob("*")
                           if f.is_file() and (report / f.relative_to(tmp)).exists())  # fmt: skip
            if clash and not force:
                raise ParameterError("{report} " + literal(f"{report} already holds {', '.join(clash[:3])}"
                                                           f"{' ...' if len(clash) > 3 else ''}: give ")
                                     + "{force} to replace them")
            if before_commit is not None:
                before_commit()
    return done


ANALYZE = Command(
    name="analyze",
    summary="Comfort of a stereo or 2D + depth clip on a display: disparity percentiles, comfort, divergence, "
            "stereo window, vertical disparity and a suggested retargeting, per frame and per shot.",
    parameters=(
        Parameter("input_path", "file", "A stereo video, image folder or image (SBS or TB, full or half), or a 2D + "
                  "depth one (iw3's _RGBD, or colour with {depth}).", option="", metavar="INPUT"),
        Parameter("display", "text", "Display preset (vergence budget --help lists them)."),
        Parameter("depth", "file", "The depth clip of a colour {input_path} (video, folder or image, same length and "
                  "size).", None),
        INPUT_KIND,
        LAYOUT,
        DEPTH_KIND,
        DEPTH_SCALE,
        Parameter("budget_arcmin", "number", "The parallax budget of vergence synthesize and convert, +-A arcmin; "
                  f"default {DEFAULT_BUDGET_ARCMIN:g}. A 2D + depth clip is planned into it per shot; each shot's "
                  "suggestion says how convert would map it there.", None),
        Parameter("comfort_arcmin", "number", "The comfort zone, +-C arcmin of vergence.", 60.0),
        Parameter("every", "integer", "Analyse every Nth frame (matching is slow); cuts use all frames.", 1),
        MIN_DISPARITY,
        MAX_DISPARITY,
        METHOD,
        Parameter("no_vertical", "flag", "Stereo: skip the vertical disparity of feature matches (SIFT on views at "
                  "most 960 px wide).", False),
        FPS,
        Parameter("report", "output", "Write analysis.json, disparity.png, a thumbnail per shot and index.html into "
                  "this folder (created when missing).", None),
        Parameter("force", "flag", "Replace the files of an earlier report in {report} (never without it).", False,
                  web=False),  # the web's reports go to a fresh folder of its own
    ),
    work=analyze,
    hooks=("progress", "before_commit"),
)
