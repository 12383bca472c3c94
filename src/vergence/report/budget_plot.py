"""Figure of a depth budget: perceived depth and roundness against scene depth (S0 §2, Eq. 2 and 4).

Drawn without pyplot state and written atomically as PNG (:mod:`vergence.report._figures`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from vergence._validate import check_positive
from vergence.report._figures import axis_top, new_figure, png_path, save_png
from vergence.viewing.geometry import (
    CARDBOARD_ROUNDNESS,
    Display,
    Shooting,
    check_display,
    divergence_baseline,
    divergence_depth,
    perceived_depth_from_depth,
    roundness,
    roundness_baseline,
)

__all__ = ["plot_budget"]

_SAMPLES = 600  # points along the depth axis: smooth curves, instant to draw
# Near the divergence depth z' and rho grow without bound: the axes stop at these multiples of the
# viewing distance H' (perceived depth) and at this roundness, so the finite part stays readable.
_MAX_PERCEIVED_FACTOR = 10.0
_MAX_ROUNDNESS = 4.0
# A depth range spanning this ratio or more is drawn on a logarithmic depth axis.
_LOG_RATIO = 10.0


def plot_budget(
    shooting: Shooting, display: Display, *, near: float, far: float, path: str | os.PathLike[str]
) -> Path:
    """Plot perceived depth (S0 Eq. 2) and roundness (Eq. 4) against scene depth; write a PNG.

    The divergence depth (if the rig has one inside ``[near, far]``) is a vertical line with the
    diverging depths shaded; the cardboard threshold ``rho = 0.3`` (:data:`CARDBOARD_ROUNDNESS`) is
    a horizontal line with the cardboard band shaded. The convergence distance H is marked.

    Parameters
    ----------
    shooting : Shooting
        The rig (b, H, W).
    display : Display
        The viewing set-up (b', H', W').
    near, far : float, keyword-only
        Scene depth range in metres, ``0 < near < far``.
    path : str or os.PathLike, keyword-only
        Output file; must end in ``.png``; its folder must exist. Written atomically.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    TypeError
        If ``shooting`` or ``display`` has the wrong type.
    ValueError
        If ``near``/``far`` are not finite with ``0 < near < far``, or ``path`` does not end in .png.
    FileNotFoundError
        If the folder of ``path`` does not exist.
    """
    if not isinstance(shooting, Shooting):
        raise TypeError(f"shooting must be a Shooting; got {type(shooting).__name__}")
    check_display(display)
    near = check_positive("near", near)
    far = check_positive("far", far)
    if not near < far:
        raise ValueError(f"far must be > near; got near={near:g}, far={far:g}")
    out = png_path(path)

    z_div = divergence_depth(shooting, display)
    z = np.geomspace(near, far, _SAMPLES) if far / near >= _LOG_RATIO else np.linspace(near, far, _SAMPLES)
    if near < z_div < far:  # sample both sides of the pole tightly
        z = np.union1d(z, [z_div * (1 - 1e-9), z_div * (1 + 1e-9)])
    zp = np.asarray(perceived_depth_from_depth(z, shooting, display), dtype=float)  # Eq. (2)
    rho = np.asarray(roundness(z, shooting, display), dtype=float)  # Eq. (4)
    rho = np.where(np.isnan(zp), np.nan, rho)  # no roundness where nothing is perceived

    fig = new_figure(figsize=(7.5, 7.0), dpi=110)
    ax_z, ax_r = fig.subplots(2, 1, sharex=True)
    b_div = divergence_baseline(shooting.window, display)
    b_round = roundness_baseline(shooting.convergence, display)
    fig.suptitle(
        f"Depth budget: b = {shooting.baseline:.4g} m, H = {shooting.convergence:.4g} m, "
        f"f/f' = {shooting.focal / display.focal:.3g}\n"
        f"b_div = {b_div:.4g} m (no divergence), b_round = {b_round:.4g} m (roundness 1 at H)",
        fontsize=10,
    )

    ax_z.plot(z, zp, color="tab:blue", lw=2, label="perceived depth z' (Eq. 2)")
    ax_z.axhline(display.distance, color="0.5", lw=1, ls=":", label=f"screen, H' = {display.distance:.3g} m")
    ax_z.set_ylim(0, axis_top(zp, _MAX_PERCEIVED_FACTOR * display.distance, 2 * display.distance))
    ax_z.set_ylabel("perceived depth z' (m)")

    ax_r.plot(z, rho, color="tab:green", lw=2, label="roundness ρ (Eq. 4)")
    ax_r.axhline(1.0, color="0.5", lw=1, ls=":", label="ρ = 1 (round)")
    ax_r.axhline(
        CARDBOARD_ROUNDNESS, color="tab:orange", lw=1.5, ls="--", label=f"cardboard, ρ < {CARDBOARD_ROUNDNESS}"
    )
    top_r = axis_top(rho, _MAX_ROUNDNESS, 1.2)
    ax_r.axhspan(0.0, CARDBOARD_ROUNDNESS, color="tab:orange", alpha=0.12, lw=0)
    ax_r.set_ylim(0, top_r)
    ax_r.set_ylabel("roundness ρ")
    ax_r.set_xlabel("scene depth z (m)")
    if far / near >= _LOG_RATIO:
        ax_r.set_xscale("log")
        ax_r.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
        ax_r.xaxis.set_major_formatter(FuncFormatter(lambda value, _pos: f"{value:g}"))
        ax_r.xaxis.set_minor_formatter(NullFormatter())

    for ax in (ax_z, ax_r):
        if near <= shooting.convergence <= far:
            label = f"convergence H = {shooting.convergence:.3g} m"
            ax.axvline(shooting.convergence, color="0.3", lw=1, ls="-.", label=label)
        if math.isfinite(z_div) and z_div < far:
            ax.axvline(z_div, color="tab:red", lw=1.5, label=f"divergence beyond z = {z_div:.4g} m")
            ax.axvspan(max(z_div, near), far, color="tab:red", alpha=0.12, lw=0)
        ax.set_xlim(near, far)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=8)

    return save_png(fig, out)
