"""Input validation shared by every public function.

Each helper checks one thing and raises a ``ValueError`` (or ``TypeError``) whose message names
the argument, the expectation and what came, e.g.
``depth must have shape (H, W) matching image (480, 640); got (480, 641)``.
Validation happens once, at the public boundary; kernels trust their inputs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from numbers import Real

import numpy as np

__all__ = [
    "as_float_array",
    "as_image",
    "as_image_pair",
    "as_view",
    "check_bool",
    "check_finite",
    "check_in_range",
    "check_positive",
    "check_positive_int",
    "check_same_hw",
    "readonly_copy",
]


def check_bool(name: str, value: object) -> bool:
    """Return ``value`` as a bool, or raise ``TypeError`` if it is not one (a string "no" is truthy)."""
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be a bool; got {type(value).__name__}")
    return bool(value)


def check_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise if it is not a finite real number."""
    if isinstance(value, bool) or not isinstance(value, Real | np.floating | np.integer):
        raise TypeError(f"{name} must be a real number; got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite; got {v}")
    return v


def check_positive(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise if it is not finite and strictly positive."""
    v = check_finite(name, value)
    if v <= 0.0:
        raise ValueError(f"{name} must be > 0; got {v:g}")
    return v


def check_positive_int(name: str, value: object) -> int:
    """Return ``value`` as an int, or raise if it is not an integer >= 1."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer; got {type(value).__name__}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1; got {value}")
    return int(value)


def check_in_range(name: str, value: object, low: float, high: float) -> float:
    """Return ``value`` as a float, or raise if it lies outside ``[low, high]``."""
    v = check_finite(name, value)
    if not low <= v <= high:
        raise ValueError(f"{name} must lie in [{low:g}, {high:g}]; got {v:g}")
    return v


def as_float_array(
    name: str,
    value: object,
    *,
    shape: Sequence[int | None] | None = None,
    allow_nan: bool = False,
    dtype: type = np.float64,
) -> np.ndarray:
    """Convert ``value`` to a float array, checking its shape and that it holds no inf (nor NaN).

    ``shape`` may hold ``None`` for a free axis, e.g. ``(None, 3)`` for N points.
    The input is never modified; the result is a new array when a conversion was needed.
    """
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric; got {type(value).__name__}") from exc
    if shape is not None:
        ok = arr.ndim == len(shape) and all(s is None or s == n for s, n in zip(shape, arr.shape))
        if not ok:
            dims = ["N" if s is None else str(s) for s in shape]
            want = "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"
            raise ValueError(f"{name} must have shape {want}; got {arr.shape}")
    if allow_nan:
        if np.isinf(arr).any():
            raise ValueError(f"{name} must not contain inf")
    elif not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def as_image(name: str, image: object, *, copy: bool = True) -> np.ndarray:
    """Return ``image`` as float32 ``(H, W)`` or ``(H, W, C)`` with C in {1, 3, 4}, values in [0, 1].

    uint8 and uint16 inputs are scaled by 1/255 and 1/65535; float inputs must already lie in
    [0, 1] and be finite. Empty images are refused. ``copy=False`` returns a float32 input itself
    (for a caller that only reads it); by default the result is always a new array.
    """
    arr = np.asarray(image)
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] not in (1, 3, 4)):
        raise ValueError(f"{name} must have shape (H, W) or (H, W, C) with C in 1, 3, 4; got {arr.shape}")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValueError(f"{name} must not be empty; got shape {arr.shape}")
    if arr.dtype == np.uint8:
        return arr.astype(np.float32) / np.float32(255.0)
    if arr.dtype == np.uint16:
        return arr.astype(np.float32) / np.float32(65535.0)
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        raise TypeError(f"{name} must be a numeric image (float in [0, 1], uint8 or uint16); got {arr.dtype}")
    if np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{name} must be float in [0, 1], uint8 or uint16; got {arr.dtype}")
    out = arr.astype(np.float32, copy=copy)
    lo, hi = float(out.min()), float(out.max())  # a NaN anywhere makes both NaN, an inf one of them
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    if lo < 0.0 or hi > 1.0:
        raise ValueError(f"{name} values must lie in [0, 1]; got [{lo:g}, {hi:g}]")
    return out


def check_same_hw(name: str, array: np.ndarray, ref_name: str, ref: np.ndarray) -> None:
    """Raise unless ``array`` has the same (H, W) as ``ref``."""
    if array.shape[:2] != ref.shape[:2]:
        raise ValueError(
            f"{name} must have shape (H, W) matching {ref_name} {tuple(ref.shape[:2])}; "
            f"got {tuple(array.shape[:2])}"
        )


def readonly_copy(array: object) -> np.ndarray:
    """A float64 copy of ``array`` that cannot be written to (for fields of frozen dataclasses)."""
    out = np.array(array, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


def readonly_fields(obj: object, *names: str) -> None:
    """Replace each array field ``names`` of the frozen dataclass ``obj`` by a read-only view of it
    (the caller's array stays writable; the dataclass's cannot be written through)."""
    for name in names:
        view = getattr(obj, name).view()
        view.flags.writeable = False
        object.__setattr__(obj, name, view)


def as_view(name: str, image: object, *, copy: bool = True) -> np.ndarray:
    """:func:`as_image` restricted to grey ``(H, W)`` or RGB ``(H, W, 3)``: a single channel axis is
    dropped, alpha is refused."""
    arr = as_image(name, image, copy=copy)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim == 3 and arr.shape[2] != 3:
        raise ValueError(f"{name} must have shape (H, W) or (H, W, 3); got {arr.shape} (no alpha)")
    return arr


def as_image_pair(first_name: str, first: object, second_name: str, second: object, *,
                  copy: bool = True) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Two views (see :func:`as_view`) that must share one shape; float32."""
    a, b = as_view(first_name, first, copy=copy), as_view(second_name, second, copy=copy)
    if a.shape != b.shape:
        raise ValueError(f"{second_name} must have the same shape as {first_name} {a.shape}; got {b.shape}")
    return a, b
