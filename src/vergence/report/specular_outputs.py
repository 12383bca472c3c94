"""The files of ``vergence specular`` (S3, issue 12): renders, offsets, analysis, previews, contact sheets, report.

:func:`write_specular_outputs` writes a :class:`~vergence.specular.SpecularResult` into a folder:

- ``physical_left.npz``, ``right.npz``, ``optimised_left.npz``: the ``render.npz`` format of
  :func:`~vergence.report.preview.save_render` (per-layer radiance, position, normal; depth,
  beauty, ``layer_names``, ``settings``), each with its ``_camera.json``, ``_depth.pfm`` and
  previews; ``optimised_left.npz`` holds what the left eye's per-pixel cameras saw (S3 §3.4);
- ``offsets.npz``: ``y`` ``(N, H, W)`` float32, the offset per layer and pixel (1: the physical
  left eye), and ``layer_names``;
- ``{physical,optimised,on_surface,near_surface}_{left,right}.png``: the tone-mapped beauty of
  the four methods of S3 §4 (one exposure for all, that of the physical left eye; the right eye
  is the same for all four), ``{method}_anaglyph.png`` each and ``anaglyphs.png``, the four
  anaglyphs tiled 2 x 2 in that order and labelled;
- ``analysis.npz``: per layer the disparity ``(N, H, W, 2)`` in arcmin before and after
  (horizontal, vertical; NaN: no match), importance and rivalry before and after, ``present``
  (the physical left eye's layers; ``present_after`` the optimised one's), ``y``, ``layer_names``,
  ``comfort_zone_arcmin`` and the matcher's settings, ``match_epsilon_m`` (the cutoff, metres) and
  ``match_window`` (width, height): :func:`~vergence.specular.layer_disparity` of
  ``optimised_left.npz``'s positions against ``right.npz``'s with them, in arcmin
  (:func:`~vergence.specular.disparity_arcmin`) for the display, gives ``disparity_after``;
  ``fit`` and ``arcmin_per_px`` say how the pair was taken to be shown (``report.json``'s
  ``display``), ``first_object`` ``(H, W)`` the index in the scene's objects of each pixel's first
  hit in the physical left eye (-1: none), what the per-object shares group by;
- contact sheets: ``analysis_disparity.png`` (horizontal disparity, a diverging map centred at 0
  with the comfort zone marked on the colour bar), ``analysis_importance.png``,
  ``analysis_rivalry.png`` and ``offsets.png``: one row per layer with a surface somewhere, NaN
  and "no surface" grey;
- ``report.json``: :meth:`SpecularResult.report() <vergence.specular.SpecularResult.report>`.

Every file is written atomically; figures are drawn without pyplot (:mod:`vergence.report._figures`).
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
from matplotlib import colormaps

from vergence.display import ANAGLYPH_METHODS, anaglyph, tile_views
from vergence.io import atomic_write, write_image, write_json
from vergence.render.tonemap import auto_exposure, tonemap
from vergence.report._figures import new_figure, save_png
from vergence.report.preview import save_render
from vergence.specular.matching import MATCH_WINDOW
from vergence.specular.pipeline import SpecularResult
from vergence.specular.result_report import layer_labels

__all__ = ["SPECULAR_METHODS", "SPECULAR_OUTPUT_FILES", "write_specular_outputs"]

#: The four methods compared in S3 §4, in the order of ``anaglyphs.png`` (row by row).
SPECULAR_METHODS = ("physical", "optimised", "on_surface", "near_surface")
_SAVED_RENDERS = ("physical_left", "right", "optimised_left")
_RENDER_SUFFIXES = (".npz", "_camera.json", "_depth.pfm", "_beauty.png", "_depth.png", "_layers.png")
#: Every file :func:`write_specular_outputs` writes, in its order.
SPECULAR_OUTPUT_FILES = (
    *(f"{stem}{suffix}" for stem in _SAVED_RENDERS for suffix in _RENDER_SUFFIXES),
    "offsets.npz",
    *(f"{m}_{eye}.png" for m in SPECULAR_METHODS for eye in ("left", "right")),
    *(f"{m}_anaglyph.png" for m in SPECULAR_METHODS),
    "anaglyphs.png",
    "analysis.npz",
    "analysis_disparity.png",
    "analysis_importance.png",
    "analysis_rivalry.png",
    "offsets.png",
    "report.json",
)
_GREY = (0.5, 0.5, 0.5)  # NaN and "no surface" in the contact sheets
_TILE_INCHES = 2.6  # width of one panel of a contact sheet
_DPI = 100
_GRID_COLUMNS = 4  # a one-column sheet (the offsets) lays its layers out in rows of this many
# Disparity (a few mismatched rims reach degrees) and rivalry (Delta L*)^2 have long tails: their colour
# scales end at this percentile of the finite |values| of the layers shown; beyond it the colour saturates.
_SCALE_PERCENTILE = 99.0


def _savez(path: Path, **arrays: np.ndarray) -> Path:
    with atomic_write(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
    return path


def _labelled(image: np.ndarray, text: str) -> np.ndarray:
    """``image`` (H, W, 3) in [0, 1] with ``text`` in its top-left corner, white on a black outline."""
    h, w = image.shape[:2]
    scale = max(0.25, min(1.0, w / 640.0))
    thick = max(1, round(2 * scale))
    org = (max(2, w // 100), max(8, round(24 * scale)))
    out = np.ascontiguousarray(np.round(np.clip(image, 0.0, 1.0) * 255.0), dtype=np.uint8)  # putText draws on 8 bits
    cv2.putText(out, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), thick + 2, cv2.LINE_AA)
    cv2.putText(out, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), thick, cv2.LINE_AA)
    return out.astype(np.float32) / np.float32(255.0)


def _sheet(path: Path, rows: list[int], names: list[str], columns: list[tuple[str, np.ndarray]], *,
           cmap: str, vmin: float, vmax: float, label: str, title: str,
           marks: tuple[float, ...] = (), extend: str = "neither") -> Path:  # fmt: skip
    """A contact sheet of the layers ``rows`` of each ``(heading, (N, H, W) data)`` of ``columns``, one
    colour bar (``marks``: values drawn as lines across it). Two or more columns: one row per layer;
    one column: the layers in a grid of up to :data:`_GRID_COLUMNS`."""
    h, w = columns[0][1].shape[1:3]
    if len(columns) == 1:
        data = columns[0][1]
        cells = [(r // _GRID_COLUMNS, r % _GRID_COLUMNS, f"{i + 1}: {names[i]}", "", data[i])
                 for r, i in enumerate(rows)]
        n_cols = min(_GRID_COLUMNS, max(1, len(rows)))
    else:
        cells = [(r, c, heading if r == 0 else "", f"{i + 1}: {names[i]}" if c == 0 else "", data[i])
                 for r, i in enumerate(rows) for c, (heading, data) in enumerate(columns)]  # fmt: skip
        n_cols = len(columns)
    if not cells:  # no layer has a surface: one grey panel says so
        cells = [(0, 0, "no surface in view", "", np.full((h, w), np.nan))]
    n_rows = cells[-1][0] + 1
    fig = new_figure(figsize=(n_cols * _TILE_INCHES + 1.3, n_rows * (_TILE_INCHES * h / w + 0.35) + 0.5), dpi=_DPI)
    axes = fig.subplots(n_rows, n_cols, squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()  # cells of the grid left empty stay blank
    colours = colormaps[cmap].with_extremes(bad=_GREY)
    for r, c, heading, side, image in cells:
        ax = axes[r, c]
        ax.set_axis_on()
        ax.set_xticks([])
        ax.set_yticks([])
        im = ax.imshow(np.ma.masked_invalid(image), cmap=colours, vmin=vmin, vmax=vmax, interpolation="nearest")
        ax.set_title(heading, fontsize=9)
        ax.set_ylabel(side, fontsize=8)
    fig.suptitle(title, fontsize=10)
    bar = fig.colorbar(im, ax=axes, shrink=0.9 if n_rows < 4 else 0.6, extend=extend)
    bar.set_label(label, fontsize=8)
    bar.ax.tick_params(labelsize=7)
    for v in marks:
        bar.ax.axhline(v, color="black", linewidth=1.6)
    if marks:
        bar.set_ticks(sorted({*marks, 0.0, vmin, vmax}))
    return save_png(fig, path)


def _pair(before: np.ndarray, after: np.ndarray) -> list[tuple[str, np.ndarray]]:
    return [("before (physical)", before), ("after (optimised)", after)]


def _masked(values: np.ndarray, present: np.ndarray) -> np.ndarray:
    return np.where(present, values, np.nan).astype(np.float32)


def _geometry(result: SpecularResult) -> dict[str, np.ndarray]:
    """``fit``, ``arcmin_per_px`` and ``first_object`` of ``analysis.npz``, where the result knows them."""
    out = {}
    display = result.settings.get("display")
    if display is not None:
        out |= {"fit": np.array(display["fit"]), "arcmin_per_px": np.array(display["arcmin_per_px"])}
    oid = getattr(result.physical_left, "object_id", None)
    if oid is not None:
        out["first_object"] = np.asarray(oid[0], dtype=np.int32)
    return out


def _finite_max(*arrays: np.ndarray, percentile: float = 100.0) -> float:
    finite = np.concatenate([a[np.isfinite(a)].ravel() for a in arrays])
    return float(np.percentile(finite, percentile)) if finite.size else 0.0


def write_specular_outputs(result: SpecularResult, folder: str | os.PathLike[str], *,
                           anaglyph_method: str = "dubois") -> list[Path]:  # fmt: skip
    """Write every output of ``vergence specular`` for ``result`` into ``folder`` (see the module's text).

    Parameters
    ----------
    result : SpecularResult
        From :func:`vergence.specular.specular_stereo`.
    folder : str or os.PathLike
        An existing folder (the CLI passes the temporary folder of :func:`vergence.io.atomic_folder`).
    anaglyph_method : str, keyword-only
        A key of :data:`vergence.display.ANAGLYPH_METHODS` for the anaglyphs.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order of :data:`SPECULAR_OUTPUT_FILES`.

    Raises
    ------
    TypeError
        If ``result`` is not a SpecularResult or ``folder`` not a path.
    ValueError
        On an unknown ``anaglyph_method`` (the message lists the valid ones).
    FileNotFoundError, NotADirectoryError
        If ``folder`` does not exist or is a file.
    """
    if not isinstance(result, SpecularResult):
        raise TypeError(f"result must be a vergence.specular.SpecularResult; got {type(result).__name__}")
    if not isinstance(folder, str | os.PathLike):
        raise TypeError(f"folder must be a str or os.PathLike; got {type(folder).__name__}")
    if anaglyph_method not in ANAGLYPH_METHODS:
        raise ValueError(f"anaglyph_method must be one of {', '.join(ANAGLYPH_METHODS)}; got {anaglyph_method!r}")
    out = Path(folder)
    if not out.is_dir():
        raise (NotADirectoryError(f"folder must be a folder; {out} is a file") if out.exists()
               else FileNotFoundError(f"output folder does not exist: {out}"))  # fmt: skip
    n = result.y.shape[0]
    names = layer_labels(n)
    exposure = auto_exposure(np.asarray(result.physical_left.beauty))  # one exposure for every image
    written: list[Path] = []
    for stem in _SAVED_RENDERS:
        written += save_render(getattr(result, stem), out, stem=stem, exposure=exposure)
    written.append(_savez(out / "offsets.npz", y=np.asarray(result.y, dtype=np.float32), layer_names=np.array(names)))

    right = tonemap(result.right.beauty, exposure=exposure)
    lefts = {m: tonemap(getattr(result, f"{m}_left").beauty, exposure=exposure) for m in SPECULAR_METHODS}
    for m in SPECULAR_METHODS:  # the right eye is one render; each method's pair is written whole
        for eye, image in (("left", lefts[m]), ("right", right)):
            path = out / f"{m}_{eye}.png"
            write_image(path, image)
            written.append(path)
    glyphs = {m: anaglyph(lefts[m], right, method=anaglyph_method) for m in SPECULAR_METHODS}
    for m in SPECULAR_METHODS:
        path = out / f"{m}_anaglyph.png"
        write_image(path, glyphs[m])
        written.append(path)
    tiles = tile_views([_labelled(glyphs[m], m.replace("_", "-")) for m in SPECULAR_METHODS], columns=2)
    write_image(out / "anaglyphs.png", tiles)
    written.append(out / "anaglyphs.png")

    b, a, zone = result.before, result.after, result.zone
    # The matcher's settings, for an independent check: specular_stereo matches every state with the
    # cutoff of the physical pair (layer_disparity's default, as its settings record) in the default window.
    epsilon = result.settings["match_epsilon_m"]
    written.append(_savez(
        out / "analysis.npz",
        disparity_before=b.disparity, disparity_after=a.disparity,
        importance_before=b.importance, importance_after=a.importance,
        rivalry_before=b.rivalry, rivalry_after=a.rivalry,
        present=b.present, present_after=a.present, y=np.asarray(result.y, dtype=np.float32),
        layer_names=np.array(names), comfort_zone_arcmin=np.array([zone.min_arcmin, zone.max_arcmin]),
        match_epsilon_m=np.array(epsilon), match_window=np.array(MATCH_WINDOW),
        **_geometry(result),
    ))  # fmt: skip
    rows = [i for i in range(n) if b.present[i].any() or a.present[i].any()]
    dx_b, dx_a = b.disparity[..., 0], a.disparity[..., 0]
    reach = _finite_max(np.abs(dx_b[rows]), np.abs(dx_a[rows]), percentile=_SCALE_PERCENTILE)
    lim = max(reach, 1.25 * max(zone.max_arcmin, -zone.min_arcmin))  # the zone always shows on the bar
    written.append(_sheet(out / "analysis_disparity.png", rows, names, _pair(dx_b, dx_a), cmap="RdBu_r", vmin=-lim,
                          vmax=lim, marks=(zone.min_arcmin, zone.max_arcmin), extend="both",
                          title="S3 §3.2 per-layer disparity (grey: no match)",
                          label="horizontal disparity (arcmin; > 0 behind the screen); lines: comfort zone; "
                                f"scale ends at the {_SCALE_PERCENTILE:g}th percentile of |d|"))  # fmt: skip
    importance = _pair(_masked(b.importance, b.present), _masked(a.importance, a.present))
    written.append(_sheet(out / "analysis_importance.png", rows, names, importance, cmap="viridis", vmin=0.0,
                          vmax=1.0, label="importance", title="S3 §3.2 importance (grey: no surface)"))
    rivalry = _pair(_masked(b.rivalry, b.present), _masked(a.rivalry, a.present))
    top = _finite_max(rivalry[0][1][rows], rivalry[1][1][rows], percentile=_SCALE_PERCENTILE)
    written.append(_sheet(out / "analysis_rivalry.png", rows, names, rivalry, cmap="magma", vmin=0.0,
                          vmax=top if top > 0 else 1.0, extend="max", title="S3 §3.2 rivalry (grey: no surface)",
                          label=f"rivalry (dL*)^2 (scale ends at the {_SCALE_PERCENTILE:g}th percentile)"))
    written.append(_sheet(out / "offsets.png", rows, names, [("", _masked(result.y, b.present))], cmap="viridis",
                          vmin=0.0, vmax=1.0, label="offset y (1: physical, 0: mono)",
                          title="S3 §3.4 camera offsets (grey: no surface)"))  # fmt: skip
    report = out / "report.json"
    write_json(report, result.report())
    written.append(report)
    return written
