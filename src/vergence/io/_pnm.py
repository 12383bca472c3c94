"""Private Netpbm (PGM/PPM) codec: raw integer samples and their maxval, with strict size checks.

OpenCV reads these too, but it neither reports the maxval (needed to map samples to [0, 1]) nor
detects a truncated raster; this small codec does both. Binary ``P5``/``P6`` and plain-text
``P2``/``P3`` are read; binary ones are written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["decode_pnm", "encode_pnm"]

_CHANNELS = {b"P2": 1, b"P3": 3, b"P5": 1, b"P6": 3}


def _header_fields(data: bytes, count: int, path: Path) -> tuple[list[bytes], int]:
    """Return ``count`` whitespace-separated header tokens (comments skipped) and the raster offset."""
    fields: list[bytes] = []
    i, n = 0, len(data)
    while len(fields) < count:
        while i < n and data[i : i + 1].isspace():
            i += 1
        if i < n and data[i : i + 1] == b"#":
            while i < n and data[i : i + 1] not in (b"\n", b"\r"):
                i += 1
            continue
        start = i
        while i < n and not data[i : i + 1].isspace() and data[i : i + 1] != b"#":
            i += 1
        if start == i:
            raise ValueError(f"cannot read {path}: truncated Netpbm header")
        fields.append(data[start:i])
    if i >= n:
        raise ValueError(f"cannot read {path}: Netpbm file has a header but no pixel data")
    return fields, i + 1  # exactly one whitespace byte separates the header from the raster


def decode_pnm(data: bytes, path: Path) -> tuple[np.ndarray, int]:
    """Decode PGM/PPM bytes to raw samples ``(H, W)`` or ``(H, W, 3)`` (uint8 or uint16) and maxval."""
    magic = data[:2]
    if magic not in _CHANNELS:
        raise ValueError(f"cannot read {path}: not a PGM/PPM file (magic {magic!r}; expected P2, P3, P5 or P6)")
    channels = _CHANNELS[magic]
    fields, offset = _header_fields(data, 4, path)
    try:
        width, height, maxval = (int(f) for f in fields[1:])
    except ValueError as exc:
        raise ValueError(f"cannot read {path}: invalid Netpbm header {b' '.join(fields)!r}") from exc
    if width < 1 or height < 1 or not 1 <= maxval <= 65535:
        raise ValueError(
            f"cannot read {path}: Netpbm size must be >= 1 x 1 and maxval in [1, 65535]; "
            f"got {width} x {height}, maxval {maxval}"
        )
    count = width * height * channels
    dtype = np.uint8 if maxval < 256 else np.uint16
    if magic in (b"P5", b"P6"):
        size = count * np.dtype(dtype).itemsize
        raster = data[offset : offset + size]
        if len(raster) < size:
            raise ValueError(f"cannot read {path}: Netpbm data is truncated ({len(raster)} of {size} bytes)")
        samples = np.frombuffer(raster, dtype=">u2" if dtype == np.uint16 else np.uint8).astype(dtype)
    else:
        tokens = data[offset:].split()
        if len(tokens) < count:
            raise ValueError(f"cannot read {path}: Netpbm data is truncated ({len(tokens)} of {count} values)")
        try:
            samples = np.array([int(t) for t in tokens[:count]], dtype=np.int64)
        except ValueError as exc:
            raise ValueError(f"cannot read {path}: Netpbm plain data holds a non-integer value") from exc
        if samples.min() < 0:
            raise ValueError(f"cannot read {path}: Netpbm data holds a negative value")
        samples = np.minimum(samples, 65536).astype(np.uint32)
    if int(samples.max()) > maxval:
        raise ValueError(f"cannot read {path}: Netpbm sample {int(samples.max())} exceeds maxval {maxval}")
    arr = samples.astype(dtype).reshape(height, width, channels)
    return (arr[:, :, 0] if channels == 1 else arr), maxval


def encode_pnm(samples: np.ndarray) -> bytes:
    """Encode uint8 or uint16 samples ``(H, W)`` (PGM) or ``(H, W, 3)`` (PPM) as binary Netpbm."""
    magic = b"P5" if samples.ndim == 2 else b"P6"
    maxval = 255 if samples.dtype == np.uint8 else 65535
    header = magic + b"\n%d %d\n%d\n" % (samples.shape[1], samples.shape[0], maxval)
    raster = np.ascontiguousarray(samples, dtype=">u2" if maxval == 65535 else np.uint8).tobytes()
    return header + raster
