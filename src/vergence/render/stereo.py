"""One call from a scene to a displayable stereo pair (for ``vergence demo`` and reports)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from vergence.render.builtin import open_scene
from vergence.render.tonemap import auto_exposure, tonemap
from vergence.render.raytree import Progress, render_stereo
from vergence.render.results import RenderResult
from vergence.render.scene import Scene

__all__ = ["StereoPreview", "stereo_preview"]


@dataclass(frozen=True, slots=True, eq=False)
class StereoPreview:
    """A rendered stereo pair ready for display.

    Attributes
    ----------
    left, right : (H, W, 3) float32
        sRGB images in [0, 1], tone-mapped with the same ``exposure`` (linear, S3 §3.2).
    left_result, right_result : RenderResult
        The full ray trees (radiance, positions, normals, depth, cameras).
    baseline, convergence : float
        The rig (metres): zero disparity at ``convergence`` (S0 §2).
    exposure : float
        Radiance multiplier used for both images.
    note : str or None
        The scene's lighting note (e.g. that a missing HDR map was replaced by a constant sky).
    """

    left: np.ndarray
    right: np.ndarray
    left_result: RenderResult
    right_result: RenderResult
    baseline: float
    convergence: float
    exposure: float
    note: str | None


def stereo_preview(
    scene: Scene | str | Path = "stadium",
    *,
    width: int | None = None,
    height: int | None = None,
    baseline: float | None = None,
    convergence: float | None = None,
    max_depth: int = 2,
    samples: int = 16,
    rng: np.random.Generator | None = None,
    progress: Progress | None = None,
) -> StereoPreview:
    """Render the shifted-sensor stereo pair of a scene and tone-map both eyes alike.

    Parameters
    ----------
    scene : Scene, built-in name or scene file
        Default: the ``stadium`` built-in (S0 §4).
    width, height : int, optional
        Image size (a missing one follows the scene camera's aspect ratio); default: the scene's.
    baseline, convergence : float, optional
        The rig in metres; default: the scene's ``stereo`` block.
    max_depth, samples, rng, progress
        As :func:`vergence.render.render`.

    Raises
    ------
    ValueError
        If the rig is not given and the scene has no ``stereo`` block.

    Examples
    --------
    >>> pair = stereo_preview("tabletop", width=16, height=12, samples=1)
    >>> pair.left.shape, pair.left.dtype.name, pair.convergence
    ((12, 16, 3), 'float32', 1.2)
    """
    if isinstance(scene, Scene):
        sc = replace(scene, camera=scene.camera.resized(width=width, height=height))
    else:
        sc = open_scene(scene, width=width, height=height)
    b = baseline if baseline is not None else (sc.stereo.baseline if sc.stereo else None)
    h = convergence if convergence is not None else (sc.stereo.convergence if sc.stereo else None)
    if b is None or h is None:
        raise ValueError(f"scene {sc.name!r} has no stereo block: give baseline and convergence")
    left, right = render_stereo(sc, baseline=b, convergence=h, max_depth=max_depth, samples=samples, rng=rng,
                                progress=progress)  # fmt: skip
    k = auto_exposure(left.beauty)
    return StereoPreview(left=tonemap(left.beauty, exposure=k), right=tonemap(right.beauty, exposure=k),
                         left_result=left, right_result=right, baseline=float(b), convergence=float(h),
                         exposure=k, note=sc.environment.note)  # fmt: skip
