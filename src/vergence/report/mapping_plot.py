"""Figure of a constraint-built disparity mapping psi (S0 §6, Eq. 7–9).

Three panels: psi against the reference disparity d with the identity and the divergence limit
``b'/W'`` (S0 Eq. 8); the mapped perceived depth (Eq. 7) and the mapped roundness (Eq. 9) against
scene depth, each beside the unmapped reference rig (Eq. 2 and 4) and the director's targets.
Drawn without pyplot state and written atomically as PNG (:mod:`vergence.report._figures`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from vergence.report._figures import axis_top, new_figure, png_path, save_png
from vergence.viewing.geometry import CARDBOARD_ROUNDNESS, perceived_depth_from_depth, roundness
from vergence.viewing.mapping_constraints import ConstrainedMapping

__all__ = ["plot_mapping"]

_SAMPLES = 801  # disparities along psi: smooth curves, instant to draw
# Perceived depth grows without bound near the divergence limit: the axis stops at this multiple of
# the viewing distance H'; roundness stops at this value.
_MAX_PERCEIVED_FACTOR = 12.0
_MAX_ROUNDNESS = 3.0
_TANGENT = 0.06  # half-length of the slope ticks at the control points, as a share of the d range


def plot_mapping(result: ConstrainedMapping, *, path: str | os.PathLike[str]) -> Path:
    """Plot psi (with identity and divergence limit) and its perceived depth and roundness; write a PNG.

    Parameters
    ----------
    result : ConstrainedMapping
        From :func:`vergence.viewing.mapping.psi_from_constraints`.
    path : str or os.PathLike, keyword-only
        Output file ending in ``.png``; its folder must exist. Written atomically.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    TypeError
        If ``result`` is not a :class:`ConstrainedMapping`.
    ValueError
        If ``path`` does not end in ``.png``.
    FileNotFoundError
        If the folder of ``path`` does not exist.
    """
    if not isinstance(result, ConstrainedMapping):
        raise TypeError(f"result must be a ConstrainedMapping; got {type(result).__name__}")
    out = png_path(path)

    ref, display = result.reference, result.display
    limit = result.divergence_limit
    s = result.sample(_SAMPLES)
    finite = np.isfinite(s.depth)
    z = s.depth[finite]
    zp_ref = np.asarray(perceived_depth_from_depth(z, ref, display), dtype=float)  # Eq. (2)
    rho_ref = np.where(np.isnan(zp_ref), np.nan, np.asarray(roundness(z, ref, display), dtype=float))  # Eq. (4)
    log_x = not math.isfinite(result.far) or result.far / result.near > 20

    fig = new_figure(figsize=(14.0, 4.6), dpi=100)
    ax_psi, ax_z, ax_r = fig.subplots(1, 3)
    far_text = "∞" if math.isinf(result.far) else f"{result.far:.4g} m"
    fig.suptitle(
        f"Disparity mapping ψ from {len(result.constraints)} constraint(s): reference b_r = {ref.baseline:.4g} m, "
        f"H = {ref.convergence:.4g} m, W = {ref.window:.4g} m (f/f' = {ref.focal / display.focal:.3g}); "
        f"scene {result.near:.4g} m – {far_text};  monotone: {'yes' if result.monotone else 'NO'}, "
        f"diverges: {'YES' if result.diverges else 'no'}",
        fontsize=10,
    )

    d_lo, d_hi = result.disparity_range
    ax_psi.plot(s.disparity, s.disparity, color="0.5", lw=1, ls=":", label="identity (reference rig)")
    ax_psi.plot(s.disparity, s.mapped, color="tab:blue", lw=2, label="ψ(d)")
    ax_psi.axhline(limit, color="tab:red", lw=1.5, ls="--", label=f"divergence limit b'/W' = {limit:.4g} (Eq. 8)")
    half = _TANGENT * (d_hi - d_lo)
    for k, cp in enumerate(result.control_points):
        tick_x = [cp.disparity - half, cp.disparity + half]
        tick_y = [cp.value - cp.slope * half, cp.value + cp.slope * half]
        ax_psi.plot(tick_x, tick_y, color="tab:orange", lw=1.2)
        label = "control points (value, slope)" if k == 0 else None
        ax_psi.plot(cp.disparity, cp.value, "o", color="tab:orange", label=label)
    ax_psi.set_xlim(d_lo, d_hi)
    span = max(float(np.max(s.mapped)), limit) - min(float(np.min(s.mapped)), d_lo)
    ax_psi.set_ylim(min(float(np.min(s.mapped)), d_lo) - 0.05 * span, max(limit, float(np.max(s.mapped))) + 0.1 * span)
    ax_psi.set_xlabel("reference disparity d (fraction of W)")
    ax_psi.set_ylabel("mapped disparity ψ(d) (fraction of W')")
    ax_psi.set_title("ψ against d", fontsize=10)

    zp = s.perceived_depth[finite]
    ax_z.plot(z, zp_ref, color="0.5", lw=1, ls=":", label="reference rig, no mapping (Eq. 2)")
    ax_z.plot(z, zp, color="tab:blue", lw=2, label="mapped z'_ψ (Eq. 7)")
    ax_z.axhline(display.distance, color="0.6", lw=1, ls="-.", label=f"screen, H' = {display.distance:.3g} m")
    z_top = axis_top(np.concatenate([zp, zp_ref]), _MAX_PERCEIVED_FACTOR * display.distance, 2 * display.distance)
    ax_z.set_ylim(0, z_top)
    ax_z.set_ylabel("perceived depth z' (m)")
    ax_z.set_title("perceived depth", fontsize=10)

    rho = s.roundness[finite]
    ax_r.plot(z, rho_ref, color="0.5", lw=1, ls=":", label="reference rig, no mapping (Eq. 4)")
    ax_r.plot(z, rho, color="tab:green", lw=2, label="mapped ρ_ψ (Eq. 9)")
    ax_r.axhline(CARDBOARD_ROUNDNESS, color="tab:orange", lw=1.2, ls="--",
                 label=f"cardboard, ρ < {CARDBOARD_ROUNDNESS}")
    ax_r.axhspan(0.0, CARDBOARD_ROUNDNESS, color="tab:orange", alpha=0.12, lw=0)
    rho_min, z_min = result.min_roundness()  # a dip between control points shows here
    ax_r.plot(z_min, rho_min, "v", color="tab:red", ms=8, label=f"lowest ρ = {rho_min:.3g} at z = {z_min:.4g} m")
    ax_r.set_ylim(0, axis_top(np.concatenate([rho, rho_ref]), _MAX_ROUNDNESS, 1.2))
    ax_r.set_ylabel("roundness ρ")
    ax_r.set_title("roundness", fontsize=10)

    first_z, first_r = True, True
    for c in result.constraints:
        if not math.isfinite(c.depth):
            continue
        if math.isfinite(c.perceived_depth):
            label = "director's target" if first_z else None
            ax_z.plot(c.depth, c.perceived_depth, "o", color="tab:orange", label=label)
            first_z = False
        if c.roundness is not None:
            label = "director's target" if first_r else None
            ax_r.plot(c.depth, c.roundness, "o", color="tab:orange", label=label)
            first_r = False
    for ax in (ax_z, ax_r):
        ax.set_xlabel("scene depth z (m)" + ("  (far = ∞)" if math.isinf(result.far) else ""))
        if log_x:
            ax.set_xscale("log")
        if z.size:
            ax.set_xlim(z[0], z[-1])
    for ax in (ax_psi, ax_z, ax_r):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7.5)

    return save_png(fig, out)
