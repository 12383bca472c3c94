"""The input of ``vergence analyze`` and ``vergence convert``: their shared options, and the opening of the clip.

Both read a packed stereo clip or a colour + depth one (:func:`~vergence.video.open_stereo`,
:func:`~vergence.video.open_depth_clip`). The options that describe it are declared once here:
Typer copies an ``OptionInfo`` for each command that takes it as a default, so one declaration
serves both commands. :func:`open_input` guesses the kind, refuses the options of the other kind
and opens the clip, with one set of messages for both commands.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from vergence.cli._app import options_named

if TYPE_CHECKING:
    from vergence.video import DepthClip, StereoClip

# What INPUT holds: a packed stereo clip, or colour + depth.
INPUT_KINDS = ("stereo", "2d+depth")

INPUT_KIND_OPTION = typer.Option(None, "--input-kind", help=f"What INPUT holds: {', '.join(INPUT_KINDS)}; default "
                                 "from its name (_RGBD) and --depth, else stereo.")
LAYOUT_OPTION = typer.Option(None, "--layout", help="Stereo INPUT layout: sbs, half-sbs, tb, half-tb; default from "
                             "the name's tag (_LRF_Full_SBS, _Half_SBS, _LR, _TB, -lr, -tb...).")
DEPTH_KIND_OPTION = typer.Option(None, "--depth-kind", help="2D + depth: what the depth holds: disparity, inverse "
                                 "(iw3's, default), metric.")
DEPTH_SCALE_OPTION = typer.Option(None, "--depth-scale", help="2D + depth: stored 8-bit value / scale = metres or "
                                  "pixels (needed for metric or disparity depth in a video).")
FPS_OPTION = typer.Option(None, "--fps", help="Frame rate of an image folder (default 24).")
METHOD_OPTION = typer.Option(None, "--method", help="Stereo: matcher (as vergence match); default sgbm.")
MIN_DISPARITY_OPTION = typer.Option(None, "--min-disparity", help="Stereo: smallest disparity searched (px); "
                                    "default -width/8, rounded up to 16.")
MAX_DISPARITY_OPTION = typer.Option(None, "--max-disparity", help="Stereo: largest disparity searched (px); default "
                                    "width/8, rounded up to 16.")

# The parameters of open_stereo and open_depth_clip as the user typed them.
_OPEN_OPTIONS = {"layout": "--layout", "kind": "--depth-kind", "scale": "--depth-scale", "fps": "--fps"}


def check_input_kind(kind: str | None) -> None:
    """Refuse an ``--input-kind`` that is not one of :data:`INPUT_KINDS` (None: guessed later)."""
    if kind is not None and kind not in INPUT_KINDS:
        raise ValueError(f"--input-kind must be one of {', '.join(INPUT_KINDS)}; got {kind!r}")


def open_input(
    input_path: Path,
    kind: str | None,
    *,
    depth: Path | None,
    layout: str | None,
    depth_kind: str | None,
    depth_scale: float | None,
    fps: float | None,
    stereo_only: Mapping[str, object] | None = None,
    depth_only: Mapping[str, object] | None = None,
) -> tuple[StereoClip | DepthClip, str]:
    """The clip INPUT holds and its kind (``"stereo"`` or ``"2d+depth"``).

    Parameters
    ----------
    input_path : Path
        INPUT, which exists.
    kind : str or None
        ``--input-kind`` (checked by :func:`check_input_kind`); None: ``"2d+depth"`` when ``--depth``
        is given or, with no ``--layout``, when the name is tagged _RGBD, else ``"stereo"``.
    depth, layout, depth_kind, depth_scale, fps
        ``--depth``, ``--layout``, ``--depth-kind`` (None: ``"inverse"``), ``--depth-scale``, ``--fps``.
    stereo_only, depth_only : mapping of str to object, optional
        The command's other options that apply to one kind only, by option name (``{"--method": method}``);
        a value None is an option not given (pass an unset flag as None).

    Returns
    -------
    tuple of (StereoClip or DepthClip, str)
        The opened clip and its kind.

    Raises
    ------
    ValueError
        If an option of the other kind is given (``"--depth-kind apply to a 2d+depth INPUT; a.mp4 is read
        as stereo (--input-kind)"``), and the errors of the opening, naming the options.
    """
    from vergence.video import guess_layout, open_depth_clip, open_stereo

    if kind is None:
        kind = "2d+depth" if depth is not None or (layout is None and guess_layout(input_path) == "rgbd") else "stereo"
    given = {"stereo": [o for o, v in (("--layout", layout), *(stereo_only or {}).items()) if v is not None],
             "2d+depth": [o for o, v in (("--depth", depth), ("--depth-kind", depth_kind),
                                         ("--depth-scale", depth_scale), *(depth_only or {}).items()) if v is not None]}
    other = "2d+depth" if kind == "stereo" else "stereo"
    if given[other]:
        raise ValueError(f"{', '.join(given[other])} apply to a {other} INPUT; {input_path.name} is read as {kind} "
                         "(--input-kind)")
    with options_named(**_OPEN_OPTIONS):
        if kind == "stereo":
            return open_stereo(input_path, layout=layout, fps=fps), kind
        return open_depth_clip(input_path, depth=depth, kind=depth_kind or "inverse", scale=depth_scale, fps=fps), kind
