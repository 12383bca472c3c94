"""The report of ``vergence analyze``: the analysis JSON, a figure of the disparity over time against
the comfort zone, a thumbnail per shot, and an HTML page that shows them (:mod:`vergence.report.html`).

Figures are drawn without pyplot state and written atomically (:mod:`vergence.report._figures`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from vergence.report._figures import new_figure, png_path, save_png
from vergence.report.html import Figure, Section, write_report

__all__ = ["ANALYSIS_REPORT_FILES", "plot_disparity_over_time", "write_analysis_report"]

# The files a report folder receives (the thumbnails are shot_NN.png besides these).
ANALYSIS_REPORT_FILES = ("analysis.json", "disparity.png", "index.html")


def _arcmin(values_px: np.ndarray, analysis: object) -> np.ndarray:
    from vergence.viewing import Display, arcmin_from_pixels

    display = Display(**analysis.display)
    scale = display.resolution / analysis.width  # the view fills the screen's width
    return np.asarray(arcmin_from_pixels(-np.asarray(values_px, dtype=np.float64) * scale, display))


def plot_disparity_over_time(analysis: object, path: str | os.PathLike[str]) -> Path:
    """Plot each analysed frame's disparity range (1-99 %, 5-95 %, median) in arcmin of vergence
    against the comfort zone and the divergence limit, with the cuts; write a PNG.

    Angles carry the sign of the disparity ``D = x_left - x_right`` (``docs/conventions.md``), as
    ``vergence analyze`` reports them: positive in front of the screen, so content behind the screen
    (and the divergence limit) plots below zero.
    """
    out = png_path(path)
    frames = np.array([f.frame for f in analysis.per_frame], dtype=np.float64)
    pct = np.array([[f.disparity_px[k] for k in ("p1", "p5", "p50", "p95", "p99")] for f in analysis.per_frame])
    angles = -_arcmin(pct, analysis)  # signed as D: in front positive
    fig = new_figure(figsize=(8.0, 3.6), dpi=110)
    ax = fig.add_subplot()
    lo, hi = analysis.zone_arcmin
    ax.axhspan(lo, hi, color="#2a9d8f", alpha=0.12, label=f"comfort zone {lo:+.0f} .. {hi:+.0f} arcmin")
    divergence = -float(_arcmin(np.array([analysis.divergence_px]), analysis)[0])
    ax.axhline(divergence, color="#e76f51", lw=1.2, ls="--", label=f"divergence {divergence:+.0f} arcmin")
    ax.fill_between(frames, angles[:, 0], angles[:, 4], color="#264653", alpha=0.25, step="mid", label="1-99 %")
    ax.fill_between(frames, angles[:, 1], angles[:, 3], color="#264653", alpha=0.45, step="mid", label="5-95 %")
    ax.plot(frames, angles[:, 2], color="#264653", lw=1.5, drawstyle="steps-mid", label="median")
    for shot in analysis.shots[1:]:
        ax.axvline(shot.start - 0.5, color="#555", lw=0.8, ls=":")
    ax.axhline(0.0, color="#999", lw=0.6)
    ax.set_xlim(-0.5, analysis.frames - 0.5)
    ax.set_xlabel("frame (dotted: cuts)")
    ax.set_ylabel("disparity, arcmin of vergence\n(+ in front of the screen)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return save_png(fig, out)


def _fmt(v: float | None, spec: str = ".2f") -> str:
    return "-" if v is None else format(v, spec)


def write_analysis_report(analysis: object, folder: str | os.PathLike[str], *, data: dict, title: str) -> Path:
    """Write ``analysis.json`` (``data``), ``disparity.png``, ``shot_NN.png`` and ``index.html`` into ``folder``.

    ``folder`` must exist (the CLI passes the temporary folder of :func:`vergence.io.atomic_folder`).
    Returns the HTML page's path.
    """
    from vergence.io import write_image, write_json

    out = Path(folder)
    write_json(out / "analysis.json", data)
    plot_disparity_over_time(analysis, out / "disparity.png")
    thumbs = []
    for k, (shot, image) in enumerate(zip(analysis.shots, analysis.thumbnails)):
        name = f"shot_{k:02d}.png"
        write_image(out / name, np.clip(image, 0.0, 1.0))
        s = shot.suggestion
        thumbs.append(Figure(name, f"shot {k}: frames {shot.start}-{shot.end - 1}; median "
                                   f"{shot.disparity_px['p50']:+.2f} px; suggestion: {s['action']}"))
    header = ("shot", "frames", "p1 px", "p50 px", "p99 px", "p1 arcmin", "p99 arcmin", "outside comfort",
              "diverging", "window violations", "vertical px", "suggestion")
    rows = [header]
    for k, shot in enumerate(analysis.shots):
        s = shot.suggestion
        advice = ("none" if s["action"] == "none" else
                  f"scale {s['scale']:.3f}, shift {s['shift_px']:+.2f} px")
        rows.append((str(k), f"{shot.start}-{shot.end - 1}", _fmt(shot.disparity_px["p1"]),
                     _fmt(shot.disparity_px["p50"]), _fmt(shot.disparity_px["p99"]),
                     _fmt(shot.disparity_arcmin["p1"], "+.1f"), _fmt(shot.disparity_arcmin["p99"], "+.1f"),
                     f"{100 * shot.outside_comfort:.1f} %", f"{100 * shot.diverging:.1f} %",
                     str(shot.window_violations), _fmt(shot.vertical_px), advice))  # fmt: skip
    lo, hi = analysis.zone_arcmin
    every = "every frame" if analysis.every == 1 else f"every {analysis.every}th frame"
    sections = [
        Section("Disparity over time",
                f"The disparity of {every} ({analysis.kind}, {analysis.width}x{analysis.height} per view, "
                f"{analysis.frames} frames at {analysis.fps:g} frames/s) as vergence on the display, against the "
                f"comfort zone {lo:+.0f} .. {hi:+.0f} arcmin and the divergence limit. Disparity in px is "
                "`x_left - x_right` of the full-resolution views, positive in front of the screen, and so is "
                "its angle in arcmin; the "
                "suggestion is `D' = scale D + shift_px`.",
                figures=(Figure("disparity.png", "1-99 % and 5-95 % ranges and median per frame; dotted: cuts"),),
                table=tuple(rows)),
        Section("Shots", "A thumbnail of each shot (its first analysed frame, left view).", figures=tuple(thumbs)),
    ]
    return write_report(out / "index.html", title=title,
                        intro="Comfort analysis by `vergence analyze`; the numbers are in `analysis.json`.",
                        sections=sections)  # fmt: skip
