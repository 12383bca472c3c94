"""Images and depth or disparity maps sent by the page (``POST /api/uploads``), kept under opaque ids.

The body is the file itself (no multipart: python-multipart is not a dependency), sent with a
Content-Type of :data:`UPLOAD_CONTENT_TYPES`; its name, if the page gives one, travels in the
``name`` query parameter and is only shown back. The type is told by content
(:func:`vergence.io.read_header`: PNG, JPEG, PFM, NPY magic bytes), never by name or Content-Type:
a JPEG sent as ``photo.png`` is stored as JPEG.

Limits: a body over :data:`MAX_UPLOAD_BYTES` is refused (413) from its Content-Length before it
is read, or as soon as the bytes read pass the limit; a header that declares more than
:data:`MAX_UPLOAD_PIXELS` pixels is refused (413) before anything is decoded. Under the limits the
file is decoded once, to refuse corrupt data (422). A ``name`` with a control character (NUL, a line
break) is refused (422) before the body is read. The last :data:`MAX_UPLOADS` uploads are kept in
the app's temporary folder; older ones are deleted.
"""

from __future__ import annotations

import hashlib
import secrets
import threading
import unicodedata
from collections import OrderedDict
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["MAX_UPLOADS", "MAX_UPLOAD_BYTES", "MAX_UPLOAD_PIXELS", "UPLOAD_CONTENT_TYPES", "Upload", "UploadError",
           "UploadStore"]  # fmt: skip

#: Largest upload, bytes (64 MiB): a 16-bit RGB PNG of 12 Mpx, or a float32 depth map of 16 Mpx.
MAX_UPLOAD_BYTES = 64 * 2**20

#: Largest declared image size, pixels (40 Mpx): 480 MB as float32 RGB once decoded, half
#: :data:`vergence.io.images.MAX_IMAGE_PIXELS`, so that two inputs of a job fit in memory.
MAX_UPLOAD_PIXELS = 40_000_000

#: Uploads kept; the oldest is deleted when one more arrives.
MAX_UPLOADS = 32

#: The Content-Types an upload may be sent with (``.npy`` as application/octet-stream); the
#: content decides the format whatever the type says.
UPLOAD_CONTENT_TYPES = ("image/png", "image/jpeg", "image/x-portable-floatmap", "application/octet-stream")

# Longest name of an upload shown back.
_MAX_NAME = 200


class UploadError(Exception):
    """An upload refused: the HTTP status (413, 415, 422) and one line saying why."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


@dataclass(frozen=True, slots=True)
class Upload:
    """One stored upload.

    Attributes
    ----------
    id : str
        Opaque; what the page passes to jobs.
    kind : str
        The format found in the content: ``"png"``, ``"jpeg"``, ``"pfm"`` or ``"npy"``.
    width, height, channels : int
        From the header (channels as stored: 4 for RGBA, 2 for grey and alpha).
    dtype : str
        Stored sample type: ``"uint8"``, ``"uint16"``, ``"float32"``, ...
    bytes : int
        Size of the file.
    sha256 : str
        Hash of the content (jobs key their cache by it).
    name : str
        The name the page gave (shown only, never a path).
    path : Path
        Server side only: the stored file.
    """

    id: str
    kind: str
    width: int
    height: int
    channels: int
    dtype: str
    bytes: int
    sha256: str
    name: str
    path: Path

    def to_dict(self) -> dict[str, Any]:
        """The upload as the API shows it: no path."""
        return {"id": self.id, "kind": self.kind, "width": self.width, "height": self.height,
                "channels": self.channels, "dtype": self.dtype, "bytes": self.bytes, "name": self.name}  # fmt: skip


def _decode(path: Path, kind: str) -> None:
    """Decode the file once to refuse corrupt data (ValueError)."""
    import numpy as np

    from vergence.io import read_image, read_pfm

    if kind == "pfm":
        read_pfm(path)  # NaN and inf allowed: depth and disparity maps mark unknown pixels so
    elif kind == "npy":
        try:
            np.load(path, mmap_mode="r", allow_pickle=False)  # checks the size against the header
        except (ValueError, OSError, EOFError) as exc:
            raise ValueError(f"not a valid .npy file ({exc})") from None
    else:
        read_image(path)


class UploadStore:
    """The uploads of one app, in ``folder``, by id.

    Parameters
    ----------
    folder : Path
        Created if missing; removed with the app's temporary folder.
    max_bytes, max_pixels, max_uploads : int
        :data:`MAX_UPLOAD_BYTES`, :data:`MAX_UPLOAD_PIXELS`, :data:`MAX_UPLOADS` by default.
    """

    def __init__(self, folder: Path, *, max_bytes: int = MAX_UPLOAD_BYTES, max_pixels: int = MAX_UPLOAD_PIXELS,
                 max_uploads: int = MAX_UPLOADS) -> None:  # fmt: skip
        self.folder = Path(folder)
        self.max_bytes, self.max_pixels, self.max_uploads = max_bytes, max_pixels, max_uploads
        self._lock = threading.Lock()
        self._uploads: OrderedDict[str, Upload] = OrderedDict()

    def get(self, upload_id: str) -> Upload:
        """The upload of an id. Raises ``KeyError`` naming the id."""
        with self._lock:
            if upload_id not in self._uploads:
                raise KeyError(f"unknown upload id {upload_id!r} (never uploaded, or deleted: "
                               f"the last {self.max_uploads} are kept)")  # fmt: skip
            return self._uploads[upload_id]

    @staticmethod
    def check_name(name: str) -> None:
        """Refuse (422) a name with a control character (NUL, a line break, ...): it is shown back and
        may become a file name, where a NUL would only fail later."""
        bad = next((c for c in name if unicodedata.category(c) == "Cc"), None)
        if bad is not None:
            raise UploadError(422, f"name must be printable text (a file name); got a control character "
                                   f"U+{ord(bad):04X} at position {name.index(bad)}")  # fmt: skip

    def check_declared(self, content_type: str | None, content_length: str | None) -> None:
        """Refuse from the headers alone: a Content-Type not in the list (415), a length over the limit (413)."""
        media = (content_type or "").split(";")[0].strip().lower()
        if media not in UPLOAD_CONTENT_TYPES:
            raise UploadError(415, f"Content-Type must be one of {', '.join(UPLOAD_CONTENT_TYPES)}; got "
                                   f"{media or 'none'!r} (send the file itself as the body)")  # fmt: skip
        if content_length is not None and content_length.isdigit() and int(content_length) > self.max_bytes:
            raise UploadError(413, f"upload too large: {int(content_length)} bytes; the limit is {self.max_bytes} "
                                   "bytes (MAX_UPLOAD_BYTES)")  # fmt: skip

    async def receive(self, chunks: AsyncIterator[bytes]) -> Path:
        """Write the body to a new file, refusing it (413) once it passes the byte limit."""
        self.folder.mkdir(parents=True, exist_ok=True)
        part = self.folder / f"{secrets.token_hex(8)}.part"
        size = 0
        try:
            with open(part, "wb") as fh:
                async for chunk in chunks:
                    size += len(chunk)
                    if size > self.max_bytes:
                        raise UploadError(413, f"upload too large: more than {self.max_bytes} bytes "
                                               "(MAX_UPLOAD_BYTES)")  # fmt: skip
                    fh.write(chunk)
        except BaseException:
            part.unlink(missing_ok=True)
            raise
        return part

    def store(self, part: Path, name: str = "") -> Upload:
        """Check a received file by content (blocking: run it off the event loop) and keep it under a new id."""
        from vergence.io import HEADER_FORMATS, read_header

        try:
            data = part.read_bytes()
            if not data:
                raise UploadError(422, "the upload is empty: send the file as the request body")
            try:
                header = read_header(data)
            except ValueError as exc:
                raise UploadError(422, f"unsupported upload: {exc}") from None
            if header.pixels > self.max_pixels:
                raise UploadError(413, f"image too large: its header declares {header.width} x {header.height} = "
                                       f"{header.pixels:,} pixels; the limit is {self.max_pixels:,} "
                                       "(MAX_UPLOAD_PIXELS)")  # fmt: skip
            if header.pixels == 0:
                raise UploadError(422, f"the {header.format.upper()} upload declares {header.width} x "
                                       f"{header.height} pixels: nothing to read")  # fmt: skip
            upload_id = secrets.token_hex(8)
            path = self.folder / f"{upload_id}{HEADER_FORMATS[header.format]}"
            part.rename(path)
            try:
                _decode(path, header.format)
            except ValueError as exc:
                path.unlink(missing_ok=True)
                message = str(exc).replace(f"cannot read {path}: ", "").replace(str(path), "the upload")
                raise UploadError(422, f"the {header.format.upper()} upload is not valid: {message}") from None
        finally:
            part.unlink(missing_ok=True)
        shown = " ".join(name.split())[:_MAX_NAME]
        upload = Upload(upload_id, header.format, header.width, header.height, header.channels, header.dtype,
                        len(data), hashlib.sha256(data).hexdigest(), shown, path)  # fmt: skip
        with self._lock:
            self._uploads[upload_id] = upload
            while len(self._uploads) > self.max_uploads:
                _, old = self._uploads.popitem(last=False)
                old.path.unlink(missing_ok=True)
        return upload
