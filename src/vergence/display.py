"""A stereo pair to what a display takes: anaglyphs, frame-packed and interleaved layouts, view tiles.

Every function takes float32 images in [0, 1] (``(H, W)`` grey or ``(H, W, 3)`` RGB; uint8/uint16
are scaled by :func:`vergence._validate.as_image`), never modifies them, and returns a new float32
image in [0, 1]. ``left`` and ``right`` must have the same shape. Pixel conventions:
``docs/conventions.md`` (row 0 at the top, column 0 at the left, both counted from 0).

Layouts (``left`` = L, ``right`` = R):

- ``anaglyph``: one RGB image for coloured glasses (red-cyan, green-magenta or amber-blue; the
  methods of :data:`ANAGLYPH_METHODS`).
- ``side_by_side`` / ``top_bottom``: L then R, next to each other or stacked; ``half=True`` squeezes
  each view to half the width (height) with area averaging so the frame keeps the size of one view
  (frame-compatible 3D broadcasts).
- ``interleave``: rows (or columns) alternate L, R, L, ... (line-interleaved polarised screens).
- ``checkerboard``: pixel (x, y) from L when x + y is even (DLP 3D projectors).
- ``tile_views``: N views in a grid, row by row (contact sheets, multi-view autostereoscopic input).

:func:`pack` packs a pair into any layout of the one table :data:`LAYOUTS` by name.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from types import MappingProxyType

import cv2
import numpy as np

from vergence import _display_kernels
from vergence._validate import as_image_pair, as_view, check_positive_int

__all__ = [
    "ANAGLYPH_METHODS",
    "LAYOUTS",
    "anaglyph",
    "checkerboard",
    "interleave",
    "pack",
    "side_by_side",
    "tile_views",
    "top_bottom",
]

# Dubois least-squares anaglyph matrices (rows: output R, G, B; columns: input R, G, B), for
# linear RGB; left eye behind the first-named filter. Method: E. Dubois, "A projection method to
# generate anaglyph stereo images", ICASSP 2001. Red-cyan: his March 2009 note "Conversion of a stereo
# pair to anaglyph with the least-squares projection method"; green-magenta and amber-blue: the
# matrices published on his anaglyph web page (www.site.uottawa.ca/~edubois/anaglyph/). In each pair
# the row sums of M_L + M_R are 1 within 0.001: a white pair stays white.
DUBOIS_RED_CYAN_LEFT = np.array(
    [[0.437, 0.449, 0.164], [-0.062, -0.062, -0.024], [-0.048, -0.050, -0.017]]
)
DUBOIS_RED_CYAN_RIGHT = np.array(
    [[-0.011, -0.032, -0.007], [0.377, 0.761, 0.009], [-0.026, -0.093, 1.234]]
)
DUBOIS_GREEN_MAGENTA_LEFT = np.array(
    [[-0.062, -0.158, -0.039], [0.284, 0.668, 0.143], [-0.015, -0.027, 0.021]]
)
DUBOIS_GREEN_MAGENTA_RIGHT = np.array(
    [[0.529, 0.705, 0.024], [-0.016, -0.015, -0.065], [0.009, 0.075, 0.937]]
)
DUBOIS_AMBER_BLUE_LEFT = np.array(
    [[1.062, -0.205, 0.299], [-0.026, 0.908, 0.068], [-0.038, -0.173, 0.022]]
)
DUBOIS_AMBER_BLUE_RIGHT = np.array(
    [[-0.016, -0.123, -0.017], [0.006, 0.062, -0.017], [0.094, 0.185, 0.911]]
)
for _m in (
    DUBOIS_RED_CYAN_LEFT,
    DUBOIS_RED_CYAN_RIGHT,
    DUBOIS_GREEN_MAGENTA_LEFT,
    DUBOIS_GREEN_MAGENTA_RIGHT,
    DUBOIS_AMBER_BLUE_LEFT,
    DUBOIS_AMBER_BLUE_RIGHT,
):
    _m.flags.writeable = False  # published constants: no caller can change them for everyone
del _m
# Rec. 601 luma weights for the half-colour anaglyph's left (red) channel.
_LUMA_601 = np.array([0.299, 0.587, 0.114])
_ORIENTATIONS = ("columns", "rows")


def _pair(left: object, right: object) -> tuple[np.ndarray, np.ndarray]:
    """Validate a stereo pair: two views of one shape."""
    return as_image_pair("left", left, "right", right)


def _rgb(view: np.ndarray) -> np.ndarray:
    """Grey (H, W) -> (H, W, 3) by replicating the channel; RGB unchanged."""
    return np.repeat(view[:, :, None], 3, axis=2) if view.ndim == 2 else view


def _channels(left_from: tuple[int, ...]) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Plain colour anaglyph: the output channels ``left_from`` from the left view, the rest from the right."""

    def combine(lc: np.ndarray, rc: np.ndarray) -> np.ndarray:
        out = rc.copy()
        out[:, :, list(left_from)] = lc[:, :, list(left_from)]
        return out

    return combine


def _half_color(lc: np.ndarray, rc: np.ndarray) -> np.ndarray:
    """``(Y(L), R_g, R_b)`` with the Rec. 601 luma of the left view."""
    luma = lc.astype(np.float64) @ _LUMA_601
    out = np.concatenate([luma[:, :, None], rc[:, :, 1:]], axis=2)
    return np.clip(out, 0.0, 1.0)  # luma weights sum to 1: only float rounding (< 1e-15) removed


def _dubois(m_left: np.ndarray, m_right: np.ndarray) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Dubois's projection ``A = M_L L + M_R R`` in linear light, clipped to the gamut, sRGB encoded
    (one Numba pass, the sRGB power laws tabulated: within 3.2e-8 of the formula, see
    :mod:`vergence._display_kernels`)."""

    def combine(lc: np.ndarray, rc: np.ndarray) -> np.ndarray:
        out = np.empty(lc.shape[:2] + (3,), dtype=np.float32)
        _display_kernels.dubois(np.ascontiguousarray(lc, dtype=np.float32), np.ascontiguousarray(rc, dtype=np.float32),
                                m_left, m_right, _display_kernels.DECODE_TABLE, _display_kernels.ENCODE_TABLE, out)
        return out

    return combine


# Anaglyph methods, name -> function of the two RGB views (the left eye behind the first-named
# filter). One table: anaglyph's dispatch, its error message and the "anaglyph-*" LAYOUTS read it.
ANAGLYPH_METHODS: MappingProxyType[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = MappingProxyType(
    {
        "amber-blue": _channels((0, 1)),
        "dubois": _dubois(DUBOIS_RED_CYAN_LEFT, DUBOIS_RED_CYAN_RIGHT),
        "dubois-amber-blue": _dubois(DUBOIS_AMBER_BLUE_LEFT, DUBOIS_AMBER_BLUE_RIGHT),
        "dubois-green-magenta": _dubois(DUBOIS_GREEN_MAGENTA_LEFT, DUBOIS_GREEN_MAGENTA_RIGHT),
        "green-magenta": _channels((1,)),
        "half-color": _half_color,
        "red-cyan": _channels((0,)),
    }
)


def anaglyph(left: object, right: object, *, method: str = "dubois") -> np.ndarray:
    """Combine a stereo pair into one anaglyph for coloured glasses.

    Methods (``L``, ``R`` the views' RGB, grey views replicated to three channels), a key of
    :data:`ANAGLYPH_METHODS`; the left eye looks through the first-named filter:

    - ``"red-cyan"``: the plain colour anaglyph, ``(L_r, R_g, R_b)``; grey views give the grey
      anaglyph. ``"green-magenta"``: ``(R_r, L_g, R_b)``. ``"amber-blue"`` (ColorCode 3-D):
      ``(L_r, L_g, R_b)``.
    - ``"half-color"`` (red-cyan): ``(Y(L), R_g, R_b)`` with the Rec. 601 luma
      ``Y = 0.299 r + 0.587 g + 0.114 b`` of the left view (less retinal rivalry on saturated reds).
    - ``"dubois"`` (red-cyan, the default), ``"dubois-green-magenta"``, ``"dubois-amber-blue"``:
      Dubois's least-squares projection, ``A = M_L L + M_R R`` computed in **linear light** (sRGB
      decoded, the matrices applied, the result clipped to [0, 1] and sRGB encoded).

    Parameters
    ----------
    left, right : array_like
        Views, ``(H, W)`` or ``(H, W, 3)``, float in [0, 1] (sRGB-encoded) or uint8/uint16; same shape.
    method : str, optional
        A key of :data:`ANAGLYPH_METHODS`.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W, 3)`` in [0, 1].

    Raises
    ------
    ValueError
        On an unknown method (the message lists the valid ones), mismatched shapes, values outside
        [0, 1], NaN, empty images or an alpha channel.
    TypeError
        If a view is not numeric.

    Notes
    -----
    Dubois's red-cyan matrices (2009 set, rows = output R, G, B) are
    ``M_L = [[0.437, 0.449, 0.164], [-0.062, -0.062, -0.024], [-0.048, -0.050, -0.017]]`` and
    ``M_R = [[-0.011, -0.032, -0.007], [0.377, 0.761, 0.009], [-0.026, -0.093, 1.234]]``, for linear
    RGB (E. Dubois, "A projection method to generate anaglyph stereo images", ICASSP 2001; the
    matrices from his 2009 note "Conversion of a stereo pair to anaglyph with the least-squares
    projection method"); the green-magenta and amber-blue ones (``DUBOIS_*`` constants) from his
    anaglyph web page. The least-squares solution can leave the display gamut; the method clips
    it to [0, 1] before encoding, as Dubois does. The other methods work on encoded values.

    Examples
    --------
    >>> white, black = np.ones((1, 1, 3)), np.zeros((1, 1, 3))
    >>> anaglyph(white, black, method="red-cyan")[0, 0]
    array([1., 0., 0.], dtype=float32)
    >>> anaglyph(white, black, method="green-magenta")[0, 0]
    array([0., 1., 0.], dtype=float32)
    >>> anaglyph(white, white, method="dubois")[0, 0].round(3)  # a white pair stays white
    array([1., 1., 1.], dtype=float32)
    """
    if not isinstance(method, str) or method not in ANAGLYPH_METHODS:
        raise ValueError(f"method must be one of {', '.join(ANAGLYPH_METHODS)}; got {method!r}")
    # every method reads the views and returns a new image: float32 views are not copied
    lv, rv = as_image_pair("left", left, "right", right, copy=False)
    out = ANAGLYPH_METHODS[method](_rgb(lv), _rgb(rv))
    return np.ascontiguousarray(out, dtype=np.float32)


def _halve(view: np.ndarray, *, width: int, height: int) -> np.ndarray:
    """Area-average resampling to (height, width); INTER_AREA is a convex average."""
    out = cv2.resize(view, (width, height), interpolation=cv2.INTER_AREA)
    return np.clip(out, 0.0, 1.0)  # convex weights: only float rounding (< 1e-6) can leave [0, 1]


def side_by_side(left: object, right: object, *, half: bool = False) -> np.ndarray:
    """Place ``left`` and ``right`` next to each other (left view on the left).

    Parameters
    ----------
    left, right : array_like
        Views ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape.
    half : bool, optional
        If True, each view is first resampled to ``W // 2`` columns with area averaging
        (``cv2.INTER_AREA``), so the frame is ``(H, 2 * (W // 2))``: the size of one view for even
        ``W`` (half side-by-side, frame-compatible). Otherwise the frame is ``(H, 2 W)``.

    Returns
    -------
    numpy.ndarray
        float32 frame, grey or RGB as the views.

    Raises
    ------
    ValueError
        On mismatched shapes, bad values, or ``half=True`` with ``W < 2``.
    TypeError
        If ``half`` is not a bool.

    Examples
    --------
    >>> side_by_side(np.zeros((1, 2)), np.ones((1, 2)))
    array([[0., 0., 1., 1.]], dtype=float32)
    >>> side_by_side(np.zeros((1, 2)), np.ones((1, 2)), half=True)
    array([[0., 1.]], dtype=float32)
    """
    lv, rv = _pair(left, right)
    if not isinstance(half, bool):
        raise TypeError(f"half must be a bool; got {type(half).__name__}")
    if half:
        h, w = lv.shape[:2]
        if w < 2:
            raise ValueError(f"left must be at least 2 pixels wide for half side-by-side; got width {w}")
        lv, rv = _halve(lv, width=w // 2, height=h), _halve(rv, width=w // 2, height=h)
    return np.concatenate([lv, rv], axis=1)


def top_bottom(left: object, right: object, *, half: bool = False) -> np.ndarray:
    """Stack ``left`` above ``right``.

    Parameters
    ----------
    left, right : array_like
        Views ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape.
    half : bool, optional
        If True, each view is first resampled to ``H // 2`` rows with area averaging
        (``cv2.INTER_AREA``): the frame is ``(2 * (H // 2), W)``. Otherwise ``(2 H, W)``.

    Returns
    -------
    numpy.ndarray
        float32 frame, grey or RGB as the views.

    Raises
    ------
    ValueError
        On mismatched shapes, bad values, or ``half=True`` with ``H < 2``.
    TypeError
        If ``half`` is not a bool.

    Examples
    --------
    >>> top_bottom(np.zeros((2, 1)), np.ones((2, 1)), half=True)
    array([[0.],
           [1.]], dtype=float32)
    """
    lv, rv = _pair(left, right)
    if not isinstance(half, bool):
        raise TypeError(f"half must be a bool; got {type(half).__name__}")
    if half:
        h, w = lv.shape[:2]
        if h < 2:
            raise ValueError(f"left must be at least 2 pixels high for half top-bottom; got height {h}")
        lv, rv = _halve(lv, width=w, height=h // 2), _halve(rv, width=w, height=h // 2)
    return np.concatenate([lv, rv], axis=0)


def interleave(left: object, right: object, *, orientation: str = "rows") -> np.ndarray:
    """Alternate lines of the two views: even rows (or columns) from ``left``, odd ones from ``right``.

    The frame has the size of one view; each eye sees every other line (line-interleaved
    polarised screens use rows, some lenticular/parallax-barrier screens columns). Row 0 and
    column 0 are the first (top, left) lines.

    Parameters
    ----------
    left, right : array_like
        Views ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape.
    orientation : {"rows", "columns"}, optional
        Which lines alternate.

    Returns
    -------
    numpy.ndarray
        float32, the shape of one view.

    Raises
    ------
    ValueError
        On an unknown orientation, mismatched shapes or bad values.

    Examples
    --------
    >>> interleave(np.zeros((3, 1)), np.ones((3, 1)))[:, 0]
    array([0., 1., 0.], dtype=float32)
    """
    if orientation not in _ORIENTATIONS:
        raise ValueError(f"orientation must be one of {', '.join(_ORIENTATIONS)}; got {orientation!r}")
    lv, rv = _pair(left, right)
    out = lv.copy()
    if orientation == "rows":
        out[1::2] = rv[1::2]
    else:
        out[:, 1::2] = rv[:, 1::2]
    return out


def checkerboard(left: object, right: object) -> np.ndarray:
    """Pixel (x, y) from ``left`` where ``x + y`` is even, from ``right`` where it is odd.

    Parameters
    ----------
    left, right : array_like
        Views ``(H, W)`` or ``(H, W, 3)`` in [0, 1], same shape.

    Returns
    -------
    numpy.ndarray
        float32, the shape of one view.

    Raises
    ------
    ValueError
        On mismatched shapes or bad values.

    Examples
    --------
    >>> checkerboard(np.zeros((2, 2)), np.ones((2, 2)))
    array([[0., 1.],
           [1., 0.]], dtype=float32)
    """
    lv, rv = _pair(left, right)
    h, w = lv.shape[:2]
    odd = (np.arange(h)[:, None] + np.arange(w)[None, :]) % 2 == 1
    out = lv.copy()
    out[odd] = rv[odd]
    return out


def tile_views(views: Sequence[object], *, columns: int | None = None) -> np.ndarray:
    """Arrange N views of one shape in a grid, row by row, from the top-left cell.

    Parameters
    ----------
    views : sequence of array_like
        N >= 1 views ``(H, W)`` or ``(H, W, 3)`` in [0, 1], all the same shape.
    columns : int, optional
        Cells per row; default ``ceil(sqrt(N))``. The grid has ``ceil(N / columns)`` rows; cells
        after the last view are black (0).

    Returns
    -------
    numpy.ndarray
        float32 ``(rows * H, columns * W[, 3])``; view ``i`` is at cell ``(i // columns, i % columns)``.

    Raises
    ------
    ValueError
        If ``views`` is empty, the views differ in shape or hold bad values, or ``columns < 1``.
    TypeError
        If ``views`` is not a sequence or ``columns`` not an integer.

    Examples
    --------
    >>> tile_views([np.full((1, 1), v) for v in (0.25, 0.5, 0.75)], columns=2)
    array([[0.25, 0.5 ],
           [0.75, 0.  ]], dtype=float32)
    """
    if isinstance(views, np.ndarray | str | bytes) or not isinstance(views, Sequence):
        raise TypeError(f"views must be a sequence (list or tuple) of images; got {type(views).__name__}")
    if len(views) == 0:
        raise ValueError("views must hold at least one view; got 0")
    arrs = [as_view(f"views[{i}]", v) for i, v in enumerate(views)]
    for i, a in enumerate(arrs[1:], start=1):
        if a.shape != arrs[0].shape:
            raise ValueError(f"views[{i}] must have the shape of views[0] {arrs[0].shape}; got {a.shape}")
    n = len(arrs)
    cols = math.ceil(math.sqrt(n)) if columns is None else check_positive_int("columns", columns)
    rows = math.ceil(n / cols)
    h, w = arrs[0].shape[:2]
    out = np.zeros((rows * h, cols * w, *arrs[0].shape[2:]), dtype=np.float32)
    for i, a in enumerate(arrs):
        r, c = divmod(i, cols)
        out[r * h : (r + 1) * h, c * w : (c + 1) * w] = a
    return out


def _cross_eyed(left: object, right: object) -> np.ndarray:
    """Side by side with the views swapped (R then L), for free viewing with crossed eyes."""
    return side_by_side(right, left)


# Stereo-pair layouts, name -> function(left, right): one entry per layout; pack's dispatch, its
# error message and the CLI's --format choices all read this table.
LAYOUTS: MappingProxyType[str, Callable[[object, object], np.ndarray]] = MappingProxyType(
    {
        "anaglyph": anaglyph,
        **{f"anaglyph-{m}": functools.partial(anaglyph, method=m) for m in ANAGLYPH_METHODS if m != "dubois"},
        "checkerboard": checkerboard,
        "columns": lambda left, right: interleave(left, right, orientation="columns"),
        "cross-eyed": _cross_eyed,
        "half-sbs": lambda left, right: side_by_side(left, right, half=True),
        "half-tb": lambda left, right: top_bottom(left, right, half=True),
        "rows": interleave,
        "sbs": side_by_side,
        "tb": top_bottom,
    }
)


def pack(left: object, right: object, *, layout: str = "sbs") -> np.ndarray:
    """Pack a stereo pair into one image in the display layout ``layout``.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) arrays
        The views, one shape (float in [0, 1], uint8 or uint16).
    layout : str
        A key of :data:`LAYOUTS`: ``"anaglyph"`` (Dubois red-cyan), ``"anaglyph-METHOD"`` for the
        other :data:`ANAGLYPH_METHODS`, ``"sbs"`` / ``"half-sbs"``, ``"tb"`` / ``"half-tb"``, ``"rows"`` /
        ``"columns"`` (interleaved), ``"checkerboard"``, ``"cross-eyed"`` (R then L).

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1].

    Raises
    ------
    ValueError
        An unknown layout (the message lists the valid ones), or the errors of the layout's function.

    Examples
    --------
    >>> import numpy as np
    >>> pack(np.zeros((1, 2)), np.ones((1, 2)), layout="cross-eyed").tolist()
    [[1.0, 1.0, 0.0, 0.0]]
    """
    if not isinstance(layout, str) or layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}; got {layout!r}")
    return LAYOUTS[layout](left, right)
