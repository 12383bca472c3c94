"""The one result type of warping, blending and view synthesis: :class:`WarpedView`.

A warped view carries its colours and, as separate named fields, what the later stages need:
where nothing arrived (``holes``), how near the seen surface is (``nearness``, larger = nearer,
with its unit), its metric depth when the warp knows it, which pixels came only from reliable
source pixels, and any further per-pixel channels (``payload``) that travelled with the colours.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

__all__ = ["NEARNESS_UNITS", "WarpedView"]

# Units of WarpedView.nearness: disparity in pixels on a rectified baseline, or inverse depth.
NEARNESS_UNITS = ("px", "1/m")


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class WarpedView:
    """A view warped, blended or synthesized from one or more references.

    Attributes
    ----------
    image : (H, W) or (H, W, C) float32
        Colours in [0, 1]; 0 in ``holes`` unless the holes were filled (pipelines).
    holes : (H, W) bool
        Target pixels no reference saw (for a filled view: the pixels hole filling made up).
    nearness : (H, W) float32
        Larger = nearer, in ``nearness_unit``: on the rectified path (``nearness_unit == "px"``)
        the source disparity ``x_left - x_right`` in pixels on the references' baseline (not
        scaled by the target position); on the 3D path (``"1/m"``) the inverse target depth
        ``1 / z``. NaN where unknown (holes, unless filled).
    nearness_unit : {"px", "1/m"}
        See ``nearness``.
    depth : (H, W) float32 or None
        Target camera-frame z in metres (``docs/conventions.md``), NaN where unknown; None when
        the warp has no metric information (rectified disparities).
    reliability : (H, W) bool or None
        True where every source pixel that contributed (with a non-zero interpolation weight) was
        reliable (e.g. not along a depth contour, :func:`~vergence.synthesis.contour_mask`); False
        in holes. None: no reliability was tracked (every pixel counts as reliable).
    payload : mapping of str to (H, W) float32
        Further per-pixel channels warped and blended like the colours (e.g. ``"fill_guide"``, the
        disparity that steers hole filling); NaN or 0 in holes as documented by the producer.
    """

    image: np.ndarray
    holes: np.ndarray
    nearness: np.ndarray
    nearness_unit: str = "px"
    depth: np.ndarray | None = None
    reliability: np.ndarray | None = None
    payload: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        hw = np.shape(self.image)[:2]
        if np.ndim(self.image) not in (2, 3):
            raise ValueError(f"WarpedView.image must have shape (H, W) or (H, W, C); got {np.shape(self.image)}")
        if self.nearness_unit not in NEARNESS_UNITS:
            raise ValueError(f"WarpedView.nearness_unit must be one of {', '.join(NEARNESS_UNITS)}; got {self.nearness_unit!r}")
        maps = {"holes": self.holes, "nearness": self.nearness, "depth": self.depth, "reliability": self.reliability}
        maps.update({f"payload[{k!r}]": v for k, v in self.payload.items()})
        for name, m in maps.items():
            if m is not None and np.shape(m) != hw:
                raise ValueError(f"WarpedView.{name} must have shape {hw} matching image; got {np.shape(m)}")
        for name in ("holes", "reliability"):
            m = getattr(self, name)
            if m is not None and np.asarray(m).dtype != bool:
                raise TypeError(f"WarpedView.{name} must be a bool array; got {np.asarray(m).dtype}")
        object.__setattr__(self, "payload", MappingProxyType(dict(self.payload)))

    def to_dict(self) -> dict:
        """JSON-ready summary: size ``[W, H]``, the share of holes (percent, 4 decimals), the
        nearness unit and the payload channel names."""
        h, w = np.shape(self.image)[:2]
        return {
            "size": [int(w), int(h)],
            "holes_percent": round(100.0 * float(np.mean(self.holes)), 4),
            "nearness_unit": self.nearness_unit,
            "payload": sorted(self.payload),
        }
