"""Moving-least-squares image deformation, similarity variant (Schaefer, McPhail, Warren 2006), as S2
warps each source photo towards a novel view (S2 §3.1).

:func:`mls_similarity` evaluates the deformation ``f`` at any points; :func:`mls_warp` resamples an
image through it, evaluating ``f`` on a coarse grid and interpolating bilinearly in between (as
Schaefer et al. 2006 §4 and S2 do: the per-pixel evaluation costs O(pixels x handles)).
Pixel coordinates are ``(x, y) = (column, row)`` with pixel centres at integers
(``docs/conventions.md``).
"""

from __future__ import annotations

import cv2
import numpy as np

from vergence._validate import as_float_array, as_image, check_positive, check_positive_int
from vergence.stereospace import _mls_kernels

__all__ = ["MLS_MIN_HANDLES", "mls_similarity", "mls_warp"]

# A similarity (rotation, uniform scale, translation: 4 unknowns) is fixed by two distinct point
# pairs; with one handle the weighted fit (mu = 0) has no solution.
MLS_MIN_HANDLES = 2


def _check_handles(src_name: str, src: object, dst_name: str, dst: object) -> tuple[np.ndarray, np.ndarray]:
    """Handles as float64 (M, 2) arrays, M >= 2, same shape, finite, ``src`` rows distinct."""
    p = as_float_array(src_name, src, shape=(None, 2))
    q = as_float_array(dst_name, dst, shape=(None, 2))
    if p.shape != q.shape:
        raise ValueError(f"{dst_name} must have the shape of {src_name} {p.shape}; got {q.shape}")
    if p.shape[0] < MLS_MIN_HANDLES:
        raise ValueError(f"{src_name} must hold at least {MLS_MIN_HANDLES} handles; got {p.shape[0]}")
    n_unique = np.unique(p, axis=0).shape[0]
    if n_unique != p.shape[0]:
        raise ValueError(
            f"{src_name} must not repeat a handle (f would take two values there); "
            f"got {p.shape[0] - n_unique} duplicate(s)"
        )
    return np.ascontiguousarray(p), np.ascontiguousarray(q)


def _deform(points: np.ndarray, p: np.ndarray, q: np.ndarray, alpha: float) -> np.ndarray:
    """The kernel on validated, C-contiguous float64 inputs."""
    out = np.empty((1, points.shape[0], 2), dtype=np.float64)
    if points.shape[0]:
        _mls_kernels.mls_similarity_points(points, p, q, np.array([0, len(p)]), alpha, out)
    return out[0]


def mls_similarity(points: object, handles_src: object, handles_dst: object, *, alpha: float = 1.0) -> np.ndarray:
    """The MLS similarity deformation ``f(v)`` that takes the handles ``p_i`` to ``q_i``.

    For each point v, the similarity (rotation, uniform scale, translation) that best maps the
    handles with weights ``w_i = 1 / |p_i - v|^(2 alpha)`` is applied to v. ``f(p_i) = q_i``
    exactly, f is smooth elsewhere, and a global similarity of the handles is reproduced
    everywhere.

    Parameters
    ----------
    points : (N, 2) array
        Evaluation points v (row vectors, pixels); N may be 0.
    handles_src : (M, 2) array
        Handles ``p_i``, M >= :data:`MLS_MIN_HANDLES`, no two equal.
    handles_dst : (M, 2) array
        Their targets ``q_i`` (may repeat).
    alpha : float
        Weight falloff exponent (> 0); Schaefer et al. use 1.

    Returns
    -------
    (N, 2) float64 array
        ``f(v)`` for each point.

    Raises
    ------
    ValueError
        Wrong shapes, NaN or inf, fewer than 2 handles, a repeated source handle, alpha <= 0.
    TypeError
        Non-numeric arrays or alpha.

    Notes
    -----
    Schaefer, McPhail, Warren 2006, §2.2 (similarity deformations), with
    ``p* = sum w_i p_i / sum w_i``, ``q*`` likewise, ``p^_i = p_i - p*``, ``q^_i = q_i - q*``::

        mu_s   = sum_i w_i p^_i p^_i^T
        f_s(v) = sum_i q^_i (A_i / mu_s) + q*,
        A_i    = w_i [p^_i; -p^_i^perp] [v - p*; -(v - p*)^perp]^T,   (x, y)^perp = (-y, x)

    computed in the equivalent complex form ``f_s(v) = (v - p*) a + q*``,
    ``a = sum w_i conj(p^_i) q^_i / sum w_i |p^_i|^2``, in one pass over the handles per point (the
    centred sums from the raw sums about v: ``stereospace/_mls_kernels.py``). A point on a handle, or
    so near one that its weight overflows, takes that handle's target (the limit of f). One Numba
    task per point; cost O(N M).

    Examples
    --------
    >>> import numpy as np
    >>> p = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    >>> mls_similarity([[5.0, 5.0]], p, 2.0 * p + 1.0).tolist()   # a global scale + shift
    [[11.0, 11.0]]
    """
    pts = np.ascontiguousarray(as_float_array("points", points, shape=(None, 2)))
    p, q = _check_handles("handles_src", handles_src, "handles_dst", handles_dst)
    a = check_positive("alpha", alpha)
    return _deform(pts, p, q, a)


def _grid_nodes(n: int, step: int) -> np.ndarray:
    """Node coordinates 0, step, 2 step, ... and the last pixel n - 1 (always a node)."""
    nodes = np.arange(0, n, step, dtype=np.float64)
    if nodes[-1] != n - 1:
        nodes = np.append(nodes, float(n - 1))
    return nodes


def node_grid(shape: tuple[int, int], grid_step: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node columns ``xs``, rows ``ys`` (:func:`_grid_nodes`) and the ``(len(ys) * len(xs), 2)``
    float64 nodes ``(x, y)``, row by row."""
    h, w = shape
    xs = _grid_nodes(w, grid_step)
    ys = _grid_nodes(h, grid_step)
    gx, gy = np.meshgrid(xs, ys)
    return xs, ys, np.ascontiguousarray(np.stack([gx.ravel(), gy.ravel()], axis=1))


def with_cells(xs: np.ndarray, ys: np.ndarray, at_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node values ``(len(ys), len(xs), ...)`` with at least two node columns and rows.

    A one-pixel-wide (or -high) output has a single node column (row): it is copied to a phantom
    node one pixel further so that the interpolation always has a cell; its weight is 0.
    """
    if xs.size == 1:
        xs, at_nodes = np.array([0.0, 1.0]), np.repeat(at_nodes, 2, axis=1)
    if ys.size == 1:
        ys, at_nodes = np.array([0.0, 1.0]), np.repeat(at_nodes, 2, axis=0)
    return xs, ys, np.ascontiguousarray(at_nodes)


def _source_map(
    handles_src: np.ndarray,
    handles_dst: np.ndarray,
    shape: tuple[int, int],
    grid_step: int,
    alpha: float,
    dtype: type = np.float32,
) -> tuple[np.ndarray, np.ndarray]:
    """Source position (``map_x``, ``map_y``: ``(H, W)``, float32 for cv2.remap) of every output
    pixel: the inverse deformation (handles ``q -> p``) at the grid nodes, bilinear in between;
    inputs already validated."""
    h, w = shape
    xs, ys, nodes = node_grid(shape, grid_step)
    at_nodes = _deform(nodes, handles_dst, handles_src, alpha).reshape(ys.size, xs.size, 2)
    if grid_step == 1:
        return at_nodes[..., 0].astype(dtype), at_nodes[..., 1].astype(dtype)
    xs, ys, at_nodes = with_cells(xs, ys, at_nodes)
    map_x = np.empty((h, w), dtype=dtype)
    map_y = np.empty((h, w), dtype=dtype)
    _mls_kernels.interpolate_grid(at_nodes, xs, ys, grid_step, map_x, map_y)
    return map_x, map_y


def mls_warp(
    image: object,
    handles_src: object,
    handles_dst: object,
    *,
    grid_step: int = 8,
    alpha: float = 1.0,
    output_shape: tuple[int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Warp ``image`` so that its handles ``p_i`` land on ``q_i`` (S2 §3.1's per-source warp).

    Resampling needs the inverse map: each output pixel v takes the colour at ``g(v)``, g being
    the MLS similarity deformation with the handles swapped (``q_i -> p_i``). g is evaluated on a
    grid of nodes every ``grid_step`` pixels (the last row and column are always nodes) and
    interpolated bilinearly in between; the image is then sampled bilinearly (``cv2.remap``).

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        Source image: float in [0, 1], uint8 or uint16.
    handles_src : (M, 2) array
        Handle positions ``p_i`` in the source image (pixels, x = column, y = row).
    handles_dst : (M, 2) array
        Their positions ``q_i`` in the output (novel view); no two equal, M >= 2.
    grid_step : int
        Grid spacing in pixels (>= 1; 1 = the exact per-pixel deformation).
    alpha : float
        Weight falloff exponent of the deformation (> 0).
    output_shape : (h, w), optional
        Size of the output; the image's size by default.

    Returns
    -------
    warped : (h, w) or (h, w, C) float32 array
        The warped image, 0 where ``valid`` is False.
    valid : (h, w) bool array
        True where the source position lies on the image's pixels (``-0.5 <= x <= W - 0.5``,
        ``-0.5 <= y <= H - 0.5``; the edge pixels are repeated over their outer half).

    Raises
    ------
    ValueError
        An empty or non-finite image, handles as :func:`mls_similarity` refuses them (here the
        repeated handles refused are in ``handles_dst``, the deformation's source), a grid step
        < 1, a non-positive alpha or output size.
    TypeError
        Non-numeric arguments, a non-integer grid step.

    Notes
    -----
    Schaefer, McPhail, Warren 2006 §2.2 (similarity) and §4 (evaluation on a grid); S2 §3.1.
    The grid adds an interpolation error, largest next to the handles, where f bends sharply to
    interpolate them. On ``benchmarks/mls.py``'s scene (640 x 480, 300 handles from a bumpy
    surface seen 0.3 m apart, offsets 0.1-9.6 px) the displacement error against the per-pixel
    evaluation is at most 0.88 px at step 8 (99th percentile 0.19 px, mean 0.018 px) and 1.51 px
    at step 16 (0.48 px, 0.055 px); there ``mls_warp`` takes about 9 ms at step 8 against 130 ms
    per pixel (2 cores). Handles with independent random offsets (no smooth parallax field) give
    errors up to about their offsets.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((20, 20), np.float32); img[5, 5] = 1.0
    >>> p = np.array([[5.0, 5.0], [15.0, 5.0], [5.0, 15.0]])
    >>> out, valid = mls_warp(img, p, p + [3.0, 2.0], grid_step=4)   # a pure translation
    >>> float(out[7, 8]), bool(valid[0, 0])
    (1.0, False)
    """
    img = as_image("image", image)
    q, p = _check_handles("handles_dst", handles_dst, "handles_src", handles_src)
    step = check_positive_int("grid_step", grid_step)
    a = check_positive("alpha", alpha)
    if output_shape is None:
        h, w = img.shape[:2]
    else:
        if not isinstance(output_shape, tuple | list) or len(output_shape) != 2:
            raise ValueError(f"output_shape must be (h, w); got {output_shape!r}")
        h = check_positive_int("output_shape[0]", output_shape[0])
        w = check_positive_int("output_shape[1]", output_shape[1])
    return _warp(img, p, q, (h, w), step, a)


def _warp(
    img: np.ndarray, p: np.ndarray, q: np.ndarray, shape: tuple[int, int], grid_step: int, alpha: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`mls_warp` on validated inputs (float32 image, float64 C-contiguous handles, ``q``
    rows distinct)."""
    h, w = shape
    map_x, map_y = _source_map(p, q, (h, w), grid_step, alpha)
    big_h, big_w = img.shape[:2]
    valid = (map_x >= -0.5) & (map_x <= big_w - 0.5) & (map_y >= -0.5) & (map_y <= big_h - 0.5)
    # Within half a pixel of the border the edge pixel is repeated (its footprint covers it).
    warped = cv2.remap(np.ascontiguousarray(img), map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    warped = warped.reshape((h, w) + img.shape[2:])
    warped[~valid] = 0.0
    return warped, valid
