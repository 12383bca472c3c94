"""Portable Float Map (PFM) reader and writer.

Format (as used by Middlebury 2014 and most HDR tools): a text header of three whitespace-separated
fields, ``PF`` (colour, 3 channels) or ``Pf`` (grey), ``width height``, and a scale whose *sign*
gives the byte order (negative: little endian, positive: big endian; the magnitude is a unit
that readers ignore), one whitespace character, then ``width * height * channels`` float32 values,
rows stored **bottom to top**. This module returns and takes rows top to bottom, like every image
in Vergence.
"""

from __future__ import annotations

import os

import numpy as np

from vergence.io._codecs import PFM_HEADER
from vergence.io._files import input_path, read_bytes
from vergence.io.atomic import atomic_write

__all__ = ["read_pfm", "write_pfm"]

def read_pfm(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a PFM file as float32, rows top to bottom: ``(H, W)`` for ``Pf``, ``(H, W, 3)`` for ``PF``.

    Values are returned as stored (inf and NaN included; Middlebury 2014 marks unknown disparity
    with inf). The byte order follows the sign of the scale field; its magnitude is ignored.

    Parameters
    ----------
    path : str or os.PathLike
        PFM file.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)`` or ``(H, W, 3)``, a new array.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        If ``path`` is missing or a directory.
    ValueError
        If the file is empty, has no valid PFM header, a zero scale or size, or the wrong amount
        of data (truncated or with trailing bytes).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "d.pfm"
    >>> write_pfm(target, np.array([[1.0, 2.0], [3.0, np.inf]], np.float32))
    >>> read_pfm(target)
    array([[ 1.,  2.],
           [ 3., inf]], dtype=float32)
    """
    p = input_path(path)
    data = read_bytes(p)
    m = PFM_HEADER.match(data[:256])
    if m is None:
        raise ValueError(f"cannot read {p}: not a PFM file (expected a 'PF' or 'Pf' header)")
    channels = 3 if m.group(1) == b"PF" else 1
    width, height = int(m.group(2)), int(m.group(3))
    try:
        scale = float(m.group(4))
    except ValueError as exc:
        raise ValueError(f"cannot read {p}: invalid PFM scale {m.group(4).decode()!r}") from exc
    if width == 0 or height == 0:
        raise ValueError(f"cannot read {p}: PFM size must be at least 1 x 1; got {width} x {height}")
    if scale == 0.0:
        raise ValueError(f"cannot read {p}: PFM scale must be non-zero (its sign gives the byte order)")
    expected = width * height * channels * 4
    raster = data[m.end() :]
    if len(raster) != expected:
        what = "truncated" if len(raster) < expected else "longer than its header says"
        raise ValueError(
            f"cannot read {p}: PFM data is {what} ({len(raster)} bytes for {width} x {height} x "
            f"{channels} float32 = {expected} bytes)"
        )
    dtype = np.dtype("<f4") if scale < 0 else np.dtype(">f4")
    arr = np.frombuffer(raster, dtype=dtype).reshape(height, width, channels)
    arr = arr[::-1].astype(np.float32)  # bottom-to-top rows -> top-to-bottom; native byte order
    return arr[:, :, 0] if channels == 1 else arr


def write_pfm(path: str | os.PathLike[str], image: object) -> None:
    """Write a float image as little-endian PFM (scale -1), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist. An existing file is replaced.
    image : array_like
        Real ``(H, W)``, ``(H, W, 1)`` (written as grey ``Pf``) or ``(H, W, 3)`` (colour ``PF``),
        rows top to bottom. Stored as float32; inf and NaN are written as they are.

    Raises
    ------
    TypeError
        If ``image`` is not real-valued.
    ValueError
        If ``image`` has another shape or is empty.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "g.pfm"
    >>> write_pfm(target, np.zeros((2, 3)))
    >>> target.read_bytes()[:12]
    b'Pf\\n3 2\\n-1.0\\n'
    """
    arr = np.asarray(image)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"image must be a real-valued array; got dtype {arr.dtype}")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] != 3):
        raise ValueError(f"image must have shape (H, W), (H, W, 1) or (H, W, 3) for PFM; got {np.shape(image)}")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValueError(f"image must not be empty; got shape {np.shape(image)}")
    kind = b"PF" if arr.ndim == 3 else b"Pf"
    header = kind + b"\n%d %d\n-1.0\n" % (arr.shape[1], arr.shape[0])
    raster = np.ascontiguousarray(arr[::-1], dtype="<f4").tobytes()
    with atomic_write(path) as tmp:
        tmp.write_bytes(header + raster)
