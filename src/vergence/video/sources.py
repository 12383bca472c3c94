"""Stereo and 2D + depth clips as streams of frames: what :func:`vergence.video.analyze_clip` reads.

- :func:`open_stereo`: a stereo video or image folder whose frames pack both views (``sbs``,
  ``half-sbs``, ``tb``, ``half-tb``), the layout guessed from the name (:func:`guess_layout`) or given.
- :func:`open_depth_clip`: colour + depth, either packed side by side in one clip as iw3 writes it
  (``_RGBD``: colour left, depth right) or as two clips of the same length and size (a colour
  video or folder, and a depth video or folder).

Depth conventions are those of ``vergence synthesize --depth-kind`` (:data:`vergence.io.DEPTH_KINDS`):
``inverse`` (iw3's and MPEG's: 0 = far, 1 = near), ``metric`` (z), ``disparity`` (pixels, larger =
nearer). A depth frame of a video is its grey level in [0, 1] (the mean of R, G, B); ``metric`` and
``disparity`` then need ``scale`` (8-bit value / scale = metres or pixels, 0 = unknown). A depth
folder may hold ``.pfm``/``.npy``/16-bit ``.png`` maps read by :func:`vergence.io.read_depth`.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.video.layout import STEREO_LAYOUTS, VIDEO_LAYOUTS, check_splits, guess_layout, split_frame, views_size
from vergence.video.reader import FrameReader, open_frames

__all__ = ["DepthClip", "StereoClip", "open_depth_clip", "open_stereo"]


@dataclass(frozen=True, slots=True, eq=False)
class StereoClip:
    """A stereo clip: frames that each pack a left and a right view.

    Attributes
    ----------
    reader : FrameReader
    layout : str
        One of :data:`~vergence.video.layout.STEREO_LAYOUTS`.
    frames, fps : int, float
        As the reader's :class:`~vergence.video.VideoInfo`.
    width, height : int
        Size of each full-resolution view (half-resolution views are stretched back to it).
    """

    reader: FrameReader
    layout: str

    @property
    def frames(self) -> int:
        return self.reader.info.frames

    @property
    def fps(self) -> float:
        return self.reader.info.fps

    @property
    def width(self) -> int:
        return views_size(self.reader.info.width, self.reader.info.height, self.layout)[0]

    @property
    def height(self) -> int:
        return views_size(self.reader.info.width, self.reader.info.height, self.layout)[1]

    def pairs(self, start: int = 0, stop: int | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """Yield ``(left, right)`` float32 ``(height, width, 3)`` views of frames ``start`` to ``stop``."""
        for frame in self.reader.frames(start, stop):
            yield split_frame(frame, self.layout)

    def lefts(self, start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
        """Yield the left views only (what shot detection looks at)."""
        if self.reader.files is None and self.layout in ("sbs", "tb"):  # a full-size video: convert the left view only
            from vergence.video._kernels import unit_float_kernel

            stop = self.reader._check_range(start, stop)
            for frame in self.reader._video_frames(start, stop, as_float=False):  # sizes checked by the reader
                yield unit_float_kernel(split_frame(frame, self.layout)[0])
            return
        for left, _ in self.pairs(start, stop):
            yield left


@dataclass(frozen=True, slots=True, eq=False)
class DepthClip:
    """A 2D + depth clip: a colour frame and its depth map per frame.

    Attributes
    ----------
    colour : FrameReader
        The colour frames (for an ``rgbd`` clip, the packed frames).
    depth : FrameReader or None
        The depth frames; None for an ``rgbd`` clip (its right half).
    kind : str
        A key of :data:`vergence.io.DEPTH_KINDS`.
    scale : float or None
        Stored value / scale = the kind's unit (see the module docstring).
    """

    colour: FrameReader
    depth: FrameReader | None
    kind: str
    scale: float | None

    @property
    def frames(self) -> int:
        return self.colour.info.frames

    @property
    def fps(self) -> float:
        return self.colour.info.fps

    @property
    def width(self) -> int:
        return self.colour.info.width // 2 if self.depth is None else self.colour.info.width

    @property
    def height(self) -> int:
        return self.colour.info.height

    def lefts(self, start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
        """Yield the colour frames only."""
        for frame in self.colour.frames(start, stop):
            yield split_frame(frame, "rgbd")[0] if self.depth is None else frame

    def pairs(self, start: int = 0, stop: int | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """Yield ``(image, depth)``: float32 ``(H, W, 3)`` and float32 ``(H, W)`` in the kind's unit, NaN = unknown."""
        if self.depth is None and self.colour.files is None:  # an RGBD video: split from its 8-bit frames
            from vergence.video._kernels import rgbd_kernel

            stop = self.colour._check_range(start, stop)
            for frame in self.colour._video_frames(start, stop, as_float=False):  # sizes checked by the reader
                image, grey = rgbd_kernel(frame)  # the colour and the depth's grey level in one pass
                yield image, self._depth_levels(grey)
            return
        if self.depth is None:
            for frame in self.colour.frames(start, stop):
                image, grey = split_frame(frame, "rgbd")
                yield image, self._depth_values(grey)
            return
        depth_frames = self._depth_maps(start, stop)
        for k, image in enumerate(self.colour.frames(start, stop), start):
            yield image, next(depth_frames)

    def _depth_maps(self, start: int, stop: int | None) -> Iterator[np.ndarray]:
        files = self.depth.files
        if files is not None and files[0].suffix.lower() in (".pfm", ".npy", ".png", ".pgm"):
            from vergence.io import read_depth

            stop = self.frames if stop is None else stop
            for k in range(start, stop):
                suffix = files[k].suffix.lower()
                integer = suffix in (".png", ".pgm")
                if self.kind == "inverse" or not integer:
                    d = read_depth(files[k], kind=self.kind, scale=self.scale)
                else:
                    d = read_depth(files[k], kind=self.kind, scale=self.scale if self.scale is not None else 1.0)
                if d.shape != (self.height, self.width):
                    raise ValueError(f"depth frame {k} ({files[k].name}) is {d.shape[1]}x{d.shape[0]}; the colour "
                                     f"frames are {self.width}x{self.height}")
                yield d
            return
        for frame in self.depth.frames(start, stop):
            yield self._depth_values(frame)

    def _depth_values(self, grey_rgb: np.ndarray) -> np.ndarray:
        from vergence.video.stability import grey_levels

        return self._depth_levels(grey_levels(grey_rgb))

    def _depth_levels(self, grey: np.ndarray) -> np.ndarray:
        """A depth frame's grey levels in [0, 1] to the kind's unit (module docstring)."""
        if self.kind == "inverse":
            return grey if self.scale is None else (grey / np.float32(self.scale)).astype(np.float32)
        values = np.rint(grey * 255.0).astype(np.float32) / np.float32(self.scale)
        values[values == 0] = np.nan  # 0 = unknown, as in read_depth's 8-bit files
        return values


def _reader(path: str | os.PathLike[str], fps: float | None) -> FrameReader:
    return open_frames(path, fps=fps)


def open_stereo(path: str | os.PathLike[str], *, layout: str | None = None, fps: float | None = None) -> StereoClip:
    """Open a stereo video or frame folder; ``layout`` overrides the one its name tags.

    Parameters
    ----------
    path : str or os.PathLike
        A video file or a folder of numbered frames.
    layout : str, optional
        One of ``sbs``, ``half-sbs``, ``tb``, ``half-tb``; default: guessed from the name
        (:func:`~vergence.video.layout.guess_layout`).
    fps : float, optional
        As :func:`~vergence.video.open_frames`.

    Raises
    ------
    ValueError
        A layout that cannot be guessed or is not a stereo one, a frame that does not split in two
        (an odd width for a side-by-side layout, half or full), and the errors of
        :func:`~vergence.video.open_frames` (unreadable, zero-length).
    """
    if layout is not None and layout not in STEREO_LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(STEREO_LAYOUTS)}; got {layout!r}")
    if layout is None:
        guessed = guess_layout(path)
        name = Path(path).name or str(Path(path).resolve())  # "." has no name
        if guessed is None:
            raise ValueError(f"cannot guess the stereo layout of {name}: its name carries no tag such as "
                             f"_LRF_Full_SBS, _Half_SBS, _LR, _TB, -lr, -tb; give the layout ({', '.join(STEREO_LAYOUTS)})")
        if guessed not in STEREO_LAYOUTS:
            raise ValueError(f"{name} is tagged {guessed!r} (colour + depth), not a stereo layout: open it as "
                             "a 2D + depth clip, or give the layout")
        layout = guessed
    reader = _reader(path, fps)
    check_splits(reader.info.width, reader.info.height, layout)
    return StereoClip(reader, layout)


def open_depth_clip(path: str | os.PathLike[str], *, depth: str | os.PathLike[str] | None = None,
                    kind: str = "inverse", scale: float | None = None, fps: float | None = None) -> DepthClip:  # fmt: skip
    """Open a 2D + depth clip: an ``rgbd`` clip (colour left, depth right), or colour and ``depth`` clips.

    Parameters
    ----------
    path : str or os.PathLike
        The packed ``rgbd`` video or folder, or the colour clip when ``depth`` is given.
    depth : str or os.PathLike, optional
        The depth clip (video or folder), same frame count and size as the colour clip.
    kind : str
        A key of :data:`vergence.io.DEPTH_KINDS`; default ``inverse`` (iw3's convention).
    scale : float, optional
        See the module docstring; needed for ``metric``/``disparity`` depth stored as video frames.
    fps : float, optional
        As :func:`~vergence.video.open_frames`.

    Raises
    ------
    ValueError
        An unknown kind, a missing scale, a depth clip of another length or size than the colour
        one, an odd width for a packed ``rgbd`` frame, and the errors of
        :func:`~vergence.video.open_frames`.
    """
    from vergence.io import DEPTH_KINDS

    if kind not in DEPTH_KINDS:
        raise ValueError(f"kind must be one of {', '.join(DEPTH_KINDS)}; got {kind!r}")
    if scale is not None and not (isinstance(scale, int | float) and np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a finite number > 0; got {scale!r}")
    colour = _reader(path, fps)
    if depth is None:
        check_splits(colour.info.width, colour.info.height, "rgbd")
        stored = None
    else:
        stored = _reader(depth, fps)
        a, b = colour.info, stored.info
        if b.frames != a.frames:
            raise ValueError(f"depth clip {Path(depth).name} has {b.frames} frames; the colour clip "
                             f"{Path(path).name} has {a.frames}")
        if (b.width, b.height) != (a.width, a.height):
            raise ValueError(f"depth clip {Path(depth).name} is {b.width}x{b.height}; the colour clip "
                             f"{Path(path).name} is {a.width}x{a.height}")
    video_depth = stored is None or stored.files is None or stored.files[0].suffix.lower() not in (
        ".pfm", ".npy", ".png", ".pgm")
    if kind != "inverse" and scale is None and video_depth:
        raise ValueError(f"{kind} depth stored as video frames needs a scale (8-bit value / scale = "
                         f"{'metres' if kind == 'metric' else 'pixels'})")
    return DepthClip(colour, stored, kind, scale)
