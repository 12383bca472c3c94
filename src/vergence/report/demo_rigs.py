"""The demo's stereoscopic-zoom sections (S0 §5–7): the Quadri-Rig and the Tri-Rig on the stadium.

Each section plans the rig of a built-in shot (the same as ``examples/shots/stadium-*.json``), draws it
from above, ray-traces its real cameras, synthesises the director's pair with ULR and Bayesian
weights and measures it against the ray-traced truth, next to S0 Table 1.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path


from vergence.report.html import Figure, Grid, Section
from vergence.rigs.shot import EXAMPLE_SHOTS

__all__ = ["DEMO_RENDER", "DEMO_SHOTS", "S0_TABLE_1", "demo_shot", "section_rig"]

# The demo's shots: examples/shots/stadium-quadri.json and stadium-tri.json (a test checks they agree),
# rendered with DEMO_SAMPLES AO rays at the size and rays per pixel of DEMO_RENDER.
DEMO_SHOTS = {"quadri": EXAMPLE_SHOTS["stadium-quadri"], "tri": EXAMPLE_SHOTS["stadium-tri"]}
# kind -> (width, height, k for k x k rays per pixel): the Quadri-Rig as `vergence rig render` does it
# (about 10 s); the Tri-Rig smaller, since its curved-ray truth takes ~100 s at the full size.
DEMO_RENDER = {"quadri": (480, 270, 3), "tri": (320, 180, 2)}
DEMO_SAMPLES = 8


def demo_shot(kind: str) -> object:
    """The demo's shot ``kind`` ("quadri" or "tri") at the demo's image size."""
    from vergence.rigs import shot_from_dict

    data = {**DEMO_SHOTS[kind]}
    width, height, _ = DEMO_RENDER[kind]
    data["camera"] = {**data["camera"], "width": width, "height": height}
    return shot_from_dict(data)


# S0 Table 1 (Quadri-Rig, blender lego, 4 cameras): (PSNR dB, DSSIM) per method and eye.
S0_TABLE_1 = {
    "ulr": {"left": (33.93, 288e-4), "right": (33.94, 290e-4)},
    "bayesian": {"left": (34.00, 287e-4), "right": (34.02, 288e-4)},
}

Progress = Callable[[str], None]


def section_rig(out: Path, progress: Progress, shot: object, number: int) -> tuple[Section, dict]:
    """Plan, render and measure ``shot``; write its figures into ``out``; the section and the report."""
    from vergence.display import anaglyph
    from vergence.io import write_image
    from vergence.report.rig_plot import plot_rig
    from vergence.rigs.shoot import render_shot

    kind = shot.rig
    stem = f"rig_{kind}"
    rig = shot.plan()
    if kind == "quadri":
        plot_rig(out / f"{stem}_plan.png", rig.cameras, elements=rig.elements,
                 virtual=[("virtual left", rig.left, "virtual"), ("virtual right", rig.right, "virtual")],
                 title="Quadri-Rig from above")  # fmt: skip
    else:
        plot_rig(out / f"{stem}_plan.png", rig.cameras,
                 virtual=[("reference right", rig.reference_right, "virtual")], title="Tri-Rig from above",
                     reach=rig.reference.convergence)  # fmt: skip
    progress(f"rendering the {kind} rig")
    width, height, k = DEMO_RENDER[kind]
    result = render_shot(shot, samples=DEMO_SAMPLES, supersample=k,
                         progress=lambda _f, m: progress(f"{kind}: {m}"))  # fmt: skip
    names = list(result.cameras)
    for name in names:
        write_image(out / f"{stem}_camera_{name}.png", result.cameras[name][0])
    rows: list[tuple[str, ...]] = [("method", "eye", "PSNR (dB)", "DSSIM", "coverage", "S0 Table 1 (PSNR / DSSIM)")]
    pair_figs, error_figs = [], []
    for method, eyes in result.images.items():
        write_image(out / f"{stem}_{method}_anaglyph.png", anaglyph(eyes["left"], eyes["right"], method="dubois"))
        pair_figs.append(Figure(f"{stem}_{method}_anaglyph.png", f"{method.upper()} pair, Dubois anaglyph."))
        for eye, m in result.report["methods"][method].items():
            res = result.results[method].get(eye)
            if res is not None:
                write_image(out / f"{stem}_{method}_{eye}.png", eyes[eye])
                write_image(out / f"{stem}_{method}_{eye}_error.png", result.error_image(method, eye))
                error_figs.append(Figure(f"{stem}_{method}_{eye}_error.png",
                                         f"{method.upper()} {eye}: |synthesised - truth| x 4; blue: no source sees it."))  # fmt: skip
            paper = S0_TABLE_1.get(method, {}).get(eye) if kind == "quadri" else None
            p = "∞ (the director's image)" if m["psnr"] is None else f"{m['psnr']:.2f}"
            d = "—" if m["dssim"] is None else f"{m['dssim']:.2e}"
            rows.append((method, eye, p, d, f"{100 * m['coverage']:.1f} %",
                         "—" if paper is None else f"{paper[0]:.2f} / {paper[1]:.2e}"))  # fmt: skip
    for eye, image in result.truth.items():
        write_image(out / f"{stem}_truth_{eye}.png", image)
    if kind == "quadri":
        text = (
            "The Quadri-Rig (S0 §5): the director puts a virtual stereo rig on the field, where no camera can "
            "go; for each element (the player, the bleachers) and each eye one real camera stands on the "
            f"camera line {rig.setback:g} m behind, on the line from the element through the virtual eye, its "
            "focal length scaled so the element is imaged as the virtual eye would (S0 Eq. 10). Each virtual "
            "eye is synthesised from all the rig's real cameras, weighted per pixel, by image-based "
            "rendering (ULR, Buehler et al. 2001; Bayesian weights, Pujades et al. 2014) and compared with "
            "the virtual eye ray-traced directly, over the pixels some real camera sees; S0 synthesises each eye from its own two cameras "
            "(`vergence rig render --sources eye`). S0 Table 1 reports its figures on the blender lego scene."
        )
        truth = {"left": "Virtual left eye, ray-traced (the truth).", "right": "Virtual right eye, ray-traced (the truth)."}
    else:
        text = (
            "The Tri-Rig (S0 §6): the director's camera is the left eye, unchanged; a subject camera makes the "
            "player round on the screen and a background camera keeps the bleachers from diverging. The right "
            "image is rendered in the reference right camera of a distorted world phi (S0 Fig. 9): every source "
            "pixel through phi, z-buffered on the distorted depth, ULR angles measured in the real world "
            "(S0 Fig. 10). S0 had no reference image for it; here the truth follows each straight ray of the "
            "reference right camera as the curve phi^-1(ray) through the real scene (curved-ray tracing)."
        )
        truth = {"left": "The director's image: the left eye and its own truth.",
                 "right": "The right eye's truth: the reference right camera's rays followed as curves phi^-1(ray)."}
    figures = (
        Figure(f"{stem}_plan.png", "The rig from above."),
        Grid(tuple(Figure(f"{stem}_camera_{n}.png", f"Real camera {n}.") for n in names),
             columns=min(4, len(names))),  # fmt: skip
        Grid(tuple(pair_figs)),
        Grid(tuple(Figure(f"{stem}_truth_{eye}.png", truth[eye]) for eye in result.truth)),
        Grid(tuple(error_figs), columns=min(4, max(1, len(error_figs)))),
    )
    text += (f" Rendered at {width}x{height} with {k}x{k} rays per pixel and {DEMO_SAMPLES} AO rays (the demo is kept "
             "short); `vergence rig render` on the example shot (480x270, 3x3 rays per pixel, 16 AO rays) gives the "
             "figures of docs/shots.md.")
    title = f"{number}. Stereoscopic zoom: the {'Quadri' if kind == 'quadri' else 'Tri'}-Rig (S0 §{5 if kind == 'quadri' else 6})"
    return Section(title, text, figures, tuple(rows)), result.report
