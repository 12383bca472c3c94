"""Figures and files of a render: tone-mapped beauty, depth with a colour bar, layer contact sheet.

Moved here from ``vergence.render.preview`` so that ``import vergence.render`` does not import
matplotlib. Tone mapping itself (:func:`vergence.render.tonemap`) stays in the renderer.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from vergence._validate import check_positive
from vergence.render.results import RenderResult, layer_names
from vergence.render.tonemap import auto_exposure, tonemap
from vergence.viewing.geometry import MAX_SCENE_DEPTH

__all__ = ["contact_sheet", "depth_preview", "save_render"]


def _check_result(result: object) -> RenderResult:
    if not isinstance(result, RenderResult):
        raise TypeError(f"result must be a vergence.render.RenderResult; got {type(result).__name__}")
    return result

def _figure_rgb(fig: Figure) -> np.ndarray:
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba(), dtype=np.float32)[:, :, :3] / 255.0


def depth_preview(depth: np.ndarray, *, title: str = "depth (m)") -> np.ndarray:
    """Depth map ``(H, W)`` drawn with a colour bar (matplotlib, Agg); NaN or inf (no hit) in grey.

    Finite depths must lie within ``MAX_SCENE_DEPTH`` (1e20 m) of zero
    (:data:`vergence.viewing.MAX_SCENE_DEPTH`); ``title`` is a str.
    """
    try:  # NaN and inf are "no hit", drawn grey
        d = np.asarray(depth, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"depth must be a real-valued array; got {type(depth).__name__}") from None
    if not isinstance(title, str):
        raise TypeError(f"title must be a str; got {type(title).__name__}")
    if d.ndim != 2 or d.size == 0:
        raise ValueError(f"depth must have shape (H, W) and not be empty; got {d.shape}")
    with np.errstate(invalid="ignore"):
        peak = float(np.abs(d[np.isfinite(d)]).max(initial=0.0))
    if peak > MAX_SCENE_DEPTH:  # matplotlib's colour-bar ticks overflowed near 1e308
        raise ValueError(f"depth must lie within {MAX_SCENE_DEPTH:g} m (MAX_SCENE_DEPTH); got |depth| up to {peak:g}")
    h, w = d.shape
    scale = max(1.0, 480.0 / max(h, w))
    fig = Figure(figsize=(w * scale / 100.0 + 1.4, h * scale / 100.0 + 0.6), dpi=100)
    ax = fig.add_axes((0.02, 0.04, 0.76, 0.88))
    cmap = colormaps["viridis"].with_extremes(bad=(0.5, 0.5, 0.5))
    finite = d[np.isfinite(d)]
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    im = ax.imshow(np.ma.masked_invalid(d), cmap=cmap, vmin=vmin, vmax=vmax if vmax > vmin else vmin + 1.0)
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)
    cax = fig.add_axes((0.81, 0.1, 0.035, 0.76))
    fig.colorbar(im, cax=cax).ax.tick_params(labelsize=8)
    return _figure_rgb(fig)


def contact_sheet(result: RenderResult, *, exposure: float | None = None) -> np.ndarray:
    """All layers and the beauty in a grid, each tile labelled with its node, path and gain.

    The beauty uses ``exposure`` (automatic when None); each layer is shown at the automatic
    exposure of its non-black pixels and labelled with the gain over the beauty's (x1 = as bright
    as in the image); a layer without light is labelled "empty".
    """
    _check_result(result)
    k = auto_exposure(result.beauty) if exposure is None else check_positive("exposure", exposure)
    names = layer_names(result.settings.max_depth)
    tiles = [("beauty", tonemap(result.beauty, exposure=k))]
    for i, name in enumerate(names):
        layer = result.radiance[i]
        lit = layer[(layer > 0).any(axis=-1)]
        if lit.size == 0:
            tiles.append((f"{i + 1}: {name}  (empty)", np.zeros_like(layer)))
            continue
        k_i = auto_exposure(lit[None])
        tiles.append((f"{i + 1}: {name}  (x{k_i / k:.3g})", tonemap(layer, exposure=k_i)))
    cols = min(4, len(tiles))
    rows = -(-len(tiles) // cols)
    h, w = result.beauty.shape[:2]
    tile_w = 2.6
    fig = Figure(figsize=(cols * tile_w, rows * (tile_w * h / w + 0.3)), dpi=100)
    for j, (label, img) in enumerate(tiles):
        ax = fig.add_subplot(rows, cols, j + 1)
        ax.imshow(img, interpolation="nearest")
        ax.set_title(label, fontsize=8)
        ax.set_axis_off()
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=0.95, wspace=0.04, hspace=0.18)
    return _figure_rgb(fig)


def save_render(result: RenderResult, folder: str | Path, *, stem: str = "render", exposure: float | None = None) -> list[Path]:
    """Write ``stem.npz``, ``stem_camera.json`` and the PNG previews of ``result`` into ``folder``.

    ``stem.npz`` holds ``radiance``, ``position``, ``normal``, ``depth``, ``beauty`` (float32),
    ``layer_names`` and ``settings`` (a JSON string). ``stem_camera.json`` is ``camera.to_dict()``
    (a pinhole one loads with :meth:`vergence.camera.Camera.from_dict`). ``stem_depth.pfm`` is the
    depth alone (metres, NaN where nothing was hit), the depth ``vergence synthesize`` takes. Previews:
    ``stem_beauty.png`` (tone-mapped with ``exposure``, automatic when None: give both eyes of a
    pair the same value), ``stem_depth.png``, ``stem_layers.png``. Every file is written atomically.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    from vergence.io import atomic_write, write_image, write_json, write_pfm

    _check_result(result)
    if not isinstance(folder, str | os.PathLike):
        raise TypeError(f"folder must be a str or os.PathLike; got {type(folder).__name__}")
    out = Path(folder)
    if not out.is_dir():
        raise (NotADirectoryError(f"folder must be a folder; {out} is a file") if out.exists()
               else FileNotFoundError(f"output folder does not exist: {out}"))  # fmt: skip
    if not isinstance(stem, str):
        raise TypeError(f"stem must be a str; got {type(stem).__name__}")
    if not stem or Path(stem).name != stem or stem in (".", ".."):
        raise ValueError(f"stem must be a plain file-name stem (no folder); got {stem!r}")
    k = auto_exposure(result.beauty) if exposure is None else check_positive("exposure", exposure)
    written = []
    npz = out / f"{stem}.npz"
    with atomic_write(npz) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(
                fh, radiance=result.radiance, position=result.position, normal=result.normal, depth=result.depth,
                beauty=result.beauty, layer_names=np.array(layer_names(result.settings.max_depth)),
                settings=np.array(json.dumps(result.settings.to_dict())),
            )  # fmt: skip
    written.append(npz)
    camera_json = out / f"{stem}_camera.json"
    write_json(camera_json, result.camera.to_dict())
    written.append(camera_json)
    depth_pfm = out / f"{stem}_depth.pfm"  # metric z, NaN = no hit: what `vergence synthesize` reads as depth
    write_pfm(depth_pfm, result.depth)
    written.append(depth_pfm)
    for name, img in (("beauty", tonemap(result.beauty, exposure=k)), ("depth", depth_preview(result.depth)),
                      ("layers", contact_sheet(result, exposure=k))):  # fmt: skip
        path = out / f"{stem}_{name}.png"
        write_image(path, img)
        written.append(path)
    return written
