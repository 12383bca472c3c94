"""The source cameras of a novel view and their images (shared by the novel-view methods).

- :func:`neighbours`: the source cameras nearest a target (centre seen from the scene + direction).
- :func:`load_view`: a collection's image as float32 RGB in [0, 1], cached in an optional dict.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from vergence.camera import Camera
from vergence.io import read_image
from vergence.stereospace.collection import Collection

__all__ = ["as_colour", "check_request", "load_view", "neighbours"]


def check_request(collection: object, target: object, exclude: object) -> tuple[Collection, Camera, set[str]]:
    """The checked arguments of a novel-view request: collection, target camera, excluded names."""
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if not isinstance(target, Camera):
        raise TypeError(f"target must be a Camera; got {type(target).__name__}")
    if isinstance(exclude, str) or not isinstance(exclude, Iterable):
        raise TypeError("exclude must be a sequence of camera names")
    excluded = set(exclude)
    unknown = excluded - set(collection.names)
    if unknown:
        raise ValueError(f"exclude names cameras not in the collection: {', '.join(sorted(unknown))}")
    return collection, target, excluded


def _axis(cam: Camera) -> np.ndarray:
    return cam.R[2]


def _scene_centre(collection: Collection) -> np.ndarray:
    if len(collection.points):
        return np.median(collection.points, axis=0)
    return collection.centers.mean(axis=0) + np.mean([_axis(c) for c in collection.cameras], axis=0)


def neighbours(collection: Collection, target: Camera, *, k: int = 4, exclude: Iterable[str] = ()) -> list[int]:
    """Indices of the ``k`` source cameras closest to ``target``, best first.

    The cost of a source ``i`` is ``|C_i - C_t| / |S - C_t| + angle(z_i, z_t)`` (radians): its centre's
    distance from the target's, seen from the scene (``S`` the median of the sparse points, so the
    first term is about the angle the two centres subtend at the object), plus the angle between the
    two optical axes. Excluded cameras are never returned.

    Raises
    ------
    TypeError
        A collection or target of the wrong type, ``exclude`` not a sequence of names.
    ValueError
        ``k < 1``, an unknown name in ``exclude``, every camera excluded.
    """
    collection, target, excluded = check_request(collection, target, exclude)
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
        raise ValueError(f"k must be an integer >= 1; got {k!r}")
    keep = [i for i, n in enumerate(collection.names) if n not in excluded]
    if not keep:
        raise ValueError("exclude leaves no source camera")
    centres = collection.centers[keep]
    scale = max(float(np.linalg.norm(_scene_centre(collection) - target.center)), 1e-12)
    axes = np.array([_axis(collection.cameras[i]) for i in keep])
    angle = np.arccos(np.clip(axes @ _axis(target), -1.0, 1.0))
    cost = np.linalg.norm(centres - target.center, axis=1) / scale + angle
    order = np.argsort(cost, kind="stable")[:k]
    return [keep[i] for i in order]


def as_colour(image: np.ndarray) -> np.ndarray:
    """``image`` as float32 RGB clipped to [0, 1] (grey images repeated on three channels)."""
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    return np.clip(img, 0.0, 1.0)


def load_view(collection: Collection, i: int, images: dict[int, np.ndarray] | None) -> np.ndarray:
    """Camera ``i``'s image (:func:`as_colour`), from and into the cache ``images`` when given."""
    if images is not None and i in images:
        return images[i]
    img = as_colour(read_image(collection.image_paths[i]))
    if images is not None:
        images[i] = img
    return img


