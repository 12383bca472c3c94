"""Disparity maps on disk: Middlebury integer PNG/PGM with a scale factor, PFM and NPY floats.

In memory a disparity map is float32 ``(H, W)`` in pixels, ``x_left - x_right``, with **NaN for
unknown** (``docs/conventions.md``). On disk each format has its own marker for unknown:

=========  ===================================  ========================================
format     stored value                         unknown
=========  ===================================  ========================================
.png/.pgm  ``round(disparity * scale)``, uint   0 (Middlebury v2 and 2001; KITTI uses
                                                scale 256)
.pfm       float32 disparity                    inf (Middlebury 2014); NaN too
.npy       float32 disparity                    NaN; inf too
=========  ===================================  ========================================

Reading maps each format's marker to NaN. In the float formats 0 is a real disparity (a point at
infinity for a parallel rig), as everywhere in Vergence ("NaN, never 0", docs/conventions.md); only
the integer formats use 0 for unknown. Writing maps NaN to 0 in PNG/PGM, to inf in PFM, and keeps NaN
in NPY; a finite disparity that an integer format would store as its unknown marker (0 after scaling
and rounding) is an error rather than a silent loss.
"""

from __future__ import annotations

import os
from pathlib import Path
from types import MappingProxyType

import numpy as np

from vergence._validate import check_positive
from vergence.io._codecs import decode_png, encode_image, load_npy, save_npy
from vergence.io._files import input_path, read_bytes, suffix_of
from vergence.io._pnm import decode_pnm, encode_pnm
from vergence.io.atomic import atomic_write
from vergence.io.pfm import read_pfm, write_pfm

__all__ = ["read_disparity", "stores_integers", "write_disparity"]

# Disparity file extension -> whether the format stores integers (and so needs a scale, with 0 = unknown).
# The one place this rule is written; everything else asks :func:`stores_integers`.
_STORES_INTEGERS = MappingProxyType({".npy": False, ".pfm": False, ".pgm": True, ".png": True})
_INTEGER_SUFFIXES = tuple(k for k, v in _STORES_INTEGERS.items() if v)
_FLOAT_SUFFIXES = tuple(k for k, v in _STORES_INTEGERS.items() if not v)
_SUPPORTED = ", ".join((*_FLOAT_SUFFIXES, *_INTEGER_SUFFIXES))


def _unknown_suffix(path: Path) -> ValueError:
    if path.is_dir():  # a folder has no extension to report: say what it is
        return ValueError(f"{path} is a folder; expected a disparity file ({_SUPPORTED})")
    return ValueError(
        f"cannot handle {path}: unknown disparity extension {path.suffix!r}; expected one of {_SUPPORTED}"
    )


def stores_integers(path: str | os.PathLike[str]) -> bool:
    """Whether the disparity format of ``path`` (by its extension) stores integers.

    ``.png``/``.pgm`` store ``round(disparity * scale)`` with 0 for unknown, so reading and writing
    them needs a ``scale``; ``.pfm``/``.npy`` store float disparity and refuse one.

    Raises
    ------
    ValueError
        If the extension is not a disparity format (the message lists them).

    Examples
    --------
    >>> stores_integers("disp.png"), stores_integers("disp.pfm")
    (True, False)
    """
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    suffix = suffix_of(p)
    if suffix not in _STORES_INTEGERS:
        raise _unknown_suffix(p)
    return _STORES_INTEGERS[suffix]


def _check_scale(scale: object, suffix: str, path: Path) -> float | None:
    """Scale is required for integer formats and refused for float ones."""
    if _STORES_INTEGERS[suffix]:
        if scale is None:
            raise ValueError(
                f"scale is required for a {suffix} disparity map ({path}): disparity = value / scale "
                "(Middlebury: 16 for tsukuba, 8 for venus; KITTI: 256)"
            )
        return check_positive("scale", scale)
    if scale is not None:
        raise ValueError(
            f"scale applies to .png/.pgm disparity maps only; {path} stores float disparity (got {scale})"
        )
    return None


def read_disparity(path: str | os.PathLike[str], *, scale: float | None = None) -> np.ndarray:
    """Read a disparity map as float32 ``(H, W)`` pixels with NaN for unknown.

    ``.png``/``.pgm`` (8 or 16-bit, grey): ``value / scale``, value 0 -> NaN (Middlebury). A
    colour file whose channels are all equal (a grey palette or RGB PNG, as Middlebury's tsukuba
    ground truth) is read as its one channel; a file with distinct channels is refused.
    ``.pfm``/``.npy``: float as stored, +-inf -> NaN (Middlebury 2014 marks unknown with inf); 0 is a
    real disparity there.

    Parameters
    ----------
    path : str or os.PathLike
        Disparity file; the extension selects the format.
    scale : float, optional
        Required for ``.png``/``.pgm`` (stored value = disparity * scale; e.g. 16 for Middlebury
        tsukuba, 8 for venus); must be omitted for ``.pfm``/``.npy``.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)``, NaN where unknown.

    Raises
    ------
    ValueError
        If ``scale`` is missing for an integer format, given for a float one, or not > 0; if the
        extension is unknown; if the file is empty, truncated, corrupt or with distinct colour channels.
    FileNotFoundError, IsADirectoryError
        If ``path`` is missing or a directory.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "disp.png"
    >>> write_disparity(target, np.array([[1.5, np.nan]]), scale=16)
    >>> read_disparity(target, scale=16)
    array([[1.5, nan]], dtype=float32)
    """
    p = input_path(path)
    stores_integers(p)
    suffix = suffix_of(p)
    factor = _check_scale(scale, suffix, p)
    if suffix == ".pfm":
        arr = read_pfm(p)
    elif suffix == ".npy":
        arr = load_npy(p, "disparity")
    else:
        data = read_bytes(p)
        arr, _ = decode_png(data, p) if suffix == ".png" else decode_pnm(data, p)
    if arr.ndim == 3 and (arr.shape[2] == 1 or (arr == arr[:, :, :1]).all()):
        arr = arr[:, :, 0]  # grey stored as palette or RGB with equal channels (Middlebury tsukuba)
    if arr.ndim != 2 or 0 in arr.shape:
        raise ValueError(f"cannot read {p}: a disparity map must be single-channel (H, W); got shape {arr.shape}")
    if factor is not None:
        out = arr.astype(np.float32) / np.float32(factor)
        out[arr == 0] = np.nan
        return out
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)) or arr.dtype == bool:
        raise ValueError(f"cannot read {p}: disparity data must be numeric; got {arr.dtype}")
    out = arr.astype(np.float32)
    out[np.isinf(out)] = np.nan
    return out


def write_disparity(
    path: str | os.PathLike[str], disparity: object, *, scale: float | None = None
) -> None:
    """Write a float disparity map ``(H, W)`` (NaN = unknown) atomically.

    ``.png``/``.pgm``: 16-bit ``round(disparity * scale)``, NaN -> 0; every known value must round
    into [1, 65535] (0 would read back as unknown; negative values cannot be stored).
    ``.pfm``: float32 little endian, NaN -> inf (Middlebury 2014). ``.npy``: float32, NaN kept.
    Known disparities of exactly 0 are kept in the float formats; the integer ones cannot tell them
    from unknown, so there they are refused.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist. An existing file is replaced.
    disparity : array_like
        Real ``(H, W)`` disparity in pixels; NaN marks unknown; inf is refused.
    scale : float, optional
        Required for ``.png``/``.pgm``, refused for ``.pfm``/``.npy``.

    Raises
    ------
    ValueError
        On a wrong shape, inf, a scaled value that does not fit 16 bits (or rounds to 0),
        a missing or superfluous ``scale``, or an unknown extension.
    TypeError
        If ``disparity`` is not numeric.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "disp.pfm"
    >>> write_disparity(target, np.array([[2.25, np.nan]]))
    >>> read_pfm(target)
    array([[2.25,  inf]], dtype=float32)
    """
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    stores_integers(p)
    suffix = suffix_of(p)
    factor = _check_scale(scale, suffix, p)
    arr = np.asarray(disparity)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"disparity must be a real-valued array; got dtype {arr.dtype}")
    if arr.ndim != 2 or 0 in arr.shape:
        raise ValueError(f"disparity must have shape (H, W) and not be empty; got {arr.shape}")
    d = arr.astype(np.float64)
    if np.isinf(d).any():
        raise ValueError("disparity must not contain inf (mark unknown pixels with NaN)")
    known = ~np.isnan(d)
    if factor is not None:
        scaled = np.rint(d[known] * factor)
        if scaled.size and (scaled.min() < 1 or scaled.max() > 65535):
            raise ValueError(
                f"disparity * scale must round into [1, 65535] for 16-bit {suffix} (0 means unknown there; "
                f"use .pfm or .npy for zero or negative disparities); got "
                f"[{scaled.min():g}, {scaled.max():g}] with scale {factor:g}"
            )
        samples = np.zeros(d.shape, np.uint16)
        samples[known] = scaled.astype(np.uint16)
        if suffix == ".png":
            payload = encode_image(".png", samples, [], p)
        else:
            payload = encode_pnm(samples)
        with atomic_write(p) as tmp:
            tmp.write_bytes(payload)
        return
    out = d.astype(np.float32)
    if suffix == ".pfm":
        write_pfm(p, np.where(known, out, np.float32(np.inf)))
        return
    save_npy(p, out)
