"""The offsets' low-resolution solve and edge-aware up-sampling (S3 §3.4).

S3 §3.4: "For regularization, the resulting optimal camera offset is blurred using an edge-aware
filter. [...] The solution is found at lower resolution and later up-sampled [KCLU07]. In this step,
the contribution of each pixel is weighted by its importance, i.e., unimportant pixels with mostly
meaningless solutions do not affect their neighbors."

Three stages, all weighted by importance:

- :func:`weighted_block_mean` takes a full-resolution table (the disparities of
  :func:`~vergence.specular.tabulate_offsets`, the importance) down to the grid of the solve: the
  importance-weighted mean of each ``f x f`` block, and the block's mean importance.
- :func:`push_pull_fill` gives the pixels without importance a value interpolated from the others
  (Gortler et al. 1996's push-pull), so that the next stage has no constant to fall back on;
- :func:`joint_bilateral_upsample` brings the solved offsets back up with the full-resolution guide
  (Kopf et al. 2007); at equal resolution it is the importance-weighted joint bilateral filter that
  S3 calls the edge-aware blur.
"""

from __future__ import annotations

import numpy as np

from vergence._validate import check_positive, check_positive_int
from vergence.specular import _resample_kernels as _k

__all__ = ["joint_bilateral_upsample", "push_pull_fill", "weighted_block_mean"]


def _real_array(name: str, value: object) -> np.ndarray:
    """``value`` as a float32 or float64 array without copying one that already is (the offset
    table is large); other real dtypes converted, bool, complex and non-numeric refused."""
    arr = np.asarray(value)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must hold real numbers; got dtype {arr.dtype}")
    if arr.dtype not in (np.float32, np.float64):
        arr = arr.astype(np.float32 if arr.dtype == np.float16 else np.float64)
    return arr


def weighted_block_mean(values: object, weights: object, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """The weighted mean of ``values`` over each ``factor x factor`` block, and the blocks' mean weight.

    Parameters
    ----------
    values : (..., H, W) or (..., H, W, C) array_like, float
        The quantity to reduce (e.g. per-layer disparity, arcmin). NaN marks a pixel with no value: it
        counts with weight 0 (with channels, a NaN in any channel does). No inf.
    weights : (..., H, W) array_like
        The pixels' weights (S3: importance), finite and >= 0, with the leading shape of ``values``;
        whether ``values`` has a channel axis is read from ``weights.ndim``.
    factor : int
        Block side ``f`` >= 1.

    Returns
    -------
    mean : (..., ceil(H / f), ceil(W / f)[, C]) float32
        ``sum(w v) / sum(w)`` over the block's usable pixels (weight > 0, value not NaN); NaN where
        that sum of weights is 0. With ``factor = 1``: ``values`` (as float32) with NaN where the
        weight is 0.
    weight_mean : (..., ceil(H / f), ceil(W / f)) float32
        ``sum(w) / n`` over the block's usable pixels, ``n`` the number of pixels in the block (a
        pixel with a NaN value counts in ``n`` with weight 0).

    Raises
    ------
    TypeError
        If ``values`` or ``weights`` is not real-valued, or ``factor`` is not an integer.
    ValueError
        On shapes that do not match, empty arrays, inf values, negative or non-finite weights, or
        ``factor < 1``.

    Notes
    -----
    Blocks start at pixel 0; those at the right and bottom edges hold the pixels they have (their
    ``n`` is smaller). Sums are in float64. Leading axes are flattened by ``reshape`` (a view for
    contiguous input) and float32 input is read as it is, without a float64 copy: the real use is the
    offset table of S3 §3.4, ``(K + 1, N, H, W, 2)`` with ``K = 32``. The inputs' inf and weight checks
    happen in the same pass as the sums.

    Examples
    --------
    >>> v = np.array([[1.0, 3.0, 5.0], [np.nan, 3.0, 7.0]])
    >>> w = np.array([[1.0, 1.0, 2.0], [4.0, 2.0, 0.0]])
    >>> mean, wmean = weighted_block_mean(v, w, 2)
    >>> mean.tolist(), wmean.tolist()
    ([[2.5, 5.0]], [[1.0, 1.0]])
    """
    v = _real_array("values", values)
    w = _real_array("weights", weights)
    f = check_positive_int("factor", factor)
    if w.ndim < 2:
        raise ValueError(f"weights must have shape (..., H, W); got {w.shape}")
    if v.ndim not in (w.ndim, w.ndim + 1) or v.shape[: w.ndim] != w.shape:
        raise ValueError(f"values must have shape {w.shape} or {w.shape} + (C,) to match weights; got {v.shape}")
    if v.size == 0:
        raise ValueError(f"values must not be empty; got shape {v.shape}")
    big_h, big_w = w.shape[-2:]
    channels = v.ndim > w.ndim
    flat_v = v.reshape(-1, big_h, big_w, v.shape[-1] if channels else 1)
    flat_w = w.reshape(-1, big_h, big_w)
    ho, wo = -(-big_h // f), -(-big_w // f)
    items = flat_w.shape[0] * ho
    mean = np.empty((flat_w.shape[0], ho, wo, flat_v.shape[-1]), np.float32)
    weight_mean = np.empty((flat_w.shape[0], ho, wo), np.float32)
    bad_values = np.zeros(items, np.bool_)
    bad_weights = np.zeros(items, np.bool_)
    _k.block_mean(flat_v, flat_w, f, mean, weight_mean, bad_values, bad_weights)
    if bad_weights.any():
        raise ValueError("weights must be finite and >= 0")
    if bad_values.any():
        raise ValueError("values must not contain inf (NaN marks a pixel with no value)")
    lead = w.shape[:-2]
    out_shape = (*lead, ho, wo, v.shape[-1]) if channels else (*lead, ho, wo)
    return mean.reshape(out_shape), weight_mean.reshape((*lead, ho, wo))


def _stack(name: str, value: object, *, nan: bool) -> np.ndarray:
    """``value`` as a non-empty float64 ``(N, H, W)`` array without inf (nor NaN unless ``nan``)."""
    arr = _real_array(name, value).astype(np.float64, copy=False)
    if arr.ndim != 3 or 0 in arr.shape:
        raise ValueError(f"{name} must have shape (N, H, W) with N, H, W >= 1; got {arr.shape}")
    if nan:
        if np.isinf(arr).any():
            raise ValueError(f"{name} must not contain inf")
    elif not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def joint_bilateral_upsample(
    values: object,
    weights: object,
    guide_low: object,
    guide_high: object,
    *,
    sigma_space: float = 1.0,
    sigma_range: float = 6.0,
    radius: int = 2,
    fill: float = 1.0,
) -> np.ndarray:
    """Importance-weighted joint bilateral up-sampling of ``values`` guided by ``guide_high`` (S3 §3.4).

    Parameters
    ----------
    values : (N, h, w) array_like
        The low-resolution solution (S3: the offsets ``y`` in [0, 1] of each layer); NaN: no value.
    weights : (N, h, w) array_like
        Each low-resolution pixel's weight (S3: its importance), finite and >= 0.
    guide_low : (N, h, w) array_like
        The guide at low resolution (e.g. :func:`weighted_block_mean` of the fine guide); NaN allowed.
    guide_high : (N, H, W) array_like
        The guide at the output resolution, ``H >= h``, ``W >= w`` (the factors ``H / h``, ``W / w``
        need not be integers); NaN allowed, in the guide's units (e.g. disparity in arcmin).
    sigma_space : float, keyword-only
        Spatial standard deviation in low-resolution pixels, > 0.
    sigma_range : float, keyword-only
        Range standard deviation in the guide's units, > 0.
    radius : int, keyword-only
        Half-side of the square window of low-resolution pixels, >= 0.
    fill : float, keyword-only
        The output where no pixel of the window is usable (S3: 1, the physical stereo camera); NaN
        allowed, to mark those pixels.

    Returns
    -------
    (N, H, W) float32
        The up-sampled values.

    Raises
    ------
    TypeError
        If an array is not real-valued or an option has the wrong type.
    ValueError
        On shapes that do not match, empty arrays, inf (or NaN in ``weights``), negative weights,
        ``sigma_space`` or ``sigma_range`` not finite and > 0, ``radius < 0``, or an infinite ``fill``.

    Notes
    -----
    Joint bilateral up-sampling (Kopf et al. 2007, Eq. (2)) with each low-resolution pixel weighted
    by its importance, as S3 §3.4 asks. Fine pixel ``p = (r, c)`` sits at the low-resolution
    coordinates ``p_low = ((r + 1/2) h / H - 1/2, (c + 1/2) w / W - 1/2)``; with ``q`` over the
    low-resolution pixels within ``radius`` (Chebyshev, clipped at the borders) of the one nearest
    ``p_low``,

    .. math::

        \\tilde v_p = \\frac{\\sum_q v_q\\, w_q\\, e^{-|p_{low} - q|^2 / 2\\sigma_s^2}\\,
                            e^{-(G_p - g_q)^2 / 2\\sigma_r^2}}
                           {\\sum_q w_q\\, e^{-|p_{low} - q|^2 / 2\\sigma_s^2}\\,
                            e^{-(G_p - g_q)^2 / 2\\sigma_r^2}}.

    The range factor is 1 where ``G_p`` or ``g_q`` is NaN; ``q`` with a NaN value or weight 0 adds
    nothing, and where no ``q`` is left the output is ``fill``. The sums are evaluated with the
    exponents shifted by the smallest one, so that guides far apart (in units of ``sigma_range``) do
    not underflow both to 0: the ratio, not an accident of float range, decides the output.

    With ``H = h`` and ``W = w`` this is the importance-weighted joint bilateral filter, the
    "edge-aware filter" that S3 §3.4 blurs the offsets with: values on the two sides of a guide edge
    much larger than ``sigma_range`` do not mix, and pixels of importance 0 do not influence their
    neighbours. Constant values stay constant.

    Examples
    --------
    >>> y = np.array([[[0.0, 1.0]]]); w = np.ones((1, 1, 2)); g = np.array([[[0.0, 50.0]]])
    >>> up = joint_bilateral_upsample(y, w, g, np.repeat(np.repeat(g, 2, 1), 2, 2), sigma_range=1.0)
    >>> up[0].round(3).tolist()
    [[0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0]]
    """
    v = _stack("values", values, nan=True)
    w = _stack("weights", weights, nan=False)
    gl = _stack("guide_low", guide_low, nan=True)
    gh = _stack("guide_high", guide_high, nan=True)
    for name, arr in (("weights", w), ("guide_low", gl)):
        if arr.shape != v.shape:
            raise ValueError(f"{name} must have the shape of values {v.shape}; got {arr.shape}")
    if gh.shape[0] != v.shape[0] or gh.shape[1] < v.shape[1] or gh.shape[2] < v.shape[2]:
        raise ValueError(f"guide_high must have shape (N, H, W) with N = {v.shape[0]}, H >= {v.shape[1]}, "
                         f"W >= {v.shape[2]}; got {gh.shape}")  # fmt: skip
    if (w < 0).any():
        raise ValueError("weights must be >= 0")
    s_space = check_positive("sigma_space", sigma_space)
    s_range = check_positive("sigma_range", sigma_range)
    if isinstance(radius, bool) or not isinstance(radius, int | np.integer):
        raise TypeError(f"radius must be an integer; got {type(radius).__name__}")
    if radius < 0:
        raise ValueError(f"radius must be >= 0; got {radius}")
    if isinstance(fill, bool) or not isinstance(fill, int | float | np.integer | np.floating):
        raise TypeError(f"fill must be a real number; got {type(fill).__name__}")
    if np.isinf(fill):
        raise ValueError(f"fill must not be inf; got {fill}")
    usable = ~np.isnan(v) & (w > 0)
    wq = np.where(usable, w, 0.0)
    vw = np.where(usable, v * wq, 0.0)
    out = np.empty(gh.shape, np.float64)
    _k.joint_bilateral(vw, wq, gl, gh, 0.5 / s_space**2, 0.5 / s_range**2, int(radius), float(fill), out)
    return out.astype(np.float32)


def _half(a: np.ndarray) -> np.ndarray:
    """Sum of each 2 x 2 block of ``(N, h, w)`` (an odd last row or column padded with 0)."""
    n, h, w = a.shape
    p = np.zeros((n, h + h % 2, w + w % 2))
    p[:, :h, :w] = a
    return p[:, 0::2, 0::2] + p[:, 1::2, 0::2] + p[:, 0::2, 1::2] + p[:, 1::2, 1::2]


def _double(a: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear up-sampling of ``(N, h, w)`` by two to ``shape`` (pixel centres aligned, edges held)."""
    n, h, w = a.shape
    big_h, big_w = shape
    ys = np.clip((np.arange(big_h) + 0.5) / 2.0 - 0.5, 0, h - 1)
    xs = np.clip((np.arange(big_w) + 0.5) / 2.0 - 0.5, 0, w - 1)
    y0, x0 = np.floor(ys).astype(int), np.floor(xs).astype(int)
    y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
    ty, tx = (ys - y0)[None, :, None], (xs - x0)[None, None, :]
    top = a[:, y0][:, :, x0] * (1 - tx) + a[:, y0][:, :, x1] * tx
    bottom = a[:, y1][:, :, x0] * (1 - tx) + a[:, y1][:, :, x1] * tx
    return top * (1 - ty) + bottom * ty


def push_pull_fill(values: object, weights: object, *, fill: float = 1.0) -> np.ndarray:
    """``values`` where ``weights > 0``; elsewhere interpolated from them by push-pull (S3 §3.4's regularisation).

    Parameters
    ----------
    values : (N, h, w) array_like
        Per image (S3: per layer) the values to keep where the weight is positive (the solved offsets).
    weights : (N, h, w) array_like
        Finite and >= 0 (S3: importance).
    fill : float, keyword-only
        The value of an image with no positive weight at all (S3: 1, the physical stereo camera).

    Returns
    -------
    (N, h, w) float64
        Equal to ``values`` where ``weights > 0``.

    Raises
    ------
    ValueError
        On shapes that differ, empty input, NaN or inf values where the weight is positive, or bad weights.

    Notes
    -----
    Push: sums of ``w v`` and ``w`` over 2 x 2 blocks, level after level, down to one pixel. Pull:
    from the coarsest level up, a pixel with weight keeps its weighted mean, one without takes the
    bilinear up-sampling of the level above (Gortler et al. 1996, "The Lumigraph", §3.3.1). The
    fill is smooth, so that S3's edge-aware blur does not see steps that no feature asked for; a
    constant fill (1) drew stripes of physical stereo across surfaces (issue 26).

    Examples
    --------
    >>> push_pull_fill(np.array([[[0.0, 5.0, 5.0, 1.0]]]), np.array([[[1.0, 0.0, 0.0, 1.0]]])).round(2).tolist()
    [[[0.0, 0.25, 0.75, 1.0]]]
    """
    v = _stack("values", values, nan=True)
    w = _stack("weights", weights, nan=False)
    if w.shape != v.shape:
        raise ValueError(f"weights must have the shape of values {v.shape}; got {w.shape}")
    if (w < 0).any():
        raise ValueError("weights must be >= 0")
    if not np.isfinite(v[w > 0]).all():
        raise ValueError("values must be finite where the weight is positive")
    if isinstance(fill, bool) or not np.isfinite(fill):
        raise ValueError(f"fill must be a finite number; got {fill!r}")
    wv, ww = [np.where(w > 0, v * w, 0.0)], [w]
    while ww[-1].shape[1] > 1 or ww[-1].shape[2] > 1:
        wv.append(_half(wv[-1]))
        ww.append(_half(ww[-1]))
    top = ww[-1]
    out = np.where(top > 0, wv[-1] / np.where(top > 0, top, 1.0), float(fill))
    for level in range(len(ww) - 2, -1, -1):
        up = _double(out, ww[level].shape[1:])
        has = ww[level] > 0
        out = np.where(has, wv[level] / np.where(has, ww[level], 1.0), up)
    return np.where(w > 0, v, out)
