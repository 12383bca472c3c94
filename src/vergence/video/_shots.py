"""One shot's render as a self-contained job, run in a loop (serial) or as Dask tasks (``--workers``).

A :class:`ShotJob` carries the clip (its readers hold paths and stream facts, never frames), the shot's
frame range, its mapping inputs and the options; :func:`render_shot` decodes its own frames, renders
them and writes the shot's segment atomically (:class:`vergence.video._segments.Segment`). A stereo
shot's stabilised disparity is read from its ``.npy`` file in the work folder (pass 2, in the caller).
The segments are joined by the caller, so the result does not depend on where or in which order
the shots ran (ARCHITECTURE.md, "Scale-out").
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.video.sources import DepthClip, StereoClip
from vergence.video.stability import FlickerMeter

# The extra that brings dask.distributed.
DASK_HINT = "pip install 'vergence[dask]'"
# Seconds to wait for a running scheduler (--scheduler ADDRESS) before giving up.
CONNECT_TIMEOUT_S = 10


@dataclass(frozen=True, slots=True)
class ShotJob:
    """Everything one shot's render needs, small enough to ship to a Dask worker (no frames)."""

    clip: StereoClip | DepthClip
    shot: int
    start: int
    end: int
    segment: Path
    disparity: Path | None  # stereo: the shot's stabilised disparity, (end - start, H, W) float32
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
    # A stereo shot whose matching runs in the task too: (min_disparity, max_disparity, method, budget_arcmin);
    # its psi (mappings[shot], None until then) follows from the matched range. Only without a transition.
    match: tuple[int, int, str, float] | None = None


def match_shot(clip: StereoClip, start: int, end: int, store: Path, lo_d: int, hi_d: int, method: str,
               stabilize: bool, threshold: float, alpha: float, source: Iterator | None = None,
               report: Callable[[], None] | None = None) -> tuple[tuple[FlickerMeter, FlickerMeter], tuple[float, float]]:  # fmt: skip
    """Pass 2 of one stereo shot: match frames ``[start, end)``, stabilise, write them to ``store`` (``.npy``).

    Returns the flicker meters (before, after stabilisation) and the shot's disparity range: the
    lowest 1st and the highest 99th percentile of its frames. ``source``: the clip's pairs already at
    ``start`` (the serial pass shares one decoder); else the shot's own range is decoded.
    """
    from vergence.video._kernels import stabilize_kernel
    from vergence.video._matching import match_padded
    from vergence.video.stability import grey_levels

    if source is None:
        source = clip.pairs(start, end)
    meters = (FlickerMeter(threshold), FlickerMeter(threshold))
    lo, hi = math.inf, -math.inf
    disparity = np.lib.format.open_memmap(store, mode="w+", dtype=np.float32, shape=(end - start, clip.height,
                                                                                      clip.width))  # fmt: skip
    prev = None
    for k in range(start, end):
        left, right = next(source)
        raw = match_padded(left, right, lo_d, hi_d, method).astype(np.float32)
        grey = grey_levels(left)
        d = raw if prev is None or not stabilize else stabilize_kernel(prev[0], grey, prev[1], raw, threshold, alpha)
        disparity[k - start] = d
        known = d[np.isfinite(d)]
        if known.size:
            p1, p99 = np.percentile(known, [1, 99])
            lo, hi = min(lo, float(p1)), max(hi, float(p99))
        meters[0].add(grey, raw)
        meters[1].add(grey, d)
        prev = (grey, d)
        if report is not None:
            report()
    disparity.flush()
    del disparity  # closed before the render opens it again
    for m in meters:
        m.reset()
    return meters, (lo, hi)


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


def render_shot(job: ShotJob, source: Iterator | None = None,
                report: Callable[[], None] | None = None) -> tuple[FlickerMeter, FlickerMeter] | None:  # fmt: skip
    """Render frames ``[start, end)`` of ``job.clip`` and write the shot's segment; return its flicker meters.

    ``source`` is the clip's frame iterator already at ``start`` (the serial loop shares one decoder);
    without it the job opens its own range (a Dask task). The meters (before, after stabilisation;
    2D + depth only, else None) come back without their last frame.
    """
    from vergence.display import pack
    from vergence.synthesis import nearness_from_depth, synthesize_stereo
    from vergence.video import _segments
    from vergence.video._kernels import stabilize_kernel
    from vergence.video.stability import grey_levels
    from vergence.video.writer import VideoWriter

    _limit_threads(job.threads)
    clip, a, b = job.clip, job.start, job.end
    stereo = isinstance(clip, StereoClip)
    if source is None:
        source = clip.lefts(a, b) if stereo else clip.pairs(a, b)
    meters = None if stereo else (FlickerMeter(job.threshold), FlickerMeter(job.threshold))
    store = np.load(job.disparity, mmap_mode="r") if stereo else None
    prev = None
    try:
        with _segments.Segment(job.segment, job.images, clip.fps, job.packed_shape, job.pixel_format, job.crf,
                               job.preset, VideoWriter) as sink:  # fmt: skip
            for k in range(a, b):
                item = next(source)
                psi = psi_at(job, k)
                if stereo:
                    image, d = item, np.array(store[k - a])
                else:
                    image, depth = item
                    raw = nearness_from_depth(depth, kind=clip.kind)
                    grey = grey_levels(image)
                    d = raw if prev is None or not job.stabilize else stabilize_kernel(
                        prev[0], grey, prev[1], raw, job.threshold, job.alpha)  # fmt: skip
                    meters[0].add(grey, raw)
                    meters[1].add(grey, d)
                    prev = (grey, d)
                result = synthesize_stereo(image, d, kind="disparity", mapping=psi, display=job.display,
                                           origin=job.origin)  # fmt: skip
                packed = np.clip(pack(result.left, result.right, layout=job.layout), 0.0, 1.0)
                packed *= np.float32(255.0)
                sink.write(np.rint(packed, out=packed).astype(np.uint8), k)  # 8 bits as VideoWriter rounds them
                if report is not None:
                    report()
    finally:
        del store  # the map closes with its last reference, before its file is removed
    if stereo:
        job.disparity.unlink(missing_ok=True)
    else:
        for m in meters:
            m.reset()  # the last frame stays behind
    return meters


def _task(job: ShotJob) -> tuple[int, tuple | None, tuple[float, float] | None, object]:
    """One Dask task: (shot, meters, matched range or None, its psi or None)."""
    from dataclasses import replace

    if job.match is None:
        return job.shot, render_shot(job), None, None
    from vergence.video.convert import _shot_mapping

    _limit_threads(job.threads)
    lo_d, hi_d, method, budget = job.match
    meters, range_in = match_shot(job.clip, job.start, job.end, job.disparity, lo_d, hi_d, method, job.stabilize,
                                  job.threshold, job.alpha)  # fmt: skip
    mapping = _shot_mapping(*range_in, job.clip.width, budget, job.display, job.shot, (job.start, job.end))
    mappings = tuple(mapping if s == job.shot else m for s, m in enumerate(job.mappings))
    render_shot(replace(job, mappings=mappings))
    return job.shot, meters, range_in, mapping


def local_cluster(workers: int):
    """A ``LocalCluster`` of ``workers`` one-thread processes, without dashboard."""
    try:
        from distributed import LocalCluster
    except ImportError:
        raise ImportError(f"dask.distributed is not installed: {DASK_HINT}") from None
    # The scheduler's small HTTP server (health, metrics) on a free local port, not 8787 (a warning when taken).
    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})  # fmt: skip


def open_client(scheduler: str, workers: int):
    """A ``dask.distributed`` Client: a new ``LocalCluster`` of ``workers`` processes, or a running scheduler."""
    try:
        from distributed import Client
    except ImportError:
        raise ImportError(f"dask.distributed is not installed: {DASK_HINT}") from None
    if scheduler == "local":
        cluster = local_cluster(workers)
        return Client(cluster), cluster
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


def run_on_dask(jobs: list[ShotJob], client, on_done: Callable[..., None]) -> None:
    """Submit one task per job to ``client``; ``on_done(job, meters, range_in, mapping)`` as each shot finishes."""
    from dataclasses import replace

    from distributed import as_completed

    threads = threads_per_task(client)
    by_shot = {job.shot: job for job in jobs}
    futures = [client.submit(_task, replace(job, threads=threads), key=f"vergence-shot-{job.shot}-{os.getpid()}",
                             pure=False) for job in jobs]  # fmt: skip
    try:
        for future in as_completed(futures):
            shot, meters, range_in, mapping = future.result()
            on_done(by_shot[shot], meters, range_in, mapping)
    except BaseException:
        for f in futures:
            f.cancel()
        raise
