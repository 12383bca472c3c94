"""The display of a command's parameters: a preset name or the three lengths (S0 §2's b', H', W')."""

from __future__ import annotations

import dataclasses

from vergence.commands._spec import Parameter, ParameterError, literal, naming
from vergence.viewing.geometry import DISPLAY_PRESETS, Display

__all__ = ["DISPLAY_PARAMETERS", "SCREEN_PIXELS", "display_from"]

#: The parameters of a display, as every command that takes one spells them.
DISPLAY_PARAMETERS = (
    Parameter("eye_separation", "number", "Viewer eye separation b' (m).", None),
    Parameter("viewing_distance", "number", "Viewing distance H' (m).", None),
    Parameter("screen_width", "number", "Screen width W' (m).", None),
)
#: The horizontal resolution, for the commands that report pixels.
SCREEN_PIXELS = Parameter("screen_pixels", "integer", "Screen width in pixels (adds parallax_px).", None)


def display_parameter(help_text: str = "Display preset instead of the three lengths") -> Parameter:
    """The ``display`` parameter (a preset name), its help listing the presets."""
    return Parameter("display", "text", f"{help_text}: {', '.join(sorted(DISPLAY_PRESETS))}.", None)


_LENGTHS = ("eye_separation", "viewing_distance", "screen_width")


def display_from(display: str | None, eye_separation: float | None, viewing_distance: float | None,
                 screen_width: float | None, screen_pixels: int | None = None) -> Display:
    """The display of a preset or of the three lengths (exactly one of the two).

    ``screen_pixels`` sets or overrides the horizontal resolution.

    Raises
    ------
    ParameterError
        Naming the parameters at fault: both given, a length missing, a length or the pixels the
        library refuses, an unknown preset.
    """
    if screen_pixels is not None and screen_pixels < 1:  # the library would name it "resolution"
        raise ParameterError("{screen_pixels} must be >= 1 (the screen width in pixels); got " + str(screen_pixels))
    values = (eye_separation, viewing_distance, screen_width)
    given = [n for n, v in zip(_LENGTHS, values) if v is not None]
    if display is not None:
        if given:
            raise ParameterError("give either {display} or the display lengths, not both (got {display} and "
                                 + ", ".join("{" + n + "}" for n in given) + ")")
        try:
            chosen = Display.preset(display)
        except ValueError as exc:  # the library's message names no argument
            raise ParameterError("{display}: " + literal(exc)) from exc
        return chosen if screen_pixels is None else dataclasses.replace(chosen, resolution=screen_pixels)
    if len(given) < 3:
        missing = ", ".join("{" + n + "}" for n in _LENGTHS if n not in given)
        raise ParameterError("the display is incomplete: give {display} PRESET or all three lengths (missing "
                             + missing + ")")
    with naming(eye_separation="eye_separation", distance="viewing_distance", width="screen_width",
                resolution="screen_pixels"):
        return Display(eye_separation=eye_separation, distance=viewing_distance, width=screen_width,
                       resolution=screen_pixels)
