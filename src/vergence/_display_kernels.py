"""Numba kernel of Dubois's anaglyph (:func:`vergence.display.anaglyph`): sRGB decoding, the two
3 x 3 projections, the gamut clip and sRGB encoding in one pass over the pixels.

The sRGB transfer curves (IEC 61966-2-1) are a line near black and a power law above it; the
power laws are read from tables of :data:`TABLE_SIZE` + 1 nodes with linear interpolation, the
lines computed. Interpolation error (``h^2 / 8 max |f''|``, ``h = 1 / TABLE_SIZE``): decoding
``((v + 0.055) / 1.055)^2.4`` on [0.04045, 1], ``|f''| <= 3.02``: 1.4e-9; encoding through ``s = sqrt(x)``,
``1.055 s^(2 / 2.4) - 0.055`` on [0.0560, 1] (x >= 0.0031308), ``|f''| <= 4.3``: 2.0e-9. A decoding
error reaches the result through a matrix row (absolute sum <= 1.8) and the encoding's slope (<= 12.92):
3.3e-8 at most, about float32's resolution at 0.5 (3e-8), the precision of the result. The slow,
obviously-correct twin is the float64 numpy formula (``tests/test_display.py``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["DECODE_TABLE", "ENCODE_TABLE", "TABLE_SIZE", "dubois"]

TABLE_SIZE = 16384
_NODES = np.linspace(0.0, 1.0, TABLE_SIZE + 1)
#: ``((v + 0.055) / 1.055)^2.4`` at ``v = i / TABLE_SIZE`` (the power law of sRGB decoding).
DECODE_TABLE = ((_NODES + 0.055) / 1.055) ** 2.4
#: ``1.055 s^(1 / 1.2) - 0.055`` at ``s = i / TABLE_SIZE``: the power law of sRGB encoding of ``x = s^2``.
ENCODE_TABLE = 1.055 * _NODES ** (2.0 / 2.4) - 0.055
for _t in (DECODE_TABLE, ENCODE_TABLE):
    _t.flags.writeable = False
del _t


@nb.njit(cache=True, inline="always")
def _lookup(table, u):  # pragma: no cover - compiled
    """``table`` (nodes at ``i / TABLE_SIZE``) interpolated linearly at ``u`` in [0, 1]."""
    n = table.shape[0] - 1
    pos = u * n
    i = min(int(pos), n - 1)
    return table[i] + (pos - i) * (table[i + 1] - table[i])


@nb.njit(cache=True, inline="always")
def _decode(v, table):  # pragma: no cover - compiled
    """sRGB-encoded ``v`` in [0, 1] to linear light."""
    return v / 12.92 if v <= 0.04045 else _lookup(table, v)


@nb.njit(cache=True, parallel=True)
def dubois(left, right, m_left, m_right, decode, encode, out):  # pragma: no cover - compiled
    """``out = encode(clip(M_L decode(left) + M_R decode(right), 0, 1))`` per pixel of the
    ``(H, W, 3)`` sRGB views (float32 in [0, 1]); ``decode``, ``encode``: :data:`DECODE_TABLE`,
    :data:`ENCODE_TABLE`."""
    h, w = out.shape[:2]
    for y in nb.prange(h):
        for x in range(w):
            l0, l1, l2 = _decode(left[y, x, 0], decode), _decode(left[y, x, 1], decode), _decode(left[y, x, 2], decode)
            r0, r1, r2 = (_decode(right[y, x, 0], decode), _decode(right[y, x, 1], decode),
                          _decode(right[y, x, 2], decode))  # fmt: skip
            for c in range(3):
                lin = (m_left[c, 0] * l0 + m_left[c, 1] * l1 + m_left[c, 2] * l2
                       + m_right[c, 0] * r0 + m_right[c, 1] * r1 + m_right[c, 2] * r2)  # fmt: skip
                lin = min(1.0, max(0.0, lin))  # Dubois: clip to the display gamut
                out[y, x, c] = 12.92 * lin if lin <= 0.0031308 else _lookup(encode, math.sqrt(lin))
