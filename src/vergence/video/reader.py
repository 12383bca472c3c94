"""Frames of a video file or of a numbered image folder, one at a time (never all in memory).

:func:`open_frames` gives a :class:`FrameReader`: its :class:`VideoInfo` (frame count, frame rate,
size) is known before any frame is decoded, and :meth:`FrameReader.frames` yields float32 RGB
frames in [0, 1]. Videos are decoded with PyAV (the ``video`` extra, see
:mod:`vergence.video._av`); folders hold one image per frame, ordered by the last number in the
file name (``frame_9.png`` before ``frame_10.png``).

A range ``frames(start, stop)`` of a video seeks to the keyframe at or before ``start`` and decodes
from there, naming each frame by its timestamp (frame k at ``start_time + k / rate``): a Dask task or
a shot late in a long clip decodes one GOP (x264: up to 250 frames) before its first frame, not the
whole clip before it. The frames are those of a decode from frame 0, bit for bit. Where the
timestamps do not number the frames (no timestamps, a variable frame rate, a gap, a header that
counts frames the stream does not hold: checked on the packets from the last keyframe to the end,
and frame by frame after the seek), or FFmpeg refuses the seek or lands past ``start``, the reader
decodes from frame 0 as it always did. A stream whose timestamps drift off the grid in the middle
and come back to it by its last keyframe is outside what these checks see.

Refused in one line (``ValueError``, or ``OSError`` for a file that cannot be read at all): a file
FFmpeg cannot open or that holds no video stream, a clip of zero frames, a folder with no numbered
images or with two images of one number, a frame that cannot be decoded, and a video that ends
before the frame count of its header (truncated): the message says at which frame it stopped.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from vergence.video._av import require_av

__all__ = ["DEFAULT_FOLDER_FPS", "FRAME_SUFFIXES", "FrameReader", "VideoInfo", "open_frames"]

# The frame rate given to an image folder when the caller names none (cinema's 24 frames/s).
DEFAULT_FOLDER_FPS = 24.0
# Image files a folder of frames may hold (read by vergence.io.read_image); depth folders may also
# hold .pfm/.npy/.pgm maps (vergence.io.read_depth).
FRAME_SUFFIXES = (".png", ".jpg", ".jpeg", ".ppm", ".pgm", ".pfm", ".npy", ".tif", ".tiff")
# How far a frame's timestamp may sit from its slot on the frame-rate grid, in frames: containers round
# timestamps to their time base (Matroska's millisecond puts a frame at 24 frames/s up to 0.012 of a frame
# off); a timestamp further off means the timestamps do not number the frames, and the reader does not
# seek. A quarter leaves room for rounding at up to 500 frames/s in milliseconds.
_PTS_SLACK = Fraction(1, 4)


@dataclass(frozen=True, slots=True)
class VideoInfo:
    """What is known of a clip before decoding it.

    Attributes
    ----------
    frames : int
        Number of frames (>= 1).
    fps : float
        Frames per second (> 0).
    width, height : int
        Size of a stored frame, pixels (both views together for a packed stereo frame).
    """

    frames: int
    fps: float
    width: int
    height: int

    def __post_init__(self) -> None:
        for name in ("frames", "width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1; got {value!r}")
        if not (isinstance(self.fps, int | float) and math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be a finite number > 0; got {self.fps!r}")


class FrameReader:
    """A clip's frames, decoded on demand. Build it with :func:`open_frames`.

    Attributes
    ----------
    path : pathlib.Path
        The video file or the image folder.
    info : VideoInfo
    """

    def __init__(self, path: Path, info: VideoInfo, files: tuple[Path, ...] | None) -> None:
        self.path = path
        self.info = info
        self._files = files

    @property
    def files(self) -> tuple[Path, ...] | None:
        """The frame files of a folder (or the one image), in order; None for a video file."""
        return self._files

    def __repr__(self) -> str:
        i = self.info
        return f"FrameReader({str(self.path)!r}, frames={i.frames}, fps={i.fps:g}, size={i.width}x{i.height})"

    def frames(self, start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
        """Yield frames ``start`` to ``stop`` (exclusive; default the last) as float32 ``(H, W, 3)`` in [0, 1].

        A video is decoded from the keyframe at or before ``start`` where its timestamps number its
        frames, else from frame 0 (the module docstring); the frames are the same either way.

        Raises
        ------
        ValueError
            A range outside ``[0, frames]``, a frame that cannot be decoded, or a video that ends before
            ``stop`` (the message names the frame where it stopped).
        """
        stop = self._check_range(start, stop)
        if self._files is not None:
            yield from self._folder_frames(start, stop)
        else:
            yield from self._video_frames(start, stop)

    def _check_range(self, start: object, stop: object) -> int:
        """``stop`` (None: the frame count) after checking ``0 <= start <= stop <= frames``."""
        n = self.info.frames
        stop = n if stop is None else stop
        for name, value in (("start", start), ("stop", stop)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise TypeError(f"{name} must be an integer; got {type(value).__name__}")
        if not 0 <= start <= stop <= n:
            raise ValueError(f"frame range must satisfy 0 <= start <= stop <= {n}; got start={start}, stop={stop}")
        return int(stop)

    def _folder_frames(self, start: int, stop: int) -> Iterator[np.ndarray]:
        from vergence.io import read_image

        for k in range(start, stop):
            image = read_image(self._files[k])
            if image.ndim == 2:
                image = np.repeat(image[:, :, None], 3, axis=2)
            if image.shape[:2] != (self.info.height, self.info.width):
                raise ValueError(f"frame {k} of {self.path} ({self._files[k].name}) is {image.shape[1]}x"
                                 f"{image.shape[0]}; the first frame is {self.info.width}x{self.info.height}")
            yield image

    def _video_frames(self, start: int, stop: int, as_float: bool = True) -> Iterator[np.ndarray]:
        """Frames ``start`` to ``stop`` of the video: seeking to the keyframe at or before ``start`` when the
        stream's timestamps number its frames (:class:`_FrameGrid`), else decoding from frame 0. ``as_float``
        False: the decoded uint8 RGB frames (:mod:`vergence.video.sources` converts what it needs itself)."""
        if start == stop:
            return
        from vergence.video._kernels import unit_float_kernel

        av = require_av()
        wanted = start  # the next frame the caller gets
        for seeking in (True, False) if start > 0 else (False,):
            k: int | None = None if seeking else 0  # index of the next frame out of the decoder; None: unknown yet
            try:
                with av.open(str(self.path)) as container:
                    stream = container.streams.video[0]
                    # Slice threads only: FFmpeg's frame threads hang when a decoder with frames in flight is
                    # closed (a consumer that stops early), measured with thread_type="AUTO" on PyAV 18.
                    stream.thread_type = "SLICE"
                    grid = _seek(container, stream, wanted, self.info.frames) if seeking else None
                    if seeking and grid is None:
                        continue  # not a constant-rate grid, or a seek FFmpeg refused: from frame 0
                    decoded = self._decoded(container, stream)
                    try:
                        for frame in decoded:
                            if grid is not None:  # the frame's index from its timestamp, checked
                                j = grid.index(frame.pts)
                                if j is None or ((j > wanted or not frame.key_frame) if k is None else j != k):
                                    break  # no grid after all, or a seek past the frame wanted: from frame 0
                                k = j
                            if k >= wanted:
                                rgb = frame.to_ndarray(format="rgb24")
                                if rgb.shape[:2] != (self.info.height, self.info.width):
                                    raise ValueError(f"frame {k} of video {self.path} is {rgb.shape[1]}x{rgb.shape[0]}; "
                                                     f"the stream is {self.info.width}x{self.info.height}")
                                yield unit_float_kernel(rgb) if as_float else rgb  # v / 255 in float32
                                wanted = k + 1
                            k += 1
                            if k >= stop:
                                return
                        else:
                            if k is not None:
                                raise ValueError(f"video {self.path} stops after {k} frames; its header announces "
                                                 f"{self.info.frames}: truncated")
                            # a seek that found no frame (into a cut file): from frame 0, which names where it stops
                    finally:
                        decoded.close()  # drains the decoder before the container closes
            except av.FFmpegError as exc:
                if k is None:
                    continue  # nothing decoded since the seek: from frame 0, which names where it fails
                raise ValueError(f"video {self.path} cannot be decoded past frame {k} of {self.info.frames} "
                                 f"({_reason(exc)}): damaged or truncated") from None

    @staticmethod
    def _decoded(container: object, stream: object) -> Iterator[object]:
        """The decoded frames (``av.VideoFrame``), in batches of the frames each packet releases.

        A batch is taken out of the decoder before it is handed on, so the caller's generator is never
        suspended inside PyAV's decoder, and the decoder is drained when the caller stops early (a
        consumer that takes one frame) before the container closes.
        """
        try:
            for packet in container.demux(stream):
                yield from list(stream.decode(packet))
        finally:
            try:
                for _ in stream.decode(None):  # drain the decoder before the container closes
                    pass
            except require_av().FFmpegError:  # a damaged stream: its own error is already on its way
                pass


@dataclass(frozen=True, slots=True)
class _FrameGrid:
    """The timestamps of a constant-rate stream: frame k at ``origin + k * ticks``, in the stream's time base.

    ``origin`` is the stream's start time and ``ticks = 1 / (rate * time_base)`` a frame's duration in
    time-base units (512 for 24 frames/s in MP4's 1/12288; 41.67 in Matroska's milliseconds).
    """

    origin: int
    ticks: Fraction

    def index(self, pts: int | None) -> int | None:
        """The frame whose slot holds ``pts`` (nearest slot); None for no timestamp or one off the grid."""
        if pts is None:
            return None
        x = (pts - self.origin) / self.ticks
        k = round(x)
        return k if abs(x - k) <= _PTS_SLACK else None

    def pts(self, k: int) -> int:
        """The timestamp of frame ``k``'s slot, rounded to the time base."""
        return self.origin + round(k * self.ticks)


def _grid(stream: object) -> _FrameGrid | None:
    """The stream's frame grid from its start time, time base and average rate; None if one is missing."""
    rate, time_base, origin = stream.average_rate, stream.time_base, stream.start_time
    if not rate or not time_base or origin is None or rate <= 0 or time_base <= 0:
        return None
    return _FrameGrid(int(origin), 1 / (Fraction(rate) * Fraction(time_base)))


def _seek(container: object, stream: object, k: int, frames: int) -> _FrameGrid | None:
    """Seek to the keyframe at or before frame ``k``: the stream's grid, or None where seeking is not reliable.

    Reliable means: the stream has a grid (:func:`_grid`), and the packets from the last keyframe to the
    end carry the timestamps of frames ``j`` to ``frames - 1``, one each (a variable frame rate, a gap or
    a count in the header that the stream does not hold fails this); the frames decoded after the seek
    are checked against the grid one by one (in ``FrameReader._video_frames``).
    """
    av = require_av()
    grid = _grid(stream)
    if grid is None:
        return None
    try:
        container.seek(grid.pts(frames - 1), stream=stream, backward=True, any_frame=False)
        tail = [grid.index(packet.pts) for packet in container.demux(stream) if packet.size]
        if not tail or None in tail or sorted(tail) != list(range(frames - len(tail), frames)):
            return None
        container.seek(grid.pts(k), stream=stream, backward=True, any_frame=False)
    except av.FFmpegError:
        return None
    return grid


def _reason(exc: Exception) -> str:
    text = getattr(exc, "strerror", None) or str(exc)
    return " ".join(str(text).split())


def _frame_number(path: Path) -> int | None:
    found = re.findall(r"\d+", path.stem)
    return int(found[-1]) if found else None


def _folder_files(folder: Path) -> tuple[Path, ...]:
    numbered: dict[int, Path] = {}
    for p in folder.iterdir():
        if p.name.startswith(".") or p.suffix.lower() not in FRAME_SUFFIXES or not p.is_file():
            continue
        k = _frame_number(p)
        if k is None:
            continue
        if k in numbered:
            raise ValueError(f"frame folder {folder} holds two frames numbered {k}: {numbered[k].name} and {p.name}")
        numbered[k] = p
    if not numbered:
        raise ValueError(f"frame folder {folder} holds no numbered frames ({', '.join(FRAME_SUFFIXES)}): "
                         "a zero-length clip")
    return tuple(numbered[k] for k in sorted(numbered))


def open_frames(path: str | os.PathLike[str], *, fps: float | None = None) -> FrameReader:
    """Open a video file or a folder of numbered images as a :class:`FrameReader`.

    Parameters
    ----------
    path : str or os.PathLike
        A video file (any container and codec FFmpeg reads: ``.mp4``, ``.mkv``, ``.mov``...), a folder
        of numbered images, or one image (a clip of one frame; :data:`FRAME_SUFFIXES`).
    fps : float, optional
        Frame rate of a folder (default :data:`DEFAULT_FOLDER_FPS`); for a video, overrides the
        rate of its header.

    Returns
    -------
    FrameReader

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        A file FFmpeg cannot open or without a video stream, zero frames, a folder without numbered
        frames, an ``fps`` that is not a finite number > 0.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from vergence.io import write_image
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> for k in range(3):
    ...     write_image(folder / f"frame_{k:03d}.png", np.full((4, 6, 3), k / 4))
    >>> reader = open_frames(folder)
    >>> reader.info
    VideoInfo(frames=3, fps=24.0, width=6, height=4)
    >>> [round(float(f[0, 0, 0]), 3) for f in reader.frames()]
    [0.0, 0.251, 0.502]
    """
    if fps is not None and not (isinstance(fps, int | float) and not isinstance(fps, bool) and math.isfinite(fps)
                                and fps > 0):
        raise ValueError(f"fps must be a finite number > 0; got {fps!r}")
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"no such video or frame folder: {p}")
    image = p.is_file() and p.suffix.lower() in FRAME_SUFFIXES
    if p.is_dir() or image:
        from vergence.io import read_image

        files = _folder_files(p) if p.is_dir() else (p,)
        height, width = read_image(files[0]).shape[:2]  # the first frame sets the clip's size
        info = VideoInfo(frames=len(files), fps=float(fps or DEFAULT_FOLDER_FPS), width=int(width), height=int(height))
        return FrameReader(p, info, files)
    return FrameReader(p, _video_info(p, fps), None)


def _video_info(path: Path, fps: float | None) -> VideoInfo:
    av = require_av()
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                raise ValueError(f"{path} holds no video stream")
            stream = container.streams.video[0]
            width, height = stream.codec_context.width, stream.codec_context.height
            rate = stream.average_rate or stream.guessed_rate or stream.base_rate
            frames = int(stream.frames)
            if frames <= 0:  # containers without a frame count (e.g. .mkv): count the packets
                frames, end = 0, 0.0
                try:
                    for packet in container.demux(stream):
                        frames += 1 if packet.size else 0
                        if packet.size and packet.pts is not None and packet.time_base:
                            end = max(end, float((packet.pts + (packet.duration or 0)) * packet.time_base))
                except av.EOFError:  # an empty or cut stream ends the count
                    pass
                # A cut file's packets end before the duration its header announces (a gap in the timestamps does
                # not: its last packet still ends there): announce the header's frame count, so that reading stops
                # with the message of a truncated MP4 (where it stopped, out of how many).
                declared = _declared_frames(container, stream, rate)
                if declared is not None and frames < declared and rate and end < (declared - 0.5) / float(rate):
                    frames = declared
    except av.EOFError:
        raise ValueError(f"video {path} ends before its first frame: a zero-length (or truncated) clip") from None
    except av.FFmpegError as exc:
        raise ValueError(f"cannot read video {path}: {_reason(exc)}") from None
    if frames < 1:
        raise ValueError(f"video {path} holds no frames: a zero-length clip")
    if not width or not height:
        raise ValueError(f"cannot read video {path}: its video stream has no frame size")
    rate_value = float(fps) if fps is not None else (float(rate) if rate else 0.0)
    if not rate_value > 0:
        raise ValueError(f"video {path} declares no frame rate: give one (fps)")
    return VideoInfo(frames=frames, fps=rate_value, width=int(width), height=int(height))


def _declared_frames(container: object, stream: object, rate: object) -> int | None:
    """Frames the header's duration announces, ``round(duration x rate)``: the stream's ``DURATION`` tag
    (Matroska), else the stream's duration, else the container's when the video is its only stream; None
    when none is known."""
    if not rate:
        return None
    seconds = None
    tag = (stream.metadata or {}).get("DURATION") or (stream.metadata or {}).get("duration")
    match = re.fullmatch(r"(\d+):(\d{2}):(\d{2}(?:\.\d+)?)", tag.strip()) if isinstance(tag, str) else None
    if match:
        seconds = int(match[1]) * 3600 + int(match[2]) * 60 + float(match[3])
    elif stream.duration and stream.time_base:
        seconds = float(stream.duration * stream.time_base)
    elif container.duration and len(container.streams) == 1:
        seconds = container.duration / 1_000_000  # AV_TIME_BASE
    if seconds is None or not seconds > 0:
        return None
    return int(round(seconds * float(rate)))
