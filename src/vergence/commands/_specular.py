"""The painted weight maps of S3 Eq. 2 (S3 §3.3) as the specular commands take them: ``[TERM:]LAYER=FILE``.

``LAYER=FILE`` scales every cost term of layer ``LAYER`` (1-based, as ``report.json``'s ``"layer"``),
``TERM:LAYER=FILE`` only ``TERM`` (:data:`vergence.specular.COST_TERMS`); maps of the same term and
layer multiply. ``FILE`` is a grey image of the render's size: PNG/PGM/JPEG values / max code (so in
[0, 1]), ``.pfm``/``.npy``/``.hdr`` as stored; finite, in [0, :data:`MAX_WEIGHT`]. Used by
``vergence specular --weight-map`` and the workbench's re-optimise job; refusals name the parameter
``{weight_map}`` (and ``{depth}``, the bounces that make the layers).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vergence.commands._naming import literal
from vergence.commands._spec import ParameterError

__all__ = ["MAX_WEIGHT", "weight_maps"]

# Largest cost weight and painted weight: the offsets depend only on the ratios of the weights
# (optimise_offsets normalises its steps), S3 uses 0.1..10, and costs of up to ~1e10 arcmin^2 times
# 1e6 x 1e6 stay finite in the float32 table the planner solves on (1e6 ^ 2 x 1e10 << 3.4e38).
MAX_WEIGHT = 1e6
# Float files whose values are taken as stored (read with vergence.io.read_disparity: NaN kept, so
# that it can be refused by name); every other image is read by vergence.io.read_image.
_FLOAT_MAP_SUFFIXES = (".pfm", ".npy")


def _read_map(path: Path, spec: str) -> np.ndarray:
    """The grey weight image of the spec ``spec`` as float64 ``(H, W)``, or a ParameterError naming ``spec``."""
    from vergence.io import read_disparity, read_image
    from vergence.io.atomic import describe_os_error

    named = "{weight_map} " + literal(spec) + ": "
    try:
        if path.suffix.lower() in _FLOAT_MAP_SUFFIXES:
            arr = read_disparity(path)  # float as stored, single channel; inf becomes NaN, refused below
        else:
            arr = read_image(path)
            if arr.ndim == 3 and (arr == arr[..., :1]).all():
                arr = arr[..., 0]  # grey stored as RGB
    except OSError as exc:
        raise ParameterError(named + literal(describe_os_error(exc))) from exc
    except ValueError as exc:
        raise ParameterError(named + literal(str(exc))) from exc
    if arr.ndim != 2:
        raise ParameterError(named + f"the map must be a grey image; got {arr.shape[2]} distinct channels")
    rule = f"weights must be finite and in [0, {MAX_WEIGHT:g}]"
    if not np.isfinite(arr).all():
        raise ParameterError(named + f"the map holds NaN or inf; {rule}")
    if (arr < 0).any():
        raise ParameterError(named + f"the map holds negative values (down to {arr.min():g}); {rule}")
    if (arr > MAX_WEIGHT).any():
        raise ParameterError(named + f"the map holds values up to {arr.max():g}; {rule}")
    return arr.astype(np.float64)


def weight_maps(specs: list[str], *, n_layers: int, width: int, height: int) -> dict[str, np.ndarray]:
    """The cost's painted maps (term -> ``(N, H, W)``) from ``[TERM:]LAYER=FILE`` specs (module docstring).

    A term no spec names is left out (weight 1 everywhere).

    Raises
    ------
    ParameterError
        Naming ``{weight_map}`` and the spec: a bad spec, term or layer, an unreadable file, a map of
        another size or values outside [0, :data:`MAX_WEIGHT`].
    """
    from vergence.specular import COST_TERMS

    maps: dict[str, np.ndarray] = {}
    for spec in specs:
        key, sep, name = spec.partition("=")
        term, colon, layer_text = key.rpartition(":")
        if not sep or not name or not layer_text:
            raise ParameterError("{weight_map} must be LAYER=FILE or TERM:LAYER=FILE; got " + literal(repr(spec)))
        named = "{weight_map} " + literal(spec) + ": "
        if colon and term not in COST_TERMS:
            raise ParameterError(named + literal(f"unknown cost term {term!r}; the terms are {', '.join(COST_TERMS)}"))
        try:
            layer = int(layer_text)
        except ValueError:
            layer = 0
        if not 1 <= layer <= n_layers:
            raise ParameterError(named + f"LAYER must be a whole number in 1..{n_layers} (the layers of "
                                 "{depth}" + f" {(n_layers + 1).bit_length() - 2}, as report.json numbers them); "
                                 f"got {literal(repr(layer_text))}")  # fmt: skip
        arr = _read_map(Path(name), spec)
        if arr.shape != (height, width):
            raise ParameterError(named + f"the map must be {width} x {height} pixels (the render's W x H); got "
                                 f"{arr.shape[1]} x {arr.shape[0]}")  # fmt: skip
        for t in (term,) if colon else COST_TERMS:
            maps.setdefault(t, np.ones((n_layers, height, width)))[layer - 1] *= arr
    return maps
