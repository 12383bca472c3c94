"""Per-layer disparity of a stereo ray tree by matching 3D positions (S3 §3.2).

Every layer of a rendered stereo pair (S3 §3.1: the first hit, the reflection, the refraction, ...)
holds, per pixel, the scene position where that light path met a surface. A pixel of a layer in
the left eye matches the pixel of the *same* layer in the right eye whose position is nearest, in a
window of ``81 x 9`` pixels centred on it; there is no match (a generalised disocclusion) when
that nearest position is ``epsilon`` = 1/100 of the scene diameter away or farther (S3 §3.2,
"Stereo matching" and "Human limitations"). S3 searches exhaustively on a GPU; here a branch and
bound over bounding boxes of the right eye's positions finds the very same minimum (see
:func:`layer_disparity`, Notes).

Sign conventions (``docs/conventions.md``): ``disparity_px`` is ``x_left - x_right`` (and
``y_left - y_right``) in image pixels; :func:`disparity_arcmin` returns the vergence change of the
displayed parallax, positive (uncrossed) behind the screen, as
:func:`vergence.viewing.arcmin_from_pixels` and :class:`vergence.viewing.ComfortZone`.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral

import numpy as np

from vergence._validate import check_bool, check_in_range, readonly_fields
from vergence.specular import _kernels
from vergence.viewing.comfort import arcmin_from_pixels
from vergence.viewing.geometry import Display, check_display

__all__ = [
    "EPSILON_FRACTION",
    "LAYER_MATCH_METHODS",
    "LayerDisparity",
    "MATCH_WINDOW",
    "disparity_arcmin",
    "layer_disparity",
    "scene_diameter",
]

# S3 §3.2: an 81 x 9 pixel search window (width, height), for the ±3° horizontal and 15′ vertical
# fusion ranges. On S3's study display (1680 px, 0.282 mm pitch, 60 cm: about 1.62′ per pixel) 9 px is
# about 14.5′ (the 15′) but 81 px is about 131′, not the ±3° (about ±111 px) nor the paper's "24 x 4
# arcmin": the paper's figures disagree, so the pixel size is kept and exposed as a parameter.
MATCH_WINDOW = (81, 9)
# S3 §3.2: "epsilon equals 1/100 of the scene diameter".
EPSILON_FRACTION = 0.01
# Range of a given epsilon, metres: its float32 square stays a normal number (the cutoff compares squares).
_EPSILON_RANGE = (1e-18, 1e18)
# Columns per bounding box of the branch and bound (a speed setting only: the result does not depend on it).
_BLOCK = 8


@dataclass(frozen=True, slots=True, eq=False)
class LayerDisparity:
    """Per-layer matches of the left eye's ray tree in the right eye's (S3 §3.2). Arrays are read-only.

    Attributes
    ----------
    disparity_px : (N, H, W, 2) float32
        Per layer and left pixel, ``(x_left - x_right, y_left - y_right)`` of its match in image
        pixels (whole numbers): the match of left pixel ``(x, y)`` is right pixel
        ``(x - dx, y - dy)``. NaN (both components) where the pixel has no match.
    distance : (N, H, W) float32
        Distance in metres between the two matched positions; NaN where there is no match.
    epsilon : float
        The match cutoff in metres: a match is nearer than ``epsilon``.
    window : tuple of int
        ``(width, height)`` of the search window in pixels.
    """

    disparity_px: np.ndarray
    distance: np.ndarray
    epsilon: float
    window: tuple[int, int]

    def __post_init__(self) -> None:
        for name in ("disparity_px", "distance"):
            if not isinstance(getattr(self, name), np.ndarray):
                raise TypeError(f"{name} must be a numpy array; got {type(getattr(self, name)).__name__}")
        if self.disparity_px.ndim != 4 or self.disparity_px.shape[-1] != 2:
            raise ValueError(f"disparity_px must have shape (N, H, W, 2); got {self.disparity_px.shape}")
        if self.distance.shape != self.disparity_px.shape[:3]:
            raise ValueError(f"distance must have shape {self.disparity_px.shape[:3]}; got {self.distance.shape}")
        readonly_fields(self, "disparity_px", "distance")

    @property
    def matched(self) -> np.ndarray:
        """``(N, H, W)`` bool: whether each left pixel of each layer has a match (S3's proximity factor)."""
        return ~np.isnan(self.distance)

    @property
    def n_layers(self) -> int:
        """Number of layers N."""
        return self.distance.shape[0]


def _positions(name: str, value: object) -> np.ndarray:
    """``value`` as C-contiguous float32 ``(N, H, W, 3)`` with no inf (NaN allowed)."""
    arr = np.asarray(value)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must be a real numeric array; got dtype {arr.dtype}")
    if arr.ndim != 4 or arr.shape[-1] != 3 or 0 in arr.shape:
        raise ValueError(f"{name} must have shape (N, H, W, 3) with N, H, W >= 1; got {arr.shape}")
    with np.errstate(over="ignore"):
        return np.ascontiguousarray(arr, dtype=np.float32)


def _window(window: object) -> tuple[int, int]:
    ok = (isinstance(window, tuple | list) and len(window) == 2
          and all(isinstance(v, Integral) and not isinstance(v, bool) for v in window))  # fmt: skip
    if not ok:
        raise TypeError(f"window must be two integers (width, height); got {window!r}")
    w, h = int(window[0]), int(window[1])
    if w < 1 or h < 1 or w % 2 == 0 or h % 2 == 0:
        raise ValueError(f"window must be two odd integers >= 1 (width, height), centred on the pixel; got {(w, h)}")
    return w, h


def _diameter(lo: np.ndarray, hi: np.ndarray) -> float:
    """Diagonal of the box ``[lo, hi]``; 0 when it is empty (lo > hi)."""
    if not (lo <= hi).all():
        return 0.0
    return float(np.linalg.norm(hi - lo))


def _bounds(name: str, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounding box of the finite pixels of checked float32 positions and the ``(N, H)`` rows that
    have one; ValueError on inf."""
    lo, hi, n_inf, active = _kernels.position_bounds(positions)
    if n_inf:
        raise ValueError(f"{name} must hold finite positions or NaN (no surface), within float32 range; "
                         f"got {n_inf} inf value(s)")  # fmt: skip
    return lo, hi, active


def scene_diameter(left_position: object, right_position: object) -> float:
    """Diameter of the scene seen by a stereo ray tree: the diagonal of the bounding box of its positions.

    Parameters
    ----------
    left_position, right_position : (N, H, W, 3) array_like
        Per-layer world positions of the two eyes (metres; NaN where a pixel has no surface), as
        :attr:`vergence.render.RenderResult.position`. A pixel counts when its three coordinates are finite.

    Returns
    -------
    float
        The diagonal, in metres, of the axis-aligned box around every such pixel of every layer of
        both eyes (0 when there is none). S3 §3.2 does not define its "scene diameter"; the box
        diagonal is at least the true diameter of the point set and at most sqrt(3) times it.

    Raises
    ------
    TypeError, ValueError
        If an array is not numeric, not ``(N, H, W, 3)``, or holds inf.

    Examples
    --------
    >>> p = np.full((1, 1, 2, 3), np.nan, np.float32)
    >>> p[0, 0, 0] = (0.0, 0.0, 0.0); p[0, 0, 1] = (3.0, 4.0, 0.0)
    >>> scene_diameter(p, p[:, :, :1])
    5.0
    """
    lo_l, hi_l, _ = _bounds("left_position", _positions("left_position", left_position))
    lo_r, hi_r, _ = _bounds("right_position", _positions("right_position", right_position))
    return _diameter(np.minimum(lo_l, lo_r), np.maximum(hi_l, hi_r))


def _match_exhaustive(left, right, active, half_w, half_h, eps2):  # noqa: ANN001, ANN202
    """Disparity and distance by :func:`._kernels.match_exhaustive` (``active``: the left rows with a surface)."""
    return _kernels.match_exhaustive(left, right, active, half_w, half_h, eps2)


def _match_bounded(left, right, active, half_w, half_h, eps2):  # noqa: ANN001, ANN202
    """Disparity and distance by :func:`._kernels.match_bounded`, on the right eye's boxes."""
    boxes = _kernels.row_boxes(right, _BLOCK)
    wboxes = _kernels.window_boxes(boxes, half_h, active)
    return _kernels.match_bounded(left, right, active, boxes, wboxes, _BLOCK, half_w, half_h, eps2)


# The search methods: both return the same matches (the tests hold them to it); "bounded" is faster.
LAYER_MATCH_METHODS = {"bounded": _match_bounded, "exhaustive": _match_exhaustive}


def layer_disparity(
    left_position: object,
    right_position: object,
    *,
    window: tuple[int, int] = MATCH_WINDOW,
    epsilon: float | None = None,
    method: str = "bounded",
) -> LayerDisparity:
    """Match each left pixel of each layer to the right pixel of the same layer nearest in 3D (S3 §3.2).

    Parameters
    ----------
    left_position, right_position : (N, H, W, 3) array_like
        Per-layer world positions of the left and right eyes in metres, NaN where a pixel of a
        layer has no surface (the ray escaped or the path does not exist), e.g. the ``position`` of
        two :class:`vergence.render.RenderResult` of one rig. Same shape; inf is refused. Matching
        is done in float32 (float64 input is rounded).
    window : (int, int), keyword-only
        ``(width, height)`` of the search window in pixels, both odd, centred on the left pixel
        (:data:`MATCH_WINDOW` = 81 x 9, S3 §3.2). Candidates outside the image are not searched.
    epsilon : float, optional, keyword-only
        Match cutoff in metres; default :data:`EPSILON_FRACTION` x :func:`scene_diameter`.
    method : str, keyword-only
        A key of :data:`LAYER_MATCH_METHODS`: ``"bounded"`` (default) or ``"exhaustive"``; the same result.

    Returns
    -------
    LayerDisparity
        ``disparity_px`` ``(x_left - x_right, y_left - y_right)`` and ``distance`` per layer and
        left pixel, NaN where there is no match.

    Raises
    ------
    TypeError
        If a position array is not numeric, ``window`` is not two integers, ``epsilon`` not a real
        number or ``method`` not a string.
    ValueError
        If the arrays are not ``(N, H, W, 3)`` of one shape or hold inf, the window sides are not
        odd and >= 1, ``epsilon`` lies outside [1e-18, 1e18] m (float32 squares), or ``method`` is
        unknown (the message lists the methods).

    Notes
    -----
    With ``p_l``, ``p_r`` the positions of layer i, left pixel ``x`` matches
    ``argmin_{x' in window(x)} |p_r(x') - p_l(x)|`` when that minimum is ``< epsilon`` (S3 §3.2).
    A pixel with a NaN coordinate (left or right) is never matched and never a match.

    *Exactness.* Every method computes ``d2 = (dx^2 + dy^2) + dz^2`` in float32 from
    ``dx = x_r - x_l`` etc., and matches when ``d2 < float32(epsilon)^2``. *Tie rule*: among
    candidates with the same smallest ``d2``, the first in the right image's raster order wins (the
    smallest row, then the smallest column). ``"exhaustive"`` tests the whole window; ``"bounded"``
    starts from the right pixel one column past the previous left pixel's match, then skips every
    8-column block of the window, and every row of such a block, whose bounding box of positions is
    farther than the best ``d2`` so far. Its lower bound is computed in the same float32 form and
    rounding is monotone, so it never exceeds the ``d2`` of a pixel in the box: a skipped pixel can
    neither win nor tie, and the two methods return identical arrays.

    Examples
    --------
    One layer, a row of points 1 cm apart seen shifted by 2 pixels in the right eye:

    >>> xs = np.arange(8, dtype=np.float32) * 0.01
    >>> left = np.zeros((1, 1, 8, 3), np.float32); left[0, 0, :, 0] = xs
    >>> right = np.full_like(left, np.nan); right[0, 0, :6, 0] = xs[2:]; right[0, 0, :6, 1:] = 0.0
    >>> out = layer_disparity(left, right, epsilon=0.001)
    >>> out.disparity_px[0, 0, :, 0]
    array([nan, nan,  2.,  2.,  2.,  2.,  2.,  2.], dtype=float32)
    """
    left = _positions("left_position", left_position)
    right = _positions("right_position", right_position)
    if left.shape != right.shape:
        raise ValueError(f"right_position must have the shape of left_position {left.shape}; got {right.shape}")
    win = _window(window)
    if not isinstance(method, str):
        raise TypeError(f"method must be a string; got {type(method).__name__}")
    if method not in LAYER_MATCH_METHODS:
        raise ValueError(f"unknown method {method!r}; valid methods: {', '.join(sorted(LAYER_MATCH_METHODS))}")
    lo_l, hi_l, active = _bounds("left_position", left)
    lo_r, hi_r, _ = _bounds("right_position", right)
    if epsilon is None:
        eps = EPSILON_FRACTION * _diameter(np.minimum(lo_l, lo_r), np.maximum(hi_l, hi_r))
        if eps > _EPSILON_RANGE[1]:
            raise ValueError(f"the scene diameter must be at most {_EPSILON_RANGE[1] / EPSILON_FRACTION:g} m for "
                             f"float32 matching; got {eps / EPSILON_FRACTION:g} m")  # fmt: skip
    else:
        eps = check_in_range("epsilon", epsilon, *_EPSILON_RANGE)
    eps32 = np.float32(eps)
    disp, dist = LAYER_MATCH_METHODS[method](left, right, active, win[0] // 2, win[1] // 2, eps32 * eps32)
    return LayerDisparity(disparity_px=disp, distance=dist, epsilon=float(eps), window=win)


def disparity_arcmin(disparity_px: object, display: Display, *, exact: bool = True) -> np.ndarray:
    """Angular disparity in arcminutes of per-layer pixel disparities seen on ``display`` (S3 §3.2 works in arcmin).

    Parameters
    ----------
    disparity_px : (..., H, W, 2) array_like
        ``(x_left - x_right, y_left - y_right)`` in image pixels, e.g.
        :attr:`LayerDisparity.disparity_px`; NaN where there is no match. The image is taken to fill
        the screen width: one image pixel is ``display.resolution / W`` display pixels.
    display : vergence.viewing.Display
        The viewing set-up; its ``resolution`` must be known.
    exact : bool, keyword-only
        Horizontal component: True (default) the exact vergence change at the screen centre,
        False the small-angle form (as :func:`vergence.viewing.arcmin_from_pixels`).

    Returns
    -------
    (..., H, W, 2) float64
        ``[..., 0]``: the vergence change of the screen parallax ``x_r - x_l``, positive (uncrossed)
        behind the screen, the sign of :class:`vergence.viewing.ComfortZone`; ``[..., 1]``: the
        angle of the vertical offset ``y_r - y_l`` (small-angle form ``s / D``), positive when the
        right eye's image lies lower. NaN where the input is NaN.

    Raises
    ------
    TypeError
        If ``disparity_px`` is not numeric, ``display`` not a Display or ``exact`` not a bool.
    ValueError
        If ``disparity_px`` is not ``(..., H, W, 2)``, holds inf, or the display resolution is unknown.

    Notes
    -----
    Parallax ``s = -d · p · N / W`` metres (pitch ``p``, ``N`` display pixels, ``W`` image
    pixels), then ``theta = 2 atan(e/2D) - 2 atan((e - s)/2D)``, the vergence geometry of
    :mod:`vergence.viewing.comfort` (S3 §3.2 gives disparities in arcmin); vertically ``theta = s / D``.
    S3's study display shows 1 px as about 1.62′ (S3 §4: 0.282 mm at 60 cm).

    Examples
    --------
    On S3's study display an image 1680 px wide is shown pixel for pixel; 1 px of crossed
    disparity (in front of the screen) is about -1.61′:

    >>> from vergence.viewing import Display
    >>> d = np.zeros((1, 1680, 2), np.float32); d[0, 0] = (1.0, 0.0)
    >>> a = disparity_arcmin(d, Display.preset("samsung-2233rz"))
    >>> round(float(a[0, 0, 0]), 2), float(a[0, 0, 1])
    (-1.61, 0.0)
    """
    try:
        arr = np.asarray(disparity_px, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"disparity_px must be numeric; got {type(disparity_px).__name__}") from exc
    if arr.ndim < 3 or arr.shape[-1] != 2 or 0 in arr.shape:
        raise ValueError(f"disparity_px must have shape (..., H, W, 2) with H, W >= 1; got {arr.shape}")
    if np.isinf(arr).any():
        raise ValueError("disparity_px must not contain inf (NaN marks a pixel with no match)")
    check_display(display, resolution=True)
    check_bool("exact", exact)
    scale = display.resolution / arr.shape[-2]  # display pixels per image pixel
    out = np.full(arr.shape, np.nan)
    for axis, exact_axis in ((0, exact), (1, False)):
        parallax = (0.0 - arr[..., axis]) * scale  # x_r - x_l (y_r - y_l) in display pixels; 0 stays +0
        valid = ~np.isnan(parallax)
        if valid.any():
            out[..., axis][valid] = arcmin_from_pixels(parallax[valid], display, exact=exact_axis)
    return out
