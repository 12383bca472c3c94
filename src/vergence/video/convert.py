"""Retarget a stereo or 2D + depth clip into a display's parallax budget, shot by shot, as video.

:func:`convert_clip` is ``vergence convert``. The clip is read in passes, frame by frame (never whole):

1. **Shots**: the cuts (:func:`vergence.video.detect_cuts`) and, for 2D + depth, each frame's
   nearness range. A clip that cannot be decoded past frame ``k`` (truncated, damaged) is converted up
   to ``k``; the result says where it stopped (:attr:`Conversion.stopped`).
2. **Disparity** (stereo only): each frame matched (the library's matcher, as ``vergence analyze``),
   stabilised (below), kept in the work folder for pass 3. Each shot is matched in its own search range,
   found from its features unless given, and widened where the matches pile up at an estimated bound
   (:mod:`vergence.video.search`); the shot's range is the 1st and 99th percentiles of all its pixels,
   pooled (as ``vergence analyze`` reports them), so stray matches do not widen it.
3. **Render**: each frame's disparity mapped into the budget and the pair synthesised
   (:func:`vergence.synthesis.synthesize_stereo`, as ``vergence synthesize``), packed into the
   layout (:func:`vergence.display.pack`) and encoded; each shot is a segment of the work folder
   (:mod:`vergence.video._segments`), joined with the input's audio at the end.

**Mapping.** One linear psi per shot maps the shot's range (nearness ``q`` of 2D + depth, or the
matched disparity ``D = x_left - x_right`` of a stereo clip, as a ``"disparity"`` depth map) onto
``+-budget_arcmin`` of vergence on the display (:func:`vergence.synthesis.plan_parallax`, budget mode:
the image fills the display's width). Frame ``t`` uses the temporal operator of Lang et al. (2010),
``psi_t = sum_k w_k(t) psi_k`` (:func:`vergence.viewing.temporal_mapping`): with ``transition = 0``
(default) the mapping is reset at each cut and constant within a shot, so a shot's depth does not
breathe; ``transition = T`` frames ramps from one shot's psi to the next over ``T`` frames around the
cut (frames in the ramp may then pass the budget by the difference of the two psi).

**Stability.** Before mapping, the disparity (nearness) map is filtered in time on content whose
colour does not change (:func:`vergence.video.stabilize_disparity`, reset at cuts), which takes out the
flicker of matching noise and of a compressed depth video. The filtered map stays within the range of
the raw maps it averages, so the budget still holds. :attr:`Conversion.flicker_before` and
``flicker_after`` give the frame-to-frame change of the output's parallax on static content
(:func:`vergence.video.disparity_flicker` times the shot's psi slope), without and with the filter.

**Scale-out.** Each shot, or each piece of a shot longer than ``split_frames`` (240 frames by default),
is a job of :mod:`vergence.video._shots`: the clip's paths, the piece's frame range, its psi and the
options, never frames; it decodes its own frames (the reader seeks) and writes its segment atomically.
A piece first runs the disparity filter over the frames before it, so the filtered maps are those of
the unsplit shot to 1e-3 of the filter's state (:mod:`vergence.video._shots`). The serial run loops
over the jobs; ``workers > 1`` or ``scheduler`` submits one Dask task per piece and pass
(``dask.distributed``, the ``dask`` extra): a stereo clip's matching (pass 2), then, once every psi is
known, the renders (pass 3). The joined output is the same, byte for byte (PNG frames and H.264 files:
``tests/video/test_convert_dask.py``). Pass 1 (cuts, ranges) stays in the caller.

**Edges.** A stereo clip's left band that the right view does not see takes its row's first matched
disparities, and each shot's depth cue at the frame's left and right edges gives the output's disparity
there: a stereo-window violation is warned about, or masked with ``floating_window``
(:mod:`vergence.video.edges`). Nothing is written over an existing ``out`` unless ``force``
(:func:`vergence.video.check_new_output`).

**Views.** A stereo clip keeps its left view and re-synthesises the right one (``origin="left"``,
default) or synthesises both around the left camera (``origin="center"``: half the disocclusions in
each view); a 2D + depth clip is the centre (default) or the left view, as ``vergence synthesize``.
"""

from __future__ import annotations

import math
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vergence.video._shots import (
    SPLIT_FRAMES,
    pooled_shot,
    SharedSource,
    ShotJob,
    close_client,
    match_shot,
    open_client,
    render_shot,
    run_on_dask,
    split_shots,
    warmup_frames,
)
from vergence.video.conversion import Conversion, ShotConversion
from vergence.video.edges import edge_cues, floating_window_of
from vergence.video.measured import measure_output
from vergence.video.outputs import VIDEO_SUFFIXES, check_new_output
from vergence.video.search import shot_search_ranges
from vergence.video.sources import DepthClip, StereoClip
from vergence.video.stability import STABILIZE_ALPHA, STATIC_THRESHOLD, Flicker, FlickerMeter
from vergence.video.writer import DEFAULT_CRF, DEFAULT_PRESET, PIXEL_FORMATS, X264_PRESETS

if TYPE_CHECKING:
    from vergence.viewing import Display
    from vergence.viewing.mapping_operators import LinearMapping

__all__ = ["CONVERT_ORIGINS", "SPLIT_FRAMES", "convert_clip"]

# Where the original view sits among the output views: the left view, or the centre of the pair.
CONVERT_ORIGINS = ("left", "center")


def _check_number(name: str, value: object, lo: float, hi: float, *, lo_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    if value > hi or value < lo or (lo_open and value == lo):
        raise ValueError(f"{name} must be in {'(' if lo_open else '['}{lo:g}, {hi:g}]; got {value!r}")
    return float(value)


def _inputs(clip: StereoClip | DepthClip) -> list[Path]:
    if isinstance(clip, StereoClip):
        return [clip.reader.path]
    return [clip.colour.path] + ([] if clip.depth is None else [clip.depth.path])


def _shot_mapping(lo: float, hi: float, width: int, budget_arcmin: float, display: Display, s: int,
                  shot: tuple[int, int]) -> LinearMapping:  # fmt: skip
    """The linear psi of a shot whose nearness (disparity) runs over ``[lo, hi]``, at the clip's width."""
    from vergence.synthesis import plan_parallax

    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"shot {s} (frames {shot[0]}-{shot[1] - 1}) has no known depth or disparity")
    if not hi > lo:
        raise ValueError(f"shot {s} (frames {shot[0]}-{shot[1] - 1}) has flat depth (one nearness everywhere): no "
                         "range to map into the budget")
    row = np.full((1, width), lo, np.float32)
    row[0, -1] = hi  # the shot's range at the clip's width: the budget in px depends on it
    return plan_parallax(row, kind="disparity", budget_arcmin=budget_arcmin, display=display).mapping


def convert_clip(
    clip: StereoClip | DepthClip,
    out: str | os.PathLike[str],
    display: Display,
    *,
    budget_arcmin: float = 30.0,
    layout: str = "sbs",
    pixel_format: str | None = None,
    crf: int = DEFAULT_CRF,
    preset: str = DEFAULT_PRESET,
    origin: str | None = None,
    stabilize: bool = True,
    threshold: float = STATIC_THRESHOLD,
    alpha: float = STABILIZE_ALPHA,
    transition: float = 0.0,
    method: str = "sgbm",
    min_disparity: int | None = None,
    max_disparity: int | None = None,
    floating_window: bool = False,
    resume: bool = False,
    force: bool = False,
    progress: Callable[[str, int, int], None] | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    split_frames: int = SPLIT_FRAMES,
) -> Conversion:
    """Retarget ``clip`` into ``+-budget_arcmin`` on ``display`` and write it to ``out`` (module docstring).

    Parameters
    ----------
    clip : StereoClip or DepthClip
        From :func:`~vergence.video.open_stereo` or :func:`~vergence.video.open_depth_clip`.
    out : str or os.PathLike
        A ``.mp4``/``.mkv``/``.mov`` file (H.264), or a folder (no extension) of PNG frames
        ``frame_000000.png``...; never one of the clip's files. Its parent folder must exist.
    display : vergence.viewing.Display
        With its ``resolution``; the view fills its width.
    budget_arcmin : float
        The parallax budget, ``+-A`` arcmin of vergence (as ``vergence synthesize``).
    layout : str
        A key of :data:`vergence.display.LAYOUTS`.
    pixel_format : str, optional
        A key of :data:`~vergence.video.PIXEL_FORMATS`; default ``yuv444p`` for anaglyphs (4:2:0
        mixes the colours of the two views at edges), else ``yuv420p``.
    crf : int
        x264 quality (0 = lossless).
    preset : str
        x264 speed, one of :data:`~vergence.video.X264_PRESETS`.
    origin : {"left", "center"}, optional
        Where the original view sits; default ``"left"`` for a stereo clip, ``"center"`` for 2D + depth.
    stabilize : bool
        Filter the disparity in time on static content (:func:`~vergence.video.stabilize_disparity`).
    threshold, alpha : float
        That filter's parameters (:data:`~vergence.video.STATIC_THRESHOLD`, :data:`~vergence.video.STABILIZE_ALPHA`);
        ``threshold`` is also the flicker measure's.
    transition : float
        Frames over which psi ramps across a cut (0: reset at the cut).
    method, min_disparity, max_disparity
        Stereo clips: the matcher and its search range, as :func:`~vergence.video.analyze_clip`.
    floating_window : bool
        Mask, per shot, the frame edge where content comes in front of the screen (a stereo-window
        violation): black columns at the left edge of the left view and the right edge of the right view,
        as wide as the output's disparity there (:attr:`ShotConversion.window`; module docstring). Without
        it, such a shot is warned about.
    resume : bool
        Reuse the finished shots of an interrupted run with the same input and options (its work
        folder ``.NAME.parts`` beside ``out``).
    force : bool
        Replace an existing ``out`` (a file, or an image folder holding files); without it such an ``out`` is
        refused before any work (:func:`~vergence.video.check_new_output`) and, should one appear meanwhile,
        at the end (the finished shots then stay in the work folder for ``resume``). Never one of the clip's files.
    progress : callable(phase, done, total), optional
        Called after each frame of each pass (``"shots"``, ``"matching"``, ``"converting"``); with Dask,
        ``"converting"`` as each shot finishes.
    workers : int
        Above 1 (with ``scheduler`` None or ``"local"``), the shots are rendered as Dask tasks on a new
        ``LocalCluster`` of that many one-thread processes (needs ``pip install 'vergence[dask]'``).
    scheduler : str, optional
        ``"local"`` (the default when ``workers > 1``), or the address of a running Dask scheduler
        (``tcp://host:8786``) whose workers see the same paths. Each shot is one task (its frame range,
        the input paths and its psi; never frames), writing its own segment; the output is the same as
        the serial run's (byte for byte with ``--images``).
    split_frames : int
        Shots longer than this many frames are split into pieces of at most that length, each its own
        job (task), which first runs the disparity filter over the frames before it (a warm-up of
        :func:`~vergence.video._shots.warmup_frames`, 25 at the default ``alpha``: the filtered
        disparity then differs from the unsplit shot's by at most 1e-3 of the filter's state at the
        warm-up's first frame). The serial run splits the same way. 0: never split.

    Returns
    -------
    Conversion

    Raises
    ------
    ValueError
        Bad options, an ``out`` that is an input, a clip that stops before its first frame, a shot
        without depth range, and the errors of matching and synthesis. A clip that breaks mid-way is
        not an error here: the frames before are written and :attr:`Conversion.stopped` says why.
        An unreachable ``scheduler`` (before any pass over the clip).
    FileExistsError
        ``out`` exists and ``force`` is False.
    ImportError
        ``workers > 1`` or ``scheduler`` without ``dask.distributed`` (``pip install 'vergence[dask]'``).
    """
    if isinstance(workers, bool) or not isinstance(workers, int | np.integer) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1; got {workers!r}")
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise ValueError(f"scheduler must be 'local' or a scheduler address; got {scheduler!r}")
    if isinstance(split_frames, bool) or not isinstance(split_frames, int | np.integer) or split_frames < 0:
        raise ValueError(f"split_frames must be an integer >= 0 (0: never split); got {split_frames!r}")
    options = {name: value for name, value in locals().items() if name not in ("workers", "scheduler")}
    if workers == 1 and scheduler in (None, "local"):
        return _convert_clip(**options, client=None)
    # The cluster first: an unreachable scheduler is refused before the passes over the clip.
    client, cluster = open_client("local" if scheduler is None else scheduler, int(workers))
    try:
        return _convert_clip(**options, client=client)
    finally:
        close_client(client, cluster)


def _convert_clip(
    clip: StereoClip | DepthClip,
    out: str | os.PathLike[str],
    display: Display,
    *,
    budget_arcmin: float,
    layout: str,
    pixel_format: str | None,
    crf: int,
    preset: str,
    origin: str | None,
    stabilize: bool,
    threshold: float,
    alpha: float,
    transition: float,
    method: str,
    min_disparity: int | None,
    max_disparity: int | None,
    floating_window: bool,
    resume: bool,
    force: bool,
    progress: Callable[[str, int, int], None] | None,
    split_frames: int,
    client: object,
) -> Conversion:
    """:func:`convert_clip` on ``client`` (a ``dask.distributed`` Client; None: serial); every option is
    given by :func:`convert_clip`, whose signature holds the defaults."""
    from vergence.display import LAYOUTS, pack
    from vergence.synthesis import nearness_from_depth
    from vergence.video import _segments
    from vergence.video.cuts import detect_cuts
    from vergence.viewing import check_display

    started = time.perf_counter()
    parallel = client is not None
    if not isinstance(clip, StereoClip | DepthClip):
        raise TypeError(f"clip must be a StereoClip or a DepthClip; got {type(clip).__name__}")
    check_display(display, resolution=True)
    budget = _check_number("budget_arcmin", budget_arcmin, 0.0, 600.0, lo_open=True)
    if not isinstance(layout, str) or layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}; got {layout!r}")
    stereo = isinstance(clip, StereoClip)
    origin = ("left" if stereo else "center") if origin is None else origin
    if origin not in CONVERT_ORIGINS:
        raise ValueError(f"origin must be one of {', '.join(CONVERT_ORIGINS)}; got {origin!r}")
    out = Path(out)
    images = out.suffix.lower() not in VIDEO_SUFFIXES
    if images and out.suffix:
        raise ValueError(f"out must be a {', '.join(VIDEO_SUFFIXES)} file or a folder without extension; "
                         f"got {out.name!r}")
    if pixel_format is None:
        pixel_format = "yuv444p" if layout.startswith("anaglyph") else "yuv420p"
    if pixel_format not in PIXEL_FORMATS:
        raise ValueError(f"pixel_format must be one of {', '.join(PIXEL_FORMATS)}; got {pixel_format!r}")
    if isinstance(crf, bool) or not isinstance(crf, int | np.integer) or not 0 <= crf <= 51:
        raise ValueError(f"crf must be an integer in [0, 51]; got {crf!r}")
    if preset not in X264_PRESETS:
        raise ValueError(f"preset must be one of {', '.join(X264_PRESETS)}; got {preset!r}")
    threshold = _check_number("threshold", threshold, 0.0, 1.0)
    alpha = _check_number("alpha", alpha, 0.0, 1.0, lo_open=True)
    transition = _check_number("transition", transition, 0.0, 1e9)
    if not out.parent.is_dir():
        raise FileNotFoundError(f"out folder {out.parent} does not exist")
    for p in _inputs(clip):
        if out.resolve() == Path(p).resolve():
            raise ValueError(f"out {out} would overwrite input {p}")
    check_new_output(out, force=bool(force))
    width, height = clip.width, clip.height
    if stereo:
        from vergence.depth import MATCHERS

        if not isinstance(method, str) or method not in MATCHERS:
            raise ValueError(f"method must be one of {', '.join(MATCHERS)}; got {method!r}")
        for name, v in (("min_disparity", min_disparity), ("max_disparity", max_disparity)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, int | np.integer)):
                raise TypeError(f"{name} must be an integer number of pixels; got {type(v).__name__}")
        if min_disparity is not None and max_disparity is not None and min_disparity >= max_disparity:
            raise ValueError(f"min_disparity must be < max_disparity; got {min_disparity} and {max_disparity}")
    packed_shape = pack(np.zeros((height, width, 3), np.float32), np.zeros((height, width, 3), np.float32),
                        layout=layout).shape  # fmt: skip
    if not images and pixel_format == "yuv420p" and (packed_shape[0] % 2 or packed_shape[1] % 2):
        raise ValueError(f"yuv420p needs an even frame size; {layout} frames of these views are "
                         f"{packed_shape[1]}x{packed_shape[0]} (use yuv444p)")
    report = progress or (lambda phase, done, total: None)

    # Pass 1: cuts, and the nearness range of each frame of a 2D + depth clip.
    guard = _segments.Stopped()
    ranges: list[tuple[float, float]] = []
    edges: list[tuple[float, float]] = []  # 2D + depth: each frame's nearness at its edges (edge_cues)
    if stereo:
        def colour_frames():
            yield from guard.wrap(clip.lefts())
    else:
        def colour_frames():
            for image, depth in guard.wrap(clip.pairs()):
                q = nearness_from_depth(depth, kind=clip.kind)
                with np.errstate(all="ignore"):
                    ranges.append((float(np.nanmin(q)), float(np.nanmax(q))) if np.isfinite(q).any()
                                  else (math.nan, math.nan))  # fmt: skip
                    edges.append(edge_cues(q))
                yield image

    try:
        cuts = detect_cuts(_segments.counted(colour_frames(), report, "shots", clip.frames))
    except ValueError:
        if guard.count == 0 and guard.reason is not None:  # broken before its first frame: nothing to keep
            raise ValueError(guard.reason) from None
        raise
    n = guard.count
    shots = cuts.shots
    cut_frames = [a for a, _ in shots[1:]]
    # Each shot's search range, from its features unless both bounds are given (vergence.video.search).
    searches = shot_search_ranges(clip, shots, min_disparity=min_disparity, max_disparity=max_disparity) if stereo else []

    suffix = out.suffix.lower() if not images else ""
    manifest = {"inputs": [str(Path(p).resolve()) for p in _inputs(clip)], "kind": "stereo" if stereo else "2d+depth",
                "frames": n, "shots": [list(s) for s in shots], "layout": layout, "pixel_format": pixel_format,
                "crf": int(crf), "preset": preset, "budget_arcmin": budget, "origin": origin,
                "stabilize": bool(stabilize), "split_frames": split_frames, "floating_window": bool(floating_window),
                "threshold": float(threshold), "alpha": float(alpha), "transition": transition,
                "display": [display.eye_separation, display.distance, display.width, display.resolution],
                **({"method": method, "search_px": [[r.lo, r.hi] for r in searches]} if stereo else
                   {"depth_kind": clip.kind, "depth_scale": clip.scale})}  # fmt: skip
    work = _segments.work_folder(out)
    _segments.prepare_work(work, manifest, resume)
    try:
        pieces = split_shots(shots, split_frames, warmup_frames(alpha, stabilize))
        segments = [_segments.segment_path(work, s, a, b, images, suffix) for s, a, b, _ in pieces]
        done = [seg.exists() for seg in segments]
        reused = [all(d for (s2, *_), d in zip(pieces, done) if s2 == s) for s in range(len(shots))]
        meters = [(FlickerMeter(threshold), FlickerMeter(threshold)) for _ in pieces]  # before, after
        jobs = [ShotJob(clip=clip, shot=s, start=a, end=b, segment=segments[i],
                        disparity=(work / f"disparity_{i:04d}.npy") if stereo else None, images=images,
                        packed_shape=tuple(packed_shape), layout=layout, pixel_format=pixel_format, crf=int(crf),
                        preset=preset, origin=origin, display=display, mappings=(), cut_frames=tuple(cut_frames),
                        transition=transition, stabilize=bool(stabilize), threshold=threshold, alpha=alpha, piece=i,
                        warmup=w, match=(searches[s], method) if stereo else None)
                for i, (s, a, b, w) in enumerate(pieces) if not done[i]]  # fmt: skip

        # Pass 2 (stereo): each unfinished piece matched and stabilised, its disparity kept in the work folder; the
        # range of every piece of a shot that is not wholly reused (a finished piece's from its record).
        range_in: list[tuple[float, float]] = []
        edge_in: list[tuple[float, float]] = []  # each shot's largest depth cue at its left and right edges
        searched: list[dict | None] = [None] * len(shots)
        if stereo:
            piece_matched: dict = {}
            for i in range(len(pieces)):
                if done[i]:  # a finished piece's range from its record: every shot's psi is known, reused or not
                    piece_matched[i] = _segments.read_range(work, i, width)
            todo = sum(job.end - job.start for job in jobs)
            count = 0

            def matched(job: ShotJob, piece_meters, found) -> None:
                nonlocal count
                meters[job.piece], piece_matched[job.piece] = piece_meters, found
                _segments.write_range(work, job.piece, found)
                if parallel:
                    count += job.end - job.start
                    report("matching", count, todo)

            if parallel and jobs:
                run_on_dask(jobs, client, matched, match=True)
            else:
                def tick() -> None:
                    nonlocal count
                    count += 1
                    report("matching", count, todo)

                source = SharedSource(clip.pairs, n)
                for job in jobs:
                    matched(job, *match_shot(job, source.at(job.start - job.warmup), tick))
                    source.moved(job.end)
            for s in range(len(shots)):
                found = [piece_matched[i] for i, (s2, *_) in enumerate(pieces) if s2 == s and i in piece_matched]
                shot_range, shot_edges, searched[s] = pooled_shot(found, searches[s], width)
                range_in.append(shot_range)
                edge_in.append(shot_edges)
        else:
            for a, b in shots:
                with np.errstate(all="ignore"):
                    range_in.append((float(np.nanmin([r[0] for r in ranges[a:b]])),
                                     float(np.nanmax([r[1] for r in ranges[a:b]]))))  # fmt: skip
                    edge_in.append(tuple(float(np.fmax.reduce([e[side] for e in edges[a:b]])) for side in (0, 1)))
        mappings = [_shot_mapping(*range_in[s], width, budget, display, s, shots[s]) for s in range(len(shots))]
        windows = [floating_window_of(mappings[s], edge_in[s], floating_window) for s in range(len(shots))]

        # Pass 3: render, pack and encode the unfinished pieces, one segment each (a job per piece: _shots).
        jobs = [replace(job, mappings=tuple(mappings), window=(windows[job.shot]["left_px"], windows[job.shot]["right_px"]))
                for job in jobs]  # fmt: skip
        todo = rendered_frames = sum(job.end - job.start for job in jobs)
        count = 0

        def rendered(job: ShotJob, piece_meters) -> None:
            nonlocal count
            if piece_meters is not None:
                meters[job.piece] = piece_meters
            done[job.piece] = True
            if parallel:
                count += job.end - job.start
                report("converting", count, todo)

        if parallel and jobs:
            run_on_dask(jobs, client, rendered)
        else:
            def tick() -> None:
                nonlocal count
                count += 1
                report("converting", count, todo)

            source = SharedSource(clip.lefts if stereo else clip.pairs, n)
            for job in jobs:
                rendered(job, render_shot(job, source.at(job.start if stereo else job.start - job.warmup), tick))
                source.moved(job.end)
        if not segments or not all(done):
            raise ValueError(f"conversion of {_inputs(clip)[0]} left shots unfinished")

        if images:
            _segments.join_folders(segments, out, replace=bool(force))
        else:
            reader = clip.reader if stereo else clip.colour
            audio = reader.path if reader.files is None else None
            _segments.join_videos(segments, out, audio, n / clip.fps, replace=bool(force))
        shutil.rmtree(work, ignore_errors=True)
    except BaseException:
        # Nothing finished (a bad option found by planning, Ctrl-C in the first shot): no work folder left behind;
        # finished shots stay for --resume.
        finished = work.is_dir() and any(p.name.startswith("shot_") for p in work.iterdir())
        if not finished:
            shutil.rmtree(work, ignore_errors=True)
        raise

    def combined(which: int) -> Flicker:
        total = count_px = pixels = pairs = 0
        for (s, *_), pair in zip(pieces, meters):
            m = pair[which]
            gain = abs(mappings[s].gain) if mappings[s] is not None else 0.0
            total += gain * m.total
            count_px, pixels, pairs = count_px + m.count, pixels + m.pixels, pairs + m.pairs
        return Flicker(mean_px=total / count_px if count_px else math.nan, pairs=pairs,
                       static_share=count_px / pixels if pixels else 0.0)  # fmt: skip

    conversions = tuple(
        ShotConversion(start=a, end=b, mapping=mappings[s], range_in=range_in[s],
                       range_px=(math.nan, math.nan) if mappings[s] is None else  # P = psi(-q), psi increasing
                       (float(mappings[s](-range_in[s][1])), float(mappings[s](-range_in[s][0]))), reused=reused[s],
                       search=searched[s], window=windows[s])
        for s, (a, b) in enumerate(shots)
    )  # fmt: skip
    conversions = measure_output(conversions, clip, out, layout, method, searches, threshold)
    return Conversion(out=out, kind="stereo" if stereo else "2d+depth", frames=n, fps=float(clip.fps), layout=layout,
                      pixel_format=None if images else pixel_format, shots=conversions,
                      flicker_before=combined(0), flicker_after=combined(1), stopped=guard.reason,
                      seconds=time.perf_counter() - started, rendered=rendered_frames)  # fmt: skip
