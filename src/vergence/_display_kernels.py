"""Numba kernel of Dubois's anaglyph (:func:`vergence.display.anaglyph`): sRGB decoding, the two
3 x 3 projections, the gamut clip and sRGB encoding, a row at a time in channel planes (:func:`dubois`).

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
    """``table`` (nodes at ``i / TABLE_SIZE``) interpolated linearly at ``u`` in [0, 1] (clamped into it:
    the index stays in the table in every vector lane)."""
    n = table.shape[0] - 1
    pos = min(max(u, 0.0), 1.0) * n
    i = min(np.int64(pos), n - 1)
    return table[np.uint64(i)] + (pos - i) * (table[np.uint64(i + 1)] - table[np.uint64(i)])


@nb.njit(cache=True, inline="always")
def _decode(v, table):  # pragma: no cover - compiled
    """sRGB-encoded ``v`` in [0, 1] to linear light."""
    return v / 12.92 if v <= 0.04045 else _lookup(table, v)


@nb.njit(cache=True, inline="always")
def _decode_row(view, y, c, table, linear, t, plane):  # pragma: no cover - compiled
    """Channel ``c`` of row ``y`` of ``view`` decoded into ``linear[t, plane]`` (inlined where ``c`` is a
    constant: with the channel a loop variable the pass took 1.14 times as long on kermit's and random
    views in a probe, 0.9 on dino's)."""
    for x in range(view.shape[1]):
        linear[t, plane, x] = _decode(np.float64(view[y, x, c]), table)


# Bands of rows of one dubois call, each a task with its own scratch rows (at most this many: the
# scratch is made once a call, 42 bytes a column a band).
_BANDS = 32


@nb.njit(cache=True, parallel=True)
def dubois(left, right, m_left, m_right, decode, encode, out):  # pragma: no cover - compiled
    """``out = encode(clip(M_L decode(left) + M_R decode(right), 0, 1))`` per pixel of the
    ``(H, W, 3)`` sRGB views (float32 in [0, 1]); ``decode``, ``encode``: :data:`DECODE_TABLE`,
    :data:`ENCODE_TABLE`.

    Row by row in channel planes: the six decoded channels, then each output channel, then the row
    interleaved into ``out``. Each stage is a loop over the row with one store, which LLVM vectorises
    (the table reads become AVX gathers). The rows are split into bands, one task each, whose scratch
    rows are made before the parallel loop: rows made inside it were left scalar ("cannot identify
    array bounds"), as was the former pass pixel by pixel ("unsafe indirect dependence"); per-thread
    scratch would need Numba's thread id, which cannot be cached."""
    h, w = out.shape[0], out.shape[1]
    bands = min(h, _BANDS)
    linear = np.empty((bands, 6, w))  # left R, G, B, right R, G, B in linear light
    encoded = np.empty((bands, 3, w), dtype=np.float32)
    for t in nb.prange(bands):
        for y in range(t * h // bands, (t + 1) * h // bands):
            _decode_row(left, y, 0, decode, linear, t, 0)  # one call a plane: the channel a constant
            _decode_row(left, y, 1, decode, linear, t, 1)
            _decode_row(left, y, 2, decode, linear, t, 2)
            _decode_row(right, y, 0, decode, linear, t, 3)
            _decode_row(right, y, 1, decode, linear, t, 4)
            _decode_row(right, y, 2, decode, linear, t, 5)
            for c in range(3):
                a0, a1, a2 = m_left[c, 0], m_left[c, 1], m_left[c, 2]
                b0, b1, b2 = m_right[c, 0], m_right[c, 1], m_right[c, 2]
                for x in range(w):
                    lin = (a0 * linear[t, 0, x] + a1 * linear[t, 1, x] + a2 * linear[t, 2, x]
                           + b0 * linear[t, 3, x] + b1 * linear[t, 4, x] + b2 * linear[t, 5, x])  # fmt: skip
                    lin = min(1.0, max(0.0, lin))  # Dubois: clip to the display gamut
                    encoded[t, c, x] = 12.92 * lin if lin <= 0.0031308 else _lookup(encode, math.sqrt(lin))
            for x in range(w):
                out[y, x, 0] = encoded[t, 0, x]
                out[y, x, 1] = encoded[t, 1, x]
                out[y, x, 2] = encoded[t, 2, x]
