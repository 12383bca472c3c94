"""Middlebury stereo evaluation: bad-pixel percentage and RMS error over the standard regions.

S1 §V.A Eq. (9)-(10); Scharstein & Szeliski 2002 and their StereoMatcher code (``StcEvaluate.cpp``).
Regions come from the official Middlebury masks when given (``nonocc.png``, ``all.png``,
``disc.png``: 255 = evaluate) or are computed from the ground truth. Disparity is
``x_left - x_right`` in pixels, NaN = unknown (``docs/conventions.md``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from vergence._validate import as_float_array, as_image, check_bool, check_finite, check_positive, check_same_hw

__all__ = [
    "RegionScore",
    "evaluate_disparity",
    "mask_agreement",
    "middlebury_regions",
    "nonoccluded_mask",
    "read_middlebury_masks",
]

# StereoMatcher's evaluation constants (Scharstein & Szeliski 2002, ``StcEvaluate.cpp``).
EVAL_BAD_THRESH = 1.0
EVAL_TEXTURELESS_WIDTH = 3
EVAL_TEXTURELESS_THRESH = 4.0
EVAL_DISP_GAP = 2.0
EVAL_DISCONT_WIDTH = 9
EVAL_IGNORE_BORDER = 10
EVAL_DISP_THRESH = 1.0
_REGION_ORDER = ("nonocc", "all", "disc", "textureless")


@dataclass(frozen=True, slots=True)
class RegionScore:
    """Scores over one region: percentage of bad pixels (S1 Eq. 9), RMS error (Eq. 10), pixel count."""

    bad: float
    rms: float
    pixels: int

    def to_dict(self) -> dict:
        """``{"bad": %, "rms": px, "pixels": n}``."""
        return {"bad": self.bad, "rms": self.rms, "pixels": self.pixels}


def _truth(name: str, value: object) -> np.ndarray:
    t = as_float_array(name, value, allow_nan=True, dtype=np.float64)
    if t.ndim != 2 or 0 in t.shape:
        raise ValueError(f"{name} must have shape (H, W); got {t.shape}")
    return t


def _border_mask(shape: tuple[int, int], border: int) -> np.ndarray:
    m = np.zeros(shape, bool)
    h, w = shape
    if h > 2 * border and w > 2 * border:
        m[border:h - border, border:w - border] = True
    return m


def nonoccluded_mask(truth: object, truth_right: object, *, tolerance: float = EVAL_DISP_THRESH) -> np.ndarray:
    """Pixels of the left view that the right view sees, from the two ground-truth disparities.

    The Middlebury rule (Scharstein & Szeliski 2002; the 2005/2006 scenes: Scharstein & Pal 2007,
    whose view1/view5 truths ``disp1.png``/``disp5.png`` give it directly): a left pixel x of known
    disparity d is non-occluded when its match ``x_r = x - round(d)`` lies in the image and the right
    truth there is known and not nearer: ``d_R(x_r) <= d + tolerance``.

    Parameters
    ----------
    truth, truth_right : (H, W) arrays
        Left and right ground-truth disparity, pixels, NaN = unknown (``read_disparity`` turns the PNG's
        0 into NaN). The right one follows the same sign convention (its pixel ``x_r`` sees ``x_r + d_R``).
    tolerance : float
        Disparity margin, pixels (1 in the Middlebury evaluation).

    Returns
    -------
    (H, W) bool
        True where the left pixel is visible in the right view. Unknown left truth is False, and so is
        a match on an unknown right truth: nothing says the pixel is visible there (0.2-0.3 % of the
        pixels of the 2005/2006 half-size scenes).

    Examples
    --------
    >>> left = np.array([[1.0, 1.0, 3.0, 3.0, 1.0, 1.0]])  # a near patch (d = 3) on a far wall (d = 1)
    >>> right = np.array([[3.0, 1.0, 1.0, 1.0, 1.0, 1.0]])  # the right view sees the patch at x = -1, 0
    >>> nonoccluded_mask(left, right).tolist()  # x = 0, 2 leave the image; the wall at x = 1 hides behind the patch
    [[False, False, False, True, True, True]]
    """
    t = _truth("truth", truth)
    tr = _truth("truth_right", truth_right)
    check_same_hw("truth_right", tr, "truth", t)
    tol = check_finite("tolerance", tolerance)
    if tol < 0.0:
        raise ValueError(f"tolerance must be a finite number of pixels >= 0; got {tolerance!r}")
    h, w = t.shape
    known = np.isfinite(t)
    xr = np.arange(w)[None, :] - np.rint(np.where(known, t, 0.0))  # float: a huge disparity leaves the image, uncast
    inside = known & (xr >= 0) & (xr < w)
    dr = np.take_along_axis(tr, np.where(inside, xr, 0).astype(np.int64), axis=1)
    with np.errstate(invalid="ignore"):
        return inside & np.isfinite(dr) & (dr <= t + tol)


def _occluded(d_left: np.ndarray, d_right: np.ndarray | None, thresh: float) -> np.ndarray:
    """Known left pixels that are not :func:`nonoccluded_mask`; without ``d_right`` a z-buffered forward
    warp of ``d_left`` stands in for it (the nearest, largest, disparity wins)."""
    h, w = d_left.shape
    known = np.isfinite(d_left)
    if d_right is None:
        ys, xs = np.nonzero(known)
        xr_float = xs - np.rint(d_left[known])
        ok = (xr_float >= 0) & (xr_float < w)
        xr = xr_float[ok].astype(np.int64)
        d_right = np.full((h, w), -np.inf)
        np.maximum.at(d_right, (ys[ok], xr), d_left[ys[ok], xs[ok]])
        d_right[np.isneginf(d_right)] = np.nan  # no left pixel lands there: nothing nearer covers it
        # a left pixel always lands on its own warp, so an empty target is never a match
    return known & ~nonoccluded_mask(d_left, d_right, tolerance=thresh)


def _discontinuities(d: np.ndarray, border: int, gap: float, width: int, occluded: np.ndarray | None) -> np.ndarray:
    """StereoMatcher ``ComputeDisparityDiscont``: jumps >= gap (both pixels) and, when given, occluded
    pixels (its ``mark_occlusions`` switch), away from the border; then a width x width dilation."""
    h, w = d.shape
    bor = border + 1
    jump = np.zeros((h, w), bool)
    if occluded is not None:
        jump[bor:h - bor - 1, bor:w - bor - 1] = occluded[bor:h - bor - 1, bor:w - bor - 1]
    if h > 2 * bor + 1 and w > 2 * bor + 1:
        ys, xs = slice(bor, h - bor), slice(bor, w - bor - 1)  # StcEvaluate: y in [bor, h-bor), x in [bor, w-bor-1)
        ys1, xs1 = slice(bor + 1, h - bor + 1), slice(bor + 1, w - bor)
        with np.errstate(invalid="ignore"):
            hj = np.abs(d[ys, xs] - d[ys, xs1]) >= gap
            vj = np.abs(d[ys, xs] - d[ys1, xs]) >= gap
        jump[ys, xs] |= hj | vj
        jump[ys, xs1] |= hj
        jump[ys1, xs] |= vj
    return cv2.dilate(jump.astype(np.uint8), np.ones((width, width), np.uint8)) > 0


def _rms(err: np.ndarray) -> float:
    """``sqrt(mean(err^2))`` (S1 Eq. 10) scaled by the largest ``|err|``, so that no square overflows."""
    peak = float(np.abs(err).max())
    if peak == 0.0:
        return 0.0
    return peak * float(np.sqrt(np.mean((err / peak) ** 2)))


def _textureless(image: np.ndarray, width: int, thresh: float) -> np.ndarray:
    """StereoMatcher ``ComputeTextureless``: 3x3 mean of the squared horizontal difference < thresh^2."""
    img = image.astype(np.float64) * 255.0
    if img.ndim == 2:
        img = img[:, :, None]
    diff2 = np.mean((img[:, :-1] - img[:, 1:]) ** 2, axis=2)  # one-sided, averaged over channels
    sq = np.zeros(img.shape[:2])
    sq[:, 1:] = diff2  # the difference with the left neighbour (0 at the first column)...
    sq[:, :-1] = np.maximum(sq[:, :-1], diff2)  # ...or with the right one, whichever is larger
    box = cv2.blur(sq, (width, width), borderType=cv2.BORDER_REPLICATE)
    return box < thresh * thresh


def middlebury_regions(
    truth: object,
    *,
    image: object = None,
    truth_right: object = None,
    border: int = EVAL_IGNORE_BORDER,
    disc_includes_occlusions: bool = True,
) -> dict[str, np.ndarray]:
    """Compute the Middlebury evaluation regions from ground truth (Scharstein & Szeliski 2002).

    Parameters
    ----------
    truth : (H, W) array
        Left ground-truth disparity, pixels, NaN = unknown (never evaluated).
    image : (H, W) or (H, W, C) array, optional
        Left image in [0, 1]; needed for the textureless region.
    truth_right : (H, W) array, optional
        Right ground-truth disparity for the occlusion test; without it a z-buffered forward
        warp of ``truth`` stands in for it.
    border : int
        Pixels ignored at each image edge (StereoMatcher's ``eval_ignore_border``).
    disc_includes_occlusions : bool
        Also grow the discontinuity region from occluded pixels, as the official Middlebury v2
        ``disc.png`` masks do (agreement 99.97 % on tsukuba, 99.7 % on venus against 98.9 % and
        98.4 % without); False gives StereoMatcher's jumps-only region.

    Returns
    -------
    dict
        Boolean masks ``"nonocc"``, ``"all"``, ``"disc"`` (near discontinuities, within nonocc) and,
        with ``image``, ``"textureless"`` (within nonocc). All exclude the border and unknown truth.

    Notes
    -----
    nonocc: with ``x_r = x - round(d_L)``, occluded if ``x_r < 0`` or ``d_R(x_r) > d_L(x) + 1``.
    disc: ``|d(x) - d(x+1)| >= 2`` or ``|d(x) - d(x, y+1)| >= 2`` (both pixels marked, away from the
    border; plus occluded pixels by default), dilated by a 9x9 box. textureless: squared horizontal
    intensity difference (max of the two one-sided ones, mean over channels) averaged over 3x3,
    below ``4^2``.
    """
    t = _truth("truth", truth)
    if isinstance(border, bool) or not isinstance(border, int | np.integer) or border < 0:
        raise ValueError(f"border must be an integer >= 0; got {border!r}")
    disc_includes_occlusions = check_bool("disc_includes_occlusions", disc_includes_occlusions)
    tr = None
    if truth_right is not None:
        tr = _truth("truth_right", truth_right)
        check_same_hw("truth_right", tr, "truth", t)
    base = _border_mask(t.shape, int(border)) & np.isfinite(t)
    occluded = _occluded(t, tr, EVAL_DISP_THRESH) & np.isfinite(t)
    nonocc = base & ~occluded
    seeds = occluded if disc_includes_occlusions else None
    regions = {
        "nonocc": nonocc,
        "all": base,
        "disc": nonocc & _discontinuities(t, int(border), EVAL_DISP_GAP, EVAL_DISCONT_WIDTH, seeds),
    }
    if image is not None:
        img = as_image("image", image)
        check_same_hw("image", img, "truth", t)
        regions["textureless"] = nonocc & _textureless(img, EVAL_TEXTURELESS_WIDTH, EVAL_TEXTURELESS_THRESH)
    return regions


def read_middlebury_masks(folder: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read the official Middlebury v2 masks found in ``folder`` (``nonocc.png``, ``all.png``, ``disc.png``).

    Only value 255 marks an evaluated pixel (in ``disc.png``, 128 = other non-occluded pixels).

    Raises
    ------
    ValueError
        If the folder holds none of the three masks, or a mask is not single-valued per pixel.
    """
    from vergence.io import read_image  # io sits beside depth in the core layer; imported lazily

    p = Path(folder)
    if not p.is_dir():
        raise FileNotFoundError(f"masks folder {p} does not exist")
    masks = {}
    for name in ("nonocc", "all", "disc"):
        f = p / f"{name}.png"
        if f.is_file():
            img = read_image(f)
            if img.ndim == 3:
                if not (img == img[:, :, :1]).all():
                    raise ValueError(f"mask {f} must be grey (equal channels)")
                img = img[:, :, 0]
            masks[name] = np.rint(img * 255.0) == 255
    if not masks:
        raise ValueError(f"no Middlebury masks (nonocc.png, all.png, disc.png) in {p}")
    return masks


def mask_agreement(mask: object, reference: object) -> float:
    """Percentage of pixels on which two boolean masks agree.

    Parameters
    ----------
    mask, reference : (H, W) bool arrays
        Same shape, not empty (an agreement over no pixel is undefined).

    Returns
    -------
    float
        ``100 * mean(mask == reference)``, in [0, 100].

    Raises
    ------
    TypeError
        If either is not a boolean array (a 0/255 image must be thresholded by the caller).
    ValueError
        If either is not 2-D, is empty, or the shapes differ.

    Examples
    --------
    >>> mask_agreement(np.array([[True, False]]), np.array([[True, True]]))
    50.0
    """
    arrays = {"mask": np.asarray(mask), "reference": np.asarray(reference)}
    for name, arr in arrays.items():
        if arr.dtype != bool:
            raise TypeError(f"{name} must be a boolean array; got dtype {arr.dtype}")
        if arr.ndim != 2 or arr.size == 0:
            raise ValueError(f"{name} must be a non-empty (H, W) array; got shape {arr.shape}")
    a, b = arrays["mask"], arrays["reference"]
    if a.shape != b.shape:
        raise ValueError(f"mask must have the shape of reference {b.shape}; got {a.shape}")
    return float(100.0 * np.mean(a == b))


def evaluate_disparity(
    estimate: object,
    truth: object,
    *,
    masks: dict[str, object] | None = None,
    image: object = None,
    truth_right: object = None,
    threshold: float = EVAL_BAD_THRESH,
    border: int | None = None,
) -> dict[str, RegionScore]:
    """Bad-pixel percentage and RMS error of a disparity map over the Middlebury regions.

    Parameters
    ----------
    estimate : (H, W) array
        Computed disparity, pixels. NaN is an unknown estimate: it counts as bad, and as disparity 0
        in the RMS (as in the Middlebury tables, whose PNG files store unknown as 0;
        :func:`vergence.io.read_disparity` turns that 0 into NaN). 0 itself is a real disparity.
    truth : (H, W) array
        Ground-truth disparity, NaN = unknown (never evaluated).
    masks : dict, optional
        Official region masks (e.g. :func:`read_middlebury_masks`); they replace the computed
        regions. Pixels of unknown truth are still dropped.
    image, truth_right : optional
        For the computed regions (see :func:`middlebury_regions`).
    threshold : float
        A pixel is bad when ``|estimate - truth| > threshold`` (strictly), S1 Eq. (9).
    border : int, optional
        Pixels ignored at each edge by the computed regions (default ``EVAL_IGNORE_BORDER`` = 10, as
        StereoMatcher; 0 for the Middlebury 2005/2006 scenes, whose left edge the nonocc rule already
        drops). Not with ``masks``.

    Returns
    -------
    dict of RegionScore
        Keyed ``"nonocc"``, ``"all"``, ``"disc"`` (and ``"textureless"`` when computed with an image);
        a region without any pixel of known truth (e.g. no discontinuity) is left out.

    Notes
    -----
    ``B = 100/N sum [|d_C - d_T| > delta_d]`` (S1 Eq. 9), ``R = sqrt(1/N sum (d_C - d_T)^2)`` (Eq. 10),
    over the N pixels of each region.

    Examples
    --------
    >>> t = np.full((30, 30), 5.0)
    >>> e = t.copy(); e[15, 15] = 7.0
    >>> s = evaluate_disparity(e, t)["all"]
    >>> s.pixels, round(s.bad, 2), round(s.rms, 4)
    (100, 1.0, 0.2)
    """
    t = _truth("truth", truth)
    e = as_float_array("estimate", estimate, allow_nan=True, dtype=np.float64)
    if e.shape != t.shape:
        raise ValueError(f"estimate must have shape {t.shape} matching truth; got {e.shape}")
    thr = check_positive("threshold", threshold)
    if masks is None:
        regions = middlebury_regions(t, image=image, truth_right=truth_right,
                                     border=EVAL_IGNORE_BORDER if border is None else border)
    else:
        if image is not None or truth_right is not None or border is not None:
            raise ValueError("masks replace the computed regions: pass image, truth_right and border only "
                             "without masks")
        if not isinstance(masks, dict) or not masks:
            raise TypeError("masks must be a non-empty dict of region name -> boolean (H, W) mask")
        regions = {}
        for name, m in masks.items():
            arr = np.asarray(m)
            if arr.shape != t.shape or arr.dtype != bool:
                raise ValueError(f"mask {name!r} must be a boolean array of shape {t.shape}; got {arr.dtype} {arr.shape}")
            regions[name] = arr & np.isfinite(t)
    unknown = np.isnan(e)  # NaN = unknown (docs/conventions.md); 0 is a real disparity
    with np.errstate(over="ignore"):
        err = np.where(unknown, -t, e - t)  # an unknown estimate scores as disparity 0
    if np.isinf(err).any():
        raise ValueError("estimate - truth must be a finite number of pixels; got a difference past the float range")
    bad = unknown | (np.abs(err) > thr)
    scores = {}
    for name in sorted(regions, key=lambda k: (_REGION_ORDER.index(k) if k in _REGION_ORDER else 99, k)):
        m = regions[name]
        n = int(m.sum())
        if n == 0:
            continue  # e.g. no discontinuity in the truth: the region has no score
        scores[name] = RegionScore(
            bad=float(100.0 * bad[m].mean()),  # Eq. (9)
            rms=_rms(err[m]),  # Eq. (10)
            pixels=n,
        )
    if not scores:
        raise ValueError("no pixel with known truth in any region; nothing to evaluate")
    return scores
