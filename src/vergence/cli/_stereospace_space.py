"""``vergence stereospace build`` and ``vergence stereospace pair``: a built StereoSpace and its pairs (S2 §4).

``build`` runs :func:`vergence.stereospace.build_space` on a camera file and writes the space folder
(``space.json``, ``points.npz``, ``map.png``: the navigation map of S2 §4.3.1). ``pair`` loads a
space folder and writes the stereo pair at a state, given directly (``--at``) or reached from one by
S2's navigation (``--from`` with ``--pan`` and/or ``--zoom``, S2 §4.1).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import console, err_console, options_named
from vergence.cli._spinner import ProgressLines
from vergence.cli._stereospace_group import camera_index, stereospace_app

__all__ = ["parse_state"]

_STATE_HELP = "i,li,j,lj: segments i <= j and the parameters li, lj in [0, 1] (li <= lj when i == j)."


def parse_state(text: str, option: str):
    """``"i,li,j,lj"`` as a :class:`~vergence.stereospace.StereoState`; a ValueError naming ``option``."""
    from vergence.stereospace import StereoState

    parts = [p.strip() for p in str(text).split(",")]
    try:
        if len(parts) != 4:
            raise ValueError
        i, j = int(parts[0]), int(parts[2])
        li, lj = float(parts[1]), float(parts[3])
    except ValueError:
        raise ValueError(f"{option} must be i,li,j,lj (two segment indices and two parameters); got {text!r}") from None
    for name, v in (("li", li), ("lj", lj)):
        if not 0.0 <= v <= 1.0:  # also refuses NaN
            raise ValueError(f"{option}: {name} must lie in [0, 1]; got {v:g}")
    return StereoState((i, j), li, lj)


@stereospace_app.command("build")
def build(
    cameras: Path = typer.Argument(..., help="Camera file (Bundler bundle.out, COLMAP, Middlebury _par, JSON)."),
    images: Path = typer.Option(..., "--images", help="Folder of the images, named as in the camera file."),
    out: Path = typer.Option(..., "--out", help="Space folder to write (space.json, points.npz, map.png)."),
    display: str = typer.Option("desktop-24", "--display", help="Display preset the pair quality is judged for."),
    force: bool = typer.Option(False, "--force", help="Write into an --out folder that is not empty (its files of "
                               "the same names are replaced)."),
) -> None:
    """Build the StereoSpace of CAMERAS: points, camera graph, regions, a quality per region vertex, map.

    The slow part is the leave-one-out view of every camera (S2's method), one progress line each on
    stderr. The folder is written all at once (nothing appears if the build fails or is interrupted).
    """
    from vergence.cli._app import preset_display

    preset_display(display)  # an unknown preset is refused before the slow work
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise ValueError(f"--out {out} exists and is not empty; give --force to write into it")
    if images.is_dir() and out.resolve() == images.resolve():
        raise ValueError(f"--out {out} is the images folder; give another folder")

    from vergence.io import atomic_folder
    from vergence.report.stereospace_map import navigation_map
    from vergence.stereospace import build_space, write_space

    with options_named(cameras_path="CAMERAS", images="--images"), ProgressLines() as progress:
        built = build_space(cameras, images=images, display=display, progress=progress)
    col = built.collection
    for note in col.warnings:
        err_console.print(f"note: {note}", highlight=False, soft_wrap=True, markup=False)
    raise_if_interrupted()
    with atomic_folder(out) as tmp:
        write_space(built, tmp)
        navigation_map(built, tmp / "map.png")
        raise_if_interrupted()
    _summary(built, out)


def _summary(built, out: Path) -> None:
    import numpy as np

    col = built.collection
    say = lambda text: console.print(text, highlight=False, markup=False)  # noqa: E731
    say(f"collection: {len(col)} cameras ({col.left_out} left out without an image, {col.unregistered} "
        f"unregistered), {col.point_count} points ({col.points_source}), median reprojection error "
        f"{col.median_reprojection_error_px:.3f} px")  # fmt: skip
    say(f"camera graph: {len(built.graph.edges)} edges; {len(built.paths)} capture path(s): "
        + "; ".join(f"a ring of {len(p) - 1} cameras" if len(p) > 2 and p[0] == p[-1] else f"{len(p)} cameras"
                    for p in built.paths))
    say(f"stereospace: {len(built.space.segments)} segments, {len(built.space.regions)} regions")
    psnr = built.psnr_db[np.isfinite(built.psnr_db)]
    if psnr.size:
        say(f"leave-one-out PSNR (mls): mean {psnr.mean():.2f} dB, range {psnr.min():.2f} to {psnr.max():.2f} dB "
            f"over {psnr.size} of {len(col)} cameras")  # fmt: skip
    qs = list(built.vertex_qualities.values())
    stereo = [q for q in qs if q.note != "mono"]
    values = np.array([q.quality for q in stereo]) if stereo else np.zeros(1)
    best = max(stereo, key=lambda q: q.quality) if stereo else None
    say(f"vertex quality on {built.display_name}: {len(stereo)} camera pairs (+{len(qs) - len(stereo)} mono, "
        f"quality 0): median {np.median(values):.3f}, max {values.max():.3f}"
        + (f" ({col.names[best.cameras[0]]} + {col.names[best.cameras[1]]})" if best else "")
        + f"; {sum(q.fits_with_shift for q in stereo)} fit the comfort zone with a shift, "
        f"{sum(q.note.startswith('not rectifiable') for q in stereo)} cannot be rectified")
    say(f"built in {built.build_seconds:.1f} s; wrote {out}/space.json, points.npz, map.png")


def _size(text: str | None) -> tuple[int, int] | None:
    """``"WxH"`` as ``(W, H)``; a ValueError naming ``--size``."""
    if text is None:
        return None
    parts = str(text).lower().split("x")
    try:
        if len(parts) != 2:
            raise ValueError
        w, h = int(parts[0]), int(parts[1])
    except ValueError:
        raise ValueError(f"--size must be WxH (two whole numbers of pixels, e.g. 800x600); got {text!r}") from None
    return w, h


@stereospace_app.command("pair")
def pair(
    space_dir: Path = typer.Argument(..., help="Space folder written by `vergence stereospace build`."),
    at: str | None = typer.Option(None, "--at", help="The state " + _STATE_HELP),
    start: str | None = typer.Option(None, "--from", help="Start state for --pan/--zoom: " + _STATE_HELP),
    best: bool = typer.Option(False, "--best", help="The best state of the space: the camera pair of the region "
                              "vertex of highest quality (`stereospace info` lists them)."),
    near: str | None = typer.Option(None, "--near", help="The state whose stereo camera stands at this camera "
                                    "(its image name, with or without extension), the eyes half-way to two "
                                    "of its neighbours."),
    pan_by: float | None = typer.Option(None, "--pan", help="With --from (or --best, --near): move the view "
                                        "position by V (collection units) at constant interocular distance "
                                        "(S2 §4.1)."),
    zoom_by: float | None = typer.Option(None, "--zoom", help="With --from (or --best, --near): change the "
                                         "interocular distance by V (collection units; applied after --pan)."),
    out: Path = typer.Option(..., "--out", help="Folder for left.png, right.png, FORMAT.png, pair.json, map.png."),
    force: bool = typer.Option(False, "--force", help="Write into an --out folder that is not empty (its files of "
                               "the same names are replaced)."),
    layout: str = typer.Option("anaglyph", "--format", help="Display format of vergence.display (anaglyph, sbs, ...)."),
    method: str = typer.Option("mls", "--method", help="Novel-view method (mls: S2's warps)."),
    size: str | None = typer.Option(None, "--size", help="WxH of the views in pixels (default the collection's "
                                    "image size)."),
    framing: str = typer.Option("fit", "--framing", help="fit: both whole rectified views fit the frame (default); "
                                "crop: the collection's scale, cut at the frame's edges."),
    shift: bool = typer.Option(True, "--shift/--no-shift", help="Shift the views horizontally so that the pair's "
                               "disparity range is centred in the display's comfort zone (default on)."),
    draw_map: bool = typer.Option(True, "--map/--no-map", help="Also write map.png with the eyes drawn."),
) -> None:
    """Write the stereo pair at a state of a built space: two novel views rectified together (S2 §3.2).

    Give the state with --at, --best or --near CAMERA, or reach it from --from by --pan and/or
    --zoom (S2's navigation: at a region border it jumps to the closest point of another region in
    the 40-degree cone, or stops). The views are fitted to the frame and, unless --no-shift,
    shifted so that the disparities are centred in the display's comfort zone (pair.json says by
    how much, and a range wider than the zone is warned about).
    """
    from vergence.display import LAYOUTS
    from vergence.stereospace import FRAMINGS, PAIR_METHODS

    given = [name for name, v in (("--at", at), ("--from", start), ("--best", best or None), ("--near", near))
             if v is not None]  # fmt: skip
    if len(given) != 1:
        raise ValueError("give exactly one of --at i,li,j,lj, --from i,li,j,lj (with --pan/--zoom), --best or "
                         f"--near CAMERA; got {', '.join(given) if given else 'none'}")  # fmt: skip
    if at is not None and (pan_by is not None or zoom_by is not None):
        raise ValueError("--pan and --zoom go with --from, --best or --near, not --at")
    if start is not None and pan_by is None and zoom_by is None:
        raise ValueError("--from needs --pan V and/or --zoom V")
    for name, v in (("--pan", pan_by), ("--zoom", zoom_by)):
        if v is not None and not math.isfinite(v):
            raise ValueError(f"{name} must be a finite number; got {v}")
    if layout not in LAYOUTS:
        raise ValueError(f"--format must be one of {', '.join(LAYOUTS)}; got {layout!r}")
    if method not in PAIR_METHODS:
        raise ValueError(f"--method must be one of {', '.join(PAIR_METHODS)}; got {method!r}")
    if framing not in FRAMINGS:
        raise ValueError(f"--framing must be one of {', '.join(FRAMINGS)}; got {framing!r}")
    views_size = _size(size)
    option = given[0]
    state = parse_state(at if at is not None else start, option) if option in ("--at", "--from") else None
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise ValueError(f"--out {out} exists and is not empty; give --force to write into it")
    if space_dir.is_dir() and out.resolve() == space_dir.resolve():
        raise ValueError(f"--out {out} is the space folder; give another folder")

    from vergence.stereospace import best_states, load_space, state_at_camera

    t0 = time.perf_counter()
    built = load_space(space_dir)
    names = built.collection.names
    chosen: dict = {"by": option.lstrip("-")}
    if near is not None:
        camera = camera_index(names, near, "--near")  # refused before the images are decoded
    prepared = None
    if best:
        ranked = best_states(built, count=1)
        if not ranked:
            raise ValueError(f"--best: the space {space_dir} has no stereo pair at a region vertex")
        state, vertex = ranked[0].state, ranked[0].vertex
        chosen.update(cameras=[names[c] for c in vertex.cameras], quality=vertex.quality)
    elif near is not None:
        prepared = built.prepared()
        state = state_at_camera(prepared, camera, built.display)
        chosen.update(camera=names[camera])
    with options_named(region=f"{option} region", li=f"{option} li", lj=f"{option} lj"):
        built.space.check_state(state)
    move = _navigate(built, state, pan_by, zoom_by)
    final = move[-1]["state"] if move else state
    prepared = built.prepared() if prepared is None else prepared
    t1 = time.perf_counter()
    with options_named(size="--size"):
        result = _stereo_pair(prepared, final, layout, method, size=views_size, framing=framing,
                              display=built.display, zone=built.zone, shift=shift)  # fmt: skip
    t2 = time.perf_counter()
    record = _pair_record(built, final, result, method, layout, move, space_dir)
    record.update(chosen=chosen, framing=framing, size=[result.rectified[0].width, result.rectified[0].height],
                  shift=None if result.shift is None else result.shift.to_dict())  # fmt: skip
    record["seconds"] = {"load_and_prepare": t1 - t0, "pair": t2 - t1}
    raise_if_interrupted()
    _write_pair(out, result, layout, record, built if draw_map else None, final)
    (i, j), p = final.region, result.point
    console.print(f"pair at region {(i, j)}, li={final.li:.4f}, lj={final.lj:.4f}: view position "
                  f"({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}), interocular {p[3]:.4g}"
                  + (f" [{', '.join(m['event'] for m in move)}]" if move else "")
                  + f"; {t2 - t1:.2f} s for the pair ({t1 - t0:.2f} s to load and prepare); wrote {out}",
                  highlight=False, markup=False)  # fmt: skip
    if result.shift is not None:
        s = result.shift
        if s.before_arcmin is not None and not s.applied:
            console.print(f"disparities {s.before_arcmin[0]:+.0f} to {s.before_arcmin[1]:+.0f} arcmin on "
                          f"{built.display_name}, not shifted (zone {s.zone_arcmin[0]:+.0f} to "
                          f"{s.zone_arcmin[1]:+.0f})", highlight=False, markup=False)  # fmt: skip
        elif s.before_arcmin is not None:
            console.print(f"convergence shift {s.shift_px:+.1f} px ({s.shift_arcmin:+.1f} arcmin): disparities "
                          f"{s.before_arcmin[0]:+.0f} to {s.before_arcmin[1]:+.0f} arcmin -> {s.after_arcmin[0]:+.0f} "
                          f"to {s.after_arcmin[1]:+.0f} (zone {s.zone_arcmin[0]:+.0f} to {s.zone_arcmin[1]:+.0f}, "
                          f"{built.display_name})", highlight=False, markup=False)  # fmt: skip
        if s.note:
            err_console.print(f"warning: {s.note}", highlight=False, soft_wrap=True, markup=False)


def _navigate(built, state, pan_by, zoom_by) -> list[dict]:
    from vergence.stereospace import pan, zoom

    steps = []
    for name, fn, v in (("pan", pan, pan_by), ("zoom", zoom, zoom_by)):
        if v is None:
            continue
        moved = fn(built.space, state, v)
        steps.append({"action": name, "by": v, "event": moved.event, "from": state, "state": moved.state})
        state = moved.state
    return steps


def _stereo_pair(prepared, state, layout, method, **options):
    from vergence.stereospace import stereo_pair

    return stereo_pair(prepared, state, layout=layout, method=method, **options)


def _state_dict(state) -> dict:
    return {"region": list(state.region), "li": state.li, "lj": state.lj}


def _pair_record(built, state, result, method, layout, move, space_dir) -> dict:
    from vergence.stereospace import DISPARITY_TRIM, pair_quality

    i, j = state.region
    if result.rectification is None:
        quality, note = None, "coincident eyes (a mono view): no stereo quality"
    else:
        quality = pair_quality(built.collection, result.cameras, built.display, zone=built.zone, trim=DISPARITY_TRIM)
        note = ""
    vertices = {f"{li},{lj}": built.vertex((i, j), li, lj).to_dict()
                for li in (0, 1) for lj in (0, 1) if i != j or li <= lj}  # fmt: skip
    return {
        "space": str(space_dir.resolve()),
        **_state_dict(state),
        "stereo_point": result.point.tolist(),
        "interocular": float(result.point[3]),
        "cameras": {"first": result.cameras[0].to_dict(), "second": result.cameras[1].to_dict()},
        "rectified": {"left": result.rectified[0].to_dict(), "right": result.rectified[1].to_dict()},
        "swapped": result.swapped,
        "method": method,
        "format": layout,
        "display": built.display_name,
        "quality": quality,
        "quality_note": note,
        "vertex_quality": vertices,
        "map_quality": built.quality_at(state),
        "move": [{"action": m["action"], "by": m["by"], "event": m["event"], "from": _state_dict(m["from"]),
                  "to": _state_dict(m["state"])} for m in move],  # fmt: skip
    }


def _write_pair(out: Path, result, layout: str, record: dict, built, state) -> None:
    import numpy as np

    from vergence.io import atomic_folder, write_image, write_json
    from vergence.report.stereospace_map import navigation_map

    with atomic_folder(out) as tmp:
        write_image(tmp / "left.png", np.clip(result.left, 0.0, 1.0))
        write_image(tmp / "right.png", np.clip(result.right, 0.0, 1.0))
        write_image(tmp / f"{layout}.png", np.clip(result.packed, 0.0, 1.0))
        write_json(tmp / "pair.json", record)
        if built is not None:
            navigation_map(built, tmp / "map.png", state=state)
        raise_if_interrupted()


# `stereospace info`'s table of best states fits 80 columns: camera names shortened to this many
# characters, the pair column this wide.
_INFO_NAME = 12
_INFO_PAIR = 2 * _INFO_NAME + 3


def _short(name: str, width: int) -> str:
    stem = Path(name).stem
    return stem if len(stem) <= width else stem[: width - 1] + "~"


def _state_text(state) -> str:
    (i, j), li, lj = state.region, state.li, state.lj
    return f"{i},{li:g},{j},{lj:g}"


@stereospace_app.command("info")
def info(
    space_dir: Path = typer.Argument(..., help="Space folder written by `vergence stereospace build`."),
    top: int = typer.Option(10, "--top", help="Best states listed (by the quality of their region vertex)."),
    as_json: bool = typer.Option(False, "--json", help="Print the description as JSON."),
) -> None:
    """Describe a built space: regions, the best states by quality and the camera names.

    Each best state is a region vertex: its eyes are two real cameras. Give its state to
    `pair --at`, or take the first with `pair --best`; `pair --near NAME` takes a camera name.
    """
    import numpy as np

    from vergence.cli._app import print_json
    from vergence.stereospace import best_states, load_space

    if isinstance(top, bool) or not 1 <= top <= 1000:
        raise ValueError(f"--top must be a whole number in [1, 1000]; got {top}")
    built = load_space(space_dir)
    col, names = built.collection, built.collection.names
    ranked = best_states(built, count=top)
    qs = [q for q in built.vertex_qualities.values() if q.cameras[0] != q.cameras[1]]
    record = {
        "space": str(space_dir.resolve()),
        "cameras_path": str(built.cameras_path),
        "cameras": [{"name": n, "loo_psnr_db": None if not np.isfinite(p) else float(p)}
                    for n, p in zip(names, built.psnr_db)],  # fmt: skip
        "points": col.point_count,
        "edges": len(built.graph.edges),
        "capture_paths": [[names[k] for k in path] for path in built.paths],
        "segments": len(built.space.segments),
        "regions": len(built.space.regions),
        "display": built.display_name,
        "zone_arcmin": [built.zone.min_arcmin, built.zone.max_arcmin],
        "camera_pairs": len(qs),
        "fit_with_shift": sum(q.fits_with_shift for q in qs),
        "best": [{"rank": k + 1, "at": _state_text(r.state), "region": list(r.state.region), "li": r.state.li,
                  "lj": r.state.lj, "cameras": [names[c] for c in r.vertex.cameras], **{
                      f: getattr(r.vertex, f) for f in ("quality", "comfort", "depth", "rectification",
                                                        "interpolation", "range_arcmin", "fits_with_shift")}}
                 for k, r in enumerate(ranked)],  # fmt: skip
    }
    if as_json:
        print_json(record)
        return
    say = lambda text="": console.print(text, highlight=False, markup=False)  # noqa: E731
    rings = "; ".join(f"a ring of {len(p) - 1}" if len(p) > 2 and p[0] == p[-1] else f"a path of {len(p)}"
                      for p in built.paths)  # fmt: skip
    say(f"{space_dir}: {len(col)} cameras, {col.point_count} points, {len(built.graph.edges)} graph edges")
    say(f"capture paths: {rings or 'none'}; {len(built.space.segments)} segments, {len(built.space.regions)} regions")
    say(f"quality on {built.display_name} (zone {built.zone.min_arcmin:+.0f} to {built.zone.max_arcmin:+.0f} arcmin): "
        f"{len(qs)} camera pairs,")
    say(f"  {record['fit_with_shift']} of them fit the zone with a shift")
    say()
    say("best states (pair --best: the first; pair --at STATE); range of the disparities")
    say(f"{'#':>3}  {'state':<14} {'cameras':<{_INFO_PAIR}} {'quality':>7} {'range':>7} {'fits':>4}")
    for row in record["best"]:
        pair_names = " + ".join(_short(n, _INFO_NAME) for n in row["cameras"])
        span = "-" if row["range_arcmin"] is None else f"{row['range_arcmin']:.0f}'"
        say(f"{row['rank']:>3}  {row['at']:<14} {pair_names:<{_INFO_PAIR}} {row['quality']:>7.3f} "
            f"{span:>7} {'yes' if row['fits_with_shift'] else 'no':>4}")
    say()
    say("cameras (pair --near NAME):")
    line = " "
    for n in names:
        word = Path(n).stem
        if len(line) + len(word) + 1 > 79:
            say(line.rstrip())
            line = " "
        line += " " + word
    if line.strip():
        say(line.rstrip())
