"""S3's tabulated ``g(y)``: disparity, rivalry and importance of every layer at every offset (S3 §3.4).

S3 §3.4 writes ``g : y -> (disparity, rivalry, importance)`` for the per-layer camera offsets and
tabulates it at ``y_m = m / k``. :func:`vergence.specular.tabulate_offsets` renders the left eye's
ray tree at each offset and matches it against the right eye; :func:`analyse_table` turns each row
into what the cost (S3 Eq. 2) reads, with the stages of S3 §3.2:

- the disparity in arcminutes on the display (:func:`~vergence.specular.disparity_arcmin`);
- L* of the row's layers (:func:`~vergence.specular.layer_lightness`, one exposure for every row
  and both eyes: the physical left eye's, so that a brighter offset is not re-exposed) against the
  right eye's L*, computed once;
- importance (:func:`~vergence.specular.importance`) and rivalry (:func:`~vergence.specular.rivalry`)
  of that pair.

Row ``k`` (``y = 1``) is the physical stereo pair; row 0 the right eye seen by both eyes.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vergence._validate import readonly_fields
from vergence.specular.importance_factors import importance
from vergence.specular.lightness import PerceivedLightness, layer_lightness, pixels_per_degree
from vergence.specular.matching import LayerDisparity, disparity_arcmin
from vergence.specular.offsets import OffsetTable
from vergence.specular.rivalry_map import rivalry
from vergence.viewing.geometry import Display, check_display

__all__ = ["OffsetAnalysis", "analyse_table"]


@dataclass(frozen=True, slots=True, eq=False)
class OffsetAnalysis:
    """``g(y_m)`` for every offset of an :class:`~vergence.specular.OffsetTable` (S3 §3.4). Arrays are read-only.

    Attributes
    ----------
    offsets : (k + 1,) float64
        ``m / k``.
    disparity : (k + 1, N, H, W, 2) float32
        Per offset, each layer's disparity in arcmin on the display (horizontal: positive behind the
        screen; vertical), NaN where the layer has no match.
    rivalry : (k + 1, N, H, W) float32
        Per offset, :attr:`vergence.specular.Rivalry.rivalry` in (ΔL*)^2; NaN in a layer with no match at all.
    importance : (k + 1, N, H, W) float32
        Per offset, :attr:`vergence.specular.Importance.weight` in [0, 1].
    exposure : float
        The tone map's radiance multiplier, shared by every offset and both eyes.
    display : Display
    seconds : float
        Wall time of the analysis.
    """

    offsets: np.ndarray
    disparity: np.ndarray
    rivalry: np.ndarray
    importance: np.ndarray
    exposure: float
    display: Display
    seconds: float

    def __post_init__(self) -> None:
        k1, n, h, w = self.importance.shape
        for name, want in (("disparity", (k1, n, h, w, 2)), ("rivalry", (k1, n, h, w)), ("offsets", (k1,))):
            if getattr(self, name).shape != want:
                raise ValueError(f"{name} must have shape {want}; got {getattr(self, name).shape}")
        readonly_fields(self, "offsets", "disparity", "rivalry", "importance")

    @property
    def original(self) -> np.ndarray:
        """The physical disparity ``(N, H, W, 2)``: the row at ``y = 1``."""
        return self.disparity[-1]

    @property
    def k(self) -> int:
        """The number of steps k (k + 1 offsets)."""
        return len(self.offsets) - 1


def analyse_table(
    table: OffsetTable,
    display: Display,
    *,
    exposure: float | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> OffsetAnalysis:
    """Disparity in arcmin, rivalry and importance of every row of ``table`` on ``display`` (S3 §3.2, §3.4).

    Parameters
    ----------
    table : OffsetTable
        :func:`~vergence.specular.tabulate_offsets`'s renders and matches.
    display : vergence.viewing.Display
        The viewing set-up; its resolution must be known.
    exposure : float, optional, keyword-only
        The tone map's multiplier (> 0); default that of :func:`~vergence.specular.perceived_lightness`
        on the physical pair (:func:`vergence.render.auto_exposure` of the left eye's beauty image).
    progress : callable(fraction, message), optional
        Called before each row and once at the end.

    Returns
    -------
    OffsetAnalysis

    Raises
    ------
    TypeError
        If ``table`` is not an OffsetTable or ``display`` not a Display.
    ValueError
        If the display's resolution is unknown or ``exposure`` is not finite and > 0.

    Notes
    -----
    Each row costs about what :func:`~vergence.specular.perceived_lightness` (one eye),
    :func:`~vergence.specular.importance` and :func:`~vergence.specular.rivalry` cost on one pair;
    ``benchmarks/specular_offsets.py`` times it with the table.
    """
    from vergence.render.tonemap import auto_exposure

    if not isinstance(table, OffsetTable):
        raise TypeError(f"table must be a vergence.specular.OffsetTable; got {type(table).__name__}")
    check_display(display)
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable(fraction, message) or None; got {type(progress).__name__}")
    t0 = time.perf_counter()
    k1, n, h, w = table.distance.shape
    if exposure is None:
        exposure = auto_exposure(np.asarray(table.left.radiance, dtype=np.float64).sum(axis=0))
    right = layer_lightness(table.right.radiance, table.right.position, display, exposure=exposure)
    ppd = pixels_per_degree(display, w)
    disparity = np.empty((k1, n, h, w, 2), np.float32)
    riv = np.empty((k1, n, h, w), np.float32)
    imp = np.empty((k1, n, h, w), np.float32)
    for m in range(k1):
        if progress is not None:
            progress(m / k1, f"offset {m}/{k1 - 1}: disparity, importance, rivalry")
        left = right if m == 0 else layer_lightness(table.radiance[m], None, display, exposure=exposure)
        pair = PerceivedLightness(left=left, right=right, exposure=float(exposure), pixels_per_degree=ppd)
        match = LayerDisparity(disparity_px=table.disparity_px[m], distance=table.distance[m], epsilon=table.epsilon,
                               window=table.window)  # fmt: skip
        disparity[m] = disparity_arcmin(match.disparity_px, display)
        riv[m] = rivalry(pair, match).rivalry
        imp[m] = importance(pair, match).weight
    if progress is not None:
        progress(1.0, "done")
    return OffsetAnalysis(offsets=np.array(table.offsets), disparity=disparity, rivalry=riv, importance=imp,
                          exposure=float(exposure), display=display, seconds=time.perf_counter() - t0)  # fmt: skip
