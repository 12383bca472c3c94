"""How the rendered pair is shown on the display: its fit, and the arcminutes of one image pixel.

Every arcmin figure of S3 (disparity, S3 §3.2; the CSF's pixels per degree, S3 §3.2 "Tone mapping")
depends on how large one image pixel appears. Two fits:

- ``"screen"``: the image stretched over the display's width, as a viewer sees it full screen; one
  image pixel is ``resolution / W`` display pixels;
- ``"native"``: one image pixel per display pixel (a 320-px render is a 320-px window).

:func:`fit_display` turns a display and a fit into the :class:`~vergence.viewing.Display` *the image
occupies*: same eyes and viewing distance, the width the image covers and its pixel count. The
functions of :mod:`vergence.specular` take the image to fill their display's width
(:func:`~vergence.specular.disparity_arcmin`, :func:`~vergence.specular.pixels_per_degree`), so
given the fitted display they measure what the fit shows. Angles are taken at the screen centre.
"""

from __future__ import annotations

import math
from numbers import Integral

from vergence.viewing.geometry import DISPLAY_PRESETS, Display, check_display

__all__ = ["DISPLAY_FITS", "arcmin_per_pixel", "display_block", "fit_display"]

#: The fits of :func:`fit_display`; the first is the default of ``vergence specular --fit``.
DISPLAY_FITS = ("screen", "native")


def _check_width(width_px: object) -> int:
    if isinstance(width_px, bool) or not isinstance(width_px, Integral) or width_px < 1:
        raise ValueError(f"width_px must be an integer >= 1; got {width_px!r}")
    return int(width_px)


def fit_display(display: Display, width_px: int, *, fit: str = "screen") -> Display:
    """The part of ``display`` an image ``width_px`` wide occupies when shown with ``fit``.

    Parameters
    ----------
    display : vergence.viewing.Display
        The screen; its ``resolution`` must be known.
    width_px : int
        The image width in pixels.
    fit : {"screen", "native"}
        ``"screen"``: stretched to the display's width; ``"native"``: one image pixel per display
        pixel (width ``width_px`` x pitch). A native image wider than the screen is a window larger
        than it; the angle of a pixel stays the pitch's.

    Returns
    -------
    Display
        Same eye separation and distance; the width the image covers and ``resolution = width_px``:
        one of its pixels is one image pixel.

    Raises
    ------
    TypeError, ValueError
        A display that is not one or has no resolution, a width that is not an integer >= 1, an
        unknown fit (the message lists :data:`DISPLAY_FITS`).

    Examples
    --------
    >>> d = Display.preset("samsung-2233rz")
    >>> native = fit_display(d, 320, fit="native")
    >>> native.resolution, round(native.pixel_pitch * 1e3, 4) == round(d.pixel_pitch * 1e3, 4)
    (320, True)
    >>> screen = fit_display(d, 320)
    >>> screen.width == d.width, round(screen.pixel_pitch / d.pixel_pitch, 2)
    (True, 5.25)
    """
    check_display(display, resolution=True)
    width_px = _check_width(width_px)
    if fit not in DISPLAY_FITS:
        raise ValueError(f"fit must be one of {', '.join(DISPLAY_FITS)}; got {fit!r}")
    width = display.width if fit == "screen" else display.pixel_pitch * width_px
    return Display(eye_separation=display.eye_separation, distance=display.distance, width=width,
                   resolution=width_px)  # fmt: skip


def arcmin_per_pixel(display: Display) -> float:
    """Arcminutes of one pixel of ``display`` at the screen centre: ``2 atan(p / 2D)``, ``p`` the pitch.

    On a fitted display (:func:`fit_display`) it is the angle of one *image* pixel; the reciprocal
    of :func:`~vergence.specular.pixels_per_degree` times 60 (S3 §4's study display: 1.62').

    >>> round(arcmin_per_pixel(Display.preset("samsung-2233rz")), 3)
    1.616
    """
    check_display(display, resolution=True)
    return 60.0 * math.degrees(2.0 * math.atan(display.pixel_pitch / (2.0 * display.distance)))


def _display_name(display: Display) -> str | None:
    """The name of ``display`` in :data:`~vergence.viewing.DISPLAY_PRESETS`, None if it is none of them."""
    return next((name for name, preset in sorted(DISPLAY_PRESETS.items()) if preset == display), None)


def display_block(display: Display, width_px: int, *, fit: str, name: str | None = None) -> dict:
    """The ``display`` block of ``report.json``: what the figures assume about how the pair is shown.

    Keys: ``name`` (``name`` or the preset ``display`` equals, None for another display), ``fit``,
    ``arcmin_per_px`` (one image pixel, :func:`arcmin_per_pixel` of the fitted display),
    ``image_width_px``, ``screen_width_px``, ``screen_px_per_image_px``, ``shown_width_m`` (the
    width the image covers), ``screen_width_m``, ``viewing_distance_m``, ``eye_separation_m``.
    """
    shown = fit_display(display, width_px, fit=fit)
    return {
        "name": _display_name(display) if name is None else name,
        "fit": fit,
        "arcmin_per_px": round(arcmin_per_pixel(shown), 6),
        "image_width_px": int(width_px),
        "screen_width_px": int(display.resolution),
        "screen_px_per_image_px": round(shown.pixel_pitch / display.pixel_pitch, 6),
        "shown_width_m": round(shown.width, 6),
        "screen_width_m": display.width,
        "viewing_distance_m": display.distance,
        "eye_separation_m": display.eye_separation,
    }
