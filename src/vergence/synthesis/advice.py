"""Warnings about a synthesized result that is valid but may not look right (issue 9).

A result is refused when it cannot fit the image (``MAX_PARALLAX_WIDTHS``); these warn when it fits
but leaves the display's comfort zone, passes the divergence limit, or is mostly made-up pixels.
Each function returns one line of text per finding (an empty tuple when all is well): the CLI
prints them on stderr and writes them into its JSON.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vergence.synthesis.controls import ParallaxPlan
from vergence.viewing.comfort import ComfortReport, ComfortZone, check_disparity_range
from vergence.viewing.geometry import Display, check_display

__all__ = ["MOSTLY_HOLES_FRACTION", "holes_warnings", "plan_comfort", "stereo_warnings"]

# A view with more than half its pixels filled by hole filling shows more guesswork than picture:
# hole filling repeats or mirrors the background (S1 §IV.B.2), it does not see the scene.
MOSTLY_HOLES_FRACTION = 0.5


def holes_warnings(holes: Sequence[object]) -> tuple[str, ...]:
    """One line for each view whose hole share exceeds ``MOSTLY_HOLES_FRACTION``.

    Parameters
    ----------
    holes : sequence of (H, W) bool arrays
        The filled pixels of each view, left to right. The lines name "view k"; with a single
        mask, "the view".

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> holes_warnings([np.zeros((2, 2), bool), np.ones((2, 2), bool)])
    ('view 1 is 100.0 % filled-in holes (more than MOSTLY_HOLES_FRACTION 50 %): most of it was not seen; lower the parallax',)
    """
    if isinstance(holes, np.ndarray) or not isinstance(holes, Sequence):
        raise TypeError(f"holes must be a sequence (list or tuple) of masks; got {type(holes).__name__}")
    out = []
    for k, h in enumerate(holes):
        m = np.asarray(h)
        if m.dtype != bool:
            raise TypeError(f"holes[{k}] must be a boolean mask; got {m.dtype}")
        share = float(m.mean()) if m.size else 0.0
        if share > MOSTLY_HOLES_FRACTION:
            label = "the view" if len(holes) == 1 else f"view {k}"
            out.append(
                f"{label} is {100.0 * share:.1f} % filled-in holes (more than MOSTLY_HOLES_FRACTION "
                f"{100.0 * MOSTLY_HOLES_FRACTION:g} %): most of it was not seen; lower the parallax"
            )
    return tuple(out)


def stereo_warnings(plan: ParallaxPlan, display: Display, *, zone: ComfortZone | None = None) -> tuple[str, ...]:
    """Lines for a parallax range that leaves ``zone`` or passes the divergence limit on ``display``.

    The image fills the screen width; ``plan.range_px`` (image pixels between adjacent views) is
    scaled to display pixels and checked with :func:`~vergence.viewing.comfort.check_disparity_range`.

    Parameters
    ----------
    plan : ParallaxPlan
    display : Display
        Its resolution must be known.
    zone : ComfortZone, optional
        Default ``ComfortZone()``, +-60 arcmin.

    Returns
    -------
    tuple of str
        At most two lines: divergence (S0 Eq. 8: uncrossed parallax wider than the eyes) and the
        comfort zone.

    Examples
    --------
    A 1920-px image on the 1920-px desktop-24: +-20 px stay within +-60 arcmin, +-300 px diverge.

    >>> from vergence.synthesis import plan_parallax
    >>> depth = np.tile([[1.0, 4.0]], (1, 960))
    >>> stereo_warnings(plan_parallax(depth, budget_px=20.0), Display.preset("desktop-24"))
    ()
    >>> len(stereo_warnings(plan_parallax(depth, budget_px=300.0), Display.preset("desktop-24")))
    2
    """
    zone = ComfortZone() if zone is None else zone
    report = _range_report(plan, display, zone)
    out = []
    if report.diverges:
        out.append(
            f"the parallax reaches {report.max_px:+.4g} display px behind the screen, past the divergence "
            f"limit {report.divergence_px:.4g} px of this display (S0 Eq. 8): the eyes would diverge"
        )
    if report.excess_px > 0:
        out.append(
            f"the parallax range {report.min_arcmin:+.4g} .. {report.max_arcmin:+.4g} arcmin leaves the comfort "
            f"zone {zone.min_arcmin:+g} .. {zone.max_arcmin:+g} arcmin by {report.excess_arcmin:.4g} arcmin"
        )
    return tuple(out)


def _range_report(plan: ParallaxPlan, display: Display, zone: ComfortZone) -> ComfortReport:
    """The report of ``plan.range_px`` on ``display`` (the arguments checked): no pass over the pixels."""
    if not isinstance(plan, ParallaxPlan):
        raise TypeError(f"plan must be a ParallaxPlan; got {type(plan).__name__}")
    check_display(display, resolution=True)
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    per_px = display.resolution / plan.parallax_px.shape[1]  # display pixels per image pixel
    return check_disparity_range(np.array(plan.range_px) * per_px, display, zone=zone)


def plan_comfort(plan: ParallaxPlan, display: Display, *, zone: ComfortZone | None = None) -> tuple[ComfortReport, float]:
    """The comfort of a planned parallax on ``display``: the report of its range and the share outside ``zone``.

    The image fills the screen width, so one image pixel is ``display.resolution / W`` display
    pixels; ``plan.range_px`` scaled so is checked with
    :func:`~vergence.viewing.comfort.check_disparity_range` (comfort zone and the divergence limit,
    S0 Eq. 8), and every known pixel of ``plan.parallax_px`` scaled so is compared with the zone's
    limits in display pixels (:meth:`ComfortZone.pixels <vergence.viewing.comfort.ComfortZone.pixels>`,
    exact vergence angles, S3 §3).

    Parameters
    ----------
    plan : ParallaxPlan
        From :func:`~vergence.synthesis.plan_parallax`; NaN pixels (unknown depth) are left out.
    display : Display
        Its resolution must be known.
    zone : ComfortZone, optional
        Default ``ComfortZone()``, +-60 arcmin.

    Returns
    -------
    report : ComfortReport
        The range in display pixels and arcmin, the zone's limits, margins, divergence.
    outside : float
        The share in [0, 1] of the known pixels whose parallax lies outside the zone (in front of
        its crossed limit or behind its uncrossed one).

    Examples
    --------
    Half the pixels at +-20 image px: on the 1920-px desktop-24 a 1920-px image keeps them
    inside +-60 arcmin; squeezed to 192 px wide, each image pixel is 10 display pixels and they leave it.

    >>> from vergence.synthesis import plan_parallax
    >>> wide = plan_parallax(np.tile([[1.0, 4.0]], (1, 960)), budget_px=20.0)
    >>> report, outside = plan_comfort(wide, Display.preset("desktop-24"))
    >>> report.inside, outside
    (True, 0.0)
    >>> narrow = plan_parallax(np.tile([[1.0, 4.0]], (1, 96)), budget_px=20.0)
    >>> plan_comfort(narrow, Display.preset("desktop-24"))[1]
    1.0
    """
    zone = ComfortZone() if zone is None else zone
    report = _range_report(plan, display, zone)
    per_px = display.resolution / plan.parallax_px.shape[1]  # display pixels per image pixel
    screen = plan.parallax_px[np.isfinite(plan.parallax_px)].astype(np.float64) * per_px
    if screen.size == 0:
        return report, 0.0
    lo, hi = report.zone_min_px, report.zone_max_px
    outside = float(np.count_nonzero((screen < lo) | (screen > hi))) / screen.size
    return report, outside
