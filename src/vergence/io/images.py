"""Image files to float32 arrays and back: PNG (8/16-bit), JPEG, PGM/PPM, PFM, NPY, Radiance HDR.

Inside Vergence an image is float32 ``(H, W)`` (grey) or ``(H, W, 3)`` (RGB): in [0, 1] when it
comes from an integer file, linear and unbounded when it comes from a float file (HDR, PFM, NPY).
Integers exist only here, at the I/O edge. See ``docs/conventions.md``.

Alpha: Vergence images carry no alpha channel. A PNG whose alpha is fully opaque loses nothing
when the channel is dropped, so it is read as RGB (or grey); a PNG with any transparent pixel is
refused with a message saying so (flatten it onto a background first), never silently composited.

Size limit: a file whose header declares more than ``MAX_IMAGE_PIXELS`` (80 million) pixels is
refused from its header, before any decoding (a few hundred bytes can declare a 100000 x 100000
PNG: decoding it would need tens of gigabytes).

EXR is not supported: the OpenCV build this project depends on has no OpenEXR codec and imageio
needs an extra download (the FreeImage plug-in) to read it. Convert EXR files to PFM or NPY.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from vergence._validate import as_image
from vergence.io._codecs import (
    MAX_IMAGE_PIXELS,
    decode_hdr,
    decode_jpeg,
    decode_png,
    encode_image,
    load_npy,
    save_npy,
)
from vergence.io._files import input_path, read_bytes, suffix_of
from vergence.io._pnm import decode_pnm, encode_pnm
from vergence.io.atomic import atomic_write
from vergence.io.pfm import read_pfm, write_pfm

__all__ = ["MAX_IMAGE_PIXELS", "read_image", "write_image"]  # MAX_IMAGE_PIXELS: beside the decoders that enforce it

_JPEG_SUFFIXES = (".jpg", ".jpeg")
_PNM_SUFFIXES = (".pgm", ".ppm", ".pnm")
_INTEGER_SUFFIXES = (".png", *_JPEG_SUFFIXES, *_PNM_SUFFIXES)
_FLOAT_SUFFIXES = (".hdr", ".npy", ".pfm")
_SUPPORTED = ", ".join(sorted((*_INTEGER_SUFFIXES, *_FLOAT_SUFFIXES)))
_EXR_MESSAGE = (
    "EXR is not supported (OpenCV here is built without OpenEXR and imageio needs the FreeImage "
    "download); convert it to .pfm or .npy"
)


def _unknown_suffix(path: Path) -> ValueError:
    if path.is_dir():  # a folder has no extension to report: say what it is
        return ValueError(f"{path} is a folder; expected an image file ({_SUPPORTED})")
    if suffix_of(path) == ".exr":
        return ValueError(f"cannot handle {path}: {_EXR_MESSAGE}")
    return ValueError(
        f"cannot handle {path}: unknown image extension {path.suffix!r}; expected one of {_SUPPORTED}"
    )


def _to_unit(samples: np.ndarray, maxval: int) -> np.ndarray:
    """Integer samples to float32 in [0, 1]."""
    return samples.astype(np.float32) / np.float32(maxval)


def _image_from_array(arr: np.ndarray, path: Path) -> np.ndarray:
    """Check a decoded float or integer array and return it as a float32 Vergence image."""
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] != 3) or 0 in arr.shape:
        raise ValueError(f"cannot read {path}: image must have shape (H, W) or (H, W, 3); got {arr.shape}")
    if arr.dtype in (np.uint8, np.uint16):
        return _to_unit(arr, int(np.iinfo(arr.dtype).max))
    if not np.issubdtype(arr.dtype, np.floating):
        raise ValueError(f"cannot read {path}: image data must be float, uint8 or uint16; got {arr.dtype}")
    out = arr.astype(np.float32)
    if not np.isfinite(out).all():
        raise ValueError(
            f"cannot read {path}: image holds NaN or inf (for disparity maps use read_disparity)"
        )
    return out


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an image file as float32 ``(H, W)`` (grey) or ``(H, W, 3)`` (RGB).

    ========================  ==========================================================
    extension                 result
    ========================  ==========================================================
    .png (8/16-bit)           samples / 255 or / 65535, in [0, 1], full 16-bit precision
    .jpg, .jpeg               samples / 255
    .pgm, .ppm, .pnm          samples / maxval (binary P5/P6 or plain P2/P3)
    .hdr (Radiance RGBE)      linear radiance, unbounded, always RGB
    .pfm                      linear float as stored (rows flipped to top to bottom)
    .npy                      float as stored; uint8/uint16 scaled to [0, 1]
    ========================  ==========================================================

    Grey files stay ``(H, W)``, and so do palette PNGs whose used colours are all grey (Middlebury
    masks); an RGB file stays RGB even when its channels are equal. A fully opaque alpha channel is
    dropped; transparency is refused (see the module notes). EXIF orientation is not applied (pixels in stored order).

    Parameters
    ----------
    path : str or os.PathLike
        Image file; the extension (case-insensitive) selects the format.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)`` or ``(H, W, 3)``, finite.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        If ``path`` is missing or a directory.
    ValueError
        If the extension is unknown (or .exr), or the file is empty, truncated, corrupt, of another
        format than its extension says, transparent, holds NaN/inf, or its header declares more than
        ``MAX_IMAGE_PIXELS`` pixels; the message names the path.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "grey.png"
    >>> write_image(target, np.array([[0.0, 1.0]]), bit_depth=16)
    >>> read_image(target)
    array([[0., 1.]], dtype=float32)
    """
    p = input_path(path)
    suffix = suffix_of(p)
    if suffix == ".npy":
        return _image_from_array(load_npy(p, "image"), p)
    if suffix == ".pfm":
        return _image_from_array(read_pfm(p), p)
    if suffix not in (*_INTEGER_SUFFIXES, ".hdr"):
        raise _unknown_suffix(p)
    data = read_bytes(p)
    if suffix == ".hdr":
        return decode_hdr(data, p)
    if suffix == ".png":
        samples, maxval = decode_png(data, p)
    elif suffix in _JPEG_SUFFIXES:
        samples, maxval = decode_jpeg(data, p), 255
    else:
        samples, maxval = decode_pnm(data, p)
    return _to_unit(samples, maxval)


def _check_bit_depth(bit_depth: object) -> int:
    if isinstance(bit_depth, bool) or not isinstance(bit_depth, int | np.integer):
        raise TypeError(f"bit_depth must be an integer (8 or 16); got {type(bit_depth).__name__}")
    if bit_depth not in (8, 16):
        raise ValueError(f"bit_depth must be 8 or 16; got {bit_depth}")
    return int(bit_depth)


def _quantise(image: object, bit_depth: int, fmt: str) -> np.ndarray:
    """Float [0, 1] (or uint8/uint16) image -> rounded uint8/uint16 samples; out of range is an error."""
    arr = np.asarray(image)
    if np.issubdtype(arr.dtype, np.floating) and arr.size:
        finite = np.isfinite(arr)
        if not finite.all():
            raise ValueError(f"image must be finite to be written as {fmt}; got NaN or inf")
        lo, hi = float(arr.min()), float(arr.max())
        if lo < 0.0 or hi > 1.0:
            raise ValueError(
                f"image values must lie in [0, 1] to be written as {bit_depth}-bit {fmt} "
                f"(they are never clipped); got [{lo:g}, {hi:g}]"
            )
    unit = as_image("image", arr)
    if unit.ndim == 3 and unit.shape[2] == 1:
        unit = unit[:, :, 0]
    if unit.ndim == 3 and unit.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W) or (H, W, 3); got {arr.shape} (alpha is not written)")
    full = 255 if bit_depth == 8 else 65535
    return np.rint(unit.astype(np.float64) * full).astype(np.uint8 if bit_depth == 8 else np.uint16)


def _float_image(image: object) -> np.ndarray:
    """Validate an image for a float format: finite, (H, W) or (H, W, 3); uint8/uint16 scaled to [0, 1]."""
    arr = np.asarray(image)
    if arr.dtype in (np.uint8, np.uint16):
        arr = as_image("image", arr)
    elif arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"image must be a real-valued array; got dtype {arr.dtype}")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] != 3) or 0 in arr.shape:
        raise ValueError(f"image must have shape (H, W) or (H, W, 3) and not be empty; got {np.shape(image)}")
    out = arr.astype(np.float32)
    if not np.isfinite(out).all():
        raise ValueError("image must be finite (no NaN or inf); for disparity maps use write_disparity")
    return out


def write_image(path: str | os.PathLike[str], image: object, *, bit_depth: int = 8) -> None:
    """Write an image atomically, in the format its extension names.

    ``.png`` (8 or 16-bit), ``.pgm`` (grey) and ``.ppm`` (RGB) (8 or 16-bit), ``.jpg``/``.jpeg``
    (8-bit, quality 95): float values must lie in [0, 1] and are rounded to the nearest level
    (``round(v * 255)`` or ``round(v * 65535)``); values outside [0, 1] are an error, never clipped.
    ``.pfm``, ``.npy``: float32 as is (any finite value). ``.hdr``: Radiance RGBE, finite values >= 0,
    about 1 % relative precision (8-bit mantissa); a grey image is written as three equal channels.
    uint8/uint16 arrays are taken as [0, 1] images (divided by 255 or 65535) first.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist. An existing file is replaced (atomically).
    image : array_like
        ``(H, W)``, ``(H, W, 1)`` or ``(H, W, 3)``.
    bit_depth : {8, 16}, optional
        Bits per sample for PNG/PGM/PPM; JPEG takes 8 only. Float formats take the default only.

    Raises
    ------
    ValueError
        On an unknown extension (or .exr), a bit depth the format cannot store, out-of-range,
        NaN or inf values, negative values for .hdr, a wrong shape or an empty image.
    TypeError
        If ``image`` is not numeric or ``bit_depth`` is not an integer.
    FileNotFoundError, IsADirectoryError
        If the folder of ``path`` is missing or ``path`` is a directory.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "ramp.png"
    >>> write_image(target, np.linspace(0, 1, 6).reshape(2, 3))
    >>> (read_image(target) * 255).round()
    array([[  0.,  51., 102.],
           [153., 204., 255.]], dtype=float32)
    """
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    suffix = suffix_of(p)
    depth = _check_bit_depth(bit_depth)
    if suffix not in (*_INTEGER_SUFFIXES, *_FLOAT_SUFFIXES):
        raise _unknown_suffix(p)
    if suffix in _FLOAT_SUFFIXES:
        if depth != 8:
            raise ValueError(
                f"bit_depth applies to PNG/PGM/PPM only; {suffix} stores float32 (got bit_depth={depth})"
            )
        arr = _float_image(image)
        if suffix == ".pfm":
            write_pfm(p, arr)
            return
        if suffix == ".npy":
            save_npy(p, arr)
            return
        if float(arr.min()) < 0.0:
            raise ValueError(f"image values must be >= 0 for Radiance .hdr; got min {float(arr.min()):g}")
        rgb = np.repeat(arr[:, :, None], 3, axis=2) if arr.ndim == 2 else arr
        payload = encode_image(".hdr", np.ascontiguousarray(rgb[:, :, ::-1]), [], p)
    elif suffix in _JPEG_SUFFIXES:
        if depth != 8:
            raise ValueError(f"bit_depth must be 8 for JPEG; got {depth}")
        samples = _quantise(image, 8, "JPEG")
        payload = encode_image(".jpg", _bgr(samples), [cv2.IMWRITE_JPEG_QUALITY, 95], p)
    elif suffix == ".png":
        samples = _quantise(image, depth, "PNG")
        payload = encode_image(".png", _bgr(samples), [], p)
    else:
        samples = _quantise(image, depth, suffix[1:].upper())
        if suffix == ".pgm" and samples.ndim != 2:
            raise ValueError(f"image must be grey (H, W) for .pgm; got {np.shape(image)} (use .ppm)")
        if suffix == ".ppm" and samples.ndim != 3:
            raise ValueError(f"image must be RGB (H, W, 3) for .ppm; got {np.shape(image)} (use .pgm)")
        payload = encode_pnm(samples)
    with atomic_write(p) as tmp:
        tmp.write_bytes(payload)


def _bgr(samples: np.ndarray) -> np.ndarray:
    """RGB -> BGR for OpenCV (grey unchanged)."""
    return np.ascontiguousarray(samples[:, :, ::-1]) if samples.ndim == 3 else samples


