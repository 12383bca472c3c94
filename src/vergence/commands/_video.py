"""The input of the video commands (``vergence analyze``, ``vergence convert``): the parameters that
describe it, and the opening of the clip.

Both read a packed stereo clip or a colour + depth one (:func:`~vergence.video.open_stereo`,
:func:`~vergence.video.open_depth_clip`). :func:`open_input` guesses the kind, refuses the parameters
of the other kind and opens the clip, with one set of messages for both commands; the refusals name
the parameters (``{layout}``, and ``{input_path}`` for the input itself).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from vergence.commands._naming import literal
from vergence.commands._spec import Parameter, ParameterError, naming

if TYPE_CHECKING:
    from vergence.video import DepthClip, StereoClip

__all__ = ["DEPTH_KIND", "DEPTH_SCALE", "FPS", "INPUT_KIND", "INPUT_KINDS", "LAYOUT", "MAX_DISPARITY", "METHOD",
           "MIN_DISPARITY", "check_input_kind", "open_input"]

# What INPUT holds: a packed stereo clip, or colour + depth.
INPUT_KINDS = ("stereo", "2d+depth")

INPUT_KIND = Parameter("input_kind", "text", f"What {{input_path}} holds: {', '.join(INPUT_KINDS)}; default from its "
                       "name (_RGBD) and {depth}, else stereo.", None)
LAYOUT = Parameter("layout", "text", "Stereo {input_path} layout: sbs, half-sbs, tb, half-tb; default from the name's "
                   "tag (_LRF_Full_SBS, _Half_SBS, _LR, _TB, -lr, -tb...).", None)
DEPTH_KIND = Parameter("depth_kind", "text", "2D + depth: what the depth holds: disparity, inverse (iw3's, default), "
                       "metric.", None)
DEPTH_SCALE = Parameter("depth_scale", "number", "2D + depth: stored 8-bit value / scale = metres or pixels (needed "
                        "for metric or disparity depth in a video).", None)
FPS = Parameter("fps", "number", "Frame rate of an image folder (default 24).", None)
METHOD = Parameter("method", "text", "Stereo: matcher (as vergence match); default sgbm.", None)
MIN_DISPARITY = Parameter("min_disparity", "integer", "Stereo: smallest disparity searched (px); default found per "
                          "shot from its features, widened where matches pile up at it.", None)
MAX_DISPARITY = Parameter("max_disparity", "integer", "Stereo: largest disparity searched (px); default found per "
                          "shot from its features, widened where matches pile up at it.", None)


def check_input_kind(input_kind: str | None) -> None:
    """Refuse an ``input_kind`` that is not one of :data:`INPUT_KINDS` (None: guessed later)."""
    if input_kind is not None and input_kind not in INPUT_KINDS:
        raise ParameterError("{input_kind}" + literal(f" must be one of {', '.join(INPUT_KINDS)}; got {input_kind!r}"))


def open_input(
    input_path: Path,
    input_kind: str | None,
    *,
    depth: Path | None,
    layout: str | None,
    depth_kind: str | None,
    depth_scale: float | None,
    fps: float | None,
    stereo_only: Mapping[str, object] | None = None,
    depth_only: Mapping[str, object] | None = None,
) -> tuple[StereoClip | DepthClip, str]:
    """The clip ``input_path`` holds and its kind (``"stereo"`` or ``"2d+depth"``).

    Parameters
    ----------
    input_path : Path
        The input, which exists.
    input_kind : str or None
        Checked by :func:`check_input_kind`; None: ``"2d+depth"`` when ``depth`` is given or, with no
        ``layout``, when the name is tagged _RGBD, else ``"stereo"``.
    depth, layout, depth_kind, depth_scale, fps
        The parameters of the same names (``depth_kind`` None: ``"inverse"``).
    stereo_only, depth_only : mapping of str to object, optional
        The command's other parameters that apply to one kind only, by name (``{"method": method}``);
        a value None is a parameter not given (pass an unset flag as None).

    Returns
    -------
    tuple of (StereoClip or DepthClip, str)
        The opened clip and its kind.

    Raises
    ------
    ParameterError
        If a parameter of the other kind is given (``"{depth_kind} apply to a 2d+depth {input_path};
        a.mp4 is read as stereo ({input_kind})"``), and the errors of the opening that name an argument,
        naming the parameter.
    """
    from vergence.video import guess_layout, open_depth_clip, open_stereo

    kind = input_kind
    if kind is None:
        kind = "2d+depth" if depth is not None or (layout is None and guess_layout(input_path) == "rgbd") else "stereo"
    given = {"stereo": [n for n, v in (("layout", layout), *(stereo_only or {}).items()) if v is not None],
             "2d+depth": [n for n, v in (("depth", depth), ("depth_kind", depth_kind), ("depth_scale", depth_scale),
                                         *(depth_only or {}).items()) if v is not None]}
    other = "2d+depth" if kind == "stereo" else "stereo"
    if given[other]:
        raise ParameterError(", ".join("{" + n + "}" for n in given[other]) + f" apply to a {other} {{input_path}}; "
                             f"{literal(input_path.name)} is read as {kind} ({{input_kind}})")
    if kind == "stereo" and layout is None:  # the refusal names the parameter that answers it
        from vergence.video.layout import STEREO_LAYOUTS

        guessed = guess_layout(input_path)
        label = literal(input_path.name or str(input_path.resolve()))  # "." has no name
        if guessed is None:
            raise ParameterError(f"cannot guess the stereo layout of {label}: its name carries no tag such as "
                                 "_LRF_Full_SBS, _Half_SBS, _LR, _TB, -lr, -tb; give {layout} "
                                 f"({', '.join(STEREO_LAYOUTS)})")
        if guessed not in STEREO_LAYOUTS:
            raise ParameterError(f"{label} is tagged {guessed!r} (colour + depth), not a stereo layout: give "
                                 "{input_kind} 2d+depth, or {layout}")
    with naming(layout="layout", kind="depth_kind", scale="depth_scale", fps="fps"):
        if kind == "stereo":
            return open_stereo(input_path, layout=layout, fps=fps), kind
        return open_depth_clip(input_path, depth=depth, kind=depth_kind or "inverse", scale=depth_scale, fps=fps), kind
