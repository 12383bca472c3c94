"""Novel views of a collection at any camera, and their leave-one-out quality (S2 §3.1, §5).

- :func:`neighbours`: the source cameras nearest a target (centre seen from the scene + direction).
- :func:`plane_view`: the baseline, two sources warped by the homography of one scene plane.
- :func:`source_depths`: a depth map per view from the collection itself (rectify + match).
- :func:`novel_view`: S2's method (``"mls"``, :func:`~vergence.stereospace.s2_view`) or ours
  (``"depth"``: per-view depth + ULR image-based rendering, Buehler et al. 2001, holes filled
  towards the background).
- :func:`leave_one_out`: each camera's view synthesised from the others, PSNR against its photo.

Lens distortion (Bundler's k1, k2) is ignored throughout: images are used as stored.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import cv2
import numpy as np

from vergence.camera import Camera
from vergence.depth import compute_disparity, rectify_pair
from vergence.io import read_image
from vergence.stereospace.collection import Collection
from vergence.stereospace.graph import camera_graph
from vergence.stereospace.mls_view import S2_MAX_SOURCES, s2_view
from vergence.synthesis import IBRSource, fill_holes, render_ibr

__all__ = [
    "DISPARITY_MARGIN_PX",
    "NOVEL_VIEW_METHODS",
    "NovelView",
    "leave_one_out",
    "neighbours",
    "novel_view",
    "plane_view",
    "source_depths",
]

NOVEL_VIEW_METHODS = ("depth", "mls")
#: Pixels added on each side of the disparity range of the sparse points (5th..95th percentile)
#: when matching a pair: the points miss the nearest and farthest surfaces by a few pixels.
DISPARITY_MARGIN_PX = 16

Progress = Callable[[float, str], None]


@dataclass(frozen=True, slots=True)
class NovelView:
    """A synthesised view.

    Attributes
    ----------
    image : (h, w, 3) float32
        The view (holes filled for ``"depth"``; 0 outside ``coverage`` for ``"plane"`` and ``"mls"``).
    coverage : (h, w) bool
        Pixels some source saw (before any filling).
    method : str
        ``"plane"``, ``"mls"`` or ``"depth"``.
    sources : tuple of str
        Names of the source cameras used.
    """

    image: np.ndarray
    coverage: np.ndarray
    method: str
    sources: tuple[str, ...]


def _check(collection: object, target: object, exclude: object) -> tuple[Collection, Camera, set[str]]:
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
    collection, target, excluded = _check(collection, target, exclude)
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


def _colour(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    return np.clip(img, 0.0, 1.0)


def _load(collection: Collection, i: int, images: dict[int, np.ndarray] | None) -> np.ndarray:
    if images is not None and i in images:
        return images[i]
    img = _colour(read_image(collection.image_paths[i]))
    if images is not None:
        images[i] = img
    return img


def _sample(image: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear samples of ``image`` at (h, w, 2) pixel positions; mask of those inside."""
    h, w = image.shape[:2]
    mx = np.nan_to_num(pixels[..., 0], nan=-10.0).astype(np.float32)
    my = np.nan_to_num(pixels[..., 1], nan=-10.0).astype(np.float32)
    out = cv2.remap(image, mx, my, interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    inside = (mx >= 0) & (mx <= w - 1) & (my >= 0) & (my <= h - 1)
    return out, inside


def _median_depth(collection: Collection, target: Camera) -> float:
    pix, z = target.project(collection.points)
    seen = (z > 0) & (pix[:, 0] >= 0) & (pix[:, 0] <= target.width - 1) & (pix[:, 1] >= 0)
    seen &= pix[:, 1] <= target.height - 1
    if not seen.any():
        raise ValueError("no point of the collection is in front of the target and inside its image")
    return float(np.median(z[seen]))


def plane_view(
    collection: Collection, target: Camera, *, exclude: Iterable[str] = (), images: dict | None = None
) -> NovelView:
    """The baseline view: the two nearest sources warped through one plane, blended by angle.

    The plane faces the target (normal = its optical axis) at the median depth ``d`` of the sparse
    points it sees: each target pixel ``x`` is lifted to ``X = backproject(x, d)`` and projected
    into source ``i`` (the homography ``H_i = K_i (R_i R_t^T + (t_i - R_i R_t^T t_t) n^T / d) K_t^-1``
    of the plane ``n^T X_t = d``, Hartley & Zisserman Eq. 13.2). The two :func:`neighbours` blend with
    weights ``w_i`` proportional to ``1 / angle(X - C_i, X - C_t)`` (a source at the target's pose
    takes all the weight). ``images``: an optional cache ``{index: image}``.
    """
    collection, target, excluded = _check(collection, target, exclude)
    idx = neighbours(collection, target, k=2, exclude=excluded)
    depth = _median_depth(collection, target)
    grid = target.pixel_grid()
    points = target.backproject(grid, np.full(grid.shape[:2], depth))
    to_t = target.center - points
    to_t /= np.linalg.norm(to_t, axis=-1, keepdims=True)
    acc = np.zeros((target.height, target.width, 3))
    wsum = np.zeros((target.height, target.width))
    for i in idx:
        cam = collection.cameras[i]
        pix, _ = cam.project(points)
        colour, inside = _sample(_load(collection, i, images), pix)
        to_s = cam.center - points
        to_s /= np.linalg.norm(to_s, axis=-1, keepdims=True)
        angle = np.arccos(np.clip((to_s * to_t).sum(axis=-1), -1.0, 1.0))
        w = np.where(inside, 1.0 / np.maximum(angle, 1e-9), 0.0)
        acc += w[..., None] * colour
        wsum += w
    coverage = wsum > 0
    image = np.zeros_like(acc, dtype=np.float32)
    image[coverage] = acc[coverage] / wsum[coverage, None]
    return NovelView(image, coverage, "plane", tuple(collection.names[i] for i in idx))


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
    pair = rectify_pair(_load(collection, left, images), _load(collection, right, images),
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


def source_depths(
    collection: Collection,
    *,
    exclude: Iterable[str] = (),
    progress: Progress | None = None,
    images: dict | None = None,
) -> dict[str, np.ndarray]:
    """A depth map for every camera of the collection, from the collection itself.

    For camera ``i``: its partner ``j`` is the :func:`~vergence.stereospace.camera_graph` neighbour
    with the nearest centre (else the best of :func:`neighbours`); the pair is rectified (Fusiello et
    al. 2000) and matched with :func:`~vergence.depth.compute_disparity` (SGBM + refinement, unknown
    kept NaN) over the disparity range of the sparse points plus :data:`DISPARITY_MARGIN_PX`; the
    disparity becomes depth ``Z = f b / (d + doffs)`` (S1 Eq. 7) in the rectified frame and is carried
    back to ``i``'s pixels through its rectifying homography. Excluded cameras get no map and are
    never partners (leave-one-out).

    Returns
    -------
    dict
        ``name -> (H, W) float64`` camera-frame depth, NaN where unknown.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    collection, _, excluded = _check(collection, collection.cameras[0], exclude)
    allowed = {i for i, n in enumerate(collection.names) if n not in excluded}
    edges = _edges(collection)
    out: dict[str, np.ndarray] = {}
    for step, i in enumerate(sorted(allowed)):
        j = _partner(collection, i, edges, allowed - {i})
        cam = collection.cameras[i]
        depth = np.full((cam.height, cam.width), np.nan)
        if j is not None:
            try:
                depth = _pair_depth(collection, i, j, images)
            except ValueError:  # a pair without texture to match: no depth
                pass
        out[collection.names[i]] = depth
        if progress is not None:
            progress((step + 1) / len(allowed), f"depth of {collection.names[i]}")
    return out


def novel_view(
    collection: Collection,
    target: Camera,
    *,
    method: str = "depth",
    exclude: Iterable[str] = (),
    depths: Mapping[str, np.ndarray] | None = None,
    k: int = 4,
    images: dict | None = None,
) -> NovelView:
    """The view of ``target`` from the ``k`` :func:`neighbours` of the collection.

    ``"mls"``: S2's method, :func:`~vergence.stereospace.s2_view` with the collection's points.
    ``"depth"``: :func:`~vergence.synthesis.render_ibr` (ULR weights, visibility test) of the sources
    with their :func:`source_depths` (computed here when ``depths`` is None, without the excluded
    cameras); sources without a depth map are skipped. Holes (pixels no source's depth sees: the
    matcher leaves textureless and half-occluded parts unknown) take S2's ``"mls"`` view where it has
    one (tuned on kermit: 17.08 dB mean leave-one-out PSNR against 16.11 filling along rows only),
    the rest is filled along rows from its background side (:func:`~vergence.synthesis.fill_holes`, disparity = 1 / proxy depth).
    """
    collection, target, excluded = _check(collection, target, exclude)
    if not isinstance(method, str) or method not in NOVEL_VIEW_METHODS:
        raise ValueError(f"method must be one of {', '.join(NOVEL_VIEW_METHODS)}; got {method!r}")
    idx = neighbours(collection, target, k=k, exclude=excluded)
    if method == "mls":
        idx = idx[:S2_MAX_SOURCES]  # S2 blends its four neighbours at most
        res = s2_view(target, [(collection.cameras[i], _load(collection, i, images)) for i in idx],
                      points=collection.points, k=min(k, S2_MAX_SOURCES))  # fmt: skip
        return NovelView(_colour(res.image), res.coverage, "mls", tuple(collection.names[i] for i in idx))
    if depths is None:
        depths = source_depths(collection, exclude=excluded, images=images)
    idx_all = idx
    idx = [i for i in idx if collection.names[i] in depths and np.isfinite(depths[collection.names[i]]).any()]
    if not idx:
        raise ValueError("no source near the target has a depth map")
    sources = [IBRSource(collection.cameras[i], _load(collection, i, images), depths[collection.names[i]]) for i in idx]
    res = render_ibr(target, sources, weights="ulr", k=k)
    coverage = res.coverage.copy()
    image = res.image.copy()
    if coverage.any() and not coverage.all():  # holes: S2's view where it has one, then rows
        near = idx_all[:S2_MAX_SOURCES]
        mls = s2_view(target, [(collection.cameras[i], _load(collection, i, images)) for i in near],
                      points=collection.points, k=min(k, S2_MAX_SOURCES))  # fmt: skip
        take = ~coverage & mls.coverage
        image[take] = _colour(mls.image)[take]
        known = coverage | take
        disparity = np.where(coverage, 1.0 / np.where(coverage, res.proxy_depth, 1.0), 1.0 / mls.proxy_depth)
        if not known.all():
            image, _ = fill_holes(image, np.where(known, disparity, 0.0), ~known)
            image = np.nan_to_num(image, nan=0.0)
    return NovelView(image.astype(np.float32), coverage, "depth", tuple(collection.names[i] for i in idx))


def psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """``10 log10(1 / MSE)`` over ``mask`` (colours in [0, 1])."""
    mse = float(np.mean((a[mask] - b[mask]) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def leave_one_out(
    collection: Collection,
    *,
    method: str,
    names: Iterable[str] | None = None,
    depths: Mapping[str, np.ndarray] | None = None,
    images: dict | None = None,
    progress: Progress | None = None,
) -> dict[str, tuple[float, NovelView]]:
    """Each named camera's view made without it, and its PSNR against its photo.

    ``method`` is ``"plane"``, ``"mls"`` or ``"depth"``. The PSNR is over the pixels the plane
    baseline covers (for every method, so the figures compare; outside them a view is not scored),
    uncovered pixels of the method counting with their value (0 for ``"mls"``, the fill for
    ``"depth"``). For ``"depth"``, ``depths`` (from :func:`source_depths` of the whole collection)
    is used for the other cameras only when their partner was not the held-out camera; without
    ``depths`` they are recomputed without it (slow: one matching per camera per view).

    Returns
    -------
    dict
        ``name -> (psnr_db, NovelView)``.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if not isinstance(method, str) or method not in ("plane", *NOVEL_VIEW_METHODS):
        raise ValueError(f"method must be one of plane, {', '.join(NOVEL_VIEW_METHODS)}; got {method!r}")
    chosen = list(collection.names) if names is None else list(names)
    unknown = set(chosen) - set(collection.names)
    if unknown:
        raise ValueError(f"names lists cameras not in the collection: {', '.join(sorted(unknown))}")
    images = {} if images is None else images
    partners = _partners(collection) if depths is not None else {}
    out = {}
    for step, name in enumerate(chosen):
        i = collection.names.index(name)
        target = collection.cameras[i]
        base = plane_view(collection, target, exclude=[name], images=images)
        if method == "plane":
            view = base
        else:
            used = None
            if method == "depth":
                if depths is None:
                    used = source_depths(collection, exclude=[name], images=images)
                else:  # a map matched against the held-out camera would leak it: recompute those
                    used = {n: d for n, d in depths.items() if n != name and partners.get(n) != name}
                    edges = _edges(collection)
                    for n, p in partners.items():
                        if p == name and n != name:
                            j = collection.names.index(n)
                            q = _partner(collection, j, edges, set(range(len(collection))) - {i, j})
                            if q is not None:
                                used[n] = _pair_depth(collection, j, q, images)
            view = novel_view(collection, target, method=method, exclude=[name], depths=used, images=images)
        photo = _load(collection, i, images)
        out[name] = (psnr(view.image, photo, base.coverage), view)
        if progress is not None:
            progress((step + 1) / len(chosen), f"{method} {name}")
    return out


def _edges(collection: Collection) -> np.ndarray:
    try:
        return camera_graph(collection).edges
    except ValueError:  # no overlapping pair: neighbours only
        return np.zeros((0, 2), np.int64)


def _partners(collection: Collection) -> dict[str, str | None]:
    """``name -> name of the camera`` :func:`source_depths` matches it with (all cameras allowed)."""
    edges = _edges(collection)
    everyone = set(range(len(collection)))
    out = {}
    for i in range(len(collection)):
        j = _partner(collection, i, edges, everyone - {i})
        out[collection.names[i]] = None if j is None else collection.names[j]
    return out
