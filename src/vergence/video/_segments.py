"""The work folder of a conversion: one segment per shot, a manifest, and the join at the end.

``vergence convert`` writes each shot as its own segment (an H.264 file, or a folder of PNG frames)
in a hidden work folder beside the output, ``.NAME.parts``; each segment is written atomically, so
a segment that exists is finished. ``--resume`` reuses them when the manifest (input, options,
shots) is the same. The join copies the segments' packets one after the other into the output (no
re-encoding: the shots were encoded with one set of x264 options), then the input's audio, into a
temporary file renamed at the end; for an image folder it moves the frames into the output folder.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vergence.video._av import require_av

MANIFEST = "manifest.json"
# Frames that may wait for the encoder thread of a segment (each a packed 8-bit frame: 12 MB at 3840x1080).
QUEUED_FRAMES = 3


def work_folder(out: Path) -> Path:
    """The hidden work folder beside ``out``."""
    return out.with_name(f".{out.name}.parts")


def segment_path(work: Path, shot: int, start: int, end: int, images: bool, suffix: str) -> Path:
    """Where shot ``shot`` (frames ``[start, end)``) is written."""
    return work / f"shot_{shot:04d}_{start:06d}-{end:06d}{'' if images else suffix}"


def prepare_work(work: Path, manifest: dict, resume: bool) -> None:
    """Create ``work`` (or, with ``resume``, check that its manifest is this conversion's)."""
    found = work / MANIFEST
    if work.exists():
        if not found.is_file():
            raise ValueError(f"work folder {work} exists and is not a conversion's (no {MANIFEST}): remove it")
        if resume:
            try:
                old = json.loads(found.read_text())
            except (OSError, ValueError):
                old = None
            if old != manifest:
                raise ValueError(f"--resume: the work folder {work} belongs to another input or other options; run "
                                 "without --resume to start again")
            return
        shutil.rmtree(work)
    work.mkdir()
    found.write_text(json.dumps(manifest, indent=1))


def write_range(work: Path, piece: int, matched) -> None:
    """Record what matching a piece found (:class:`vergence.video._histogram.MatchedPiece`; a later ``--resume``
    needs its histogram for its shot's psi)."""
    from vergence.io import atomic_write

    h = matched.histogram
    with atomic_write(work / f"range_{piece:04d}.npz") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, counts=h.counts, extremes=np.array([h.lo, h.hi]), search_px=np.array(matched.search_px),
                 frames=np.array([matched.widened_frames, matched.saturated_frames]),
                 edges=np.array(matched.edges, np.float64))  # fmt: skip


def read_range(work: Path, piece: int, width: int):
    """A finished piece's :class:`vergence.video._histogram.MatchedPiece`, as :func:`write_range` recorded it."""
    from vergence.video._histogram import MatchedPiece, ShotHistogram

    path = work / f"range_{piece:04d}.npz"
    try:
        with np.load(path) as data:
            h = ShotHistogram(width)
            if data["counts"].shape != h.counts.shape:
                raise ValueError("another width")
            h.counts[:] = data["counts"]
            h.lo, h.hi = (float(v) for v in data["extremes"])
            lo, hi = (int(v) for v in data["search_px"])
            widened, saturated = (int(v) for v in data["frames"])
            left, right = (float(v) for v in data["edges"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"--resume: {path} is missing or damaged ({type(exc).__name__}): run without --resume") from None
    return MatchedPiece(h, (lo, hi), widened, saturated, (left, right))


def join_videos(segments: list[Path], out: Path, audio_from: Path | None, duration_s: float, *,
                replace: bool = False) -> None:  # fmt: skip
    """Copy the packets of ``segments`` one after the other into ``out`` (atomically), then the audio.

    Audio packets past ``duration_s`` (the video's length) are left out: a truncated input's audio
    is cut where its converted video ends. An existing ``out`` is replaced only with ``replace``
    (else :class:`FileExistsError`, also when it appeared while joining).
    """
    from vergence.io import atomic_write

    av = require_av()
    options = {"movflags": "+faststart"} if out.suffix.lower() in (".mp4", ".mov") else {}
    with atomic_write(out, replace=replace) as tmp, av.open(str(tmp), mode="w", options=options) as container:
        with av.open(str(segments[0])) as first:
            template = first.streams.video[0]
            stream = container.add_stream_from_template(template)
            stream.time_base = template.time_base
        audio_in = audio_out = source = None
        if audio_from is not None:
            try:
                source = av.open(str(audio_from))
            except av.FFmpegError:
                source = None
            if source is not None and source.streams.audio:
                audio_in = source.streams.audio[0]
                audio_out = container.add_stream_from_template(audio_in)
        try:
            offset = 0
            for path in segments:
                with av.open(str(path)) as seg:
                    vs = seg.streams.video[0]
                    end = offset
                    for packet in seg.demux(vs):
                        if packet.dts is None:
                            continue
                        packet.pts = None if packet.pts is None else packet.pts + offset
                        packet.dts = packet.dts + offset
                        end = max(end, (packet.pts if packet.pts is not None else packet.dts) + (packet.duration or 0))
                        packet.stream = stream
                        container.mux(packet)
                    offset = end
            if audio_in is not None:
                for packet in source.demux(audio_in):
                    if packet.dts is None:
                        continue
                    if packet.pts is not None and float(packet.pts * audio_in.time_base) >= duration_s:
                        break
                    packet.stream = audio_out
                    container.mux(packet)
        finally:
            if source is not None:
                source.close()


def join_folders(segments: list[Path], out: Path, *, replace: bool = False) -> None:
    """Link (or copy) the frames of the segment folders into the folder ``out`` (all or nothing).

    An ``out`` holding files is refused (:class:`FileExistsError`) unless ``replace``; then it is replaced
    whole (no frame of an older, longer conversion is left among the new ones), the old folder moved
    aside until the new one is in place.
    """
    import uuid

    from vergence.video.outputs import check_new_output

    check_new_output(out, force=replace)
    tmp = out.with_name(f".{out.name}.tmp-{uuid.uuid4().hex[:12]}")
    old = out.with_name(f".{out.name}.old-{uuid.uuid4().hex[:12]}")
    tmp.mkdir()
    try:
        for folder in segments:
            for f in sorted(folder.iterdir()):
                try:  # a link keeps the segment whole until the join is committed (Ctrl-C, then --resume)
                    os.link(f, tmp / f.name)
                except OSError:
                    shutil.copy2(f, tmp / f.name)
        if out.exists():
            os.rename(out, old)
        os.rename(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
        if old.exists():
            if out.exists():
                shutil.rmtree(old, ignore_errors=True)
            else:  # the new folder did not arrive: the old one back
                os.rename(old, out)


class Stopped:
    """Wraps a frame stream; a ValueError mid-way (truncated or damaged input) ends it and is kept."""

    def __init__(self) -> None:
        self.count = 0
        self.reason: str | None = None

    def wrap(self, items):
        it = iter(items)
        while True:
            try:
                item = next(it)
            except StopIteration:
                return
            except ValueError as exc:
                self.reason = str(exc)
                return
            self.count += 1
            yield item


def counted(items, report: Callable[[str, int, int], None], phase: str, total: int):
    for k, item in enumerate(items, 1):
        yield item
        report(phase, k, total)


class Segment:
    """One shot's output: a VideoWriter, or an atomic folder of PNG frames, fed by a worker thread.

    Encoding (x264, PNG) runs in its own thread while the caller synthesises the next frame (PyAV and
    the PNG writer release the GIL); at most :data:`QUEUED_FRAMES` frames wait. An error of the worker
    is raised by the next ``write`` or by ``__exit__``; the segment is then abandoned (nothing renamed).
    """

    def __init__(self, path: Path, images: bool, fps: float, shape: tuple[int, ...], pixel_format: str, crf: int,
                 preset: str, writer: type) -> None:  # fmt: skip
        self.path, self.images = path, images
        if images:
            from vergence.io import atomic_folder

            self._ctx = atomic_folder(path)
        else:
            self._ctx = writer(path, fps=fps, width=shape[1], height=shape[0], pixel_format=pixel_format, crf=crf,
                               preset=preset)  # fmt: skip
        self._error: BaseException | None = None

    def __enter__(self) -> Segment:
        import queue
        import threading

        self._target = self._ctx.__enter__()
        self._queue: queue.Queue = queue.Queue(maxsize=QUEUED_FRAMES)
        self._thread = threading.Thread(target=self._work, name=f"segment {self.path.name}", daemon=True)
        self._thread.start()
        return self

    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self._error is not None:
                continue  # drain after an error
            frame, k = item
            try:
                if self.images:
                    from vergence.io import write_image

                    write_image(self._target / f"frame_{k:06d}.png", frame)
                else:
                    self._target.write(frame)
            except BaseException as err:  # raised in the caller's thread
                self._error = err

    def write(self, frame: np.ndarray, k: int) -> None:
        if self._error is not None:
            raise self._error
        self._queue.put((frame, k))

    def __exit__(self, exc_type: object, exc: BaseException | None, tb: object) -> None:
        self._queue.put(None)
        self._thread.join()
        if exc is None and self._error is not None:
            err = self._error
            self._ctx.__exit__(type(err), err, err.__traceback__)
            raise err
        self._ctx.__exit__(exc_type, exc, tb)
