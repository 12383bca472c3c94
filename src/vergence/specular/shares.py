"""Shares of matched layer pixels inside the comfort zone, plain and importance-weighted, per layer and per object.

An importance-weighted share (:func:`~vergence.specular.comfort_share`) says how much of what S3
§3.2 calls important lies inside the zone; it can hide a surface whose pixels became unimportant, or
a mirror drowned by the glass objects that share its layer. So every figure here comes twice: the
plain share of matched pixels whose horizontal disparity lies in the zone, and the weighted one,
each with its counts, per layer (:func:`zone_count`) and per specular object (:func:`object_shares`:
the pixels whose first hit, in the physical left eye, is that mirror or glass object; its layers past
the first are what is seen in or through it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence._validate import readonly_fields
from vergence.viewing.comfort import ComfortZone

__all__ = ["MOSTLY_OUTSIDE", "LayerState", "ZoneCount", "comfort_share", "object_shares", "specular_objects",
           "zone_count", "zone_warnings"]

#: A specular object whose plain share inside the zone after optimisation is below this is warned
#: about ("stays mostly outside the zone").
MOSTLY_OUTSIDE = 0.5


@dataclass(frozen=True, slots=True, eq=False)
class LayerState:
    """What a viewer gets from the left eye's layers against the right eye (S3 §3.2). Arrays are read-only.

    Attributes
    ----------
    disparity : (N, H, W, 2) float32
        Arcmin on the display, NaN where the layer has no match.
    importance : (N, H, W) float32
    rivalry : (N, H, W) float32
        (ΔL*)^2, NaN in a layer with no match at all.
    present : (N, H, W) bool
        Where the left eye's layer has a surface.
    """

    disparity: np.ndarray
    importance: np.ndarray
    rivalry: np.ndarray
    present: np.ndarray

    def __post_init__(self) -> None:
        readonly_fields(self, "disparity", "importance", "rivalry", "present")

    @property
    def matched(self) -> np.ndarray:
        """``(N, H, W)`` bool: the layer pixel has a match."""
        return ~np.isnan(self.disparity[..., 0])


def comfort_share(state: LayerState, zone: ComfortZone) -> np.ndarray:
    """Per layer, the importance-weighted share of matched pixels whose horizontal disparity lies in ``zone``.

    ``sum w [min <= d_x <= max] / sum w`` over the layer's matched pixels, ``w`` the importance;
    NaN for a layer with no important matched pixel. (The vertical disparity is not part of the
    comfort zone; :func:`specular_stereo`'s cost counts it whole.)
    """
    if not isinstance(state, LayerState):
        raise TypeError(f"state must be a LayerState; got {type(state).__name__}")
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a vergence.viewing.ComfortZone; got {type(zone).__name__}")
    dx = state.disparity[..., 0]
    w = np.where(state.matched, state.importance, 0.0).astype(np.float64)
    inside = (dx >= zone.min_arcmin) & (dx <= zone.max_arcmin)
    total = w.sum(axis=(1, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (w * inside).sum(axis=(1, 2)) / total, np.nan)


@dataclass(frozen=True, slots=True)
class ZoneCount:
    """Per layer, matched pixels and those inside a comfort zone, counted and importance-weighted.

    Attributes
    ----------
    matched, inside : (N,) int64
        Pixels with a match, and those of them whose horizontal disparity lies in the zone.
    weight, weight_inside : (N,) float64
        The importance summed over the same pixels.
    """

    matched: np.ndarray
    inside: np.ndarray
    weight: np.ndarray
    weight_inside: np.ndarray

    def share(self, layers: slice | list[int] | None = None) -> float | np.ndarray:
        """``inside / matched`` per layer (NaN: nothing matched), or over ``layers`` pooled (a float)."""
        return _ratio(self.inside, self.matched, layers)

    def weighted_share(self, layers: slice | list[int] | None = None) -> float | np.ndarray:
        """``weight_inside / weight`` per layer (NaN: no important matched pixel), or over ``layers`` pooled."""
        return _ratio(self.weight_inside, self.weight, layers)


def _ratio(num: np.ndarray, den: np.ndarray, layers: slice | list[int] | None) -> float | np.ndarray:
    if layers is not None:
        a, b = float(np.sum(num[layers])), float(np.sum(den[layers]))
        return a / b if b > 0 else float("nan")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1), np.nan)


def zone_count(state: object, zone: ComfortZone, mask: np.ndarray | None = None) -> ZoneCount:
    """Count, per layer, the matched pixels of ``state`` and those inside ``zone`` (only where ``mask``).

    Parameters
    ----------
    state : LayerState
    zone : ComfortZone
        A pixel is inside when ``min_arcmin <= d_x <= max_arcmin`` (its horizontal disparity).
    mask : (H, W) bool, optional
        Pixels to count (default: all).

    Returns
    -------
    ZoneCount
    """
    if not isinstance(state, LayerState):
        raise TypeError(f"state must be a LayerState; got {type(state).__name__}")
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a vergence.viewing.ComfortZone; got {type(zone).__name__}")
    matched = state.matched
    if mask is not None:
        mask = np.asarray(mask)
        if mask.dtype != bool or mask.shape != matched.shape[1:]:
            raise ValueError(f"mask must be a bool array of shape {matched.shape[1:]}; got {mask.dtype} {mask.shape}")
        matched = matched & mask
    dx = state.disparity[..., 0]
    with np.errstate(invalid="ignore"):
        inside = matched & (dx >= zone.min_arcmin) & (dx <= zone.max_arcmin)
    w = np.where(matched, state.importance, 0.0).astype(np.float64)
    return ZoneCount(matched=matched.sum(axis=(1, 2)), inside=inside.sum(axis=(1, 2)), weight=w.sum(axis=(1, 2)),
                     weight_inside=(w * inside).sum(axis=(1, 2)))  # fmt: skip


def specular_objects(scene: object) -> list[dict]:
    """The mirror and glass objects of ``scene``: ``object`` (index in ``scene.objects``), ``name`` (its
    material's name), ``type`` (``"mirror"`` or ``"glass"``) and ``shape`` (sphere, rectangle, mesh)."""
    from vergence.render.scene import Glass, Mirror

    out = []
    for i, obj in enumerate(scene.objects):
        mat = scene.materials[obj.material]
        if isinstance(mat, Glass | Mirror):
            out.append({"object": i, "name": obj.material, "type": "glass" if isinstance(mat, Glass) else "mirror",
                        "shape": type(obj).__name__.lower()})  # fmt: skip
    return out


def _num(v: float) -> float | None:
    return None if not np.isfinite(v) else round(float(v), 4)


def _layer_rows(before: ZoneCount, after: ZoneCount, names: list[str], first: int) -> list[dict]:
    rows = []
    for i in range(first, len(names)):
        if before.matched[i] == 0 and after.matched[i] == 0:
            continue
        rows.append({"layer": i + 1, "name": names[i],
                     "matched_before": int(before.matched[i]), "inside_before": int(before.inside[i]),
                     "inside_share_before": _num(before.share()[i]),
                     "comfort_share_before": _num(before.weighted_share()[i]),
                     "matched_after": int(after.matched[i]), "inside_after": int(after.inside[i]),
                     "inside_share_after": _num(after.share()[i]),
                     "comfort_share_after": _num(after.weighted_share()[i])})  # fmt: skip
    return rows


def pooled_counts(before: ZoneCount, after: ZoneCount, layers: slice) -> dict:
    """The counts and shares of ``layers`` pooled, before and after (the keys of :func:`object_shares`)."""
    return {"matched_before": int(before.matched[layers].sum()), "inside_before": int(before.inside[layers].sum()),
            "inside_share_before": _num(before.share(layers)), "comfort_share_before": _num(before.weighted_share(layers)),
            "matched_after": int(after.matched[layers].sum()), "inside_after": int(after.inside[layers].sum()),
            "inside_share_after": _num(after.share(layers)), "comfort_share_after": _num(after.weighted_share(layers))}  # fmt: skip


def object_shares(before: object, after: object, first_object: np.ndarray, objects: list[dict], zone: ComfortZone,
                  names: list[str]) -> list[dict]:  # fmt: skip
    """Per specular object, the zone shares of the layers seen in or through it, before and after.

    Parameters
    ----------
    before, after : LayerState
        The physical and the optimised left eye, measured against the right eye.
    first_object : (H, W) int
        The object of each pixel's first hit in the physical left eye (``RenderResult.object_id[0]``);
        the optimised eye's first layer is the physical one (its offset stays 1), so the same pixels
        belong to the object after.
    objects : list of dict
        :func:`specular_objects` of the scene.
    zone : ComfortZone
    names : list of str
        The layer names (:func:`~vergence.specular.layer_labels`).

    Returns
    -------
    list of dict
        For each object of ``objects`` seen at some pixel: its entry, ``pixels`` (first hits on it),
        the pooled counts and shares of its layers 2..N (``matched``, ``inside``,
        plain ``inside_share`` and importance-weighted ``comfort_share``, before and after) and
        ``layers``, the same per layer with a match.
    """
    out = []
    for obj in objects:
        mask = np.asarray(first_object) == obj["object"]
        if not mask.any():
            continue
        b, a = zone_count(before, zone, mask), zone_count(after, zone, mask)
        out.append({**obj, "pixels": int(mask.sum()), **pooled_counts(b, a, slice(1, None)),
                    "layers": _layer_rows(b, a, names, 1)})  # fmt: skip
    return out


def zone_warnings(objects: list[dict], zone: ComfortZone) -> list[str]:
    """One line per specular object (:func:`object_shares`) whose plain share inside ``zone`` after
    optimisation is below :data:`MOSTLY_OUTSIDE`."""
    lines = []
    for obj in objects:
        share = obj["inside_share_after"]
        if share is None or share >= MOSTLY_OUTSIDE:
            continue
        before = obj["inside_share_before"]
        lines.append(f"the {obj['type']} '{obj['name']}' (objects[{obj['object']}], {obj['shape']}) stays mostly "
                     f"outside the {zone.min_arcmin:g}..{zone.max_arcmin:g} arcmin zone: {100 * share:.0f} % of its "
                     f"{obj['matched_after']} matched layer pixels inside after optimisation"
                     + ("" if before is None else f" ({100 * before:.0f} % before)"))  # fmt: skip
    return lines
