"""Stereo matching of a rectified pair: OpenCV StereoBM / StereoSGBM, our block matcher, refinement.

S1 §III.B: local (window) matching and global matching minimising ``E(d) = E_data + lambda E_smooth``
(S1 Eq. 8), of which semi-global matching is the standard approximation. Disparity is
``x_left - x_right`` in pixels (a left pixel x matches the right pixel x - d), NaN = unknown
(``docs/conventions.md``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from functools import partial
from types import MappingProxyType

import cv2
import numpy as np

from vergence._validate import as_image, check_bool, check_positive_int
from vergence.depth._pair import check_block_size, check_disparity_range, stereo_pair_u8
from vergence.depth.block import COSTS, match_blocks
from vergence.depth.patchmatch import PatchMatchParameters, match_patchmatch, patchmatch_stereo
from vergence.depth.planes import fill_from_planes
from vergence.depth.refine import SMOOTHING_METHODS, RefinedDisparity, confidence_map, refine_disparity
from vergence.depth.texture import LOW_TEXTURED_PERCENT, MIN_TEXTURE, MIN_TEXTURED_PERCENT, textured_pixels

__all__ = ["BOUND_PX", "BOUND_SHARE", "MATCHERS", "bound_shares", "compute_disparity", "match_bm", "match_sgbm",
           "sgbm_parameters"]

# A matched pixel within this of a search bound is at the bound (px; SGBM's quarter-pixel steps and the
# refinement's median move a saturated match by less).
BOUND_PX = 1.0
# More than this share of the matched pixels at a bound (over the columns where the whole range fits): the
# content reaches past it. Half a percent: a plane past the bound covers far more, noise at a bound far less
# (vergence.video.search uses the same figures for each frame of a clip).
BOUND_SHARE = 0.005


def sgbm_parameters(height: int, width: int, num_disparities: int, channels: int) -> dict:
    """Our StereoSGBM settings for an image size, a disparity count and a channel count.

    Block 5 px; smoothness penalties ``P1 = 8 c b^2`` and ``P2 = 16 c b^2`` (a lower P2/P1 than
    OpenCV's sample keeps depth edges, which the refinement then cleans); uniqueness 2 %, left-right
    check at 1 px, gradient pre-filter cap 15, no internal speckle filter (``remove_speckles`` runs in
    the refinement), 3-way mode (both cores).

    Block, P2 and uniqueness were chosen on the training scenes of ``benchmarks/stereo_split.json``
    only (``benchmarks/stereo_sgbm_grid.py``: mean % bad of the whole default pipeline over a grid of
    P2 in 8-128 c b^2, uniqueness 0-15 %, block 3-7): block 5 and uniqueness 2 % took the training
    mean from 13.14 to 12.27 (block 3 and 10 % before; higher P2 was worse on every textureless scene).
    On the held-out scenes, measured once afterwards, the mean went from 13.63 to 13.13. Scored again
    after the views were matched on mirrored margins (:func:`_mirror_padded`) and the median resized,
    these settings still led the grid on the training scenes (7.46 %; P2 8, 24 or 32 c b^2, uniqueness
    0 or 5 %, block 3 or 7: 7.47-8.38 %). OpenCV's other modes scored lower training means (``MODE_HH``,
    8 paths: 7.17 %; ``MODE_HH4``: 6.63 %), nearly all of it on midd1 (24.25 -> 18.67 % with HH4) and
    bowling1, with dolls and aloe worse; the 3-way mode stays because HH4 took 3.7 times raw 3-way
    SGBM at 1080p (the bound is 3x) and was worse there (3.05 % against 2.71 % bad on the scene of
    ``benchmarks/matching.py``). (``benchmarks/stereo_sgbm_grid.py 16:2:5:hh 16:2:5:hh4``.)
    """
    for name, v in (("height", height), ("width", width), ("num_disparities", num_disparities), ("channels", channels)):
        check_positive_int(name, v)
    return {
        "numDisparities": int(num_disparities),
        **_block_and_penalties(5, channels),
        "uniquenessRatio": 2,
        "disp12MaxDiff": 1,
        "preFilterCap": 15,
        "speckleWindowSize": 0,
        "speckleRange": 0,
        "mode": cv2.StereoSGBM_MODE_SGBM_3WAY,
    }


def _block_and_penalties(block: int, channels: int) -> dict:
    """SGBM block size and its smoothness penalties ``P1 = 8 c b^2``, ``P2 = 16 c b^2``."""
    return {"blockSize": block, "P1": 8 * channels * block * block, "P2": 16 * channels * block * block}


def _mirror_padded(a: np.ndarray, b: np.ndarray, lo: int, count: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Both views mirrored past their left and right sides, so that OpenCV matches every column.

    OpenCV's StereoBM and StereoSGBM give no answer in the ``max(lo + count, 0)`` leftmost columns
    (and the ``max(-lo, 0)`` rightmost ones), where part of the search range falls outside the other
    view: at 128 disparities that is a fifth of a 640-px image, left to the filling. Matched on
    mirrored margins (``BORDER_REFLECT_101``) those columns find the disparities that stay inside.
    Mirroring was chosen over repeated or black margins on the training scenes of
    ``benchmarks/stereo_split.json`` (``benchmarks/stereo_border.py``).

    Returns the padded views and the widths added on the left and on the right.
    """
    pad_left, pad_right = max(lo + count, 0), max(-lo, 0)
    if pad_left or pad_right:
        a = cv2.copyMakeBorder(a, 0, 0, pad_left, pad_right, cv2.BORDER_REFLECT_101)
        b = cv2.copyMakeBorder(b, 0, 0, pad_left, pad_right, cv2.BORDER_REFLECT_101)
    return a, b, pad_left, pad_right


def _cropped(raw: np.ndarray, pad_left: int, pad_right: int, lo: int, hi: int, block: int) -> np.ndarray:
    """The answer of the padded views on the original columns, NaN where the match touches a margin.

    A match in the mirrored margin is not a match (the true one is outside the other view), and one
    whose window reaches into it is biased by the mirrored content: pixels whose match lies less than
    ``block // 2 + 1`` px from the other view's edge are left unknown, as OpenCV leaves its blind band,
    for the filling. (Without that, the refinement spread a 1 px bias of the edge's last pixels over
    the whole band on the slanted background of ``benchmarks/matching.py``; dropping them instead,
    the band scores as it did with no margins, 0 % bad against 3.6 %: the bad share of columns 10-127
    of that scene, measured once by a script not kept; the whole scene's 2.71 % is the benchmark's
    own figure.) The rule applies on the side
    where the search range reaches past the other view: the left for a positive ``hi``, the right for
    a negative ``lo``.

    StereoSGBM's last ``block // 2`` columns are wrong besides (disparity 0 on nearly every row of the
    training scenes: its window there is cut by the image's edge); those of the padded views that are
    original columns are left unknown too. (A mirrored margin on the right for them instead changed
    the matching up to 80 px from the edge on tsukuba's weakly textured right side, 2.35 -> 2.85 % bad:
    measured once with ``_mirror_padded`` padding the right side too, by a script not kept.)
    """
    tail = max(block // 2 - pad_right, 0)
    raw = raw[:, pad_left : raw.shape[1] - pad_right]
    d = _from_fixed(raw, lo, hi)
    if tail:
        d[:, raw.shape[1] - tail :] = np.nan
    x_right = np.arange(d.shape[1], dtype=np.float32) - d
    edge = block // 2 + 1
    if hi > 0:
        d[x_right < edge] = np.nan
    if lo < 0:
        d[x_right > d.shape[1] - 1 - edge] = np.nan
    return d


def _matched_whole_width(compute: Callable[[np.ndarray, np.ndarray], np.ndarray], a: np.ndarray, b: np.ndarray,
                         lo: int, hi: int, count: int, block: int) -> np.ndarray:
    """Disparity of every column of the 8-bit pair by an OpenCV matcher ``compute(left, right)`` (fixed point)
    with matching windows of ``block`` px: matched on mirrored margins (:func:`_mirror_padded`), cut back
    (:func:`_cropped`)."""
    pa, pb, pad_left, pad_right = _mirror_padded(a, b, lo, count)
    return _cropped(compute(pa, pb), pad_left, pad_right, lo, hi, block)


def _from_fixed(raw: np.ndarray, lo: int, hi: int) -> np.ndarray:
    d = raw.astype(np.float32) / np.float32(16.0)  # OpenCV: 4 fractional bits
    d[(raw < lo * 16) | (d > hi)] = np.nan  # invalid marker (min - 1) * 16, or beyond the asked range
    return d


def match_sgbm(
    left: object, right: object, *, max_disparity: int, min_disparity: int = 0, block_size: int | None = None
) -> np.ndarray:
    """Semi-global matching (OpenCV StereoSGBM, 3-way) with :func:`sgbm_parameters`; sub-pixel.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) images
        Rectified pair in [0, 1] (or 8/16-bit), same size, both grey or both colour.
    max_disparity, min_disparity : int
        Disparity search range, pixels (searched in blocks of 16 from ``min_disparity``).
    block_size : int, optional
        Odd matching block size; default from :func:`sgbm_parameters`.

    Returns
    -------
    (H, W) float32
        Disparity at 1/16 px, NaN where SGBM found no unique, left-right consistent match or the
        value lies outside ``[min_disparity, max_disparity]``.
    """
    a, b = stereo_pair_u8(left, right)
    lo, hi, count = check_disparity_range(max_disparity, min_disparity, a.shape[1])
    channels = 1 if a.ndim == 2 else 3
    prm = sgbm_parameters(a.shape[0], a.shape[1], count, channels)
    prm.update(_block_and_penalties(check_block_size(block_size, prm["blockSize"], shape=a.shape), channels))
    matcher = cv2.StereoSGBM_create(minDisparity=lo, **prm)
    return _matched_whole_width(matcher.compute, a, b, lo, hi, count, prm["blockSize"])


def match_bm(
    left: object, right: object, *, max_disparity: int, min_disparity: int = 0, block_size: int | None = None
) -> np.ndarray:
    """Local block matching (OpenCV StereoBM: SAD on the x-Sobel-filtered grey images); sub-pixel.

    Colour pairs are converted to grey. Default block 9 px up to 1000 px, 15 beyond; texture
    threshold 10, uniqueness 15 %, left-right check at 1 px. Returns NaN where no match is accepted.
    """
    a, b = stereo_pair_u8(left, right)
    if a.ndim == 3:
        a, b = cv2.cvtColor(a, cv2.COLOR_RGB2GRAY), cv2.cvtColor(b, cv2.COLOR_RGB2GRAY)
    lo, hi, count = check_disparity_range(max_disparity, min_disparity, a.shape[1])
    bs = check_block_size(block_size, 9 if max(a.shape) <= 1000 else 15, shape=a.shape, minimum=5,
                          matcher="StereoBM")
    bm = cv2.StereoBM_create(numDisparities=count, blockSize=bs)
    bm.setMinDisparity(lo)
    bm.setPreFilterCap(31)
    bm.setTextureThreshold(10)
    bm.setUniquenessRatio(15)
    bm.setDisp12MaxDiff(1)
    return _matched_whole_width(bm.compute, a, b, lo, hi, count, bs)


MATCHERS: MappingProxyType[str, Callable[..., np.ndarray]] = MappingProxyType(dict(sorted(
    {"bm": match_bm, "sgbm": match_sgbm, "patchmatch": match_patchmatch,
     **{c: partial(match_blocks, cost=c) for c in COSTS}}.items())))
"""Matcher name -> ``matcher(left, right, *, max_disparity, min_disparity, block_size)`` giving raw
disparity (NaN = no answer); read-only: OpenCV's ``bm`` and ``sgbm``, PatchMatch Stereo
(:func:`~vergence.depth.patchmatch.match_patchmatch`, Bleyer et al. 2011), and one window matcher per
:data:`~vergence.depth.block.COSTS` entry. :func:`compute_disparity`, its error message and the CLI's
``--method`` choices all read this table."""


def compute_disparity(
    left: object,
    right: object,
    *,
    max_disparity: int,
    min_disparity: int = 0,
    method: str = "sgbm",
    smoothing: str = "median",
    keep_invalid: bool = False,
    block_size: int | None = None,
    valid: object = None,
    patchmatch: PatchMatchParameters | None = None,
    planes: bool = False,
) -> RefinedDisparity:
    """Disparity of a rectified pair: matching then refinement (our default pipeline).

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) images
        Rectified pair, same size, both grey or both colour.
    max_disparity, min_disparity : int
        Disparity search range, pixels; it must fit inside the image width.
    method : str
        A name of :data:`MATCHERS`: ``sgbm``: :func:`match_sgbm` (default); ``bm``: :func:`match_bm`;
        ``patchmatch``: :func:`~vergence.depth.patchmatch.patchmatch_stereo` (PatchMatch Stereo, slanted
        windows, with its own refinement; slower, see the README's table for when it pays);
        ``sad``/``ssd``/``ncc``: :func:`~vergence.depth.block.match_blocks` with that window cost.
    smoothing : str
        A name of :data:`~vergence.depth.refine.SMOOTHING_METHODS` (``median``, ``none``):
        the edge-aware smoothing of :func:`~vergence.depth.refine.refine_disparity`. With
        ``patchmatch`` the refinement is PatchMatch Stereo's own (left-right check, plane-based filling,
        then, with ``median``, the weighted median of the filled pixels: PMS §3.4), which scored better on
        the training scenes than our refinement of its left-right checked map (``benchmarks/stereo_table.py --tune``).
    keep_invalid : bool
        Keep NaN where the matcher gave no answer; by default every pixel gets a disparity
        (background extrapolation, S1 §III.B).
    block_size : int, optional
        Matching window, pixels (odd); default from the image size.
    valid : (H, W) bool array, optional
        The pixels of ``left`` that hold image content, e.g. :attr:`~vergence.depth.RectifiedPair.left_valid`
        (rectification leaves black borders). Outside it the disparity is NaN whatever ``keep_invalid``:
        nothing is matched there, no pixel is filled from there, and the texture share counts inside only.
    patchmatch : PatchMatchParameters, optional
        Settings of ``method="patchmatch"`` (default ``PatchMatchParameters()``; ``block_size`` replaces
        its window); refused with another method.
    planes : bool
        Fill the unmatched pixels of planar colour segments from their robust disparity planes before the
        background filling (:func:`~vergence.depth.planes.fill_from_planes`; ``refine_disparity(planes=True)``):
        for large weakly textured surfaces; off by default (see the README's table for the figures).
        With ``patchmatch`` the pixels that failed its left-right check take the segment planes instead of
        PMS's own filling and weighted median where a segment has one (training mean 13.97 -> 13.39 % bad,
        ``benchmarks/stereo_planes.py --patchmatch``).

    Returns
    -------
    RefinedDisparity
        ``disparity`` (float32, pixels), ``confidence`` in [0, 1], the ``matched`` mask, the
        ``textured_percent`` of the left image and ``warnings`` (a pair with less than
        :data:`~vergence.depth.texture.LOW_TEXTURED_PERCENT` % of textured pixels; matches piled up at a
        bound of the search: :func:`bound_shares` above :data:`BOUND_SHARE`, the content reaching past it).

    Raises
    ------
    ValueError
        On pairs of different sizes, grey/colour mixes, a disparity range wider than the image, an
        unknown method (the message lists them), an image with less than
        :data:`~vergence.depth.texture.MIN_TEXTURED_PERCENT` % of textured pixels (checked before
        matching: a uniform pair has no disparity to find), or when no pixel could be matched.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> right = rng.random((40, 80)).astype(np.float32)
    >>> left = np.roll(right, 5, axis=1)  # a left pixel x sees the right pixel x - 5
    >>> res = compute_disparity(left, right, max_disparity=15)
    >>> float(np.median(res.disparity[:, 20:]))
    5.0
    """
    if not isinstance(method, str) or method not in MATCHERS:
        raise ValueError(f"method must be one of {', '.join(MATCHERS)}; got {method!r}")
    keep_invalid = check_bool("keep_invalid", keep_invalid)
    planes = check_bool("planes", planes)
    if patchmatch is not None:
        if method != "patchmatch":
            raise ValueError(f"patchmatch parameters apply to method 'patchmatch' only; got method {method!r}")
        if not isinstance(patchmatch, PatchMatchParameters):
            raise TypeError(f"patchmatch must be a PatchMatchParameters; got {type(patchmatch).__name__}")
    a, _ = stereo_pair_u8(left, right)  # the arguments' errors before the texture's
    check_disparity_range(max_disparity, min_disparity, a.shape[1])
    check_block_size(block_size, 1, shape=a.shape)
    inside = _valid_mask(valid, a.shape[:2])
    textured = {}
    for name, image in (("left", left), ("right", right)):
        texture = textured_pixels(as_image(name, image))
        textured[name] = 100.0 * float(texture[inside].mean() if name == "left" else texture.mean())
        if textured[name] < MIN_TEXTURED_PERCENT:
            raise ValueError(
                f"{name} has no texture to match: {textured[name]:.2g} % of its pixels have a local contrast of "
                f"at least {MIN_TEXTURE * 255:g}/255 (MIN_TEXTURE); at least {MIN_TEXTURED_PERCENT:g} % "
                "(MIN_TEXTURED_PERCENT) are needed: a uniform image has no disparity to find"
            )
    warnings = tuple(
        f"only {textured[name]:.1f} % of {name} has texture to match (below {LOW_TEXTURED_PERCENT:g} %): "
        "the disparity elsewhere is extrapolated from it, not measured"
        for name in ("left", "right") if textured[name] < LOW_TEXTURED_PERCENT
    )
    if method == "patchmatch":
        result = _patchmatch_refined(left, right, max_disparity, min_disparity, smoothing, keep_invalid, block_size,
                                     patchmatch, inside, planes)
        warnings += _bound_warnings(np.where(result.matched, result.disparity, np.nan), min_disparity, max_disparity)
    else:
        raw = MATCHERS[method](left, right, max_disparity=max_disparity, min_disparity=min_disparity,
                               block_size=block_size)
        raw[~inside] = np.nan
        warnings += _bound_warnings(raw, min_disparity, max_disparity)
        result = refine_disparity(raw, as_image("left", left), smoothing=smoothing, keep_invalid=keep_invalid,
                                  planes=planes)
    disparity, confidence = result.disparity.copy(), result.confidence.copy()
    disparity[~inside] = np.nan
    confidence[~inside] = 0.0
    return dataclasses.replace(result, disparity=disparity, confidence=confidence, matched=result.matched & inside,
                               textured_percent=textured["left"], warnings=warnings)


def bound_shares(disparity: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """Shares of the matched pixels (finite ``disparity``) within :data:`BOUND_PX` of the search bounds ``lo``
    and ``hi``, over the columns where every disparity of ``[lo, hi]`` has its match inside the other view
    (``[max(hi, 0), width + min(lo, 0))``; elsewhere a matcher's edge values say nothing of the bounds).

    A matcher cannot return a disparity outside its search: content beyond a bound is matched at (or near)
    it, so a share there well above that of its neighbours says the range was too narrow.

    Examples
    --------
    >>> d = np.full((2, 8), 3.0); d[0, 4:] = 6.0
    >>> bound_shares(d, 0, 6)
    (0.0, 0.5)
    """
    d = np.asarray(disparity, dtype=np.float64)
    first, end = max(int(np.ceil(hi)), 0), d.shape[1] + min(int(np.floor(lo)), 0)
    known = d[:, first:end] if end > first else d
    known = known[np.isfinite(known)]
    if known.size == 0:
        return 0.0, 0.0
    return float(np.mean(known <= lo + BOUND_PX)), float(np.mean(known >= hi - BOUND_PX))


def _bound_warnings(raw: np.ndarray, lo: int, hi: int) -> tuple[str, ...]:
    """A warning per search bound the matches pile up at (:func:`bound_shares` above :data:`BOUND_SHARE`)."""
    shares = bound_shares(raw, lo, hi)
    return tuple(f"{100 * share:.1f} % of the matched pixels sit at the search's {side} bound ({bound} px): their "
                 "disparity is that bound, not a measure (the content may lie past it: search a wider range to know)"
                 for side, bound, share in (("lower", lo, shares[0]), ("upper", hi, shares[1])) if share > BOUND_SHARE)


def _patchmatch_refined(left: object, right: object, max_disparity: int, min_disparity: int, smoothing: str,
                        keep_invalid: bool, block_size: int | None, parameters: PatchMatchParameters | None,
                        inside: np.ndarray, planes: bool) -> RefinedDisparity:
    """PatchMatch Stereo with its own refinement (PMS §3.4); ``smoothing="none"`` stops before its median;
    ``planes``: the segment planes fill the pixels that failed its left-right check, where they can."""
    if not isinstance(smoothing, str) or smoothing not in SMOOTHING_METHODS:
        raise ValueError(f"smoothing must be one of {', '.join(SMOOTHING_METHODS)}; got {smoothing!r}")
    prm = PatchMatchParameters() if parameters is None else parameters
    if block_size is not None:
        a, _ = stereo_pair_u8(left, right)
        window = check_block_size(block_size, prm.window, shape=a.shape, minimum=3, matcher="patchmatch")
        prm = dataclasses.replace(prm, window=window, step=min(prm.step, window // 2))
    res = patchmatch_stereo(left, right, max_disparity=max_disparity, min_disparity=min_disparity, parameters=prm)
    matched = np.isfinite(res.raw) & inside
    if not matched.any():
        raise ValueError("the matcher found no reliable disparity; check the disparity range and the image pair")
    out = (res.disparity if smoothing == "median" else res.filled).copy()
    support = matched
    if planes:
        raw = np.where(inside, res.raw, np.nan).astype(np.float32)
        planar = fill_from_planes(raw, as_image("left", left))
        support = np.isfinite(planar)
        out[support & ~matched] = planar[support & ~matched]
    if keep_invalid:
        out[~support] = np.nan
    return RefinedDisparity(out, confidence_map(res.raw, out), matched)


def _valid_mask(valid: object, hw: tuple[int, int]) -> np.ndarray:
    """``valid`` as a boolean (H, W) mask selecting at least one pixel; all True when None."""
    if valid is None:
        return np.ones(hw, bool)
    m = np.asarray(valid)
    if m.dtype != bool:
        raise TypeError(f"valid must be a boolean array; got dtype {m.dtype}")
    if m.shape != hw:
        raise ValueError(f"valid must have the shape (H, W) of left {hw}; got {m.shape}")
    if not m.any():
        raise ValueError("valid must select at least one pixel of left; got an all-False mask")
    return m
