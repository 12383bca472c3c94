"""One piece of a shot as a self-contained job, run in a loop (serial) or as Dask tasks (``--workers``).

A :class:`ShotJob` carries the clip (its readers hold paths and stream facts, never frames), the
piece's frame range, its mapping inputs and the options; :func:`match_shot` (stereo) and
:func:`render_shot` decode their own frames, and each piece's segment is written atomically
(:class:`vergence.video._segments.Segment`). The segments are joined by the caller, so the result does
not depend on where or in which order the pieces ran (ARCHITECTURE.md, "Scale-out").

**Pieces.** A shot longer than ``split_frames`` is split into pieces of at most that many frames
(:func:`split_shots`), each a job. The disparity filter of :func:`vergence.video.stabilize_disparity`
is recursive, so a piece does not start cold: it first runs the filter over the
:func:`warmup_frames` frames before its start (decoded, and for a stereo clip matched, again; not
rendered). On a static pixel the state before the warm-up weighs ``(1 - alpha)^K`` after ``K``
frames, so with ``K = ceil(log(SPLIT_TOLERANCE) / log(1 - alpha))`` (25 frames at the default
alpha 0.25) a piece's filtered disparity differs from the unsplit shot's by at most
:data:`SPLIT_TOLERANCE` (1e-3) of the difference between the raw and the filtered map at the warm-up's
first frame (tested: the 8-bit frames of a split shot lie within one level of the unsplit ones; on the
test clips they are equal). A pixel unknown through the whole warm-up keeps no older value. The
serial run uses the same pieces, so both give the same bytes. Each piece's flicker meter counts the
pair across its start (the warm-up's last frame), so the pairs measured are those of the unsplit shot.
"""

from __future__ import annotations

import itertools
import logging
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.video._histogram import MatchedPiece, ShotHistogram
from vergence.video.edges import edge_cues, fill_left_band, masked_window
from vergence.video.search import SearchRange
from vergence.video.sources import DepthClip, StereoClip
from vergence.video.stability import FlickerMeter

# The extra that brings dask.distributed.
DASK_HINT = "pip install 'vergence[dask]'"
# Seconds to wait for a running scheduler (--scheduler ADDRESS) before giving up.
CONNECT_TIMEOUT_S = 10
# Shots longer than this (frames) are split into pieces (10 s at 24 frames/s), each its own task.
SPLIT_FRAMES = 240
# Weight left to the filter's state from before a piece's warm-up (module docstring).
SPLIT_TOLERANCE = 1e-3


def warmup_frames(alpha: float, stabilize: bool = True, tolerance: float = SPLIT_TOLERANCE) -> int:
    """Frames a piece runs the disparity filter over before its start (at least 1: the flicker pair across it).

    Examples
    --------
    >>> warmup_frames(0.25), warmup_frames(1.0), warmup_frames(0.25, stabilize=False)
    (25, 1, 1)
    """
    if not stabilize or alpha >= 1.0:
        return 1
    return max(1, math.ceil(math.log(tolerance) / math.log1p(-alpha)))


def split_shots(shots: list[tuple[int, int]], split_frames: int, warmup: int) -> list[tuple[int, int, int, int]]:
    """Pieces ``(shot, start, end, warmup)`` of ``shots``: a shot longer than ``split_frames`` is cut into
    ``ceil(length / split_frames)`` pieces of near-equal length; a piece after a shot's first runs the
    filter over ``min(warmup, start - shot start)`` frames first. ``split_frames`` 0: no shot is split.

    Examples
    --------
    >>> split_shots([(0, 5), (5, 15)], 4, 2)
    [(0, 0, 2, 0), (0, 2, 5, 2), (1, 5, 8, 0), (1, 8, 12, 2), (1, 12, 15, 2)]
    """
    pieces = []
    for s, (a, b) in enumerate(shots):
        count = 1 if split_frames <= 0 else max(1, math.ceil((b - a) / split_frames))
        edges = [a + round(i * (b - a) / count) for i in range(count + 1)]
        pieces += [(s, p, q, 0 if p == a else min(warmup, p - a)) for p, q in zip(edges, edges[1:])]
    return pieces


@dataclass(frozen=True, slots=True)
class ShotJob:
    """Everything one shot's render needs, small enough to ship to a Dask worker (no frames)."""

    clip: StereoClip | DepthClip
    shot: int
    start: int
    end: int
    segment: Path
    disparity: Path | None  # stereo: the piece's stabilised disparity, (end - start, H, W) float32
    images: bool
    packed_shape: tuple[int, ...]
    layout: str
    pixel_format: str
    crf: int
    preset: str
    origin: str
    display: object
    mappings: tuple  # every shot's psi (a ramp across a cut needs its neighbours')
    cut_frames: tuple[int, ...]
    transition: float
    stabilize: bool
    threshold: float
    alpha: float
    threads: int | None = None  # Numba/OpenCV threads for this task (its share of the host's cores)
    piece: int = 0  # index among the conversion's pieces (the key of its results)
    warmup: int = 0  # frames before start run through the disparity filter only (module docstring)
    # A stereo piece's matching: (its shot's search range, method); run by match_shot before any render.
    match: tuple[SearchRange, str] | None = None
    # The floating window: columns masked at the left edge of the left view and the right edge of the right one.
    window: tuple[int, int] = (0, 0)


class _Filtered:
    """A piece's disparity filter (:func:`vergence.video.stabilize_disparity`, from the piece's first frame) and
    its flicker meters (before, after); :meth:`step` takes one frame, a warm-up frame counting no pair but
    the one across the piece's start."""

    def __init__(self, job: ShotJob) -> None:
        self.job = job
        self.meters = (FlickerMeter(job.threshold), FlickerMeter(job.threshold))
        self._prev: tuple[np.ndarray, np.ndarray] | None = None

    def step(self, colour: np.ndarray, raw: np.ndarray, warmup: bool) -> np.ndarray:
        from vergence.video._kernels import stabilize_kernel
        from vergence.video.stability import grey_levels

        job, prev = self.job, self._prev
        grey = grey_levels(colour)
        d = raw if prev is None or not job.stabilize else stabilize_kernel(prev[0], grey, prev[1], raw, job.threshold,
                                                                           job.alpha)  # fmt: skip
        self._prev = (grey, d)
        for m, value in zip(self.meters, (raw, d)):
            m.add(grey, value)
            if warmup:
                m.restart()  # only the pair across the piece's start is counted
        return d

    def finish(self) -> tuple[FlickerMeter, FlickerMeter]:
        for m in self.meters:
            m.reset()  # the last frame stays behind
        return self.meters


def pooled_shot(found: list[MatchedPiece], search: SearchRange,
                width: int) -> tuple[tuple[float, float], tuple[float, float], dict | None]:  # fmt: skip
    """What the matched pieces of one stereo shot found, together: its range (the 1st and 99th percentiles of all
    its pixels, pooled, as ``vergence analyze``), its largest edge cues (:mod:`vergence.video.edges`) and its
    search record (the range searched, frames widened and saturated, the ends of the range on its bound);
    ``(inf, -inf)``, NaN and None for a shot without a matched piece."""
    from vergence.video._histogram import PERCENTILES
    from vergence.video.search import on_bound

    if not found:
        return (math.inf, -math.inf), (math.nan, math.nan), None
    pooled = ShotHistogram(width)
    for f in found:
        pooled.merge(f.histogram)
    pct = dict(zip(PERCENTILES, pooled.pooled()))
    edges = tuple(float(np.fmax.reduce([f.edges[e] for f in found])) for e in (0, 1))
    lo, hi = min(f.search_px[0] for f in found), max(f.search_px[1] for f in found)
    record = {**search.to_dict(), "search_px": [lo, hi], "widened_frames": sum(f.widened_frames for f in found),
              "saturated_frames": sum(f.saturated_frames for f in found),
              "on_bound": on_bound({"p1": pct[1], "p99": pct[99]}, lo, hi)}  # fmt: skip
    return (float(pct[1]), float(pct[99])), (edges[0], edges[1]), record


def match_shot(job: ShotJob, source: Iterator | None = None,
               report: Callable[[], None] | None = None) -> tuple[tuple[FlickerMeter, FlickerMeter], MatchedPiece]:  # fmt: skip
    """Pass 2 of one stereo piece: match frames ``[start - warmup, end)`` in the shot's search range (widened
    where the matches pile up at an estimated bound: :func:`vergence.video.search.match_searched`), stabilise,
    write ``[start, end)`` to ``job.disparity`` (``.npy``).

    Returns the flicker meters (before, after stabilisation) and the :class:`MatchedPiece`. ``source``: the
    clip's pairs already at ``start - warmup`` (the serial pass shares one decoder); else the piece's own range
    is decoded.
    """
    from vergence.video.search import match_searched

    _limit_threads(job.threads)
    clip, start, end, first = job.clip, job.start, job.end, job.start - job.warmup
    search, method = job.match
    if source is None:
        source = clip.pairs(first, end)
    filtered = _Filtered(job)
    histogram = ShotHistogram(clip.width)
    lo, hi = search.lo, search.hi
    widened = saturated = 0
    edges = [math.nan, math.nan]
    disparity = np.lib.format.open_memmap(job.disparity, mode="w+", dtype=np.float32,
                                          shape=(end - start, clip.height, clip.width))  # fmt: skip
    for k in range(first, end):
        left, right = next(source)
        frame = match_searched(left, right, search, method, lo=lo, hi=hi)
        lo, hi = frame.lo, frame.hi  # a widened range holds for the rest of the piece
        d = filtered.step(left, fill_left_band(frame.disparity.astype(np.float32)), k < start)
        if k < start:
            continue
        widened, saturated = widened + frame.widened, saturated + frame.saturated
        edges = [float(np.fmax(e, c)) for e, c in zip(edges, edge_cues(d))]
        disparity[k - start] = d
        histogram.add(d[np.isfinite(d)].astype(np.float64))
        if report is not None:
            report()
    disparity.flush()
    del disparity  # closed before the render opens it again
    return filtered.finish(), MatchedPiece(histogram, (lo, hi), widened, saturated, (edges[0], edges[1]))


def psi_at(job: ShotJob, k: int):
    """Frame ``k``'s psi: its shot's, or the temporal blend of Lang et al. (2010) near a cut."""
    from vergence.viewing.mapping import BlendedMapping, temporal_weights

    if job.transition == 0 or not job.cut_frames:
        return job.mappings[job.shot]
    w = temporal_weights(float(k), list(job.cut_frames), transition=job.transition)
    if w.max() == 1.0:
        return job.mappings[int(np.argmax(w))]
    return BlendedMapping(tuple(job.mappings), w)  # psi_t = sum_k w_k(t) psi_k


def _limit_threads(threads: int | None) -> None:
    if threads is None:
        return
    import numba

    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        import cv2
    except ImportError:  # pragma: no cover - OpenCV is a dependency of the matchers only
        return
    cv2.setNumThreads(int(threads))


# Layouts packed straight into 8 bits: where each view's block sits, (row, column) in view sizes (left, right).
_BLOCKS = {"sbs": ((0, 0), (0, 1)), "tb": ((0, 0), (1, 0)), "cross-eyed": ((0, 1), (0, 0))}


def packed_uint8(left: np.ndarray, right: np.ndarray, layout: str) -> np.ndarray:
    """``rint(clip(pack(left, right, layout), 0, 1) * 255)`` as uint8, as :class:`~vergence.video.VideoWriter` rounds.

    Full side-by-side, top-bottom and cross-eyed frames of float32 RGB views are written in one parallel
    pass per view (no float frame in between); other layouts are packed by :func:`vergence.display.pack` first.
    """
    from vergence.display import pack
    from vergence.video._kernels import to_uint8_kernel

    rgb = left.ndim == 3 and left.shape[2] == 3 and left.dtype == right.dtype == np.float32 and left.shape == right.shape
    if layout in _BLOCKS and rgb:
        h, w = left.shape[:2]
        (ly, lx), (ry, rx) = _BLOCKS[layout]
        out = np.empty((h * (1 + max(ly, ry)), w * (1 + max(lx, rx)), 3), np.uint8)
        to_uint8_kernel(left, out[ly * h:(ly + 1) * h, lx * w:(lx + 1) * w])
        to_uint8_kernel(right, out[ry * h:(ry + 1) * h, rx * w:(rx + 1) * w])
        return out
    packed = np.ascontiguousarray(pack(left, right, layout=layout), dtype=np.float32)
    out = np.empty(packed.shape, np.uint8)
    to_uint8_kernel(packed if packed.ndim == 3 else packed[:, :, None], out if out.ndim == 3 else out[:, :, None])
    return out


def render_shot(job: ShotJob, source: Iterator | None = None,
                report: Callable[[], None] | None = None) -> tuple[FlickerMeter, FlickerMeter] | None:  # fmt: skip
    """Render frames ``[start, end)`` of ``job.clip`` and write the piece's segment; return its flicker meters.

    ``source`` is the clip's frame iterator already at ``start - warmup`` (a stereo piece: at
    ``start``; the serial loop shares one decoder); without it the job opens its own range (a Dask
    task). A 2D + depth piece first runs the disparity filter over its warm-up frames. The meters
    (before, after stabilisation; 2D + depth only, else None) come back without their last frame.
    """
    from vergence.synthesis import nearness_from_depth, synthesize_stereo
    from vergence.video import _segments
    from vergence.video.writer import VideoWriter

    _limit_threads(job.threads)
    clip, a, b = job.clip, job.start, job.end
    stereo = isinstance(clip, StereoClip)
    first = a if stereo else a - job.warmup
    if source is None:
        source = clip.lefts(a, b) if stereo else clip.pairs(first, b)
    filtered = None if stereo else _Filtered(job)
    store = np.load(job.disparity, mmap_mode="r") if stereo else None
    try:
        with _segments.Segment(job.segment, job.images, clip.fps, job.packed_shape, job.pixel_format, job.crf,
                               job.preset, VideoWriter) as sink:  # fmt: skip
            for k in range(first, b):
                item = next(source)
                if stereo:
                    image, d = item, np.array(store[k - a])
                else:
                    image, depth = item
                    d = filtered.step(image, nearness_from_depth(depth, kind=clip.kind), k < a)
                    if k < a:
                        continue
                result = synthesize_stereo(image, d, kind="disparity", mapping=psi_at(job, k), display=job.display,
                                           origin=job.origin)  # fmt: skip
                left, right = masked_window(result.left, result.right, job.window)
                sink.write(packed_uint8(left, right, job.layout), k)
                if report is not None:
                    report()
    finally:
        del store  # the map closes with its last reference, before its file is removed
    if stereo:
        job.disparity.unlink(missing_ok=True)
        return None
    return filtered.finish()


def _match_task(job: ShotJob) -> tuple[int, tuple, MatchedPiece]:
    """One Dask task of pass 2: (piece, meters, what its matching found)."""
    meters, matched = match_shot(job)
    return job.piece, meters, matched


def _render_task(job: ShotJob) -> tuple[int, tuple | None]:
    """One Dask task of pass 3: (piece, meters or None)."""
    return job.piece, render_shot(job)


def local_cluster(workers: int):
    """A ``LocalCluster`` of ``workers`` one-thread processes, without dashboard."""
    try:
        from distributed import LocalCluster
    except ImportError:
        raise ImportError(f"dask.distributed is not installed: {DASK_HINT}") from None
    # The scheduler's small HTTP server (health, metrics) on a free local port, not 8787 (a warning when taken).
    # Its logs silenced, in the workers and in this process (the "distributed" loggers): stderr keeps our own lines
    # ("Worker process still alive after 4.0 seconds, killing" at every close, SIGINT notices at Ctrl-C).
    # The worker processes start with SIGINT ignored (an ignored signal stays ignored across exec, and Python then
    # installs no KeyboardInterrupt handler): Ctrl-C at a terminal reaches the whole process group, and a worker's
    # traceback would bury our "interrupted" line; this process stops them when it closes the cluster.
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                            silence_logs=logging.CRITICAL,
                            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})  # fmt: skip
    finally:
        if main and previous is not None:  # None: a handler not set from Python, left as it was
            signal.signal(signal.SIGINT, previous)


def open_client(scheduler: str, workers: int):
    """A ``dask.distributed`` Client: a new ``LocalCluster`` of ``workers`` processes, or a running scheduler."""
    try:
        from distributed import Client
    except ImportError:
        raise ImportError(f"dask.distributed is not installed: {DASK_HINT}") from None
    if scheduler == "local":
        cluster = local_cluster(workers)
        return Client(cluster), cluster
    logging.getLogger("distributed").setLevel(logging.CRITICAL)  # our lines only on stderr (local_cluster)
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S), None
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise ValueError(f"cannot reach the Dask scheduler {scheduler!r} ({type(exc).__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else 'no answer'})") from None  # fmt: skip


def threads_per_task(client) -> int:
    """Cores per worker thread on the most crowded host of ``client``'s cluster (at least 1)."""
    info = client.scheduler_info().get("workers", {})
    per_host: dict[str, int] = {}
    for w in info.values():
        host = str(w.get("host", w.get("id", "")))
        per_host[host] = per_host.get(host, 0) + int(w.get("nthreads", 1))
    crowded = max(per_host.values(), default=1)
    return max(1, (os.cpu_count() or 1) // crowded)


def close_client(client, cluster) -> None:
    """Close what :func:`open_client` opened."""
    client.close()
    if cluster is not None:
        cluster.close()


def run_on_dask(jobs: list[ShotJob], client, on_done: Callable[..., None], *, match: bool = False) -> None:
    """Submit one task per job to ``client`` (its match with ``match``, else its render); ``on_done(job, *result)``
    as each piece finishes (``meters, matched`` of a match, ``meters`` of a render)."""
    from dataclasses import replace

    from distributed import as_completed

    threads = threads_per_task(client)
    by_piece = {job.piece: job for job in jobs}
    task, phase = (_match_task, "match") if match else (_render_task, "render")
    futures = [client.submit(task, replace(job, threads=threads), key=f"vergence-{phase}-{job.piece}-{os.getpid()}",
                             pure=False) for job in jobs]  # fmt: skip
    try:
        for future in as_completed(futures):
            piece, *result = future.result()
            on_done(by_piece[piece], *result)
    except BaseException:
        for f in futures:
            f.cancel()
        raise


class SharedSource:
    """The serial run's decoder, shared by consecutive pieces; a piece that starts before it (a warm-up, or a
    piece after a reused one far behind) opens its own range (the reader seeks)."""

    def __init__(self, open_range: Callable, frames: int) -> None:
        self._open, self._frames = open_range, frames
        self._it = None
        self._at = 0

    def at(self, start: int):
        """The iterator, at frame ``start``."""
        if self._it is None or start < self._at:
            self._it, self._at = self._open(start, self._frames), start
        for _ in itertools.islice(self._it, start - self._at):  # frames of reused pieces
            pass
        self._at = start
        return self._it

    def moved(self, end: int) -> None:
        """The last user took the frames up to ``end``."""
        self._at = end
