"""The demo's S3 section: glass and mirrors made fusible on ``glasses`` (S3 §3-4).

The built-in ``glasses`` scene (two glass spheres, a goblet and a tilted mirror before a lettered
wall) on its own rig is run through :func:`vergence.specular.specular_stereo` for S3's study
display: the ray tree of each eye, the per-layer disparity, importance and rivalry, the table of the
left eye at ``y = m / k`` and the per-pixel, per-layer offsets, the final render and S3 §4's
baselines. The section shows what ``vergence specular`` writes (the same files,
:func:`vergence.report.specular_outputs.write_specular_outputs`): the layers, their disparities,
importance and rivalry before and after, the offsets, the four methods as anaglyphs, and the
report's figures.

The image is :data:`SIZE` (S3 renders 512 x 512; the section keeps the demo within about half a
minute more on two cores) with S3's k = 32 and D = 2.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from vergence.report.html import Figure, Grid, Section

__all__ = ["DISPLAY", "SIZE", "SpecularDemo", "section_specular"]

#: Image size of the section (width, height): the built-in scene's default.
SIZE = (320, 240)
#: The display the pair is judged for: S3's study display (S3 §4.2).
DISPLAY = "samsung-2233rz"
FOLDER = "specular"

Progress = Callable[[str], None]


@dataclass(frozen=True, slots=True)
class SpecularDemo:
    """What the section measured: ``report`` (:meth:`vergence.specular.SpecularResult.report`) and the wall time."""

    report: dict
    seconds: float


def _share(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.0f} %"


def section_specular(out: Path, progress: Progress, number: int) -> tuple[Section, SpecularDemo]:
    """Run S3 on ``glasses`` and write the section's files under ``out / "specular"``.

    Parameters
    ----------
    out : Path
        The report's (temporary) folder.
    progress : callable(str)
        Told what runs (one line per stage).
    number : int
        The section's number in the page.
    """
    from vergence.render import Tracer, builtin_scene
    from vergence.report.specular_outputs import write_specular_outputs
    from vergence.rigs import stereo_pair
    from vergence.specular import specular_stereo
    from vergence.viewing import Display

    t0 = time.perf_counter()
    scene = builtin_scene("glasses", width=SIZE[0], height=SIZE[1])
    left, right = stereo_pair(scene.camera.build(), baseline=scene.stereo.baseline,
                              convergence=scene.stereo.convergence)  # fmt: skip
    last = [""]

    def stage(_fraction: float, message: str) -> None:
        head = message.split(":")[0].split(" ")[0]
        if head != last[0]:
            last[0] = head
            progress(f"S3 on glasses: {message}")

    result = specular_stereo(Tracer(scene), left, right, Display.preset(DISPLAY), progress=stage)
    folder = out / FOLDER
    folder.mkdir()
    write_specular_outputs(result, folder)
    report = result.report()
    seconds = time.perf_counter() - t0
    cb, ca = report["cost_before"], report["cost_after"]
    text = (
        f"The built-in glasses scene ({SIZE[0]}x{SIZE[1]}, its rig: baseline {scene.stereo.baseline:g} m, "
        f"converged at {scene.stereo.convergence:g} m) shown on S3's study display ({DISPLAY}). Each eye is a "
        "Whitted ray tree of 7 layers (S3 §3.1: 1 is the first hit, R and T reflection and refraction paths). "
        "Each layer of the left eye is matched to the same layer of the right eye by 3D position (S3 §3.2), "
        "which gives its disparity in arcmin, its importance (proximity x distinctiveness x contrast) and "
        "its rivalry. The left eye's shading camera of every layer and pixel then moves along the baseline "
        "(offset y: 1 physical, 0 mono) to lower the cost of S3 Eq. 2 as docs/specular.md derives it: absolute "
        "and data terms measure the distance to the comfort zone less a 15 arcmin margin, so a layer already "
        "inside stays put; relative keeps layers 3 arcmin apart and in order; rivalry counts above 10 dL* "
        "(alpha = 1, 1, 10, 0.1), solved on a table of k = 32 offsets (S3 §3.4). On glasses every layer is "
        "already comfortable, so little moves and the cost stays about where it was. "
        "'After' is measured on the final render, not predicted. The four methods of S3 §4: physical, ours "
        "(optimised), on-surface (reflections painted on the surface) and near-surface (5 arcmin from it). "
        f"Mean cost before -> after: absolute {cb['absolute']:.1f} -> {ca['absolute']:.1f}, relative "
        f"{cb['relative']:.1f} -> {ca['relative']:.1f}, rivalry {cb['rivalry']:.0f} -> {ca['rivalry']:.0f}, "
        f"data {cb['data']:.1f} -> {ca['data']:.1f}, total {cb['total']:.0f} -> {ca['total']:.0f}. "
        f"{seconds:.0f} s in all; docs/specular.md has the figures at 512 px and the command."
    )
    rows = [("layer", "pixels", "matched", "comfort share before", "after", "separated before", "after", "mean y")]
    for layer in report["layers"]:
        if not layer["pixels"]:
            continue
        rows.append((f"{layer['layer']} {layer['name']}", f"{layer['pixels']}", _share(layer["matched_before"]),
                     _share(layer["comfort_share_before"]), _share(layer["comfort_share_after"]),
                     _share(layer["separated_share_before"]), _share(layer["separated_share_after"]),
                     f"{layer['offset_mean']:.2f}"))  # fmt: skip
    anaglyphs = Grid(tuple(Figure(f"{FOLDER}/{m}_anaglyph.png", caption) for m, caption in (
        ("physical", "physical stereo"), ("optimised", "optimised (S3 §3.4)"),
        ("on_surface", "on-surface (S3 §4.1)"), ("near_surface", "near-surface (S3 §4.1, Templin et al. 2012)"),
    )), columns=2)  # fmt: skip
    figures = (
        Figure(f"{FOLDER}/physical_left_layers.png", "The left eye's ray-tree layers (physical)."),
        Figure(f"{FOLDER}/analysis_disparity.png",
               "Horizontal disparity per layer (arcmin; the comfort zone marked on the bar), before and after."),
        Figure(f"{FOLDER}/analysis_importance.png", "Importance per layer, before and after."),
        Figure(f"{FOLDER}/analysis_rivalry.png", "Rivalry per layer ((ΔL*)²), before and after."),
        Figure(f"{FOLDER}/offsets.png", "The offsets y per layer (1: physical, 0: mono; layer 1 stays at 1)."),
        anaglyphs,
    )
    title = f"{number}. Glass and mirrors that fuse: specular disparity (S3)"
    return Section(title, text, figures, tuple(rows)), SpecularDemo(report=report, seconds=seconds)
