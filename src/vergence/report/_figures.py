"""Private helpers of the report figures: the PNG path check, a pyplot-free figure, the atomic save.

Figures are drawn on a bare :class:`matplotlib.figure.Figure` with the Agg canvas, so no pyplot state
is created or left behind, and written as PNG through :func:`vergence.io.atomic_write`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from vergence.io import atomic_write

__all__ = ["axis_top", "new_figure", "png_path", "save_png"]

# Head room above the highest plotted value, as a share of it.
_HEAD_ROOM = 0.08


def png_path(path: str | os.PathLike[str]) -> Path:
    """``path`` as a Path, or a ValueError unless it ends in ``.png`` (checked before any drawing)."""
    out = Path(path)
    if out.suffix.lower() != ".png":
        raise ValueError(f"path must end in .png; got {str(path)!r}")
    return out


def new_figure(*, figsize: tuple[float, float], dpi: float) -> Figure:
    """A constrained-layout figure on its own Agg canvas (no pyplot)."""
    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Figure, out: Path) -> Path:
    """Write ``fig`` to ``out`` as PNG atomically; return ``out``."""
    with atomic_write(out) as tmp:
        fig.savefig(tmp, format="png")
    return out


def axis_top(values: np.ndarray, cap: float, floor: float) -> float:
    """Upper axis limit: the largest finite value, kept within ``[floor, cap]``, plus head room."""
    finite = values[np.isfinite(values)]
    top = float(finite.max()) if finite.size else floor
    return max(floor, min(top, cap)) * (1.0 + _HEAD_ROOM)
