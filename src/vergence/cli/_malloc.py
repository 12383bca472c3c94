"""glibc's malloc for a process that renders many images: freed blocks kept for reuse.

``vergence serve`` renders a stereo pair per request; each pair allocates and frees images of
several megabytes. With glibc's default thresholds the heap's free top was handed back to the
system after a pair and faulted in again by the next: kermit's 640 x 480 anaglyph pair took 1,769
page faults and 2.6-5.9 CPU-ms of system time a pair (``benchmarks/stereospace_pair.py``, load 4),
none with :func:`keep_freed_memory`. The library itself sets nothing (``vergence``'s docstring).
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "keep_freed_memory"]

#: Blocks below this come from the heap (reused once freed), not from their own mapping: the value
#: glibc's dynamic threshold stops at on 64-bit systems.
MMAP_THRESHOLD = 32 << 20
#: The heap's free top is handed back to the system only above this: twice :data:`MMAP_THRESHOLD`, as
#: glibc's dynamic threshold sets it.
TRIM_THRESHOLD = 64 << 20
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h


def keep_freed_memory(environ: Mapping[str, str]) -> bool:
    """Set glibc's ``M_MMAP_THRESHOLD`` and ``M_TRIM_THRESHOLD`` (:data:`MMAP_THRESHOLD`,
    :data:`TRIM_THRESHOLD`) with ``mallopt``, unless the user chose either
    (``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_`` in ``environ``). Returns whether both
    were set: False too where the C library has no ``mallopt`` or refuses (not glibc)."""
    if "MALLOC_MMAP_THRESHOLD_" in environ or "MALLOC_TRIM_THRESHOLD_" in environ:
        return False
    import ctypes  # ~7 ms: only for the commands that call this

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1 and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1
