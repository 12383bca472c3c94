"""The demo's StereoSpace section (S2): a pan and a zoom through the stereo pairs of the dino ring.

The dino collection (Seitz et al. 2006: 48 photographs on a ring around a small plaster dinosaur,
Middlebury ``dino_par.txt`` cameras, no points: they are matched and triangulated on loading) is
turned into its camera graph and StereoSpace (S2 §3-4). From an automatically chosen start the
section walks a pan sequence and a zoom sequence (S2 §4.1, Figs. 17-18), each frame the stereo pair
at that state (two novel views by S2's method, rectified together, S2 §3.2) as a Dubois anaglyph, and
measures the novel views by leave-one-out on a spread subset of the views (S2 §3.1, §5).

The data lives outside the repository: ``$VERGENCE_SHARED_DATA/collections/dino``, by default
``<repository>/../shared/data/collections/dino`` (the rule of :func:`vergence.render.shared_hdri`).
Without it the section is one line saying so, and the demo goes on.

Decisions (S2 leaves them open)
-------------------------------
- The start state: for every three consecutive cameras ``p, q, r`` of a capture path of the graph,
  the state with the first eye at the middle of segment ``p-q`` and the second at the middle of
  ``q-r`` (view position near camera ``q``, interocular distance ``|c_r - c_p| / 2``); the one whose
  pair has the smallest disparity range on the demo's television is taken
  (:func:`~vergence.stereospace.pair_quality`: the range is what no horizontal shift can fix).
- The pan moves by :data:`PAN_STEP` times the start's interocular distance a frame. The zoom starts
  in the same region with both eyes a quarter of a segment from camera ``q`` (half the start's
  interocular distance) and grows it by :data:`ZOOM_STEP` times the start's interocular distance a
  frame.
- Leave-one-out: :data:`LOO_VIEWS` evenly spaced views, not all 48 (the per-view depths of all of
  them take minutes on two cores; ``benchmarks/stereospace_loo.py`` prints the full table, with the
  same figures for these views): the depth maps of a held-out view's sources are matched and checked
  without it, as :func:`~vergence.stereospace.leave_one_out` does.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.report.html import Figure, Grid, Section

__all__ = ["LOO_VIEWS", "PAN_STEP", "StereoSpaceDemo", "ZOOM_STEP", "dino_folder", "section_stereospace",
           "spread_views"]

DINO_CAMERAS = "dino_par.txt"
#: The display preset of the map's qualities: the preset nearest the demo's television (1.2 m at 3 m).
MAP_DISPLAY = "tv-55"
MAP_FILE = "stereospace_map.png"
# Frames of each sequence (the first is the start) and the moves between them, as fractions of the
# start's interocular distance: three pan moves of half of it cross a region's border (the first eye
# reaches camera q after about half a segment), three zoom moves go from half of it to twice it.
FRAMES = 4
PAN_STEP = 0.5
ZOOM_STEP = 0.5
# Views of the leave-one-out table (evenly spaced over the collection): four keep the section within
# about 30 s on two cores (each view costs four depth matchings and three novel views); sources per view.
LOO_VIEWS = 4
SOURCES = 4
# |view - photo| x ERROR_GAIN in the error images (a quarter of the range is white), as the benchmark.
ERROR_GAIN = 4.0
PAIR_LAYOUT = "anaglyph"  # Dubois red-cyan, as the other sections' anaglyphs

Progress = Callable[[str], None]
MapFigure = Callable[[Path, object, Sequence[object]], "Figure | Grid"]


@dataclass(frozen=True, slots=True)
class Frame:
    """One frame of a sequence: the state, what the move to it did (``"start"`` for the first frame,
    else a :data:`~vergence.stereospace.MOVE_EVENTS` value) and its interocular distance (metres)."""

    state: object  # vergence.stereospace.StereoState
    event: str
    interocular: float


@dataclass(frozen=True, slots=True)
class StereoSpaceDemo:
    """What the section measured: the start, the two sequences and the leave-one-out PSNR (dB),
    ``psnr_db[view][method]`` for ``method`` in ``"plane"``, ``"mls"``, ``"depth"``."""

    start: object  # vergence.stereospace.StereoState
    pan: tuple[Frame, ...]
    zoom: tuple[Frame, ...]
    psnr_db: dict[str, dict[str, float]]
    seconds: float


def dino_folder() -> Path:
    """``$VERGENCE_SHARED_DATA/collections/dino``, else ``<repository>/../shared/data/collections/dino``."""
    root = os.environ.get("VERGENCE_SHARED_DATA")
    base = Path(root) if root else Path(__file__).resolve().parents[3].parent / "shared" / "data"
    return base / "collections" / "dino"


def _walk(space, start, move, step: float, frames: int) -> tuple[Frame, ...]:
    """``frames`` frames from ``start``, each the ``move`` (pan or zoom) of the previous one by ``step``."""
    out = [Frame(start, "start", float(space.point(start.region[0], start.li, start.region[1], start.lj)[3]))]
    for _ in range(frames - 1):
        m = move(space, out[-1].state, step)
        s = m.state
        out.append(Frame(s, m.event, float(space.point(s.region[0], s.li, s.region[1], s.lj)[3])))
    return tuple(out)


def _caption(prepared, kind: str, k: int, frame: Frame) -> str:
    names = prepared.collection.names
    (i, j), cams = frame.state.region, prepared.segment_cameras
    seg = lambda s: f"{Path(names[cams[s, 0]]).stem}-{Path(names[cams[s, 1]]).stem}"  # noqa: E731
    return (f"{kind} frame {k} ({frame.event}): region ({i}, {j}), eyes on {seg(i)} at li = {frame.state.li:.3f} "
            f"and {seg(j)} at lj = {frame.state.lj:.3f}; interocular distance {100 * frame.interocular:.1f} cm.")


def _sequence_figures(out: Path, prepared, kind: str, frames: Sequence[Frame], progress: Progress) -> Grid:
    from vergence.io import write_image
    from vergence.stereospace import stereo_pair

    figures = []
    for k, frame in enumerate(frames):
        progress(f"StereoSpace: {kind} frame {k + 1} of {len(frames)}")
        pair = stereo_pair(prepared, frame.state, layout=PAIR_LAYOUT)
        name = f"stereospace_{kind}_{k}.png"
        write_image(out / name, pair.packed)
        figures.append(Figure(name, _caption(prepared, kind.capitalize(), k, frame)))
    return Grid(tuple(figures), columns=min(4, len(figures)))


def spread_views(names: Sequence[str], count: int) -> list[str]:
    """``count`` names evenly spaced over ``names`` (the first included): ``names[floor(k n / count)]``;
    all of them when ``count >= n``."""
    n = len(names)
    count = min(count, n)
    return [names[k * n // count] for k in range(count)]


def _colour(image: np.ndarray) -> np.ndarray:
    """An image as the novel views see their sources: three channels (a grey one repeated)."""
    return np.repeat(image[..., None], 3, axis=2) if image.ndim == 2 else image


def _leave_one_out(prepared, views: Sequence[str], progress: Progress) -> tuple[dict, dict]:
    """PSNR (dB) per view and method over the plane baseline's pixels (as
    :func:`~vergence.stereospace.leave_one_out`), and the views and photos by name."""
    from vergence.metrics import psnr
    from vergence.stereospace import novel_view, plane_view

    collection = prepared.collection
    # The sources as the views' cache holds them (float32, three channels, in [0, 1]): the prepared
    # collection decoded them already.
    images = {k: _colour(img) for k, img in enumerate(prepared.images)}
    scores, shown = {}, {}
    for step, name in enumerate(views):
        progress(f"StereoSpace: leave-one-out {step + 1} of {len(views)} ({name})")
        i = collection.names.index(name)
        target = collection.cameras[i]
        plane = plane_view(collection, target, exclude=[name], images=images)
        mls = novel_view(collection, target, method="mls", exclude=[name], k=SOURCES, images=images)
        # each source's depth matched and checked without the held-out camera, as leave_one_out does
        depth = novel_view(collection, target, method="depth", exclude=[name], k=SOURCES, images=images)
        photo = images[i]
        views_of = {"plane": plane, "mls": mls, "depth": depth}
        scores[name] = {m: psnr(v.image, photo, mask=plane.coverage) for m, v in views_of.items()}
        shown[name] = ({m: v.image for m, v in views_of.items()}, photo)
    return scores, shown


def map_figure(folder: Path, display: str = MAP_DISPLAY) -> MapFigure:
    """The ``map_figure`` of :func:`section_stereospace`: the space of the collection in ``folder``
    built by :func:`~vergence.stereospace.build_space` (graph, regions, leave-one-out, a quality per
    region vertex on the preset ``display``) and drawn by
    :func:`~vergence.report.stereospace_map.navigation_map` with the eyes of the first state (S2 Fig. 11)."""

    def draw(out: Path, prepared, states) -> Figure:
        from vergence.report.stereospace_map import navigation_map
        from vergence.stereospace import build_space

        built = build_space(Path(folder) / DINO_CAMERAS, images=folder, display=display,
                            collection=prepared.collection)  # loaded once, by the section
        navigation_map(built, Path(out) / MAP_FILE, state=states[0])
        best = max(built.vertex_qualities.values(), key=lambda v: v.quality)
        names = " + ".join(Path(built.collection.names[c]).stem for c in best.cameras)
        return Figure(MAP_FILE, f"The navigation map (S2 Fig. 11): the cameras and their capture path seen from "
                      f"above, the sparse points as the scene's impostor, and the StereoSpace drawn at its view "
                      f"positions, coloured by the best quality of a stereo pair there on the {display} preset "
                      f"(comfort x depth x rectification x leave-one-out, docs/stereospace.md); the eyes of the pan's "
                      f"first frame are marked. Best vertex: {names} ({best.quality:.2f}).")  # fmt: skip

    return draw


def _missing(folder: Path, number: int) -> Section:
    return Section(f"{number}. StereoSpace: browsing a photo collection in stereo (S2)",
                   f"Skipped: the dino collection was not found at {folder} (set VERGENCE_SHARED_DATA to the "
                   "folder holding collections/dino).")  # fmt: skip


def section_stereospace(
    out: Path,
    progress: Progress,
    number: int,
    *,
    display: object,
    folder: Path | None = None,
    frames: int = FRAMES,
    loo_views: int = LOO_VIEWS,
    map_figure: MapFigure | None = None,
) -> tuple[Section, StereoSpaceDemo | None]:
    """Load dino, walk a pan and a zoom from the start state, run the leave-one-out table; write the
    figures into ``out``. Without the data: a one-line section and None.

    Parameters
    ----------
    folder : Path, optional
        The dino folder (``dino_par.txt`` and the images); default :func:`dino_folder`.
    display : vergence.viewing.Display
        The display of the start rule (the demo's television, ``vergence.report.demo.DEMO_DISPLAY``).
    frames, loo_views : int
        Frames of each sequence (>= 2) and views of the leave-one-out table (>= 1).
    map_figure : callable, optional
        ``map_figure(out, prepared, states) -> Figure | Grid``: the navigation map of the space
        (S2 Fig. 11) with the sequences' states, written into ``out``; shown first when given.
    """
    from vergence.io import write_image
    from vergence.stereospace import PreparedCollection, load_collection, pan, start_state, state_near, zoom
    from vergence.synthesis import error_image

    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 2:
        raise ValueError(f"frames must be an integer >= 2; got {frames!r}")
    if isinstance(loo_views, bool) or not isinstance(loo_views, int) or loo_views < 1:
        raise ValueError(f"loo_views must be an integer >= 1; got {loo_views!r}")
    folder = dino_folder() if folder is None else Path(folder)
    if not (folder / DINO_CAMERAS).is_file():
        return _missing(folder, number), None
    started = time.perf_counter()
    progress("StereoSpace: loading dino (matching and triangulating its points)")
    collection = load_collection(folder / DINO_CAMERAS, images=folder)
    prepared = PreparedCollection(collection)
    space = prepared.space
    progress("StereoSpace: choosing the start")
    start, (p, q, r), range_arcmin = start_state(prepared, display)
    s0 = float(space.point(start.region[0], start.li, start.region[1], start.lj)[3])
    pan_frames = _walk(space, start, pan, PAN_STEP * s0, frames)
    zoom_frames = _walk(space, state_near(prepared, p, q, r, 0.25), zoom, ZOOM_STEP * s0, frames)
    figures: list[Figure | Grid] = []
    # S2 Fig. 11, the navigation map: drawn by the caller's map_figure (the lead wires the report's map
    # function in here); nothing is drawn in its place without one.
    if map_figure is not None:
        figures.append(map_figure(out, prepared, [f.state for f in (*pan_frames, *zoom_frames)]))
    figures.append(_sequence_figures(out, prepared, "pan", pan_frames, progress))
    figures.append(_sequence_figures(out, prepared, "zoom", zoom_frames, progress))

    views = spread_views(collection.names, loo_views)
    scores, shown = _leave_one_out(prepared, views, progress)
    rows: list[tuple[str, ...]] = [("held-out view", "plane (dB)", "S2 mls (dB)", "depth (dB)", "depth - plane (dB)")]
    for name in views:
        s = scores[name]
        rows.append((name, f"{s['plane']:.2f}", f"{s['mls']:.2f}", f"{s['depth']:.2f}", f"{s['depth'] - s['plane']:+.2f}"))
    mean = {m: float(np.mean([scores[n][m] for n in views])) for m in ("plane", "mls", "depth")}
    rows.append(("mean", f"{mean['plane']:.2f}", f"{mean['mls']:.2f}", f"{mean['depth']:.2f}",
                 f"{mean['depth'] - mean['plane']:+.2f}"))  # fmt: skip
    # The error images of the view with the median depth PSNR (a typical one, not the best).
    shown_view = sorted(views, key=lambda n: scores[n]["depth"])[len(views) // 2]
    images, photo = shown[shown_view]
    stem = f"stereospace_loo_{Path(shown_view).stem}"
    write_image(out / f"{stem}_photo.png", photo)
    labels = {"plane": "the plane baseline", "mls": "S2's MLS method", "depth": "ours (per-view depth + ULR)"}
    for m, img in images.items():
        write_image(out / f"{stem}_{m}.png", img)
        write_image(out / f"{stem}_{m}_error.png", error_image(img, photo, gain=ERROR_GAIN))
    figures.append(Grid((Figure(f"{stem}_photo.png", f"{shown_view}: the photo (held out)."),
                         *(Figure(f"{stem}_{m}.png", f"{shown_view} made without it by {labels[m]}: "
                                  f"{scores[shown_view][m]:.2f} dB.") for m in images)), columns=4))  # fmt: skip
    figures.append(Grid(tuple(Figure(f"{stem}_{m}_error.png", f"|{m} view - photo| x {ERROR_GAIN:g}, mean over channels.")
                              for m in images), columns=3))  # fmt: skip
    seconds = time.perf_counter() - started
    result = StereoSpaceDemo(start, pan_frames, zoom_frames, scores, seconds)
    text = _text(prepared, result, (p, q, r), range_arcmin, views, shown_view)
    return Section(f"{number}. StereoSpace: browsing a photo collection in stereo (S2)", text, tuple(figures),
                   tuple(rows)), result  # fmt: skip


def _events(frames: Sequence[Frame]) -> str:
    jumped = [str(k) for k, f in enumerate(frames) if f.event == "jumped"]
    stopped = [str(k) for k, f in enumerate(frames) if f.event == "stopped"]
    parts = [f"frame{'s' if len(jumped) > 1 else ''} {', '.join(jumped)} jumped to another region" if jumped
             else "no frame jumped"]  # fmt: skip
    if stopped:
        parts.append(f"frame{'s' if len(stopped) > 1 else ''} {', '.join(stopped)} stopped at a border")
    return "; ".join(parts)


def _text(prepared, result: StereoSpaceDemo, pqr: tuple[int, int, int], range_arcmin: float,
          views: Sequence[str], shown_view: str) -> str:
    col = prepared.collection
    stem = lambda k: Path(col.names[k]).stem  # noqa: E731
    p, q, r = pqr
    s0 = result.pan[0].interocular
    n_views = len(col)
    return (
        f"The dino ring (Seitz et al. 2006): {n_views} photographs around a small plaster dinosaur, "
        f"{col.point_count} points matched and triangulated with the known cameras. Its camera graph has "
        f"{len(prepared.space.segments)} segments, whose pairs make {len(prepared.space.regions)} regions of "
        "the StereoSpace (S2 §4: a stereo point is the view position and the interocular distance). "
        f"Start: among the states with the eyes at the middles of two consecutive segments of the capture path, "
        f"the one whose pair has the smallest disparity range on the demo's television (`pair_quality`): "
        f"between {stem(p)}, {stem(q)} and {stem(r)}, {range_arcmin:.0f} arcmin, interocular distance "
        f"{100 * s0:.1f} cm. The pan (S2 §4.1, Fig. 17) moves the view position by {PAN_STEP:g} x that a frame at "
        f"constant interocular distance: {_events(result.pan)}. The zoom (Fig. 18) starts in the same region with "
        f"the eyes a quarter of a segment from {stem(q)} and grows the interocular distance by {ZOOM_STEP:g} x "
        f"{100 * s0:.1f} cm a frame along its gradient: {_events(result.zoom)}. Each frame is the stereo pair "
        "at its state, two novel views by S2's method (MLS-warped neighbours, S2 §3.1) rectified together "
        "(S2 §3.2), as a red-cyan Dubois anaglyph. "
        f"The table: leave-one-out PSNR over the pixels the plane baseline covers, on {len(views)} of the "
        f"{n_views} views, evenly spaced (all {n_views} take minutes: `benchmarks/stereospace_loo.py` prints the "
        "full table); each view made without its photo by the one-plane baseline, S2's MLS method and ours "
        "(per-view depth matched in the collection and checked against the other views, + ULR), its "
        f"sources' depth maps made without it. Under it {shown_view}, the view with the median depth PSNR: the photo, the three "
        "views and their errors."
    )
