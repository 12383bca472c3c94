"""Shared fixtures: the real data in ../shared/data (tests skip with a reason when it is missing)."""

from __future__ import annotations

import os
from pathlib import Path

# Before anything imports Numba's threading layer: OpenMP threads that spin while they wait steal the
# two shared cores the suite runs on (the ``vergence`` command sets the same default; the library
# itself leaves the environment alone). A policy set by the user wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# Numba's cache where the `vergence` command keeps it (the user's cache folder, which `make setup`'s
# `vergence warm` fills), not beside the sources; a folder the user chose (NUMBA_CACHE_DIR) wins.
# Before anything imports Numba, which reads the variable once.
from vergence._cache import use_numba_cache_dir  # noqa: E402

use_numba_cache_dir(os.environ)

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path to ``../shared/data``; skips the test when the folder is not beside the checkout."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared test data not found at {SHARED_DATA} (see shared/data/SOURCES.md)")
    return SHARED_DATA


# CI runs the property tests with a fixed seed so that a landing never depends on the draw; locally
# hypothesis explores new examples on every run.
if os.environ.get("CI"):
    settings.register_profile("ci", derandomize=True, print_blob=True)
    settings.load_profile("ci")


# --- image files whose header declares a huge size over a few bytes of data (fuzzer cases) ---


def _huge_png(width: int, height: int) -> bytes:
    import struct
    import zlib

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    chunk = lambda tag, body: (  # noqa: E731
        struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF)
    )
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")


def _huge_jpeg(width: int, height: int) -> bytes:
    import io as _io

    from PIL import Image

    buf = _io.BytesIO()
    Image.new("L", (8, 8)).save(buf, format="JPEG")
    data = bytearray(buf.getvalue())
    sof = data.find(b"\xff\xc0")
    data[sof + 5 : sof + 9] = height.to_bytes(2, "big") + width.to_bytes(2, "big")
    return bytes(data)




def _huge_hdr(width: int, height: int) -> bytes:
    return f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode() + b"\0" * 64


@pytest.fixture
def huge_image():
    """``huge_image(name)``: bytes of a .png/.hdr (100000 x 100000) or .jpg (60000 x 60000) file."""
    makers = {".png": lambda: _huge_png(100_000, 100_000), ".hdr": lambda: _huge_hdr(100_000, 100_000),
              ".jpg": lambda: _huge_jpeg(60_000, 60_000)}
    return lambda name: makers[name[name.rindex("."):]]()
