"""What an image or map file is, from its first bytes: format, size, channels, sample type; nothing decoded.

The format is told by content (magic bytes), never by a name: PNG (``\\x89PNG``), JPEG
(``\\xff\\xd8\\xff``), PFM (``PF`` colour / ``Pf`` grey) and NumPy ``.npy`` (``\\x93NUMPY``). The
size comes from the header (PNG's IHDR chunk, JPEG's start-of-frame marker, PFM's text line, the
NPY dictionary), so a caller can refuse a file that declares too many pixels before decoding it
(a few hundred bytes can declare a 100000 x 100000 PNG). Used by the workbench's uploads
(:mod:`vergence.web.uploads`).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from vergence.io._codecs import PFM_HEADER, jpeg_size, png_size  # the readers' own header parsers

__all__ = ["HEADER_FORMATS", "ImageHeader", "read_header"]

#: The formats :func:`read_header` recognises, by name, and the file suffix each is read with.
HEADER_FORMATS = {"png": ".png", "jpeg": ".jpg", "pfm": ".pfm", "npy": ".npy"}

_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
_JPEG_MAGIC = b"\xff\xd8\xff"
_NPY_MAGIC = b"\x93NUMPY"
# PNG colour type -> channels (grey, RGB, palette, grey + alpha, RGBA); bit depth 16 -> uint16.
_PNG_CHANNELS = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}


@dataclass(frozen=True, slots=True)
class ImageHeader:
    """The header of an image or map file (:func:`read_header`).

    Attributes
    ----------
    format : str
        ``"png"``, ``"jpeg"``, ``"pfm"`` or ``"npy"`` (a key of :data:`HEADER_FORMATS`).
    width, height : int
        Size in pixels, as the header declares it.
    channels : int
        Samples per pixel as stored (a PNG palette counts 3, an alpha channel counts).
    dtype : str
        The stored sample type as a NumPy name: ``"uint8"``, ``"uint16"``, ``"float32"``, ...
    """

    format: str
    width: int
    height: int
    channels: int
    dtype: str

    @property
    def pixels(self) -> int:
        """``width * height``."""
        return self.width * self.height


def _npy_header(data: bytes) -> ImageHeader:
    stream = io.BytesIO(data)
    try:
        version = np.lib.format.read_magic(stream)
        if version not in ((1, 0), (2, 0)):
            raise ValueError(f"version {version[0]}.{version[1]} is not supported (1.0 and 2.0 are)")
        reader = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, dtype = reader(stream)
    except (ValueError, EOFError) as exc:
        raise ValueError(f"not a valid .npy header ({' '.join(str(exc).split())})") from None
    if dtype.hasobject or len(shape) not in (2, 3):
        raise ValueError(f".npy array must be numeric with shape (H, W) or (H, W, C); got {dtype} {shape}")
    return ImageHeader("npy", int(shape[1]), int(shape[0]), 1 if len(shape) == 2 else int(shape[2]), dtype.name)


def read_header(data: bytes) -> ImageHeader:
    """The format and declared size of an image or map file from its bytes, without decoding it.

    Parameters
    ----------
    data : bytes
        The file's bytes (its beginning suffices for PNG, PFM and NPY; a JPEG's start-of-frame may
        follow metadata segments, so give a JPEG whole).

    Returns
    -------
    ImageHeader

    Raises
    ------
    TypeError
        If ``data`` is not bytes.
    ValueError
        If the content is none of PNG, JPEG, PFM, NPY, or its header is truncated or malformed.

    Examples
    --------
    >>> h = read_header(b"Pf\\n640 480\\n-1.0\\n")
    >>> h.format, h.width, h.height, h.channels, h.dtype
    ('pfm', 640, 480, 1, 'float32')
    """
    if not isinstance(data, bytes | bytearray | memoryview):
        raise TypeError(f"data must be bytes; got {type(data).__name__}")
    data = bytes(data)
    if data.startswith(_PNG_MAGIC):
        size = png_size(data)
        if size is None or len(data) < 26:
            raise ValueError("PNG header is truncated (no IHDR chunk)")
        bits, colour = data[24], data[25]
        if colour not in _PNG_CHANNELS:
            raise ValueError(f"PNG colour type {colour} is not valid")
        return ImageHeader("png", *size, _PNG_CHANNELS[colour], "uint16" if bits == 16 else "uint8")
    if data.startswith(_JPEG_MAGIC):
        size = jpeg_size(data)
        if size is None:
            raise ValueError("JPEG header is truncated or malformed (no start-of-frame marker)")
        sof = _sof_components(data)
        return ImageHeader("jpeg", *size, sof, "uint8")
    if data.startswith((b"PF", b"Pf")):
        m = PFM_HEADER.match(data[:256])
        if m is None:
            raise ValueError("PFM header is malformed (expected 'PF' or 'Pf', width height, scale)")
        return ImageHeader("pfm", int(m.group(2)), int(m.group(3)), 3 if m.group(1) == b"PF" else 1, "float32")
    if data.startswith(_NPY_MAGIC):
        return _npy_header(data)
    raise ValueError(f"content is not PNG, JPEG, PFM or NPY (first bytes {data[:8]!r})")


def _sof_components(data: bytes) -> int:
    """Components of the first JPEG start-of-frame (1 grey, 3 colour, 4 CMYK); 0 if none is found."""
    i, n = 2, len(data)
    while i + 10 <= n and data[i] == 0xFF:
        marker = data[i + 1]
        if marker == 0xFF:
            i += 1
        elif marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            i += 2
        elif 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            return data[i + 9]
        else:
            i += 2 + int.from_bytes(data[i + 2 : i + 4], "big")
    return 0
