"""``vergence demo``: the main job on built-in data, written as ``DIR/index.html`` with its figures.

The scene is S0 §4's long-lens shot: a player 30 m away with the bleachers 80 m behind the camera
line, framed with a normalised focal length f = 10 and shown on a television with f' = 2.5. A plain
two-camera rig can either keep the eyes from diverging (b = b_div, cardboard subject) or make the
subject round (b = b_round, diverging background) but not both (S0 Eq. 6); the Tri-Rig's disparity
mapping psi (S0 §6) does both. The last section browses a photo collection in stereo (S2, the dino
ring of the shared data; one line saying so when the data is missing).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.report.demo_rigs import demo_shot, section_rig
from vergence.report.demo_specular import section_specular
from vergence.report.demo_stereospace import dino_folder, map_figure, section_stereospace
from vergence.report.html import Figure, Grid, Section, write_report
from vergence.viewing.budget import DepthBudget, depth_budget
from vergence.viewing.geometry import (
    CARDBOARD_ROUNDNESS,
    Display,
    Shooting,
    divergence_baseline,
    roundness_baseline,
)
from vergence.viewing.mapping_constraints import ConstrainedMapping, psi_from_constraints

__all__ = ["DEMO_DISPLAY", "DemoResult", "run_demo", "stadium_shooting"]

# S0 §4: subject (player) and background (bleachers) distances from the camera line, metres.
SUBJECT_DEPTH = 30.0
BACKGROUND_DEPTH = 80.0
# S0 §2: a long lens, f = H/W = 10, converged on the subject.
SHOOTING_FOCAL = 10.0
# A television seen with f' = H'/W' = 2.5 (S0 §2): 1.2 m wide, 3 m away, 1920 px, eyes 65 mm apart.
DEMO_DISPLAY = Display(eye_separation=0.065, distance=3.0, width=1.2, resolution=1920)
# Scene depths shown in the budget table and the plots.
TABLE_DEPTHS = (15.0, 20.0, 30.0, 40.0, 60.0, 80.0, 150.0)
PLOT_NEAR, PLOT_FAR = 12.0, 200.0
# Rendered stadium pair: size and ambient-occlusion samples (about 1 s a view on 2 cores).
RENDER_WIDTH, RENDER_HEIGHT, RENDER_SAMPLES = 640, 360, 16

Progress = Callable[[str], None]


@dataclass(frozen=True, slots=True)
class DemoResult:
    """What the demo wrote: the report and the key numbers it shows."""

    index: Path
    divergence_rig: DepthBudget
    roundness_rig: DepthBudget
    tri_rig: ConstrainedMapping
    stadium_disparity_px: dict[str, tuple[float, float]]
    dibr_quality: object  # vergence.synthesis.ViewQuality of the DIBR right eye against the ray-traced one
    rig_reports: dict  # "quadri"/"tri" -> vergence.rigs.shoot.ShotRender.report (PSNR, DSSIM, coverage)
    stereospace: object = None  # vergence.report.demo_stereospace.StereoSpaceDemo; None without the dino data
    specular: object = None  # vergence.report.demo_specular.SpecularDemo


def stadium_shooting(baseline: float) -> Shooting:
    """The S0 §4 rig with a given baseline: converged on the player, f = 10."""
    return Shooting(baseline=baseline, convergence=SUBJECT_DEPTH, window=SUBJECT_DEPTH / SHOOTING_FOCAL)


def _fmt(v: float | None, digits: int = 3) -> str:
    if v is None:
        return "-"
    if math.isinf(v):
        return "inf"
    return f"{v:.{digits}g}"


def _budget_table(name: str, budget: DepthBudget) -> list[tuple[str, ...]]:
    """Rows as ``vergence budget`` prints them: z' infinite where the eyes are parallel, null where they
    diverge; roundness as in ``budget --json`` (S0 Eq. 4 as is: negative past divergence); the same notes."""
    rows = []
    for s in budget.samples:
        perceived = "inf" if s.note == "eyes parallel" else _fmt(s.perceived_depth, 3)
        rows.append((name, f"{s.depth:g}", _fmt(s.parallax_px, 3), perceived, _fmt(s.roundness, 2), s.note))
    return rows


def _section_budget(out: Path, progress: Progress) -> tuple[Section, DepthBudget, DepthBudget]:
    from vergence.report.budget_plot import plot_budget

    display = DEMO_DISPLAY
    window = SUBJECT_DEPTH / SHOOTING_FOCAL
    b_div = divergence_baseline(window, display)  # S0 Eq. (3)
    b_round = roundness_baseline(SUBJECT_DEPTH, display)  # S0 Eq. (5)
    div_rig = depth_budget(stadium_shooting(b_div), display, TABLE_DEPTHS)
    round_rig = depth_budget(stadium_shooting(b_round), display, TABLE_DEPTHS)
    progress("plotting the two plain rigs")
    plot_budget(stadium_shooting(b_div), display, near=PLOT_NEAR, far=PLOT_FAR, path=out / "budget_b_div.png")
    plot_budget(stadium_shooting(b_round), display, near=PLOT_NEAR, far=PLOT_FAR, path=out / "budget_b_round.png")
    subject_div = next(s for s in div_rig.samples if s.depth == SUBJECT_DEPTH)
    text = (
        f"S0 §4's long-lens shot: a player {SUBJECT_DEPTH:g} m away, bleachers at {BACKGROUND_DEPTH:g} m, "
        f"framed with f = H/W = {SHOOTING_FOCAL:g} (convergence window {window:g} m wide) and shown on a "
        f"{display.width:g} m television seen from {display.distance:g} m (f' = {display.focal:g}, "
        f"{display.resolution} px). S0 Eq. (6): b_round / b_div = f/f' = {div_rig.focal_ratio:g}. "
        f"With b = b_div = {b_div:.3f} m the eyes never diverge but the player's roundness is "
        f"{subject_div.roundness:.2f} (< {CARDBOARD_ROUNDNESS:g}: a cardboard cut-out). With "
        f"b = b_round = {b_round:.3f} m the player is round (1.0) but everything beyond "
        f"{round_rig.divergence_depth:.1f} m, the bleachers included, asks the eyes to diverge. "
        "(With b = b_div the roundness is the same at every depth: Eq. (4)'s z term vanishes.) "
        "Disparities are in screen pixels (positive = behind the screen). Past the divergence depth nothing "
        "is perceived (z' is empty) and the roundness is S0 Eq. (4) as is, negative, as `vergence budget "
        "--json` reports it."
    )
    table = (("rig", "depth z (m)", "disparity (px)", "perceived z' (m)", "roundness", "problem"),)
    table += tuple(_budget_table(f"b_div = {b_div:.3f} m", div_rig))
    table += tuple(_budget_table(f"b_round = {b_round:.3f} m", round_rig))
    figures = (
        Grid((
            Figure("budget_b_div.png", f"b = b_div = {b_div:.4f} m: perceived depth and roundness against scene depth "
                   "(cardboard subject)."),
            Figure("budget_b_round.png", f"b = b_round = {b_round:.3f} m: round subject, but the eyes diverge beyond "
                   "the marked depth."),
        )),
    )
    return Section("1. One rig cannot do both (S0 §2)", text, figures, table), div_rig, round_rig


def _section_tri_rig(out: Path, progress: Progress) -> tuple[Section, ConstrainedMapping]:
    from vergence.report.mapping_plot import plot_mapping

    display = DEMO_DISPLAY
    b_round = roundness_baseline(SUBJECT_DEPTH, display)  # S0 Eq. (5)
    reference = stadium_shooting(b_round)
    constraints = [
        f"z={SUBJECT_DEPTH:g},perceived={display.distance:g},roundness=1",
        "z=inf,perceived=inf",
    ]
    progress("building the Tri-Rig mapping psi")
    tri = psi_from_constraints(reference, display, constraints, near=PLOT_NEAR, far=math.inf)
    plot_mapping(tri, path=out / "tri_rig_psi.png")
    z = (PLOT_NEAR, SUBJECT_DEPTH, BACKGROUND_DEPTH, PLOT_FAR)
    zp = [float(tri.perceived_depth(v)) for v in z]
    rho = [float(tri.roundness(v)) for v in z]
    table = (("scene depth z (m)", "perceived z' (m)", "roundness"),) + tuple(
        (f"{a:g}", _fmt(b, 3), _fmt(c, 2)) for a, b, c in zip(z, zp, rho)
    )
    bleachers = BACKGROUND_DEPTH
    text = (
        "The Tri-Rig (S0 §6) keeps the director's camera as the left view and builds the right view "
        "through a disparity mapping psi fixed by constraints. Here, S0 Fig. 8 (right): the player on the "
        f"screen (z' = {display.distance:g} m) with roundness 1, and infinity seen at infinity (psi reaches the "
        "divergence limit b'/W' only at infinite depth). psi is the Gregory–Delbourgo monotone rational "
        "Hermite interpolant of the control points (S0 §6, Eq. 7–9), reference rig b_round: it keeps "
        "the player's disparities and compresses the background's. "
        f"The bleachers at {bleachers:g} m are then seen at {float(tri.perceived_depth(bleachers)):.1f} m with "
        f"roundness {float(tri.roundness(bleachers)):.2f} (b_div: 0.25, b_round: divergence). "
        f"psi is monotone: {'yes' if tri.monotone else 'no'}; ever past the divergence limit: "
        f"{'yes' if tri.diverges else 'no'}."
    )
    fig = Figure("tri_rig_psi.png", "psi(d) with the identity and the divergence limit; mapped perceived depth and roundness.")
    return Section("2. The Tri-Rig's disparity mapping (S0 §6)", text, (fig,), table), tri


def _section_stadium(out: Path, progress: Progress) -> tuple[Section, dict[str, tuple[float, float]]]:
    from vergence.display import anaglyph, side_by_side
    from vergence.io import write_image
    from vergence.render import builtin_scene, screen_disparity, stereo_preview

    display = DEMO_DISPLAY
    scene = builtin_scene("stadium", width=RENDER_WIDTH, height=RENDER_HEIGHT)
    window = 2.0 * SUBJECT_DEPTH * math.tan(math.radians(scene.camera.fov_deg) / 2.0)
    b_div = divergence_baseline(window, display)  # S0 Eq. (3)
    b_round = roundness_baseline(SUBJECT_DEPTH, display)  # S0 Eq. (5)
    section1_window = SUBJECT_DEPTH / SHOOTING_FOCAL  # section 1 frames the player with f = 10
    section1_b_div = divergence_baseline(section1_window, display)
    limit_px = display.divergence_disparity * display.resolution
    rows: list[tuple[str, ...]] = [("rig", "baseline (m)", "nearest (px)", "farthest (px)", "divergence limit (px)")]
    figures = []
    measured: dict[str, tuple[float, float]] = {}
    for name, baseline in (("b_div", b_div), ("b_round", b_round)):
        progress(f"rendering the stadium pair with {name}")
        pair = stereo_preview(
            scene, baseline=baseline, convergence=SUBJECT_DEPTH, samples=RENDER_SAMPLES, rng=np.random.default_rng(0)
        )
        write_image(out / f"stadium_{name}_anaglyph.png", anaglyph(pair.left, pair.right, method="dubois"))
        figures.append(Figure(f"stadium_{name}_anaglyph.png", f"Dubois anaglyph, b = {name} = {baseline:.4f} m."))
        if name == "b_div":
            write_image(out / "stadium_b_div_sbs.png", side_by_side(pair.left, pair.right, half=True))
        # Screen disparity x_r - x_l of every first hit, scaled from the render's width to the display's.
        disp_px = -screen_disparity(pair.left_result, pair.right_result)
        disp = disp_px[np.isfinite(disp_px)] / pair.left_result.camera.width * display.resolution
        measured[name] = (float(disp.min()), float(disp.max()))
        rows.append((name, f"{baseline:.3f}", f"{disp.min():+.1f}", f"{disp.max():+.1f}", f"{limit_px:.1f}"))
    text = (
        f"The built-in stadium scene (a player {SUBJECT_DEPTH:g} m away, bleachers from 60 m, a "
        f"{scene.camera.fov_deg:g} degree lens: a {window:.2f} m window at the player) ray-traced for both eyes "
        f"with the two plain rigs above, {RENDER_WIDTH}x{RENDER_HEIGHT} px. The table gives the screen "
        "disparity measured on the rendered geometry (every first-hit point projected into both views, "
        f"scaled to the {display.resolution}-px television): with b_round the bleachers' disparity passes "
        "the divergence limit b'/W' (S0 Eq. 8), with b_div it never does but the player looks flat. "
        f"Why b_div is {b_div:.4f} m here but {section1_b_div:.4f} m in section 1: b_div = b'W/W' (S0 Eq. 3) "
        "grows with the convergence window W, and the two sections frame the player differently. Section 1 "
        f"uses f = H/W = {SHOOTING_FOCAL:g}, so W = {SUBJECT_DEPTH:g}/{SHOOTING_FOCAL:g} = {section1_window:g} m; "
        f"the stadium's camera has a {scene.camera.fov_deg:g} degree lens, so W = 2 H tan(fov/2) = "
        f"{window:.3f} m (f = {SUBJECT_DEPTH / window:.2f}). On the same television (b' = {display.eye_separation:g} m, "
        f"W' = {display.width:g} m): {display.eye_separation:g} x {section1_window:g} / {display.width:g} = "
        f"{section1_b_div:.4f} m against {display.eye_separation:g} x {window:.3f} / {display.width:g} = {b_div:.4f} m. "
        f"b_round = b'H/H' = {b_round:.2f} m depends on H and H' only: the same in both."
    )
    figures = [Grid(tuple(figures)),
               Figure("stadium_b_div_sbs.png", "The b_div pair, half side-by-side (for 3D TVs).")]
    section = Section("3. Rendered: the stadium pair (S0 §4, S3 §3.1 ray tree)", text, tuple(figures), tuple(rows))
    return section, measured


def _section_dibr(out: Path, progress: Progress) -> tuple[Section, object]:
    from vergence.display import anaglyph, interleave, side_by_side, top_bottom
    from vergence.io import write_image
    from vergence.render import builtin_scene, stereo_preview
    from vergence.synthesis import assess_view, synthesize_view

    progress("rendering the tabletop pair")
    scene = builtin_scene("tabletop", width=RENDER_WIDTH, height=RENDER_HEIGHT * 4 // 3)
    pair = stereo_preview(scene, samples=RENDER_SAMPLES)  # deterministic AO: no noise differs between the eyes
    progress("synthesizing the right eye from the left eye and its depth (DIBR)")
    left_cam, right_cam = pair.left_result.camera, pair.right_result.camera
    synth = synthesize_view(pair.left, pair.left_result.depth, left_cam, right_cam)
    quality = assess_view(synth.image, pair.right)
    error = np.abs(synth.image.astype(np.float64) - pair.right).mean(axis=-1)
    write_image(out / "tabletop_left.png", pair.left)
    write_image(out / "tabletop_right_traced.png", pair.right)
    write_image(out / "tabletop_right_dibr.png", synth.image)
    write_image(out / "tabletop_error_x4.png", np.clip(4.0 * error, 0.0, 1.0).astype(np.float32))
    write_image(out / "tabletop_holes.png", synth.holes.astype(np.float32))
    formats = {
        "anaglyph": anaglyph(pair.left, synth.image, method="dubois"),
        "sbs_half": side_by_side(pair.left, synth.image, half=True),
        "top_bottom_half": top_bottom(pair.left, synth.image, half=True),
        "row_interleaved": interleave(pair.left, synth.image, orientation="rows"),
    }
    for name, img in formats.items():
        write_image(out / f"tabletop_{name}.png", img)
    holes_pct = 100.0 * float(synth.holes.mean())
    reg_pct = 100.0 * quality.registration_pixels / quality.pixels
    text = (
        f"The built-in tabletop scene ray-traced for both eyes (baseline {pair.baseline * 100:g} cm, zero parallax "
        f"at {pair.convergence:g} m). The right eye is then made from the left eye's colour and depth alone by "
        "depth-image-based rendering (S1 §IV: forward warp with the gap/hole rule, contour handling, "
        f"background-directed hole filling; {holes_pct:.1f} % of pixels were disoccluded) and compared with "
        f"the ray-traced right eye: PSNR {quality.psnr_db:.2f} dB, SSIM {quality.ssim:.4f}, DSSIM "
        f"{quality.dssim:.4f}; registration error (S1 Eq. 11–13, over the {reg_pct:.0f} % of pixels with texture) "
        f"RMS {quality.registration_rms_px:.2f} px, 95th percentile {quality.registration_ranked_px[0.95]:.2f} px. "
        "The DIBR view stands beside its truth; under them the input, the error (4x the mean absolute "
        "difference) and the disoccluded pixels; last, the pair in display formats."
    )
    table = (
        ("view", "PSNR (dB)", "SSIM", "DSSIM", "registration RMS (px)", "registration 95 % (px)", "disoccluded (%)"),
        (
            "DIBR right eye vs ray-traced",
            f"{quality.psnr_db:.2f}",
            f"{quality.ssim:.4f}",
            f"{quality.dssim:.4f}",
            f"{quality.registration_rms_px:.2f}",
            f"{quality.registration_ranked_px[0.95]:.2f}",
            f"{holes_pct:.2f}",
        ),
    )
    figures = (
        Grid((
            Figure("tabletop_right_traced.png", "Right eye, ray-traced (the truth)."),
            Figure("tabletop_right_dibr.png", "Right eye, synthesized by DIBR from the left eye + depth."),
        )),
        Grid((
            Figure("tabletop_left.png", "Left eye, ray-traced (the DIBR input, with its depth)."),
            Figure("tabletop_error_x4.png", "|DIBR - truth| x 4 (mean over channels)."),
            Figure("tabletop_holes.png", "Disoccluded pixels (white), filled from the background side."),
        ), columns=3),
        Grid((
            Figure("tabletop_anaglyph.png", "Left + DIBR right: Dubois anaglyph."),
            Figure("tabletop_sbs_half.png", "Half side-by-side."),
            Figure("tabletop_top_bottom_half.png", "Half top-bottom."),
            Figure("tabletop_row_interleaved.png", "Row-interleaved (passive polarised screens)."),
        )),
    )
    return Section("4. View synthesis against the truth (S1)", text, figures, table), quality


def run_demo(out_dir: str | Path, *, progress: Progress | None = None) -> DemoResult:
    """Run the main job on built-in data and write ``out_dir/index.html`` with its figures.

    All or nothing: everything is written into a hidden temporary folder beside ``out_dir`` and moved
    into place only once complete (a new ``out_dir`` by one rename; into an existing one file by file,
    ``index.html`` last). On any error or interruption (``KeyboardInterrupt``) the temporary folder is
    removed and ``out_dir`` is left as it was.

    Parameters
    ----------
    out_dir : str or Path
        Output folder; created if missing. Existing demo files in it are replaced, other files kept.
    progress : callable, optional
        Called with a short message before each step and once more just before the output is moved into
        place; an exception it raises (a ``KeyboardInterrupt`` the caller noticed) aborts the demo cleanly.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out must be a folder; {out} is a file")
    out.parent.mkdir(parents=True, exist_ok=True)
    say = progress or (lambda _msg: None)
    try:
        work = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    except OSError as exc:  # the hidden working folder's name is ours, not the user's: say where
        reason = (exc.strerror or str(exc)).lower()
        raise OSError(f"cannot write the demo into {out}: {reason} in {out.parent}") from None
    try:
        say("depth budget of the two plain rigs")
        budget_section, div_rig, round_rig = _section_budget(work, say)
        say("the Tri-Rig mapping")
        tri_section, tri = _section_tri_rig(work, say)
        say("the stadium pair")
        stadium_section, stadium_disparity = _section_stadium(work, say)
        say("view synthesis")
        dibr_section, dibr_quality = _section_dibr(work, say)
        rig_sections, rig_reports = [], {}
        for number, kind in ((5, "quadri"), (6, "tri")):
            say(f"the stereoscopic zoom: {kind} rig")
            section, rig_reports[kind] = section_rig(work, say, demo_shot(kind), number)
            rig_sections.append(section)
        say("StereoSpace on the dino ring")
        stereo_section, stereospace = section_stereospace(work, say, 7, display=DEMO_DISPLAY,
                                                          map_figure=map_figure(dino_folder()))  # fmt: skip
        say("S3: glass and mirrors on glasses")
        specular_section, specular = section_specular(work, say, 8)
        sections = [budget_section, tri_section, stadium_section, dibr_section, *rig_sections, stereo_section,
                    specular_section]  # fmt: skip
        say("writing index.html")
        write_report(
            work / "index.html",
            title="Vergence demo: a stereoscopic long-lens shot",
            intro=(
                "Everything on this page was computed by `vergence demo` from built-in data (the StereoSpace "
                "section: from the dino photographs of the shared data); each figure is a PNG beside this file. "
                "To try it yourself on your display, start the workbench with `vergence serve` (add `--data DIR` "
                "for your collections and scenes) and open the address it prints, http://127.0.0.1:8765 by default."
            ),
            sections=sections,
        )
        say("moving the report into place")
        _publish(work, out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return DemoResult(
        index=out / "index.html",
        divergence_rig=div_rig,
        roundness_rig=round_rig,
        tri_rig=tri,
        stadium_disparity_px=stadium_disparity,
        dibr_quality=dibr_quality,
        rig_reports=rig_reports,
        stereospace=stereospace,
        specular=specular,
    )


def _publish(work: Path, out: Path) -> None:
    """Move the finished report from ``work`` to ``out``: one rename for a new folder, else file by file
    with ``index.html`` last (a reader never sees a page whose figures are missing)."""
    if not out.exists():
        os.replace(work, out)
        return
    names = sorted(p.name for p in work.iterdir() if p.name != "index.html") + ["index.html"]
    for name in names:
        os.replace(work / name, out / name)
