"""Write frames to a video file atomically: H.264 in 4:2:0 by default, 4:4:4 on request, audio copied.

The video is encoded into a hidden temporary file beside the target (:func:`vergence.io.atomic_write`)
and renamed when :class:`VideoWriter` closes without error: a reader (or a player) never sees a
half-written file, and an error or Ctrl-C leaves the target as it was.

Chroma subsampling: ``yuv420p`` (:data:`DEFAULT_PIXEL_FORMAT`) is what every player decodes; it
halves the colour resolution both ways, which for an anaglyph mixes the left view's red into the
right view's cyan at every edge (crosstalk): use ``yuv444p`` there (H.264 High 4:4:4 profile,
played by FFmpeg-based players such as mpv and VLC).
"""

from __future__ import annotations

import math
import os
from contextlib import ExitStack
from fractions import Fraction
from pathlib import Path
from types import TracebackType

import numpy as np

from vergence.video._av import require_av

__all__ = ["DEFAULT_CRF", "DEFAULT_PIXEL_FORMAT", "DEFAULT_PRESET", "PIXEL_FORMATS", "X264_PRESETS", "VideoWriter"]

# Pixel formats offered (name -> what it is for); the option's choices and the error read it.
PIXEL_FORMATS = {
    "yuv420p": "4:2:0, every player (default)",
    "yuv444p": "4:4:4, full colour resolution: anaglyph without chroma crosstalk",
}
DEFAULT_PIXEL_FORMAT = "yuv420p"
# x264's constant rate factor: 18 is "visually lossless" in x264's documentation; 0 is lossless.
DEFAULT_CRF = 18
# x264's speed presets, fastest first: at one CRF a faster preset is as good to the eye but larger
# (x264's documentation); "medium" is x264's default. At 3840x1080 on 2 cores "veryfast" encodes about
# twice as fast as "medium" (benchmarks/video_convert.py).
X264_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow", "slower", "veryslow")
DEFAULT_PRESET = "medium"
# x264 encodes frame sizes that are multiples of 2 in 4:2:0 (one chroma sample per 2x2 block).
_CHROMA_BLOCK = {"yuv420p": 2, "yuv444p": 1}


class VideoWriter:
    """An H.264 video written frame by frame into a temporary file, renamed to ``path`` on success.

    Parameters
    ----------
    path : str or os.PathLike
        The video file (``.mp4``, ``.mkv`` or ``.mov``); its folder must exist.
    fps : float
        Frame rate, > 0.
    width, height : int
        Frame size in pixels; even for ``yuv420p``.
    pixel_format : str
        A key of :data:`PIXEL_FORMATS`.
    crf : int
        x264 constant rate factor in [0, 51]: 0 is lossless, larger is smaller and worse.
    audio_from : str or os.PathLike, optional
        A media file whose first audio stream is copied (packets as they are, no re-encoding).
    preset : str
        One of :data:`X264_PRESETS` (speed against file size).

    Raises
    ------
    ValueError
        A bad size, rate, format, CRF or extension, or an ``audio_from`` without audio.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "grey.mp4"
    >>> with VideoWriter(out, fps=24, width=32, height=16) as video:
    ...     for _ in range(3):
    ...         video.write(np.full((16, 32, 3), 0.5, np.float32))
    >>> out.is_file(), video.frames_written
    (True, 3)
    """

    def __init__(self, path: str | os.PathLike[str], *, fps: float, width: int, height: int,
                 pixel_format: str = DEFAULT_PIXEL_FORMAT, crf: int = DEFAULT_CRF,
                 audio_from: str | os.PathLike[str] | None = None, preset: str = DEFAULT_PRESET) -> None:  # fmt: skip
        self.path = Path(path)
        if self.path.suffix.lower() not in (".mp4", ".mkv", ".mov"):
            raise ValueError(f"path must be a .mp4, .mkv or .mov file; got {self.path.name!r}")
        if not (isinstance(fps, int | float) and not isinstance(fps, bool) and math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a finite number > 0; got {fps!r}")
        if pixel_format not in PIXEL_FORMATS:
            raise ValueError(f"pixel_format must be one of {', '.join(PIXEL_FORMATS)}; got {pixel_format!r}")
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1; got {value!r}")
        block = _CHROMA_BLOCK[pixel_format]
        if width % block or height % block:
            raise ValueError(f"{pixel_format} needs an even frame size; got {width}x{height} (use yuv444p or "
                             "crop a pixel)")
        if isinstance(crf, bool) or not isinstance(crf, int | np.integer) or not 0 <= crf <= 51:
            raise ValueError(f"crf must be an integer in [0, 51]; got {crf!r}")
        if preset not in X264_PRESETS:
            raise ValueError(f"preset must be one of {', '.join(X264_PRESETS)}; got {preset!r}")
        self.preset = preset
        self.fps, self.width, self.height = float(fps), int(width), int(height)
        self.pixel_format, self.crf = pixel_format, int(crf)
        self.audio_from = None if audio_from is None else Path(audio_from)
        self.frames_written = 0
        self._stack: ExitStack | None = None
        # More options for x264 (FFmpeg's names, e.g. {"g": "8"}: a keyframe every 8 frames), set before
        # the writer opens: what the reader's seeking tests need, not an option of the API.
        self._x264_options: dict[str, str] = {}

    def __enter__(self) -> VideoWriter:
        from vergence.io import atomic_write

        av = require_av()
        stack = ExitStack()
        self._audio_in = self._audio_out = None
        try:
            if self.audio_from is not None:  # checked before the output file is started
                try:
                    source = stack.enter_context(av.open(str(self.audio_from)))
                except av.FFmpegError as exc:
                    raise ValueError(f"audio_from {self.audio_from} cannot be read: {exc}") from None
                if not source.streams.audio:
                    raise ValueError(f"audio_from {self.audio_from} holds no audio stream")
                self._audio_in, self._audio_source = source.streams.audio[0], source
            tmp = stack.enter_context(atomic_write(self.path))
            options = {"movflags": "+faststart"} if self.path.suffix.lower() in (".mp4", ".mov") else {}
            self._container = stack.enter_context(av.open(str(tmp), mode="w", options=options))
            rate = Fraction(self.fps).limit_denominator(1001)
            stream = self._container.add_stream("libx264", rate=rate)
            stream.width, stream.height, stream.pix_fmt = self.width, self.height, self.pixel_format
            stream.options = {"crf": str(self.crf), "preset": self.preset, **self._x264_options}
            self._stream = stream
            if self._audio_in is not None:
                self._audio_out = self._container.add_stream_from_template(self._audio_in)
        except BaseException as err:
            if not stack.__exit__(type(err), err, err.__traceback__):
                raise
        self._stack = stack
        return self

    def write(self, frame: object) -> None:
        """Encode one frame: ``(height, width, 3)`` float in [0, 1] (rounded to 8 bits) or uint8."""
        if self._stack is None:
            raise ValueError("write needs an open VideoWriter: use it in a with block")
        a = np.asarray(frame)
        if a.shape != (self.height, self.width, 3):
            raise ValueError(f"frame must have shape {(self.height, self.width, 3)}; got {a.shape}")
        if a.dtype != np.uint8:
            if not np.issubdtype(a.dtype, np.floating):
                raise TypeError(f"frame must be float in [0, 1] or uint8; got dtype {a.dtype}")
            if not (np.isfinite(a).all() and a.min() >= 0.0 and a.max() <= 1.0):
                raise ValueError("frame must hold finite values in [0, 1]")
            a = np.rint(a * 255.0).astype(np.uint8)
        av = require_av()
        picture = av.VideoFrame.from_ndarray(np.ascontiguousarray(a), format="rgb24")
        for packet in self._stream.encode(picture):
            self._container.mux(packet)
        self.frames_written += 1

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:  # fmt: skip
        stack, self._stack = self._stack, None
        if stack is None:
            return
        if exc_type is None:
            try:
                if self.frames_written == 0:
                    raise ValueError(f"no frame was written to {self.path}: a video needs at least one")
                for packet in self._stream.encode(None):
                    self._container.mux(packet)
                if self._audio_in is not None:
                    for packet in self._audio_source.demux(self._audio_in):
                        if packet.dts is None:
                            continue
                        packet.stream = self._audio_out
                        self._container.mux(packet)
            except BaseException as err:
                stack.__exit__(type(err), err, err.__traceback__)
                raise
        stack.__exit__(exc_type, exc, tb)
