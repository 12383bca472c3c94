"""Per-view depth of a collection from the collection itself, checked against the other views.

Ours (S2 §6 says its in-between views are what most needs improving): each camera is matched with a
partner (:func:`vergence.depth.compute_disparity` on the Fusiello-rectified pair), and the matched
depth is then checked, pixel by pixel, before it may drive a novel view:

1. **Texture.** A pixel whose grey level varies by less than :data:`TEXTURE_MIN_STD` (standard
   deviation over a :data:`TEXTURE_WINDOW` square) has nothing to match: the matcher's value there is
   a guess carried in from the surroundings. Such guesses on a black backdrop, placed in front of the
   object, hide it in the novel view; they are dropped (the backdrop itself is filled later).
2. **Photo-consistency.** Each pixel, lifted to 3D with its depth, is projected into the
   :data:`CONSISTENCY_VIEWS` cameras nearest to it (:func:`~vergence.stereospace.neighbours`, the
   excluded ones never among them); its colour must agree with theirs, the mean absolute difference
   over a :data:`CONSISTENCY_WINDOW` square below :data:`CONSISTENCY_TOLERANCE`, in at least
   :data:`CONSISTENCY_VOTES` of the views that see it (all of them when fewer see it; a point hidden
   from one view by an occluder still passes in the others). A wrong depth puts the pixel on another
   part of the scene in the other views and fails.

Parameters were chosen on kermit and the even-numbered dino views (see benchmarks/stereospace_loo.py).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import cv2
import numpy as np

from vergence.depth import compute_disparity, rectify_pair
from vergence.stereospace.collection import Collection
from vergence.stereospace.graph import camera_graph
from vergence.stereospace.sources import check_request, load_view, neighbours

__all__ = [
    "CONSISTENCY_TOLERANCE",
    "CONSISTENCY_VIEWS",
    "CONSISTENCY_VOTES",
    "CONSISTENCY_WINDOW",
    "DISPARITY_MARGIN_PX",
    "TEXTURE_MIN_STD",
    "TEXTURE_WINDOW",
    "check_depth",
    "source_depth",
    "source_depths",
]

#: Pixels added on each side of the disparity range of the sparse points (5th..95th percentile)
#: when matching a pair: the points miss the nearest and farthest surfaces by a few pixels.
DISPARITY_MARGIN_PX = 16
#: Grey-level standard deviation (images in [0, 1]) below which a pixel has no depth.
TEXTURE_MIN_STD = 0.005
#: Side of the square window of the texture measure, pixels.
TEXTURE_WINDOW = 7
#: Views a depth is checked against.
CONSISTENCY_VIEWS = 4
#: Side of the square window of the colour comparison, pixels.
CONSISTENCY_WINDOW = 5
#: Mean absolute colour difference (RGB in [0, 1]) under which two views agree.
CONSISTENCY_TOLERANCE = 0.06
#: Views that must agree (fewer when fewer see the point).
CONSISTENCY_VOTES = 3

Progress = Callable[[float, str], None]
PairCache = dict[tuple[int, int], np.ndarray]


def _ordered(collection: Collection, i: int, j: int) -> bool:
    """Whether the pair can be rectified: one centre at positive x of the other camera."""
    ci, cj = collection.cameras[i], collection.cameras[j]
    return float(ci.R[0] @ (cj.center - ci.center)) > 0 or float(cj.R[0] @ (ci.center - cj.center)) > 0


def _partner(collection: Collection, i: int, edges: np.ndarray, allowed: set[int]) -> int | None:
    """The camera ``i`` is matched with: its graph neighbour with the nearest centre that can be
    rectified with it, else the first such of :func:`neighbours` (None without one)."""
    centre = collection.centers[i]
    linked = sorted({int(b if a == i else a) for a, b in edges if i in (a, b)} & allowed,
                    key=lambda j: float(np.linalg.norm(collection.centers[j] - centre)))  # fmt: skip
    others = [collection.names[n] for n in range(len(collection)) if n not in allowed or n == i]
    rest = neighbours(collection, collection.cameras[i], k=len(collection), exclude=others) if allowed - {i} else []
    for j in linked + [j for j in rest if j not in linked]:
        if _ordered(collection, i, j):
            return j
    return None


def _pair_depth(collection: Collection, i: int, j: int, images: dict | None) -> np.ndarray:
    """Depth of camera ``i`` (its frame, NaN unknown) from matching it with camera ``j``."""
    cam_i, cam_j = collection.cameras[i], collection.cameras[j]
    # Fusiello's frame needs the right centre at positive x of the left camera: i is left when j is
    # to its right, else j must have i to its right (converging cameras may satisfy neither)
    i_left = float(cam_i.R[0] @ (cam_j.center - cam_i.center)) > 0
    left, right = (i, j) if i_left else (j, i)
    pair = rectify_pair(load_view(collection, left, images), load_view(collection, right, images),
                        collection.cameras[left], collection.cameras[right])  # fmt: skip
    rect = pair.rectification
    # the disparity range of the sparse points seen by both rectified cameras
    pl, zl = rect.left_camera.project(collection.points)
    pr, zr = rect.right_camera.project(collection.points)
    ok = (zl > 0) & (zr > 0) & np.isfinite(pl).all(axis=1) & np.isfinite(pr).all(axis=1)
    if ok.sum() < 2:
        return np.full((cam_i.height, cam_i.width), np.nan)
    disp = pl[ok, 0] - pr[ok, 0]
    lo = int(np.floor(np.percentile(disp, 5))) - DISPARITY_MARGIN_PX
    hi = int(np.ceil(np.percentile(disp, 95))) + DISPARITY_MARGIN_PX
    a, b, valid, rcam, hom = pair.left, pair.right, pair.left_valid, rect.left_camera, rect.left_homography
    if not i_left:  # the right view's disparity: match the mirrored pair (right becomes left)
        # mirrored columns x' = W - 1 - x give the disparity d' = d + (W_right - W_left)
        shift = pair.right.shape[1] - pair.left.shape[1]
        a, b, valid = pair.right[:, ::-1], pair.left[:, ::-1], pair.right_valid[:, ::-1]
        lo, hi = lo + shift, hi + shift
        rcam, hom = rect.right_camera, rect.right_homography
    width = a.shape[1]
    # the search must fit the image: shift the window inwards, keep its length
    lo = max(lo, -(width // 2) + 16)
    hi = min(max(hi, lo + 16), width // 2 - 16)
    res = compute_disparity(np.ascontiguousarray(a), np.ascontiguousarray(b), max_disparity=hi, min_disparity=lo,
                            keep_invalid=True, valid=np.ascontiguousarray(valid))  # fmt: skip
    d = res.disparity.astype(np.float64)
    if not i_left:
        d = d[:, ::-1] - shift  # x_left - x_right again, in the right image's columns
    denom = d + rect.doffs_px  # Z = f b / (d + doffs), S1 Eq. 7
    with np.errstate(divide="ignore", invalid="ignore"):
        z_rect = np.where(denom > 0, rect.focal_px * rect.baseline / denom, np.nan)
    # gather: each original pixel of i, through T (m_rect ~ T m_orig), to its rectified depth
    grid = cam_i.pixel_grid()
    homog = np.concatenate([grid, np.ones(grid.shape[:2] + (1,))], axis=-1) @ np.asarray(hom).T
    rpix = homog[..., :2] / homog[..., 2:3]
    rx, ry = np.rint(rpix[..., 0]), np.rint(rpix[..., 1])
    inside = (rx >= 0) & (rx < z_rect.shape[1]) & (ry >= 0) & (ry < z_rect.shape[0])
    zr_at = np.full(grid.shape[:2], np.nan)
    zr_at[inside] = z_rect[ry[inside].astype(int), rx[inside].astype(int)]
    known = np.isfinite(zr_at)
    world = np.full(grid.shape[:2] + (3,), np.nan)
    world[known] = rcam.backproject(rpix[known], zr_at[known])
    depth = np.full(grid.shape[:2], np.nan)
    depth[known] = (world[known] @ cam_i.R.T + cam_i.t)[:, 2]
    depth[depth <= 0] = np.nan
    return depth


def _agrees(collection: Collection, i: int, depth: np.ndarray, test: np.ndarray, views: list[int],
            image: np.ndarray, images: dict | None) -> np.ndarray:
    """The pixels of ``test`` whose point at ``depth`` passes the photo-consistency test in ``views``."""
    cam = collection.cameras[i]
    points = cam.backproject(cam.pixel_grid(), np.where(test, depth, 1.0))
    seen = np.zeros(depth.shape, np.int32)
    agree = np.zeros(depth.shape, np.int32)
    window = (CONSISTENCY_WINDOW, CONSISTENCY_WINDOW)
    for j in views:
        other = collection.cameras[j]
        pix, z = other.project(points)
        mx, my = pix[..., 0].astype(np.float32), pix[..., 1].astype(np.float32)
        inside = (z > 0) & (mx >= 0) & (mx <= other.width - 1) & (my >= 0) & (my <= other.height - 1)
        sampled = cv2.remap(load_view(collection, j, images), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        difference = cv2.boxFilter(np.abs(sampled - image).mean(axis=2), -1, window)
        seen += inside
        agree += inside & (difference < CONSISTENCY_TOLERANCE)
    return test & (seen > 0) & (agree >= np.minimum(CONSISTENCY_VOTES, seen))


def check_depth(
    collection: Collection, i: int, depth: np.ndarray, *, exclude: Iterable[str] = (), images: dict | None = None
) -> np.ndarray:
    """Camera ``i``'s ``depth`` with the pixels that fail the texture or photo-consistency test set
    to NaN (see the module's text); excluded cameras are never among the views it is checked against.

    Returns
    -------
    (H, W) float64
    """
    i = _camera(collection, i)
    collection, cam, excluded = check_request(collection, collection.cameras[i], exclude)
    depth = np.asarray(depth, dtype=np.float64)
    if depth.shape != (cam.height, cam.width):
        raise ValueError(f"depth must be {cam.height} x {cam.width} (camera {i}); got {depth.shape}")
    image = load_view(collection, i, images)
    grey = image.mean(axis=2)
    size = (TEXTURE_WINDOW, TEXTURE_WINDOW)
    mean = cv2.boxFilter(grey, -1, size)
    std = np.sqrt(np.maximum(cv2.boxFilter(grey * grey, -1, size) - mean * mean, 0.0))
    known = np.isfinite(depth) & (depth > 0) & (std > TEXTURE_MIN_STD)
    others = [n for k, n in enumerate(collection.names) if k != i and n not in excluded]
    if not known.any() or not others:
        return np.where(known, depth, np.nan)
    views = neighbours(collection, cam, k=CONSISTENCY_VIEWS, exclude=[collection.names[i], *excluded])
    return np.where(_agrees(collection, i, depth, known, views, image, images), depth, np.nan)


def source_depth(
    collection: Collection,
    i: int,
    *,
    exclude: Iterable[str] = (),
    images: dict | None = None,
    pairs: PairCache | None = None,
) -> np.ndarray:
    """Camera ``i``'s checked depth (NaN unknown), made without the excluded cameras.

    Its partner is the :func:`~vergence.stereospace.camera_graph` neighbour with the nearest centre
    that can be rectified with it (else the best such of :func:`neighbours`); the pair is rectified
    (Fusiello et al. 2000) and matched with :func:`~vergence.depth.compute_disparity` (SGBM +
    refinement, unknown kept NaN) over the disparity range of the sparse points plus
    :data:`DISPARITY_MARGIN_PX`; the disparity becomes depth ``Z = f b / (d + doffs)`` (S1 Eq. 7) in the
    rectified frame and is carried back to ``i``'s pixels through its rectifying homography; then
    :func:`check_depth`. ``pairs``: an optional cache of the matched depths by ``(i, partner)``.
    """
    i = _camera(collection, i)
    collection, cam, excluded = check_request(collection, collection.cameras[i], exclude)
    allowed = {k for k, n in enumerate(collection.names) if n not in excluded and k != i}
    j = _partner(collection, i, _edges(collection), allowed)
    if j is None:
        return np.full((cam.height, cam.width), np.nan)
    if pairs is not None and (i, j) in pairs:
        raw = pairs[(i, j)]
    else:
        try:
            raw = _pair_depth(collection, i, j, images)
        except ValueError:  # a pair without texture to match: no depth
            raw = np.full((cam.height, cam.width), np.nan)
        if pairs is not None:
            pairs[(i, j)] = raw
    return check_depth(collection, i, raw, exclude=excluded, images=images)


def source_depths(
    collection: Collection,
    *,
    exclude: Iterable[str] = (),
    progress: Progress | None = None,
    images: dict | None = None,
) -> dict[str, np.ndarray]:
    """:func:`source_depth` of every camera of the collection but the excluded ones.

    Excluded cameras get no map, are never partners and never check a depth (leave-one-out).

    Returns
    -------
    dict
        ``name -> (H, W) float64`` camera-frame depth, NaN where unknown.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    collection, _, excluded = check_request(collection, collection.cameras[0], exclude)
    allowed = [i for i, n in enumerate(collection.names) if n not in excluded]
    out: dict[str, np.ndarray] = {}
    for step, i in enumerate(allowed):
        out[collection.names[i]] = source_depth(collection, i, exclude=excluded, images=images)
        if progress is not None:
            progress((step + 1) / len(allowed), f"depth of {collection.names[i]}")
    return out


# The last collection's graph edges: every source of every leave-one-out view asks for them again
# (about 0.1 s for dino's 48 cameras each time). A collection is immutable; the identity test
# keeps another collection from reading them.
_LAST_EDGES: list = [None, None]


def _edges(collection: Collection) -> np.ndarray:
    if _LAST_EDGES[0] is collection:
        return _LAST_EDGES[1]
    try:
        edges = camera_graph(collection).edges
    except ValueError:  # no overlapping pair: neighbours only
        edges = np.zeros((0, 2), np.int64)
    _LAST_EDGES[:] = [collection, edges]
    return edges


def _camera(collection: object, i: object) -> int:
    """``i`` checked as a camera index of ``collection``."""
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < len(collection):
        raise ValueError(f"i must be a camera index in [0, {len(collection) - 1}]; got {i!r}")
    return int(i)


def _partners(collection: Collection) -> dict[str, str | None]:
    """``name -> name of the camera`` :func:`source_depth` matches it with (all cameras allowed)."""
    edges = _edges(collection)
    everyone = set(range(len(collection)))
    out = {}
    for i in range(len(collection)):
        j = _partner(collection, i, edges, everyone - {i})
        out[collection.names[i]] = None if j is None else collection.names[j]
    return out
