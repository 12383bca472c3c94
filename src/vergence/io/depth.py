"""Depth maps of a given kind and scale (metric depth, inverse depth or disparity) as float32 ``(H, W)``.

The kinds (:data:`DEPTH_KINDS`) are those the view synthesis understands
(:func:`vergence.synthesis.nearness_from_depth`): ``"metric"`` camera-frame z (metres, or any
length unit), ``"inverse"`` inverse depth (MPEG's 8-bit convention: 0 is the far plane, Fehn
2004), ``"disparity"`` pixels, larger = nearer. Conventions: ``docs/conventions.md``.
"""

from __future__ import annotations

import os
from pathlib import Path
from types import MappingProxyType

import numpy as np

from vergence._validate import check_positive
from vergence.io._files import input_path, suffix_of
from vergence.io.disparity import read_disparity, stores_integers
from vergence.io.images import read_image

__all__ = ["DEPTH_KINDS", "read_depth"]

# What a depth map holds (name -> meaning); one entry per kind: the CLI choices and the errors read it.
DEPTH_KINDS = MappingProxyType(
    {
        "disparity": "pixels, larger = nearer",
        "inverse": "inverse depth, larger = nearer (8/16-bit files: [0, 1], 0 = the far plane)",
        "metric": "camera-frame z, > 0",
    }
)

# The files a depth map can be read from: those of the disparity maps (read_disparity).
_DEPTH_SUFFIXES = (".pfm", ".npy", ".png", ".pgm")


def _pfm_magic(path: Path) -> bytes:
    """The first two bytes of a PFM file: ``PF`` (colour) or ``Pf`` (grey)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(2)
    except OSError as exc:
        raise OSError(f"cannot read {path}: {exc.strerror or exc}") from exc


def read_depth(path: str | os.PathLike[str], *, kind: str = "metric", scale: float | None = None) -> np.ndarray:
    """Read a depth map of ``kind`` as float32 ``(H, W)``, NaN where unknown.

    Parameters
    ----------
    path : str or os.PathLike
        ``.png``/``.pgm`` (8 or 16-bit grey) or ``.pfm``/``.npy`` (float as stored; NaN and inf =
        unknown).
    kind : {"disparity", "inverse", "metric"}
        What the file holds, see :data:`DEPTH_KINDS`.
    scale : float, optional
        Integer files: stored value / scale = the map's unit (default 1), value 0 = unknown. For
        ``kind="inverse"`` the file is read as an image in [0, 1] (0 = the far plane, a real value)
        and divided by ``scale`` when given. Must be omitted for float files.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)``.

    Raises
    ------
    ValueError
        An unknown kind, a scale that is not > 0 or is given for a float file, a colour image for
        inverse depth, a colour (``PF``) PFM, or any error of :func:`~vergence.io.read_disparity`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from vergence.io import write_disparity
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "depth.png"
    >>> write_disparity(target, np.array([[1.5, np.nan]]), scale=1000)
    >>> read_depth(target, kind="metric", scale=1000)
    array([[1.5, nan]], dtype=float32)
    """
    if kind not in DEPTH_KINDS:
        raise ValueError(f"kind must be one of {', '.join(DEPTH_KINDS)}; got {kind!r}")
    if scale is not None:
        check_positive("scale", scale)
    p = input_path(path)
    if p.suffix.lower() not in _DEPTH_SUFFIXES:
        hint = " (a vergence render writes its depth as *_depth.pfm beside the .npz)" if p.suffix.lower() == ".npz" else ""
        raise ValueError(f"cannot read depth {p}: unknown depth-map extension {p.suffix!r}; expected one of "
                         f"{', '.join(_DEPTH_SUFFIXES)}{hint}")  # fmt: skip
    integer = stores_integers(p)  # a scale turns their values into the map's unit, 0 = unknown
    if suffix_of(p) == ".pfm" and _pfm_magic(p) == b"PF":
        # A colour PFM is an image, not a depth map (read_disparity would take equal channels as grey).
        raise ValueError(f"depth {p} must be a single-channel PFM ('Pf' header); got a colour 'PF' file")
    if kind == "inverse" and integer:
        depth = read_image(p)
        if depth.ndim != 2:
            raise ValueError(f"depth {p} must be a single-channel image; got shape {depth.shape}")
        return depth if scale is None else (depth / np.float32(scale)).astype(np.float32)
    return read_disparity(p, scale=(1.0 if scale is None else scale) if integer else scale)
