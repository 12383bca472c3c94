"""The figures of an S3 run, JSON-ready: what ``report.json`` of ``vergence specular`` holds (S3 §3-4).

Every share is given plainly (pixels inside the comfort zone among the matched ones, with their
counts) beside the importance-weighted one, per layer, pooled over the specular layers and per mirror
or glass object (:mod:`vergence.specular.shares`); a separation share says how much of each
reflection still reads as one (S3 §2).
"""

from __future__ import annotations

import math

import numpy as np

from vergence.specular.shares import LayerState, comfort_share, object_shares, pooled_counts, zone_count, zone_warnings

__all__ = ["SEPARATION_ARCMIN", "layer_labels", "specular_report"]

#: Two layers closer than this in depth pool into one (S3 §2: about 2 arcmin); a specular layer at
#: least this far from its first surface, on the physical side, still reads as a reflection.
SEPARATION_ARCMIN = 2.0


def _separated_share(state: LayerState, physical: LayerState) -> np.ndarray:
    """Per layer past the first, the importance-weighted share of pixels still at least
    :data:`SEPARATION_ARCMIN` from the first surface on their physical side (NaN: no such pixel)."""
    d0, p0 = state.disparity[0, ..., 0], physical.disparity[0, ..., 0]
    out = np.full(state.disparity.shape[0], np.nan)
    for i in range(1, len(out)):
        side = np.sign(physical.disparity[i, ..., 0] - p0)
        ok = state.matched[i] & state.matched[0] & physical.matched[i] & physical.matched[0] & (side != 0)
        w = np.where(ok, state.importance[i], 0.0).astype(np.float64)
        if w.sum() > 0:
            sep = np.where(ok, side * (state.disparity[i, ..., 0] - d0), 0.0)
            out[i] = float((w * (sep >= SEPARATION_ARCMIN)).sum() / w.sum())
    return out


def _num(v: float) -> float | None:
    return None if not math.isfinite(v) else round(float(v), 4)


def _ratio(a: int, b: int) -> float | None:
    return None if b == 0 else round(float(a) / b, 4)


def layer_labels(n: int) -> list[str]:
    """Names of the heap nodes 1..n: ``"1"`` the first hit, then ``R`` (reflection) / ``T`` (refraction) paths."""
    from vergence.render.results import layer_names

    return layer_names(int(math.log2(n + 1)) - 1)


def specular_report(result: object) -> dict:
    """JSON-ready figures of ``result`` (a :class:`~vergence.specular.SpecularResult`): the display
    geometry they assume, cost terms before and after, and per layer the matched share, the plain
    share of matched pixels inside the comfort zone (``inside_share``, with its counts
    ``matched_pixels`` and ``inside_pixels``) beside the importance-weighted one (``comfort_share``),
    the separation share and the mean offset; the same plain and weighted shares pooled over the
    specular layers (``specular_layers``) and per mirror or glass object (``objects``,
    :func:`~vergence.specular.object_shares`), and one ``warnings`` line per object that stays mostly
    outside the zone."""
    names = layer_labels(result.y.shape[0])
    layers = []
    share_b, share_a = comfort_share(result.before, result.zone), comfort_share(result.after, result.zone)
    count_b, count_a = zone_count(result.before, result.zone), zone_count(result.after, result.zone)
    plain_b, plain_a = count_b.share(), count_a.share()
    sep_b = _separated_share(result.before, result.before)
    sep_a = _separated_share(result.after, result.before)
    for i, name in enumerate(names):
        present = int(result.before.present[i].sum())
        layers.append({
            "layer": i + 1, "name": name, "pixels": present,
            "matched_before": _ratio(result.before.matched[i].sum(), present),
            "matched_after": _ratio(result.after.matched[i].sum(), int(result.after.present[i].sum())),
            "matched_pixels_before": int(count_b.matched[i]), "inside_pixels_before": int(count_b.inside[i]),
            "matched_pixels_after": int(count_a.matched[i]), "inside_pixels_after": int(count_a.inside[i]),
            "inside_share_before": _num(plain_b[i]), "inside_share_after": _num(plain_a[i]),
            "comfort_share_before": _num(share_b[i]), "comfort_share_after": _num(share_a[i]),
            "separated_share_before": _num(sep_b[i]), "separated_share_after": _num(sep_a[i]),
            "offset_mean": float(result.y[i][result.before.present[i]].mean()) if present else None,
        })  # fmt: skip
    settings = {k: v for k, v in result.settings.items() if k not in ("display", "objects")}
    oid = getattr(result.physical_left, "object_id", None)
    objects = [] if oid is None else object_shares(result.before, result.after, oid[0], result.settings.get("objects", []),
                                                   result.zone, names)  # fmt: skip
    return {
        "specular": result.specular,
        "display": result.settings.get("display"),
        "settings": settings,
        "comfort_zone_arcmin": [result.zone.min_arcmin, result.zone.max_arcmin],
        "cost_before": result.cost_before.means(),
        "cost_after": result.cost_after.means(),
        "layers": layers,
        "specular_layers": pooled_counts(count_b, count_a, slice(1, None)),
        "objects": objects,
        "warnings": zone_warnings(objects, result.zone),
        **{key: check.to_dict() for key in ("render_check", "render_check_raw")
           if (check := getattr(result, key, None)) is not None},
        "seconds": {k: round(v, 3) for k, v in result.seconds.items()},
    }
