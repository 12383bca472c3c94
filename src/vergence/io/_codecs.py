"""Bytes to raw samples and back for PNG, JPEG, Radiance HDR and NPY: internal API of :mod:`vergence.io`.

The image, disparity and header readers share these codecs (:mod:`~vergence.io.images`,
:mod:`~vergence.io.disparity`, :mod:`~vergence.io.header`), as they share :mod:`~vergence.io._pnm`
for Netpbm; users call :func:`vergence.io.read_image` and friends. Every decoder refuses a file whose
header declares more than :data:`MAX_IMAGE_PIXELS` pixels before decoding it, and reports a corrupt
file once, by a ValueError naming the path and the codec's reason (not also on stderr).
"""

from __future__ import annotations

import io
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, UnidentifiedImageError

from vergence.io._files import check_not_empty
from vergence.io.atomic import atomic_write

__all__ = [
    "MAX_IMAGE_PIXELS",
    "PFM_HEADER",
    "decode_hdr",
    "decode_jpeg",
    "decode_png",
    "encode_image",
    "hdr_size",
    "jpeg_size",
    "load_npy",
    "png_size",
    "save_npy",
]

#: Largest image (width x height) that ``read_image`` decodes: 80 Mpx, i.e. 960 MB as float32 RGB.
#: Below Pillow's own decompression-bomb threshold (89.5 Mpx), so Pillow never warns first.
MAX_IMAGE_PIXELS = 80_000_000

# Header of a PFM file: type, width, height, scale, then exactly one whitespace byte before the raster.
# One pattern for the reader (vergence.io.pfm) and the header sniffer (vergence.io.header).
PFM_HEADER = re.compile(rb"\A(P[Ff])\s+(\d+)\s+(\d+)\s+([-+]?[0-9.]+(?:[eE][-+]?\d+)?)\s")

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _drop_opaque_alpha(arr: np.ndarray, path: Path) -> np.ndarray:
    """Return the colour channels of a 4-channel array whose alpha is fully opaque; refuse otherwise."""
    full = np.iinfo(arr.dtype).max
    transparent = int(np.count_nonzero(arr[:, :, 3] != full))
    if transparent:
        raise ValueError(
            f"cannot read {path}: it has an alpha channel with {transparent} non-opaque pixels; "
            "Vergence images have no alpha, flatten it onto a background first"
        )
    return arr[:, :, :3]


def png_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from the IHDR chunk, or None when the header is too short to say."""
    if len(data) < 24 or data[12:16] != b"IHDR":
        return None
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def hdr_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from the Radiance resolution line (``-Y H +X W`` and its variants), or None."""
    m = re.search(rb"\n\n([-+][XY]) (\d+) ([-+][XY]) (\d+)\n", data[:65536])
    if m is None:
        return None
    first, second = int(m.group(2)), int(m.group(4))
    return (second, first) if m.group(1)[1:] == b"Y" else (first, second)


def jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from the first start-of-frame marker, or None when none is found."""
    i, n = 2, len(data)
    while i + 9 <= n:
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:  # markers without a length
            i += 2
            continue
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            return int.from_bytes(data[i + 7 : i + 9], "big"), int.from_bytes(data[i + 5 : i + 7], "big")
        i += 2 + int.from_bytes(data[i + 2 : i + 4], "big")
    return None


_HEADER_SIZES = {".png": png_size, ".hdr": hdr_size, ".jpg": jpeg_size, ".jpeg": jpeg_size}


def _check_declared_size(data: bytes, suffix: str, path: Path) -> None:
    """Refuse a file whose header declares more than ``MAX_IMAGE_PIXELS`` pixels, before decoding."""
    size = _HEADER_SIZES[suffix](data)
    if size is not None and size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise ValueError(
            f"cannot read {path}: its header declares {size[0]} x {size[1]} = {size[0] * size[1]:,} pixels; "
            f"the limit is {MAX_IMAGE_PIXELS:,}"
        )


@contextmanager
def _codec_messages() -> Iterator[list[str]]:
    """Collect what C codecs print on file descriptor 2 (libpng's "libpng error: IDAT: CRC error")
    instead of letting it reach the user's terminal; the lines are available after the block.

    OpenCV's own logging is silenced too. If descriptor 2 cannot be duplicated, nothing is collected.
    """
    lines: list[str] = []
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        saved = None
    try:
        if saved is None:
            yield lines
            return
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 2)
            try:
                yield lines
            finally:
                os.dup2(saved, 2)
                os.close(saved)
                sink.seek(0)
                text = sink.read().decode("utf-8", errors="replace")
                lines.extend(ln.removeprefix("libpng error: ").removeprefix("libpng warning: ")
                             for ln in text.splitlines() if ln.strip())  # fmt: skip
    finally:
        cv2.utils.logging.setLogLevel(level)


def _imdecode(data: bytes, path: Path, what: str) -> np.ndarray:
    """``cv2.imdecode``; a corrupt file is reported once, by our ValueError naming the codec's reason,
    not also by libpng's or OpenCV's own lines on stderr."""
    with _codec_messages() as messages:
        arr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if arr is None:
        reason = f" ({'; '.join(messages)})" if messages else ""
        raise ValueError(f"cannot read {path}: {what} data is corrupt or truncated{reason}")
    return arr


def decode_png(data: bytes, path: Path) -> tuple[np.ndarray, int]:
    """Raw PNG samples ``(H, W)`` or ``(H, W, 3)`` RGB (uint8 or uint16) and their maxval."""
    if not data.startswith(_PNG_SIGNATURE):
        raise ValueError(f"cannot read {path}: not a PNG file (bad signature)")
    if data.rfind(b"IEND") < 0:
        raise ValueError(f"cannot read {path}: PNG file is truncated (no IEND chunk)")
    _check_declared_size(data, ".png", path)
    colour_type = data[25] if len(data) > 25 else -1
    arr = _imdecode(data, path, "PNG")
    if arr.ndim == 3 and arr.shape[2] == 4:
        arr = _drop_opaque_alpha(arr, path)
    if arr.ndim == 3:
        # grey (+alpha) PNGs come back from OpenCV with the grey replicated, and so do palette PNGs
        # whose colours are all grey (Middlebury masks): keep one channel
        grey_palette = colour_type == 3 and bool((arr == arr[:, :, :1]).all())
        arr = arr[:, :, 0] if colour_type in (0, 4) or grey_palette else arr[:, :, ::-1]  # BGR -> RGB
    return np.ascontiguousarray(arr), int(np.iinfo(arr.dtype).max)


def decode_jpeg(data: bytes, path: Path) -> np.ndarray:
    """8-bit JPEG samples ``(H, W)`` or ``(H, W, 3)`` RGB; truncation is detected by Pillow."""
    _check_declared_size(data, ".jpg", path)
    try:
        with Image.open(io.BytesIO(data), formats=["JPEG"]) as im:
            im.load()
            if im.mode not in ("L", "RGB"):
                raise ValueError(f"cannot read {path}: JPEG mode {im.mode} is not supported; expected grey or RGB")
            return np.asarray(im, dtype=np.uint8).copy()
    except UnidentifiedImageError as exc:
        raise ValueError(f"cannot read {path}: not a JPEG file") from exc
    except OSError as exc:  # Pillow reports truncated or broken data as OSError
        raise ValueError(f"cannot read {path}: JPEG data is corrupt or truncated ({exc})") from exc


def decode_hdr(data: bytes, path: Path) -> np.ndarray:
    """Radiance RGBE to linear float32 RGB ``(H, W, 3)``."""
    if not data.startswith((b"#?RADIANCE", b"#?RGBE")):
        raise ValueError(f"cannot read {path}: not a Radiance HDR file (expected a '#?RADIANCE' header)")
    _check_declared_size(data, ".hdr", path)
    arr = _imdecode(data, path, "Radiance HDR")
    if arr.ndim != 3 or arr.dtype != np.float32:
        raise ValueError(f"cannot read {path}: Radiance HDR data is corrupt or truncated")
    return np.ascontiguousarray(arr[:, :, ::-1])  # BGR -> RGB


def encode_image(ext: str, arr: np.ndarray, params: list[int], path: Path) -> bytes:
    """``cv2.imencode`` of ``arr`` (BGR order) as ``ext``; a refusal is a ValueError naming the path and
    the codec's reason."""
    try:
        with _codec_messages() as messages:
            ok, buf = cv2.imencode(ext, arr, params)
    except cv2.error:
        ok = False
    if not ok:
        reason = f" ({'; '.join(messages)})" if messages else ""
        raise ValueError(f"cannot write {path}: the {ext} encoder refused a {arr.shape[1]} x {arr.shape[0]} image{reason}")
    return buf.tobytes()


def load_npy(path: Path, what: str) -> np.ndarray:
    """Load a ``.npy`` array without pickles; errors name the path."""
    check_not_empty(path)
    try:
        fh = open(path, "rb")  # noqa: SIM115 - closed below; open errors stay OSError
    except OSError as exc:
        raise OSError(f"cannot read {path}: {exc.strerror or exc}") from exc
    with fh:
        try:
            return np.load(fh, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise ValueError(f"cannot read {path}: not a valid {what} .npy file ({exc})") from exc


def save_npy(path: Path, array: np.ndarray) -> None:
    """Write ``array`` as ``.npy`` (no pickles) atomically."""
    with atomic_write(path) as tmp, open(tmp, "wb") as fh:
        np.save(fh, array, allow_pickle=False)
