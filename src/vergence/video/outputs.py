"""Where ``vergence convert`` writes: the output's name (its layout tag) and the rule that nothing is lost.

:func:`converted_path` names the output; :func:`check_new_output` refuses an output that exists (a video
file, or an image folder holding files) unless the caller says to replace it: converting ``x_RGBD.mp4``
into a folder that holds ``x_LRF_Full_SBS.mp4`` (another clip, or an earlier conversion) leaves that
file as it was.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

__all__ = ["VIDEO_SUFFIXES", "check_new_output", "converted_path"]

# Output containers (anything else is an image folder of PNG frames).
VIDEO_SUFFIXES = (".mp4", ".mkv", ".mov")


def converted_path(out: str | os.PathLike[str], source: str | os.PathLike[str], layout: str, *,
                   images: bool = False) -> Path:  # fmt: skip
    """The output path of a conversion, its name carrying the layout tag (:func:`~vergence.video.layout_video_name`).

    ``out`` an existing folder: the output goes inside it, named after ``source`` (its own layout tag
    taken off) with ``layout``'s tag, a ``.mp4`` (or, with ``images``, a folder). ``out`` a file name:
    its tag is added when it carries none; a tag of another layout is refused.

    Examples
    --------
    >>> converted_path("movie.mp4", "in_RGBD.mp4", "sbs").name
    'movie_LRF_Full_SBS.mp4'
    >>> converted_path("movie_Half_SBS.mkv", "in.mp4", "half-sbs").name
    'movie_Half_SBS.mkv'
    """
    from vergence.video.layout import LAYOUT_TAGS, guess_layout, layout_video_name

    o = Path(out)
    if o.is_dir():
        stem = Path(source).stem if Path(source).suffix else Path(source).name
        for pattern, _ in LAYOUT_TAGS:
            stem = re.sub(pattern, "", stem)
        stem = re.sub(r"[-_.\s]+$", "", re.sub(r"([-_])[-_]+", r"\1", stem)) or "converted"  # "a_LRF_Full_SBS" -> "a"
        return o / layout_video_name(stem, layout, suffix="" if images else ".mp4")
    suffix = o.suffix.lower()
    if images == (suffix in VIDEO_SUFFIXES):
        what = "a folder (no extension)" if images else f"a {', '.join(VIDEO_SUFFIXES)} file or a folder (no extension)"
        raise ValueError(f"out must be {what}; got {o.name!r}")
    stem = o.name[: len(o.name) - len(o.suffix)] if suffix else o.name
    guessed = guess_layout(o)
    if guessed == layout or stem.endswith(layout_video_name("", layout, suffix="")):
        return o
    if guessed is not None:
        raise ValueError(f"out {o.name} is tagged {guessed!r}; the output layout is {layout!r}")
    return o.with_name(layout_video_name(stem, layout, suffix=o.suffix))


def check_new_output(out: str | os.PathLike[str], *, force: bool = False, name: str = "out",
                     hint: str = "force=True") -> None:  # fmt: skip
    """Refuse ``out`` when it exists (a file, a link, or a folder holding anything) unless ``force``.

    An empty folder is not refused (nothing in it is lost). ``name`` and ``hint`` word the message as
    the caller's user spells them (``--out``, ``--force``).

    Raises
    ------
    FileExistsError
        ``out OUT exists: give force=True to replace it``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "x_LRF_Full_SBS.mp4").write_bytes(b"a clip")
    >>> check_new_output(folder / "x_LRF_Full_SBS.mp4")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    FileExistsError: out .../x_LRF_Full_SBS.mp4 exists: give force=True to replace it
    >>> check_new_output(folder / "x_LRF_Full_SBS.mp4", force=True)
    """
    o = Path(out)
    if force:
        return
    if o.is_dir() and not o.is_symlink():
        if any(o.iterdir()):
            raise FileExistsError(f"{name} {o} exists and holds files: give {hint} to replace it")
        return
    if o.exists() or o.is_symlink():
        raise FileExistsError(f"{name} {o} exists: give {hint} to replace it")
