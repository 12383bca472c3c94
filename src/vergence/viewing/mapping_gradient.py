"""Gradient-domain disparity mapping of a disparity *map* (Lang et al. 2010).

Instead of mapping each disparity value, map the disparity gradients: compress depth jumps
(``|g| > threshold`` -> ``scale * g``), keep the small gradients of local detail, and rebuild the
map whose gradients best match, ``min sum (grad d' - g')^2`` (a Poisson problem), with one anchor
per connected region of valid pixels.
"""

from __future__ import annotations

import numpy as np

from vergence._validate import check_positive
from vergence.viewing._shared import check_disparities, real_array
from vergence.viewing.geometry import MAX_ABS_DISPARITY

__all__ = ["SCALE_RANGE", "gradient_domain_mapping"]

# The jump factor ``scale``: a millionth to a million. Lang et al. 2010 compress jumps by factors near
# 0.1-0.5; the bounds keep ``scale * g`` finite for any map of |d| <= MAX_ABS_DISPARITY (no overflow).
SCALE_RANGE = (1e-6, 1e6)


def _edges(valid: np.ndarray, d: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward-difference edges between 4-neighbours that are both valid: (from, to, d[to] - d[from])."""
    src, dst, grad = [], [], []
    for axis in (1, 0):  # x then y
        if d.shape[axis] < 2:
            continue
        a = [slice(None)] * 2
        b = [slice(None)] * 2
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        both = valid[tuple(a)] & valid[tuple(b)]
        src.append(index[tuple(a)][both])
        dst.append(index[tuple(b)][both])
        grad.append((d[tuple(b)] - d[tuple(a)])[both])
    if not src:
        empty = np.zeros(0)
        return empty.astype(np.int64), empty.astype(np.int64), empty
    return np.concatenate(src), np.concatenate(dst), np.concatenate(grad)


def gradient_domain_mapping(disparity: object, *, threshold: float, scale: float) -> np.ndarray:
    """Remap a disparity map in the gradient domain: compress jumps, keep detail (Lang et al. 2010).

    Target gradients ``g' = scale * g`` where ``|g| > threshold``, else ``g`` (forward differences
    between 4-neighbours, Lang et al. 2010's phi_grad). The result ``d'`` minimises
    ``sum over edges (d'_q - d'_p - g'_pq)^2`` (the normal equations are a discrete Poisson
    equation, solved exactly: by the DCT when every pixel is valid, by a sparse direct solve
    otherwise); each 4-connected region of valid pixels keeps its mean disparity (the anchor that
    fixes the free constant).

    Parameters
    ----------
    disparity : array_like, shape (N,) or (H, W)
        Disparity map, any unit; NaN = invalid (excluded, stays NaN).
    threshold : float
        Gradient magnitude above which a gradient is a jump, > 0 (same unit as ``disparity``).
    scale : float
        Factor applied to jumps, > 0 (< 1 compresses, > 1 expands).

    Returns
    -------
    ndarray, float64, same shape as ``disparity``

    Raises
    ------
    ValueError
        If ``disparity`` is not 1-D or 2-D, is empty, all NaN, holds inf or a value past
        :data:`~vergence.viewing.geometry.MAX_ABS_DISPARITY`; if ``threshold`` is not positive or
        ``scale`` lies outside :data:`SCALE_RANGE`.
    TypeError
        If ``disparity`` is not numeric (text included).

    Notes
    -----
    Where the target gradients are integrable (1-D profiles, jumps along straight rows or
    columns), ``d'`` reproduces them exactly: a 10-px jump with ``scale = 0.2`` becomes 2 px while
    the detail slopes stay as they were (Lang et al. 2010; a 10-px jump x0.2 keeps the detail slopes
    exactly). Elsewhere it is the least-squares compromise.

    Examples
    --------
    >>> profile = np.array([0.0, 0.1, 0.2, 10.2, 10.3])
    >>> np.round(gradient_domain_mapping(profile, threshold=1.0, scale=0.2), 6).tolist()
    [3.2, 3.3, 3.4, 5.4, 5.5]
    """
    d = real_array("disparity", disparity, allow_nan=True)
    if d.ndim not in (1, 2) or d.size == 0:
        raise ValueError(f"disparity must have shape (N,) or (H, W) and not be empty; got {d.shape}")
    if np.isnan(d).all():
        raise ValueError(f"disparity must hold at least one valid (not NaN) value; got {d.size} NaN")
    check_disparities("disparity", d[~np.isnan(d)], unit="")  # |d| <= MAX_ABS_DISPARITY: differences stay finite
    tau = check_positive("threshold", threshold)
    factor = check_positive("scale", scale)
    if not SCALE_RANGE[0] <= factor <= SCALE_RANGE[1]:
        raise ValueError(f"scale must lie in [{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}]; got {factor:g}")
    grid = d.reshape(1, -1) if d.ndim == 1 else d
    valid = ~np.isnan(grid)
    if valid.all():
        out = _solve_full_grid(grid, tau, factor)
    else:
        out = _solve_sparse(grid, valid, tau, factor)
    return out.reshape(d.shape)


def _compress(g: np.ndarray, tau: float, factor: float) -> np.ndarray:
    return np.where(np.abs(g) > tau, factor * g, g)


def _solve_full_grid(grid: np.ndarray, tau: float, factor: float) -> np.ndarray:
    """Exact solve on a grid with no invalid pixel: the normal equations are the Neumann Laplacian,
    diagonalised by the orthonormal DCT-II (eigenvalues ``4 sin^2(pi k / 2n)`` per axis)."""
    import scipy.fft  # here, not at the top: SciPy costs ~1 s to import, and only this solve needs it

    h, w = grid.shape
    gx = _compress(np.diff(grid, axis=1), tau, factor)
    gy = _compress(np.diff(grid, axis=0), tau, factor)
    rhs = np.zeros(grid.shape)  # A^T g' (minus the divergence of g')
    rhs[:, 1:] += gx
    rhs[:, :-1] -= gx
    rhs[1:, :] += gy
    rhs[:-1, :] -= gy
    eig = (2.0 - 2.0 * np.cos(np.pi * np.arange(h) / h))[:, None] + (2.0 - 2.0 * np.cos(np.pi * np.arange(w) / w))
    eig[0, 0] = 1.0  # the constant mode is free: fixed by the anchor below
    coeff = scipy.fft.dctn(rhs, type=2, norm="ortho") / eig
    coeff[0, 0] = 0.0
    out = scipy.fft.idctn(coeff, type=2, norm="ortho")
    return out + (grid.mean() - out.mean())  # anchor: keep the mean disparity


def _solve_sparse(grid: np.ndarray, valid: np.ndarray, tau: float, factor: float) -> np.ndarray:
    """Sparse least squares on the valid pixels, one pinned pixel and a mean anchor per region."""
    import scipy.ndimage  # here, not at the top: SciPy costs ~1 s to import, and only the solves need it
    import scipy.sparse
    import scipy.sparse.linalg

    n = int(valid.sum())
    out = np.full(grid.shape, np.nan)
    if n == 0:
        return out
    index = np.full(grid.shape, -1, dtype=np.int64)
    index[valid] = np.arange(n)
    src, dst, g = _edges(valid, grid, index)
    g_target = _compress(g, tau, factor)
    values = grid[valid]
    labels, n_regions = scipy.ndimage.label(valid)  # 4-connectivity: the regions the edges connect
    region = labels[valid] - 1
    # Pin the first pixel of each region: the pinned normal equations are symmetric positive definite.
    pinned = np.zeros(n, dtype=bool)
    pinned[np.unique(region, return_index=True)[1]] = True
    m = src.size
    rows = np.repeat(np.arange(m), 2)
    cols = np.column_stack([src, dst]).ravel()
    signs = np.tile([-1.0, 1.0], m)
    A = scipy.sparse.csr_matrix((signs, (rows, cols)), shape=(m, n))
    free = np.flatnonzero(~pinned)
    solution = np.zeros(n)
    if free.size:
        A_free = A[:, free]
        normal = (A_free.T @ A_free).tocsc()
        solution[free] = scipy.sparse.linalg.spsolve(normal, A_free.T @ g_target)
    # Anchor: each region keeps its mean disparity.
    counts = np.bincount(region, minlength=n_regions)
    shift = (np.bincount(region, weights=values, minlength=n_regions)
             - np.bincount(region, weights=solution, minlength=n_regions)) / counts
    out[valid] = solution + shift[region]
    return out
