"""Which way is up in a collection, and which eye of a pair is the left one (S2 §4.2).

S2 rectifies a pair "with the x axis from left to right centre" (§3.2) and browses it with the
image's up staying up (§4.2). The order of the eyes decides both: Fusiello's rectified frame has
``r1 = (c_right - c_left)/|.|`` and ``r2 = k x r1`` (``k`` the left camera's optical axis) as its
image down axis, so swapping the eyes turns the rectified images by 180 degrees. Deciding the order
from one camera's image axes (``baseline . R[0] < 0``) fails when the photos are rolled: on a ring
whose images are turned 90 degrees about their optical axes (dino), the baseline of neighbouring
cameras is perpendicular to their image x axes (a cosine of about 0.006), its sign flips from one
state to the next, and so does the pair. Here the order follows the collection's world up.

- :func:`collection_up`: the unit direction perpendicular to the cameras' optical axes and to the
  directions of their centres from their mean (photos taken at about one height, level or tilted
  alike: a ring, an arc, a row), signed by a vote of the cameras' image-up axes ``-R[1]``.
- :func:`eye_order`: the left eye is the one that puts the rectified image's down axis ``r2``
  against that up (``r2 . up < 0``).
"""

from __future__ import annotations

import numpy as np

from vergence.camera import Camera

__all__ = ["UP_AGREEMENT", "UP_DISTINCT", "UP_MIN_COSINE", "collection_up", "eye_order"]

UP_AGREEMENT = 0.5
"""Length of the mean of the cameras' unit image-up axes above which they agree on "up": the fallback
of :func:`collection_up` when the cameras' geometry leaves no direction free (kermit 0.94; dino, a
ring of photos rolled 90 degrees, 0.02)."""
UP_DISTINCT = 0.5
"""The fitted up is used when its singular value is at most this fraction of the next one (the
cameras' axes and centre directions leave one direction clearly free); otherwise the mean image-up
when the cameras agree on it (:data:`UP_AGREEMENT`)."""
UP_MIN_COSINE = 1e-6
"""Below this ``|r2 . up|`` (a baseline along up, rectified images rolled 90 degrees whichever the
order) the order falls back to the first camera's x axis."""


def collection_up(cameras: object) -> np.ndarray:
    """The world up of a set of cameras, shape (3,), unit.

    Parameters
    ----------
    cameras : sequence of Camera
        At least one.

    Returns
    -------
    (3,) float64
        ``n``, the right singular vector of the smallest singular value of the matrix whose rows are
        the cameras' unit optical axes ``R[2]`` and the unit directions of their centres from the
        mean centre; its sign makes ``sum_k (-R_k[1]) . n >= 0`` (a vote of the image-up axes: a
        minority of photos rolled by 90 to 180 degrees does not turn it; a ring rolled 90 degrees
        throughout, as dino, ties at 0 and keeps the fitted sign, the same for every pair). When that
        direction is not clearly free (its singular value above :data:`UP_DISTINCT` of the next: the
        cameras look in all directions or stand in a vertical plane), the normalised mean image-up
        when its length reaches :data:`UP_AGREEMENT`, else still ``n``.

    Raises
    ------
    TypeError
        Not a sequence of Camera, or none.

    Examples
    --------
    Three cameras on an arc whose image up is world +y, the middle one rolled by 180 degrees (its
    image up is -y): up is still +y.

    >>> from vergence.camera import look_at
    >>> cams = [look_at([x, 0, 0], [0, 0, 5], [0, 1 if x else -1, 0], fov_deg=60, width=64, height=48)
    ...         for x in (-1, 0, 1)]
    >>> collection_up(cams).round(6).tolist()
    [0.0, 1.0, 0.0]
    """
    cams = list(cameras) if not isinstance(cameras, Camera) else []
    if not cams or not all(isinstance(c, Camera) for c in cams):
        raise TypeError("cameras must be a non-empty sequence of Camera")
    axes = np.array([c.R[2] for c in cams], dtype=np.float64)
    ups = np.array([-c.R[1] for c in cams], dtype=np.float64)
    centers = np.array([c.center for c in cams], dtype=np.float64)
    offsets = centers - centers.mean(axis=0)
    norms = np.linalg.norm(offsets, axis=1)
    scale = float(norms.max()) if len(norms) else 0.0
    dirs = offsets[norms > 1e-9 * max(scale, 1e-300)]
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    _, s, vt = np.linalg.svd(np.concatenate([axes, dirs]), full_matrices=True)
    s3 = np.zeros(3)
    s3[: len(s)] = s
    n = vt[2]
    mean_up = ups.mean(axis=0)
    if s3[2] > UP_DISTINCT * s3[1] and np.linalg.norm(mean_up) >= UP_AGREEMENT:
        return mean_up / np.linalg.norm(mean_up)
    return n if float((ups @ n).sum()) >= 0.0 else -n


def eye_order(first: Camera, second: Camera, up: np.ndarray) -> bool:
    """Whether the left eye of the pair ``(first, second)`` is ``second`` (the pair is swapped).

    With ``first`` as the left eye, Fusiello's rectified image down axis is
    ``r2 = first.R[2] x (second.center - first.center)`` (normalised); the pair is swapped when
    ``r2 . up > 0`` (the rectified image would be upside down), so that rows run down the world.
    Where ``|r2 . up|`` is below :data:`UP_MIN_COSINE` (a baseline along up), the left eye is the
    one with the smaller x in ``first``'s frame.

    Examples
    --------
    World up -y; ``a`` level (image up -y), ``b`` 10 cm to its right and rolled by 180 degrees, so
    that ``a`` lies at positive x in ``b``'s frame: ``a`` is the left eye in either order.

    >>> from vergence.camera import look_at
    >>> a = look_at([0, 0, 0], [0, 0, 5], [0, -1, 0], fov_deg=60, width=64, height=48)
    >>> b = look_at([0.1, 0, 0], [0.1, 0, 5], [0, 1, 0], fov_deg=60, width=64, height=48)
    >>> up = np.array([0.0, -1.0, 0.0])
    >>> eye_order(a, b, up), eye_order(b, a, up)
    (False, True)
    """
    baseline = second.center - first.center
    r2 = np.cross(first.R[2], baseline)
    norm = float(np.linalg.norm(r2))
    cosine = float(r2 @ up) / norm if norm > 0.0 else 0.0
    if abs(cosine) >= UP_MIN_COSINE:
        return cosine > 0.0
    return bool(baseline @ first.R[0] < 0.0)
