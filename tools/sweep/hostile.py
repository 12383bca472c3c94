"""Hostile values and files: what a fuzzer or a careless user hands to Vergence.

Every value carries a name (used in case ids and in the summary) and whether it is *clearly* invalid
(``strict``): a command that exits 0 on a strict value (``nan`` for a length, a folder for an image) is
suspicious whatever its output, while a merely extreme value (``1e20``, ``-1``) is judged by its output.
"""

from __future__ import annotations

import json
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Hostile:
    """One hostile command-line value: ``text`` is what the user typed."""

    name: str
    text: str
    strict: bool


# Values for a float option. 5e-324 is the smallest subnormal (divisions by it overflow); 1e308 is near
# the largest double (products overflow); 1e20 is past any physical length in metres.
FLOAT_VALUES = (
    Hostile("negative", "-1", False),
    Hostile("zero", "0", False),
    Hostile("subnormal", "5e-324", False),
    Hostile("huge", "1e308", False),
    Hostile("large", "1e20", False),
    Hostile("nan", "nan", True),
    Hostile("inf", "inf", False),
    Hostile("neg_inf", "-inf", True),
    Hostile("empty", "", True),
    Hostile("word", "abc", True),
)

# Values for an integer option: 2**31 and 2**63 overflow C ints and int64; 10**30 overflows everything.
INT_VALUES = (
    Hostile("negative", "-1", False),
    Hostile("zero", "0", False),
    Hostile("large", "1000001", False),
    Hostile("int32_overflow", str(2**31), False),
    Hostile("int64_overflow", str(2**63), False),
    Hostile("huge", str(10**30), False),
    Hostile("fraction", "1.5", True),
    Hostile("empty", "", True),
    Hostile("word", "abc", True),
)

STR_VALUES = (
    Hostile("empty", "", True),
    Hostile("unknown", "no-such-choice", True),
    Hostile("long", "x" * 5000, True),
    Hostile("number", "1e308", True),
)

# Output locations: the case folder's ``{existing_dir}`` is an existing folder, ``{input}`` an input
# file of the case (writing there would overwrite an input).
OUTPUT_VALUES = (
    Hostile("existing_folder", "{case}/existing_dir", False),
    Hostile("missing_parent", "{case}/no/such/parent/out.png", False),
    Hostile("unknown_extension", "{case}/out.xyz", False),
    Hostile("empty", "", True),
    Hostile("input_file", "{input}", False),
)


# --- hostile files: name -> (file name, writer); writers take the path and write the bytes ---------


def _png_chunk(tag: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF)


def png_bytes(width: int, height: int, *, color_type: int = 0, data: bytes | None = None) -> bytes:
    """A PNG whose header declares ``width x height`` (8-bit; the pixel data may not match)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)
    channels = {0: 1, 2: 3, 4: 2, 6: 4}[color_type]
    raw = data if data is not None else b"".join(b"\0" + bytes(width * channels) for _ in range(height))
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IDAT", zlib.compress(raw))
            + _png_chunk(b"IEND", b""))


def _jpeg_bytes(width: int, height: int) -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.new("L", (8, 8)).save(buf, format="JPEG")
    data = bytearray(buf.getvalue())
    sof = data.find(b"\xff\xc0")
    data[sof + 5 : sof + 9] = height.to_bytes(2, "big") + width.to_bytes(2, "big")
    return bytes(data)


def _textured_png(width: int, height: int, channels: int) -> bytes:
    rng = np.random.default_rng(7)
    pixels = rng.integers(0, 256, (height, width, channels), dtype=np.uint8)
    color_type = {1: 0, 2: 4, 3: 2, 4: 6}[channels]
    raw = b"".join(b"\0" + pixels[y].tobytes() for y in range(height))
    return png_bytes(width, height, color_type=color_type, data=raw)


def _pfm(width: int, height: int, channels: int, *, truncate: bool = False) -> bytes:
    values = np.full((height, width, channels), 2.0, "<f4")
    body = values.tobytes()
    header = f"{'PF' if channels == 3 else 'Pf'}\n{width} {height}\n-1.0\n".encode()
    return header + (body[: len(body) // 3] if truncate else body)


def _nested_json(depth: int) -> bytes:
    return ("[" * depth + "]" * depth).encode()


HUGE_SIDE = 100_000  # 10^10 declared pixels: past any pixel limit, a few bytes on disk
JPEG_HUGE_SIDE = 60_000  # 3.6 Gpx, JPEG's 16-bit size fields allow at most 65535
NESTING = 100_000  # past Python's recursion limit (1000) by two orders of magnitude


def hostile_files() -> dict[str, bytes | None]:
    """Name -> bytes of each hostile input file (``None``: the path does not exist or is a folder)."""
    good = _textured_png(16, 12, 3)
    return {
        "missing": None,
        "folder": None,
        "empty_file": b"",
        "truncated_png": good[: len(good) // 2],
        "huge_png": png_bytes(HUGE_SIDE, HUGE_SIDE, data=b"\0" * 64),
        "huge_jpeg": _jpeg_bytes(JPEG_HUGE_SIDE, JPEG_HUGE_SIDE),
        "huge_hdr": f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {HUGE_SIDE} +X {HUGE_SIDE}\n".encode() + b"\0" * 64,
        "truncated_jpeg": _jpeg_bytes(8, 8)[:-40],
        "truncated_pfm": _pfm(16, 12, 1, truncate=True),
        "pfm_3_channels": _pfm(16, 12, 3),
        "png_4_channels": _textured_png(16, 12, 4),
        "png_2_channels": _textured_png(16, 12, 2),
        "png_1x1": _textured_png(1, 1, 3),
        "png_black": png_bytes(16, 12, color_type=2),
        "nested_json": _nested_json(NESTING),
        "bom_json": b"\xef\xbb\xbf" + json.dumps({"camera": {}}).encode(),
        "garbage": bytes(range(256)) * 4,
    }


# Which hostile files fit which input: an image gets image hostiles; a depth/disparity map also gets
# the wrong-channel PFM; cameras and scenes get text hostiles.
FILE_SUFFIX = {
    "truncated_png": ".png", "huge_png": ".png", "huge_jpeg": ".jpg", "huge_hdr": ".hdr", "truncated_jpeg": ".jpg",
    "truncated_pfm": ".pfm", "pfm_3_channels": ".pfm", "png_4_channels": ".png", "png_2_channels": ".png",
    "png_1x1": ".png", "png_black": ".png", "nested_json": ".json", "bom_json": ".json", "garbage": ".png",
    "empty_file": ".png", "missing": ".png", "folder": "",
}
# All but "png_black": a black image is valid input (it is hostile only where texture is needed).
STRICT_FILES = frozenset(FILE_SUFFIX) - {"png_black", "png_1x1", "png_4_channels", "png_2_channels"}


def write_hostile_files(folder: Path) -> dict[str, Path]:
    """Write every hostile file into ``folder`` and return name -> path."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, data in hostile_files().items():
        path = folder / f"{name}{FILE_SUFFIX[name]}"
        if name == "folder":
            path.mkdir(exist_ok=True)
        elif data is not None:
            path.write_bytes(data)
        paths[name] = path
    return paths
