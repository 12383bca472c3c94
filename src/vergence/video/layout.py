"""Stereo frame layouts of a video or image file, guessed from the tags in its name (iw3, Bino).

A stereo video stores both views in one frame: side by side (``sbs``, left view on the left) or top
and bottom (``tb``, left view on top), at full resolution (each view as large as the original) or
at half resolution (each view squeezed to half the width or height, ``half-sbs`` / ``half-tb``).
The names are those of :data:`vergence.display.LAYOUTS`. A 2D + depth video as iw3 writes it
(``_RGBD``) holds the colour on the left and the depth on the right (``rgbd``).

Name tags (:data:`LAYOUT_TAGS`, checked in order, the first match wins):

=====================================  ===========  =========================================
tag in the file or folder name          layout       convention
=====================================  ===========  =========================================
``_LRF``, ``Full_SBS``, ``FSBS``        sbs          iw3 (``_LRF_Full_SBS``), VR players
``Half_SBS``, ``HSBS``, ``_LR``         half-sbs     iw3 (``_LR``: half side by side)
``_TBF``, ``Full_TB``, ``FTB``, FOU     tb           iw3, VR players
``Half_TB``, ``HTB``, ``HOU``, ``_TB``  half-tb      iw3 (``_TB``: half top-bottom)
``-lrh``, ``-lrq``                      half-sbs     Bino (half width)
``-lr``                                 sbs          Bino (left-right)
``-tbh``, ``-abh``                      half-tb      Bino (half height)
``-tb``, ``-ab``                        tb           Bino (top-bottom, above-below)
``_RGBD``, ``-rgbd``                    rgbd         iw3 (colour left, depth right)
=====================================  ===========  =========================================

iw3's tags are upper case after an underscore, Bino's lower case after a hyphen: ``_LR`` is iw3's
half side by side, ``-lr`` Bino's full one. Right-first layouts (Bino's ``-rl``, ``-bt``) are not
read: their name is refused as a layout that cannot be guessed.
"""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np

__all__ = ["LAYOUT_TAGS", "STEREO_LAYOUTS", "VIDEO_LAYOUTS", "guess_layout", "layout_video_name", "split_frame"]

# The stereo layouts a frame can be split into: name -> (axis, half). axis 1 = side by side, 0 = top-bottom.
STEREO_LAYOUTS = {"sbs": (1, False), "half-sbs": (1, True), "tb": (0, False), "half-tb": (0, True)}
# Every layout a file name can carry: the stereo ones and iw3's colour + depth frames.
VIDEO_LAYOUTS = (*STEREO_LAYOUTS, "rgbd")

# (regular expression on the file name without its extension, layout); the first match wins. A tag
# ends at a separator or the end of the name (``_LR`` does not match ``_LRX``).
_END = r"(?=$|[-_.\s\[\]()])"
LAYOUT_TAGS: tuple[tuple[str, str], ...] = (
    (r"_RGBD" + _END, "rgbd"),
    (r"-rgbd" + _END, "rgbd"),
    (r"(?i:full[-_]?sbs)" + _END, "sbs"),
    (r"(?i:half[-_]?sbs)" + _END, "half-sbs"),
    (r"(?i:full[-_]?(?:tb|ou))" + _END, "tb"),
    (r"(?i:half[-_]?(?:tb|ou))" + _END, "half-tb"),
    (r"(?i)(?<![a-z])FSBS" + _END, "sbs"),
    (r"(?i)(?<![a-z])HSBS" + _END, "half-sbs"),
    (r"(?i)(?<![a-z])F(?:TB|OU)" + _END, "tb"),
    (r"(?i)(?<![a-z])H(?:TB|OU)" + _END, "half-tb"),
    (r"_LRF" + _END, "sbs"),
    (r"_TBF" + _END, "tb"),
    (r"_LR" + _END, "half-sbs"),
    (r"_TB" + _END, "half-tb"),
    (r"-lr[hq]" + _END, "half-sbs"),
    (r"-lr" + _END, "sbs"),
    (r"-(?:tb|ab)[hq]" + _END, "half-tb"),
    (r"-(?:tb|ab)" + _END, "tb"),
)

# The tag :func:`layout_video_name` gives each layout: the stereo layouts and rgbd are guessed back by the
# table above; the display-only layouts of vergence.display (anaglyph, interleaved, checkerboard,
# cross-eyed) get a tag for people that guess_layout leaves unread (a clip in them cannot be split
# back into its views; Bino's "-rl" is refused as right-first).
_NAME_TAGS = {"sbs": "_LRF_Full_SBS", "half-sbs": "_Half_SBS", "tb": "_Full_TB", "half-tb": "_Half_TB",
              "rgbd": "_RGBD", "anaglyph": "_Anaglyph", "checkerboard": "_Checkerboard", "columns": "_Columns",
              "rows": "_Rows", "cross-eyed": "-rl"}


def _name_tag(layout: str) -> str | None:
    if layout in _NAME_TAGS:
        return _NAME_TAGS[layout]
    if layout.startswith("anaglyph-"):  # anaglyph-METHOD of vergence.display.LAYOUTS
        return "_Anaglyph_" + layout.split("-", 1)[1].replace("-", "_").title()
    return None


def guess_layout(path: str | Path) -> str | None:
    """The layout named by a tag in ``path``'s file or folder name, or None when no tag is found.

    Parameters
    ----------
    path : str or os.PathLike
        A video file or an image folder; only its last component, without the extension, is read.

    Returns
    -------
    str or None
        One of :data:`VIDEO_LAYOUTS`.

    Examples
    --------
    >>> guess_layout("holiday_LRF_Full_SBS.mp4"), guess_layout("movie-tb.mkv"), guess_layout("clip.mp4")
    ('sbs', 'tb', None)
    """
    stem = Path(path).stem if Path(path).suffix else Path(path).name
    for pattern, layout in LAYOUT_TAGS:
        if re.search(pattern, stem):
            return layout
    return None


def layout_video_name(stem: str, layout: str, *, suffix: str = ".mp4") -> str:
    """A file name that carries ``layout``'s tag, e.g. ``clip_LRF_Full_SBS.mp4``.

    ``layout`` is one of :data:`VIDEO_LAYOUTS` (:func:`guess_layout` reads the name back) or another
    layout of :data:`vergence.display.LAYOUTS` (``_Anaglyph``, ``_Rows``... : named, not read back).
    """
    from vergence.display import LAYOUTS

    tag = _name_tag(layout) if isinstance(layout, str) and (layout in VIDEO_LAYOUTS or layout in LAYOUTS) else None
    if tag is None:
        raise ValueError(f"layout must be one of {', '.join(dict.fromkeys([*VIDEO_LAYOUTS, *LAYOUTS]))}; got {layout!r}")
    return f"{stem}{tag}{suffix}"


def split_frame(frame: np.ndarray, layout: str) -> tuple[np.ndarray, np.ndarray]:
    """The two views of a packed stereo frame (or the colour and depth halves of an ``rgbd`` frame).

    Half-resolution views are stretched back to the full frame size (bilinear), so that a disparity
    measured on them is in pixels of the full-resolution views.

    Parameters
    ----------
    frame : (H, W, 3) array
        A packed frame.
    layout : str
        One of :data:`VIDEO_LAYOUTS`.

    Returns
    -------
    left, right : (h, w, 3) arrays
        ``sbs``/``rgbd``: ``(H, W/2)``; ``tb``: ``(H/2, W)``; ``half-sbs`` and ``half-tb``: ``(H, W)``.

    Raises
    ------
    ValueError
        An unknown layout, or a frame dimension that does not split in two (an odd width for a side
        by side layout, an odd height for a top-bottom one).
    """
    if layout not in VIDEO_LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(VIDEO_LAYOUTS)}; got {layout!r}")
    axis, half = STEREO_LAYOUTS.get(layout, (1, False))
    h, w = frame.shape[:2]
    check_splits(w, h, layout)
    if axis == 1:
        a, b = frame[:, : w // 2], frame[:, w // 2:]
    else:
        a, b = frame[: h // 2], frame[h // 2:]
    if half:
        a, b = (cv2.resize(v, (w, h), interpolation=cv2.INTER_LINEAR) for v in (a, b))
    return a, b


def check_splits(width: int, height: int, layout: str) -> None:
    """Refuse a frame size that ``layout`` cannot split into two equal halves."""
    axis = STEREO_LAYOUTS.get(layout, (1, False))[0]
    side, size = ("width", width) if axis == 1 else ("height", height)
    if size % 2:
        what = "side by side" if axis == 1 else "top-bottom"
        raise ValueError(f"layout {layout} ({what}) needs an even frame {side}; got {width}x{height}")


def views_size(width: int, height: int, layout: str) -> tuple[int, int]:
    """``(width, height)`` of each full-resolution view of a ``layout`` frame of this size."""
    axis, half = STEREO_LAYOUTS.get(layout, (1, False))
    if half:
        return width, height
    return (width // 2, height) if axis == 1 else (width, height // 2)


def frame_from_views(left: np.ndarray, right: np.ndarray, layout: str) -> np.ndarray:
    """Pack two views into one ``layout`` frame (the inverse of :func:`split_frame` for full layouts)."""
    from vergence.display import pack

    if layout == "rgbd":
        return np.concatenate([left, right], axis=1)
    return pack(left, right, layout=layout)
