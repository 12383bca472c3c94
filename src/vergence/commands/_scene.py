"""The stereo rig of a scene, as the commands that render one take it (``render --eye``, ``specular``, the
workbench's specular job): the ``baseline`` and ``convergence`` parameters, or the scene's "stereo" block."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vergence.commands._naming import literal
from vergence.commands._spec import ParameterError

if TYPE_CHECKING:
    from vergence.camera import Camera
    from vergence.render import Scene

__all__ = ["scene_rig"]


def scene_rig(scene: Scene, baseline: float | None, convergence: float | None, *,
              needed_by: str) -> tuple[Camera, Camera, float, float]:  # fmt: skip
    """The shifted-sensor pair of ``baseline`` / ``convergence``, or of the scene's "stereo" block.

    Parameters
    ----------
    scene : vergence.render.Scene
        Its camera must be a pinhole (the rig shifts the sensor).
    baseline, convergence : float or None
        b and H in metres; None: the scene's.
    needed_by : str
        What needs the rig, as the caller's user knows it (``"vergence specular"``): the start of a
        refusal that names no parameter.

    Returns
    -------
    tuple of (Camera, Camera, float, float)
        ``(left, right, b, H)`` (:func:`vergence.rigs.stereo_pair`).

    Raises
    ------
    ParameterError
        In one line beginning with ``needed_by`` or the parameter at fault (``{baseline}``,
        ``{convergence}``): a scene camera that is not a pinhole, a missing length, a length outside
        ``LENGTH_RANGE``, eyes past ``MAX_SCENE_EXTENT``.
    """
    import numpy as np

    from vergence.render import MAX_SCENE_EXTENT
    from vergence.rigs import stereo_pair
    from vergence.viewing import LENGTH_RANGE

    if scene.camera.lens != "pinhole":
        raise ParameterError(literal(f"{needed_by} needs a pinhole scene camera (the rig shifts the sensor); "
                                      f"got lens {scene.camera.lens!r}"))  # fmt: skip
    rig = scene.stereo
    b = baseline if baseline is not None else (rig.baseline if rig else None)
    h = convergence if convergence is not None else (rig.convergence if rig else None)
    if b is None or h is None:
        raise ParameterError(literal(needed_by) + ' needs {baseline} and {convergence} (the scene has no "stereo" '
                             "block)")  # fmt: skip
    for name, value in (("baseline", b), ("convergence", h)):
        # the rig's lengths as the viewing geometry takes them: the sensor shift fx b / (2H) stays finite
        if not LENGTH_RANGE[0] <= value <= LENGTH_RANGE[1]:
            raise ParameterError("{" + name + "}" + f" must be in [{LENGTH_RANGE[0]:g}, {LENGTH_RANGE[1]:g}] m "
                                 f"(LENGTH_RANGE); got {value:g}")  # fmt: skip
    left, right = stereo_pair(scene.camera.build(), baseline=b, convergence=h)
    reach = max(float(np.abs(c.center).max()) for c in (left, right))
    if reach > MAX_SCENE_EXTENT:  # the eyes at -+ b/2: the scene's limit holds for them too
        raise ParameterError("{baseline}" + f" must keep both eyes within {MAX_SCENE_EXTENT:g} m of the origin "
                             f"(MAX_SCENE_EXTENT); they reach {reach:g} m")  # fmt: skip
    return left, right, b, h
