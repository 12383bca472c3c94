"""S2's novel view (S2 §3.1): up to four source photos, each warped by the MLS similarity
deformation whose handles are the sparse 3D points projected into it and into the novel camera,
blended with S2's penalties (angle + field of view) on a proxy built from the points.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vergence._validate import as_float_array, as_image, check_positive, check_positive_int
from vergence.camera import Camera
from vergence.stereospace import _mls_kernels, _mls_view_kernels
from vergence.stereospace.mls import MLS_MIN_HANDLES, node_grid, with_cells

__all__ = ["S2_HANDLE_CELL_PX", "S2_MAX_SOURCES", "S2_PENALTY_FLOOR", "S2_THRESHOLD_SCALE", "S2View", "s2_view"]

# S2 §3.1 blends "four of its neighbouring cameras"; ULR's k (Buehler et al. 2001) is the same 4.
S2_MAX_SOURCES = 4
# As SIBR's ulr_v3.frag (and vergence.synthesis.render_ibr): the angle penalty is floored at 1e-4 rad
# so that a source at the novel camera's own centre still has a positive penalty and the threshold
# (a multiple of a penalty) is never 0.
S2_PENALTY_FLOOR = 1e-4
# SIBR's threshold is 1.0000001 times the k-th penalty: the k-th source gets a weight of 1e-7, not 0,
# so a pixel whose k sources tie keeps a positive weight sum.
S2_THRESHOLD_SCALE = 1.0000001
# A source whose normalised weight is at most this is not sampled (S2_THRESHOLD_SCALE gives the k-th
# source about 1e-7): the colour of a pixel changes by less than 1e-6 (float32 keeps ~6e-8 at 1).
NEGLIGIBLE_WEIGHT = 1e-6
# Grid spacing of the MLS maps, pixels: the warp evaluated at the grid's nodes, bilinear in between
# (as Schaefer et al. 2006 §4; S2 gives no spacing); not exported: the default of s2_view and of the
# stereo pair's views. The maps cost nodes x handles. Leave-one-out PSNR of S2's view by step (mean,
# dB; ``benchmarks/stereospace_loo.py --collections kermit dino --methods mls --grid-step N``; kermit's
# 9 views and dino's even-numbered ones chose the step, its odd-numbered ones were held out):
#
#   step            4       6       8       10      12      16
#   kermit        16.482  16.474  16.462  16.452  16.425  16.383
#   dino even     27.704  27.723  27.714  27.721  27.643  27.620
#   dino odd      27.618  27.628  27.612  27.607  27.597  27.557   (held out)
#
# 10 is the largest step within 0.02 dB of 8 (the default before) on the views it was chosen on; on
# the held-out views it gives -0.005 dB. It takes 0.64 of step 8's nodes (640 x 480); docs/stereospace.md
# gives the pairs' time and how far the views move.
S2_GRID_STEP = 10
#: Handles kept per source: one per ``S2_HANDLE_CELL_PX`` square cell of the novel view (the first
#: point, in the collection's order, whose target position falls in it). A dense SfM cloud gives
#: thousands of handles a source (dino about 6,000), more than the MLS map resolves at its grid
#: step; one per 4 px cell makes dino's 4-source pair 132 -> 95 ms (kermit's 634 points: no change;
#: benchmarks/stereospace_pair.py) and changes the views by 0.001-0.005 mean absolute (colours in
#: [0, 1]; tests/stereospace/test_mls_view.py checks dino0011's view).
S2_HANDLE_CELL_PX = 4.0
#: The sources' maps share their common handles' weights (one evaluation for all of them) when the
#: handles not common to all are at most this share of the common ones: a handle not shared costs
#: about 6 times one evaluated per source in that kernel (a short loop per node), a common one
#: 0.7 of the 4 sources' separate evaluations. Dino's pairs (1,310-1,325 common handles, 0-2 not)
#: spend 13.7 instead of 20.5 CPU-ms on their maps; kermit's (about 410 common, 184 not) 13.4 against
#: 11.3, so they keep the per-source kernel (benchmarks/stereospace_pair.py's states, load 8).
SHARED_EXTRA_SHARE = 0.2


@dataclass(frozen=True, slots=True)
class S2View:
    """A novel view made by S2's method.

    Attributes
    ----------
    image : (h, w) or (h, w, C) float32
        The blended view, 0 where ``coverage`` is False.
    coverage : (h, w) bool
        True where at least one warped source has a sample.
    weights : (S, h, w) float64
        Normalised blending weight of each source (0 where it has no sample).
    handle_counts : (S,) int64
        Handles each source's warp used (0: fewer than 2 of the points were seen, the source is
        left out).
    proxy_depth : float
        Depth (target camera frame, metres) of the proxy plane used for the angle penalties.
    """

    image: np.ndarray
    coverage: np.ndarray
    weights: np.ndarray
    handle_counts: np.ndarray
    proxy_depth: float


def _check_sources(sources: object) -> tuple[list[tuple[Camera, np.ndarray]], bool]:
    """Validated (Camera, (H, W, C) image) pairs and whether the images came as (H, W)."""
    if not isinstance(sources, Sequence) or isinstance(sources, str | bytes):
        raise TypeError(f"sources must be a sequence of (Camera, image) pairs; got {type(sources).__name__}")
    if not 1 <= len(sources) <= S2_MAX_SOURCES:
        raise ValueError(f"sources must hold 1 to {S2_MAX_SOURCES} (Camera, image) pairs; got {len(sources)}")
    out = []
    grey = False
    for k, pair in enumerate(sources):
        if not isinstance(pair, Sequence) or len(pair) != 2 or not isinstance(pair[0], Camera):
            raise TypeError(f"sources[{k}] must be a (Camera, image) pair")
        cam, img = pair[0], as_image(f"sources[{k}] image", pair[1])
        if img.shape[:2] != (cam.height, cam.width):
            raise ValueError(
                f"sources[{k}] image must have shape (H, W) = ({cam.height}, {cam.width}) of its camera; "
                f"got {img.shape[:2]}"
            )
        if img.ndim == 2:
            grey, img = True, img[..., None]
        if out and img.shape[2] != out[0][1].shape[2]:
            raise ValueError(f"sources[{k}] image must have {out[0][1].shape[2]} channel(s) as sources[0]; got {img.shape[2]}")
        out.append((cam, img))
    return out, grey


@dataclass(frozen=True, slots=True, eq=False)
class SourceSet:
    """Source cameras made ready for S2's views (:func:`render_source_set`): what depends on the sources
    and the points only, never on the target, so a collection computes it once.

    ``images``: each image in the corner of the largest size, times ``unit`` the float32 images. When
    every image is exactly ``v / 255`` in float32 (an 8-bit photo) the stored values are its bytes with
    ``unit = 1/255`` (the views differ by at most 6e-8): RGB packed in one uint32 a pixel,
    ``R | G << 8 | B << 16``, ``(N, Hm, Wm)`` (a third of the float32 images' memory; one load a
    bilinear tap instead of three), other channel counts ``(N, Hm, Wm, C)`` uint8 (a quarter). Otherwise
    float32 ``(N, Hm, Wm, C)`` with ``unit = 1``. ``sizes (N, 2)`` its ``(h, w)``, ``centres (N, 3)``,
    ``pixels (N, P, 2)`` the points projected into each camera and ``seen (N, P)`` which of them are
    in front of it and on its image (``-0.5 <= x <= w - 0.5``).
    """

    cameras: tuple[Camera, ...]
    images: np.ndarray
    sizes: np.ndarray
    centres: np.ndarray
    pixels: np.ndarray
    seen: np.ndarray
    unit: float

    @property
    def channels(self) -> int:
        """Channels of the images."""
        return 3 if self.images.ndim == 3 else self.images.shape[3]

    def image(self, k: int) -> np.ndarray:
        """Image ``k`` as float32 ``(h, w, C)``, the values it was given (exactly)."""
        h, w = self.sizes[k]
        stored = self.images[k, :h, :w]
        if stored.ndim == 2:  # packed RGB
            stored = np.stack([(stored >> shift) & 255 for shift in (0, 8, 16)], axis=2).astype(np.uint8)
        return stored if self.unit == 1.0 else _from_bytes(stored)


def pack_rgb(image: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` RGB bytes (any integer type in 0..255) as one uint32 a pixel,
    ``R | G << 8 | B << 16`` (the render kernel's packed images)."""
    wide = image.astype(np.uint32)
    return wide[..., 0] | (wide[..., 1] << 8) | (wide[..., 2] << 16)


def _from_bytes(values: np.ndarray) -> np.ndarray:
    """float32 ``v / 255`` of 8-bit values (the rule :func:`source_set` checks exactness with)."""
    return values.astype(np.float32) / np.float32(255.0)


def source_set(cameras: Sequence[Camera], images: Sequence[np.ndarray], points: np.ndarray) -> SourceSet:
    """A :class:`SourceSet` of validated cameras, ``(H, W, C)`` float32 images (one channel
    count) and ``(P, 3)`` float64 points."""
    sizes = np.array([img.shape[:2] for img in images], dtype=np.int64).reshape(-1, 2)
    as_bytes = [np.rint(img * np.float32(255.0)) for img in images]
    eight_bit = all(((b >= 0) & (b <= 255)).all() and np.array_equal(_from_bytes(b.astype(np.uint8)), img)
                    for b, img in zip(as_bytes, images))  # fmt: skip
    packed = eight_bit and images[0].shape[2] == 3
    stored_shape = (len(images), *sizes.max(axis=0)) + (() if packed else (images[0].shape[2],))
    stack = np.zeros(stored_shape, dtype=np.uint32 if packed else np.uint8 if eight_bit else np.float32)
    for n, img in enumerate(images):
        stored = pack_rgb(as_bytes[n]) if packed else as_bytes[n] if eight_bit else img
        stack[n, : img.shape[0], : img.shape[1]] = stored
    as_bytes.clear()
    pixels = np.empty((len(cameras), len(points), 2))
    seen = np.empty((len(cameras), len(points)), dtype=bool)
    for n, cam in enumerate(cameras):
        pixels[n], z = cam.project(points)
        x, y = pixels[n, :, 0], pixels[n, :, 1]
        seen[n] = (z > 0) & (x >= -0.5) & (x <= cam.width - 0.5) & (y >= -0.5) & (y <= cam.height - 0.5)
    centres = np.array([cam.center for cam in cameras]).reshape(-1, 3)
    return SourceSet(tuple(cameras), stack, sizes, centres, pixels, seen, 1.0 / 255.0 if eight_bit else 1.0)


# The handle cells marked in a grid (the rest sorted): those of the target image and as much again
# around it, at most this many cells (a handle cell far below a pixel has no grid).
_MAX_GRID_CELLS = 1 << 22


def _cell_window(width: int, height: int, cell: float) -> np.ndarray:
    """``(x0, y0, x1, y1)``, the cells of :func:`_mls_view_kernels.select_handles`'s grid."""
    x0, y0 = math.floor(-width / 2 / cell), math.floor(-height / 2 / cell)
    x1, y1 = math.floor(1.5 * width / cell) + 1, math.floor(1.5 * height / cell) + 1
    if (x1 - x0) * (y1 - y0) > _MAX_GRID_CELLS:
        x1, y1 = x0, y0  # no grid: every point sorted
    return np.array([x0, y0, x1, y1], dtype=np.int64)


@functools.lru_cache(maxsize=8)
def _view_nodes(h: int, w: int, grid_step: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`~vergence.stereospace.mls.node_grid` of an ``h x w`` view and its nodes in float32: the same
    for every view of that size (a stereo pair's two eyes and the next states'), made once. Shared: never
    written (left writeable so that the kernels keep their one compiled signature)."""
    xs, ys, nodes = node_grid((h, w), grid_step)
    return xs, ys, nodes, nodes.astype(np.float32)


def _node_angles(target: Camera, nodes: np.ndarray, centres: np.ndarray, depth: float) -> np.ndarray:
    """``P_ANG (S, len(nodes))`` (S2 §3.1 Eq. (4)): at each node's proxy point ``P`` (its ray at
    camera-frame ``depth``), the angle between ``C_target - P`` and ``centres[s] - P`` (atan2 of
    the cross and dot products: accurate at small angles too); :func:`_mls_view_kernels.node_angles`."""
    out = np.empty((len(centres), len(nodes)))
    _mls_view_kernels.node_angles(np.ascontiguousarray(nodes, dtype=np.float64), np.linalg.inv(target.K),
                                  np.ascontiguousarray(target.R.T), target.center,
                                  np.ascontiguousarray(centres, dtype=np.float64), float(depth), out)  # fmt: skip
    return out


def _source_maps(nodes: np.ndarray, q: np.ndarray, pixels: np.ndarray, handles: list[tuple[int, np.ndarray]],
                 alpha: float) -> np.ndarray:
    """The MLS maps (``q -> p``) of the sources ``handles`` (source, its handles' point indices) at
    ``nodes`` (float32), ``(len(handles), len(nodes), 2)`` float32: the sources' common handles
    evaluated once for all of them (:func:`_mls_kernels.mls_shared_handles`) when 2 to 4 sources
    share most (:data:`SHARED_EXTRA_SHARE`), else each source's own
    (:func:`_mls_kernels.mls_similarity_points`)."""
    mapped = np.empty((len(handles), len(nodes), 2), dtype=np.float32)
    times = np.zeros(pixels.shape[1], dtype=np.int64)  # of how many sources each point is a handle
    for _, sel in handles:
        times[sel] += 1
    common = np.flatnonzero(times == len(handles))  # ascending, as each source's handles
    extras = [sel[times[sel] < len(handles)] for _, sel in handles]
    n_extra = sum(e.size for e in extras)
    if 2 <= len(handles) <= _mls_kernels.MAX_SHARED_SETS and n_extra <= SHARED_EXTRA_SHARE * common.size:
        dst = np.stack([pixels[n, common] for n, _ in handles]).astype(np.float32)
        extra_src = np.concatenate([q[e] for e in extras]).astype(np.float32)
        extra_dst = np.concatenate([pixels[n, e] for (n, _), e in zip(handles, extras)]).astype(np.float32)
        offsets = np.concatenate([[0], np.cumsum([e.size for e in extras])]).astype(np.int64)
        _mls_kernels.mls_shared_handles(nodes, q[common].astype(np.float32), dst, extra_src, extra_dst, offsets,
                                        alpha, mapped)  # fmt: skip
        return mapped
    p32 = np.concatenate([pixels[n, sel] for n, sel in handles]).astype(np.float32)
    q32 = np.concatenate([q[sel] for _, sel in handles]).astype(np.float32)
    offsets = np.concatenate([[0], np.cumsum([sel.size for _, sel in handles])]).astype(np.int64)
    _mls_kernels.mls_similarity_points(nodes, q32, p32, offsets, alpha, mapped)
    return mapped


def render_source_set(
    target: Camera, sources: SourceSet, ids: Sequence[int], points: np.ndarray, *, grid_step: int, alpha: float,
    k: int, keep_weights: bool,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, float]:
    """S2's view of ``target`` from the sources ``ids`` of a :class:`SourceSet`: ``(image (h, w, C)
    float32, weights (S, h, w) float64 or None, handle counts (S,), proxy depth)``; inputs valid.

    A source's handles are the points in front of the source and the target and on the source's
    image, projected into the source (p) and the target (q), one per :data:`S2_HANDLE_CELL_PX` cell
    of the target; its MLS map (``q -> p``) is evaluated at the grid nodes in float32.
    """
    q, z_target = target.project(points)
    in_front = z_target > 0
    if not in_front.any():
        raise ValueError("points must hold at least one point in front of target")
    proxy_depth = float(np.median(z_target[in_front]))
    h, w = target.height, target.width
    xs, ys, nodes, nodes32 = _view_nodes(h, w, grid_step)
    ids = np.asarray(ids, dtype=np.int64)
    used = ids.copy()
    counts = np.zeros(len(ids), dtype=np.int64)
    at_nodes = np.zeros((len(ids), ys.size, xs.size, 3))
    at_nodes[..., 2] = _node_angles(target, nodes, sources.centres[ids], proxy_depth).reshape(-1, ys.size, xs.size)
    chosen = np.empty((len(ids), len(points)), dtype=np.int64)
    found = np.empty(len(ids), dtype=np.int64)
    _mls_view_kernels.select_handles(sources.seen, ids, in_front, q, float(S2_HANDLE_CELL_PX),
                                     _cell_window(w, h, S2_HANDLE_CELL_PX), chosen, found)  # fmt: skip
    handles = []
    for s, n in enumerate(ids):
        sel = chosen[s, : found[s]]
        if sel.size < MLS_MIN_HANDLES:
            used[s] = -1
            continue
        counts[s] = sel.size
        handles.append((n, sel))
    if handles:  # the maps of all sources in one parallel loop
        mapped = _source_maps(nodes32, q, sources.pixels, handles, alpha)
        at_nodes[used >= 0, ..., :2] = mapped.reshape(len(handles), ys.size, xs.size, 2)
    if not counts.any():
        raise ValueError(f"sources must include one that sees at least {MLS_MIN_HANDLES} of the points")
    if xs.size == 1 or ys.size == 1:  # a one-pixel-wide or -high view: phantom nodes (else no copy)
        xs, ys, cells = with_cells(xs, ys, np.moveaxis(at_nodes, 0, 2))
        at_nodes = np.ascontiguousarray(np.moveaxis(cells, 2, 0))
    image = np.empty((h, w, sources.channels), dtype=np.float32)
    weights = np.empty((len(ids), h, w) if keep_weights else (len(ids), 0, 0))
    _mls_view_kernels.render_view(sources.images, sources.sizes, used, at_nodes, xs, ys, grid_step, S2_PENALTY_FLOOR,
                                  k, S2_THRESHOLD_SCALE, NEGLIGIBLE_WEIGHT, image, weights, sources.unit)  # fmt: skip
    return image, (weights if keep_weights else None), counts, proxy_depth


def s2_view(
    target: Camera,
    sources: Sequence[tuple[Camera, object]],
    *,
    points: object,
    grid_step: int = S2_GRID_STEP,
    alpha: float = 1.0,
    k: int = S2_MAX_SOURCES,
) -> S2View:
    """The view of ``target`` made from up to 4 source photos by S2's method.

    Each source image is warped by :func:`~vergence.stereospace.mls_warp`, its handles being the
    points projected into the source (``p_i``) and into the target (``q_i``); the warped images
    are blended with ULR weights (Buehler et al. 2001) of S2's penalty ``P = P_ANG + P_FOV``.

    Parameters
    ----------
    target : Camera
        The novel camera; the output has its size.
    sources : sequence of (Camera, image)
        1 to :data:`S2_MAX_SOURCES` source cameras with their images (same channel count, each the
        size of its camera; float in [0, 1], uint8 or uint16).
    points : (P, 3) array
        Sparse 3D points of the scene (metres), e.g. from SfM. A point serves as a handle of a
        source when it is in front of the source and the target and projects onto the source
        image. Occlusion is not tested (SfM points carry no visibility here).
    grid_step : int
        Grid spacing of the MLS warps, pixels (>= 1).
    alpha : float
        MLS weight falloff exponent (> 0).
    k : int
        Sources in the ULR set (>= 1); the k-th best gets weight ~0, and pixels with fewer than
        k warped samples blend them equally.

    Returns
    -------
    S2View
        Image, coverage, weights, handle counts and the proxy depth.

    Raises
    ------
    ValueError
        No source or more than 4, an image not the size of its camera, differing channel counts,
        non-finite points, no point in front of the target, no source seeing 2 of the points.
    TypeError
        A target that is not a Camera, a source that is not a (Camera, image) pair.

    Notes
    -----
    S2 §3.1, Eq. (4)::

        P_ANG(C_i, x, y) = arccos( (C_n - P) . (C_i - P) / (|C_n - P| |C_i - P|) )
        P_FOV(C_i, x, y) = inf if p(x, y) lies outside I_i, 0 otherwise;   P = P_ANG + P_FOV

    S2 takes P on a Poisson surface of a dense point cloud. Here the proxy is the plane at the
    median target-frame depth of the points in front of the target (each pixel's P is its ray at
    that depth): the penalties only weigh the blend, they never move a pixel, and S2 notes that
    such inaccuracies are well tolerated. P_FOV uses where the warp samples the source (the MLS
    map), not the proxy's projection, so a pixel is blended from exactly the sources it has
    samples of. Blending as ULR (Buehler et al. 2001; SIBR's threshold, without ``render_ibr``'s cap):
    ``w_i = max(0, 1 - P_i / (1.0000001 P_(k)))``, ``P_ANG`` floored at 1e-4 rad, normalised.

    Computation (one Numba pass over the pixels, no full-size intermediate): the MLS maps of all
    sources are evaluated at the grid nodes in float32 (within 2e-3 px of float64 on dino's 6,019
    handles a source; the handles that 2-4 sources share weighed once for all of them,
    :data:`SHARED_EXTRA_SHARE`), ``P_ANG`` exactly at the nodes (atan2) and both bilinearly in between
    (``P_ANG`` within 3.3e-5 rad of the per-pixel angle on kermit's views, 3.5e-7 rad on dino's);
    sources are sampled bilinearly with exact weights (edge pixels repeated over their outer half),
    and a source whose normalised weight is at most 1e-6 (the k-th one's ~1e-7) is not sampled.
    Against the former per-source ``mls_warp`` + numpy blend, stereo pairs of kermit and dino
    differ by 2e-7 to 8e-7 on average, 1.3e-3 at most (``benchmarks/stereospace_pair.py``'s states).
    Cameras are pinhole: lens distortion (e.g. Bundler's k1, k2) is not modelled. Leave-one-out
    on ``kermit`` (all 634 Bundler points as handles, grid step 8): kermit001 from its two nearest
    cameras scores 17.7 dB PSNR on the covered pixels (the nearest photo unwarped: 11.4 dB), 14.5
    to 18.3 dB over the 9 registered views from their 4 nearest cameras.
    """
    if not isinstance(target, Camera):
        raise TypeError(f"target must be a Camera; got {type(target).__name__}")
    pairs, grey = _check_sources(sources)
    pts = as_float_array("points", points, shape=(None, 3))
    step = check_positive_int("grid_step", grid_step)
    a = check_positive("alpha", alpha)
    kk = check_positive_int("k", k)
    src = source_set([cam for cam, _ in pairs], [img for _, img in pairs], pts)
    image, weights, counts, proxy_depth = render_source_set(target, src, range(len(pairs)), pts, grid_step=step, alpha=a,
                                                  k=kk, keep_weights=True)  # fmt: skip
    if grey:
        image = image[..., 0]
    return S2View(image=image, coverage=weights.sum(axis=0) > 0, weights=weights, handle_counts=counts,
                  proxy_depth=proxy_depth)
