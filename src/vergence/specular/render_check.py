"""The final render of S3 §3.4 checked for lost and foreign layer pixels, and repaired.

S3 §3.4 renders each layer of the left eye from its own per-pixel camera. Near a silhouette (a
sphere's rim, a mirror's edge, a goblet's outline) the ray of a moved camera can miss the surface
that the pixel's own first hit is on: the layer is then *lost* there (the pixel shows the first
surface without its reflection or refraction: a dark 1-px rim, since glass and mirrors have no
radiance of their own), or the moved ray meets a specular surface where the physical pixel has
none and the layer is *foreign* (a bright rim of another object's reflection on a diffuse surface).
The layers a pixel has are the physical left eye's (S3 §3.1: the ray tree of the physical render);
the offsets only move the camera each layer is shaded from.

- :func:`check_render` counts both, per layer, and the pixels with either (the rims).
- :func:`repair_render` removes foreign layers and re-traces each lost layer pixel at offsets moved
  towards the physical left eye, ``y + (1 - y) t`` for ``t`` in :data:`REPAIR_STEPS`, keeping the
  first at which the layer exists; a pixel that has it at none takes the physical left eye's layer
  (``y = 1``, which has it by definition). Afterwards no layer pixel is lost or foreign.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vergence._validate import readonly_fields

__all__ = ["REPAIR_STEPS", "RenderCheck", "RepairedRender", "check_render", "repair_render"]

#: Fractions ``t`` of the way back to the physical left eye tried for a lost layer pixel, in order.
REPAIR_STEPS = (0.25, 0.5, 0.75)


@dataclass(frozen=True, slots=True, eq=False)
class RenderCheck:
    """Layer pixels a final render lost or gained against the physical left eye. Arrays are read-only.

    Attributes
    ----------
    lost : (N,) int64
        Per layer, pixels where the physical left eye has the layer and the render does not.
    foreign : (N,) int64
        Per layer, pixels where the render has the layer and the physical left eye does not.
    rim : int
        Pixels with a lost or foreign layer (the rims of issue 26).
    """

    lost: np.ndarray
    foreign: np.ndarray
    rim: int

    def __post_init__(self) -> None:
        readonly_fields(self, "lost", "foreign")

    @property
    def clean(self) -> bool:
        """No layer pixel lost or foreign."""
        return self.rim == 0

    def to_dict(self) -> dict:
        """JSON-ready counts."""
        return {"lost": [int(v) for v in self.lost], "foreign": [int(v) for v in self.foreign], "rim": int(self.rim)}


@dataclass(frozen=True, slots=True, eq=False)
class RepairedRender:
    """:func:`repair_render`'s result: the render, its offsets, and the checks before and after."""

    render: object
    y: np.ndarray
    before: RenderCheck
    after: RenderCheck

    def __post_init__(self) -> None:
        readonly_fields(self, "y")


def _present(res: object) -> np.ndarray:
    return np.isfinite(np.asarray(res.position)).all(axis=-1)


def check_render(physical: object, optimised: object) -> RenderCheck:
    """Count the layer pixels ``optimised`` lost or gained against ``physical`` (see the module text).

    Parameters
    ----------
    physical, optimised : vergence.render.RenderResult
        The physical left eye and the final render (:func:`~vergence.specular.render_offsets`), same
        camera size and number of layers.

    Returns
    -------
    RenderCheck

    Raises
    ------
    TypeError
        If an argument is not a RenderResult.
    ValueError
        If their layers or sizes differ.

    Examples
    --------
    >>> check_render(left, left).to_dict()  # doctest: +SKIP
    {'lost': [0, 0, 0, 0, 0, 0, 0], 'foreign': [0, 0, 0, 0, 0, 0, 0], 'rim': 0}
    """
    from vergence.render import RenderResult

    for name, res in (("physical", physical), ("optimised", optimised)):
        if not isinstance(res, RenderResult):
            raise TypeError(f"{name} must be a vergence.render.RenderResult; got {type(res).__name__}")
    if physical.position.shape != optimised.position.shape:
        raise ValueError(f"physical and optimised must have the same layers and size; got {physical.position.shape} "
                         f"and {optimised.position.shape}")  # fmt: skip
    before, after = _present(physical), _present(optimised)
    lost, foreign = before & ~after, ~before & after
    return RenderCheck(lost=lost.sum(axis=(1, 2)).astype(np.int64), foreign=foreign.sum(axis=(1, 2)).astype(np.int64),
                       rim=int((lost | foreign).any(axis=0).sum()))  # fmt: skip


def repair_render(
    scene: object,
    left: object,
    right: object,
    y: object,
    physical: object,
    optimised: object,
    *,
    samples: int = 16,
    rng: np.random.Generator | None = None,
    ao_distance: float | None = None,
) -> RepairedRender:
    """``optimised`` without lost or foreign layer pixels, and the offsets it was shaded from (see the module text).

    Parameters
    ----------
    scene : vergence.render.Scene or vergence.render.Tracer
    left, right : Camera
        The shifted-sensor rig of the render.
    y : (N, H, W) array_like
        The offsets ``optimised`` was rendered with (:func:`~vergence.specular.render_offsets`).
    physical, optimised : vergence.render.RenderResult
        The physical left eye and the final render.
    samples, rng, ao_distance
        As :func:`~vergence.specular.render_offsets` (use the final render's).

    Returns
    -------
    RepairedRender
        ``render``: layer ``i`` removed where ``physical`` has none, and re-traced where
        ``physical`` has it and ``optimised`` does not; ``y``: the offsets with those pixels' new
        values (1 where the physical layer was copied), and 1 where ``physical`` has no such layer
        past the first (no camera shades it); ``before``/``after``: :func:`check_render`
        of ``optimised`` and of ``render`` (``after.rim`` is 0).

    Raises
    ------
    TypeError, ValueError
        As :func:`check_render` and :func:`~vergence.specular.render_offsets`.
    """
    from vergence.specular.offsets import check_rig, tree_level, offset_map, tracer_of, offset_rays

    before = check_render(physical, optimised)
    tracer = tracer_of(scene)
    left, right = check_rig(left, right)
    n = physical.position.shape[0]
    ymap = np.array(offset_map(np.asarray(y), (n, left.height, left.width)), dtype=np.float32)
    has, got = _present(physical), _present(optimised)
    ymap[1:][~has[1:]] = 1.0  # a layer the pixel does not have is shaded from no camera: say physical
    if before.clean:
        return RepairedRender(render=optimised, y=ymap, before=before, after=before)
    rad, pos, nrm = (np.array(getattr(optimised, name)) for name in ("radiance", "position", "normal"))
    for i in range(n):
        rad[i][~has[i] & got[i]] = 0.0  # foreign: not a layer of this pixel
        pos[i][~has[i] & got[i]] = np.nan
        nrm[i][~has[i] & got[i]] = np.nan
        todo = has[i] & ~got[i]
        for t in REPAIR_STEPS:
            if not todo.any():
                break
            trial = ymap[i] + (1.0 - ymap[i]) * np.float32(t)
            origins, directions = offset_rays(left, right, trial)
            tree = tracer.trace_rays(origins[todo], directions[todo], max_depth=tree_level(i + 1), samples=samples,
                                     rng=rng, ao_distance=ao_distance)  # fmt: skip
            ok = np.isfinite(tree.position[i]).all(axis=-1)
            rows, cols = np.nonzero(todo)
            rows, cols = rows[ok], cols[ok]
            rad[i][rows, cols], pos[i][rows, cols], nrm[i][rows, cols] = (
                tree.radiance[i][ok], tree.position[i][ok], tree.normal[i][ok])
            ymap[i][rows, cols] = trial[rows, cols]
            todo[rows, cols] = False
        rad[i][todo], pos[i][todo], nrm[i][todo] = physical.radiance[i][todo], physical.position[i][todo], \
            physical.normal[i][todo]  # fmt: skip
        ymap[i][todo] = 1.0
    fixed = replace(optimised, radiance=rad, position=pos, normal=nrm, beauty=rad.sum(axis=0))
    return RepairedRender(render=fixed, y=ymap, before=before, after=check_render(physical, fixed))
