"""The input of ``vergence convert`` in the command line's words: its options and the opening of the clip.

The parameters and the opening are the library's (:mod:`vergence.commands._video`), shared with
``vergence analyze``'s work; here they become Typer options (``--layout``, the argument ``INPUT``)
and their refusals the command line's one-line errors.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from vergence.commands._spec import Parameter, ParameterError
from vergence.commands._video import (DEPTH_KIND, DEPTH_SCALE, FPS, INPUT_KIND, LAYOUT, MAX_DISPARITY, METHOD,
                                      MIN_DISPARITY)  # fmt: skip
from vergence.commands._video import check_input_kind as _check_input_kind
from vergence.commands._video import open_input as _open_input

if TYPE_CHECKING:
    from vergence.video import DepthClip, StereoClip

__all__ = ["DEPTH_KIND_OPTION", "DEPTH_SCALE_OPTION", "FPS_OPTION", "INPUT_KIND_OPTION", "LAYOUT_OPTION",
           "MAX_DISPARITY_OPTION", "METHOD_OPTION", "MIN_DISPARITY_OPTION", "check_input_kind", "open_input"]


def _spelled(name: str) -> str:
    """A parameter of the input as ``vergence convert`` spells it: ``INPUT``, else ``--name-with-dashes``."""
    return "INPUT" if name == "input_path" else "--" + name.replace("_", "-")


def _option(p: Parameter) -> Any:
    """The Typer option of a library parameter (Typer copies it for each command that takes it as a default)."""
    return typer.Option(p.default, p.cli, help=ParameterError(p.help).spelled(_spelled))


INPUT_KIND_OPTION = _option(INPUT_KIND)
LAYOUT_OPTION = _option(LAYOUT)
DEPTH_KIND_OPTION = _option(DEPTH_KIND)
DEPTH_SCALE_OPTION = _option(DEPTH_SCALE)
FPS_OPTION = _option(FPS)
METHOD_OPTION = _option(METHOD)
MIN_DISPARITY_OPTION = _option(MIN_DISPARITY)
MAX_DISPARITY_OPTION = _option(MAX_DISPARITY)


def check_input_kind(kind: str | None) -> None:
    """Refuse an ``--input-kind`` that is not one of the library's kinds (None: guessed later)."""
    try:
        _check_input_kind(kind)
    except ParameterError as exc:
        raise ValueError(exc.spelled(_spelled)) from exc


def open_input(input_path: Path, kind: str | None, *, depth: Path | None, layout: str | None,
               depth_kind: str | None, depth_scale: float | None, fps: float | None,
               stereo_only: Mapping[str, object] | None = None) -> tuple[StereoClip | DepthClip, str]:  # fmt: skip
    """:func:`vergence.commands._video.open_input` (``stereo_only`` by parameter name, ``{"method": method}``),
    its refusals naming the options (``--depth-kind apply to a 2d+depth INPUT; a.mp4 is read as stereo
    (--input-kind)``)."""
    try:
        return _open_input(input_path, kind, depth=depth, layout=layout, depth_kind=depth_kind,
                           depth_scale=depth_scale, fps=fps, stereo_only=stereo_only)  # fmt: skip
    except ParameterError as exc:
        raise ValueError(exc.spelled(_spelled)) from exc
