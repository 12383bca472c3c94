"""Validators shared by the public functions of ``vergence.synthesis`` (one pass each).

Every public function of the subpackage validates its arguments once with these, then calls the
unchecked stages of :mod:`vergence.synthesis._stages`.
"""

from __future__ import annotations

import numpy as np

from vergence._validate import as_image, check_finite, check_same_hw
from vergence.camera import Camera
from vergence.synthesis import _kernels

# Largest filter radius (pixels) of contour handling (edge dilation, contour bands): the dilation
# kernel loops over 2 r + 1 pixels per pixel, and a depth edge spread wider than 64 px is no longer
# a contour but a different depth map.
MAX_FILTER_RADIUS = 64
# Largest Gaussian sigma (pixels) of depth smoothing: SciPy's kernel spans 8 sigma + 1 taps, so 1024
# px (an 8193-tap kernel) already flattens any map of a few thousand pixels; past it the kernel size
# overflows or takes minutes for no visible change.
MAX_SMOOTH_SIGMA = 1024.0
# The kernels take their tolerances and limits as float32: a larger magnitude would overflow to inf.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def rows(arr: np.ndarray) -> np.ndarray:
    """A C-contiguous 2-D view (rows x everything else) of an array, for the counting kernels."""
    a = np.ascontiguousarray(arr)
    return a.reshape(a.shape[0], -1) if a.ndim >= 2 else a.reshape(1, -1)


def count_nonfinite(arr: np.ndarray) -> tuple[int, int]:
    """NaN and inf counts of a float array, in one parallel pass."""
    a = rows(arr)
    n_nan = np.empty(a.shape[0], dtype=np.int64)
    n_inf = np.empty(a.shape[0], dtype=np.int64)
    _kernels.count_nonfinite(a, n_nan, n_inf)
    return int(n_nan.sum()), int(n_inf.sum())


def check_image(name: str, image: object) -> np.ndarray:
    """:func:`vergence._validate.as_image` without copying a valid float32 image (one Numba pass).

    The kernels never write to their inputs, so a float32 image is used in place; anything else
    (and any invalid image, for its error message) goes through ``as_image``.
    """
    arr = np.asarray(image)
    if arr.ndim == 3 and arr.shape[2] == 4:
        # Warping and blending mix colours by weight: a straight alpha channel would be averaged as
        # a colour, not composited, so RGBA is refused rather than silently mis-blended.
        raise ValueError(
            f"{name} must be grey (H, W) or colour (H, W, 1 or 3); got shape {arr.shape} "
            "(an alpha channel: composite or drop it first)"
        )
    if arr.dtype != np.float32 or arr.ndim not in (2, 3) or arr.size == 0 or (arr.ndim == 3 and arr.shape[2] not in (1, 3)):
        return as_image(name, image)  # converts, or raises its own message
    arr = np.ascontiguousarray(arr)
    a = rows(arr)
    bad = np.empty(a.shape[0], dtype=np.int64)
    _kernels.count_outside(a, np.float32(0.0), np.float32(1.0), bad)
    if bad.any():
        return as_image(name, image)  # raises the non-finite or range message
    return arr


def within_float32(name: str, value: float) -> float:
    """Return ``value``, or raise if its magnitude exceeds ``FLOAT32_MAX`` (the kernels' float32)."""
    if abs(value) > FLOAT32_MAX:
        raise ValueError(f"{name} must be at most {FLOAT32_MAX:.4g} in magnitude (a float32); got {value:g}")
    return value


def check_nonnegative(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise if it is not finite, >= 0 and a float32."""
    v = check_finite(name, value)
    if v < 0:
        raise ValueError(f"{name} must be >= 0; got {v:g}")
    return within_float32(name, v)


def check_radius(name: str, value: object) -> int:
    """Return ``value`` as an int, or raise if it is not an integer in [0, MAX_FILTER_RADIUS]."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer; got {type(value).__name__}")
    if not 0 <= value <= MAX_FILTER_RADIUS:
        raise ValueError(f"{name} must lie in [0, {MAX_FILTER_RADIUS}] pixels (MAX_FILTER_RADIUS); got {value}")
    return int(value)


def check_sigma(name: str, value: object) -> float:
    """Return ``value`` as a float, or raise if it is not in (0, MAX_SMOOTH_SIGMA] pixels."""
    v = check_finite(name, value)
    if not 0.0 < v <= MAX_SMOOTH_SIGMA:
        raise ValueError(f"{name} must lie in (0, {MAX_SMOOTH_SIGMA:g}] pixels (MAX_SMOOTH_SIGMA); got {v:g}")
    return v


def check_map(name: str, value: object, ref_name: str | None = None, ref: np.ndarray | None = None) -> np.ndarray:
    """Validate a depth or disparity map as C-contiguous float32: ``(H, W)`` (like ``ref`` when
    given), not empty, NaN for unknown, no inf, not all unknown (one Numba pass)."""
    if np.iscomplexobj(value):
        raise TypeError(f"{name} must be real; got a complex array")
    try:
        d = np.ascontiguousarray(value, dtype=np.float32)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric; got {type(value).__name__}") from exc
    if d.ndim != 2 or d.size == 0:
        raise ValueError(f"{name} must have shape (H, W); got {d.shape}")
    if ref is not None:
        check_same_hw(name, d, ref_name, ref)
    n_nan, n_inf = count_nonfinite(d)
    if n_inf:
        raise ValueError(f"{name} must not contain inf (use NaN for unknown)")
    if n_nan == d.size:
        raise ValueError(f"{name} must have at least one known value; got all unknown (NaN)")
    return d


def check_method(name: str, value: object, table: object) -> str:
    """Return ``value`` if it is a key of ``table``, else raise listing the valid names."""
    if not isinstance(value, str) or value not in table:  # type: ignore[operator]
        raise ValueError(f"{name} must be one of {', '.join(table)}; got {value!r}")  # type: ignore[call-overload]
    return value


def check_holes(holes: object, ref: np.ndarray) -> np.ndarray:
    """A boolean ``(H, W)`` hole mask matching ``ref``."""
    m = np.asarray(holes)
    if m.dtype != bool:
        raise TypeError(f"holes must be a boolean mask; got {m.dtype}")
    if m.ndim != 2:
        raise ValueError(f"holes must have shape (H, W); got {m.shape}")
    check_same_hw("holes", m, "image", ref)
    return np.ascontiguousarray(m)


def check_known_disparity(disparity: object, holes: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """A float32 ``(H, W)`` disparity, finite outside ``holes`` (0 in them)."""
    if np.iscomplexobj(disparity):
        raise TypeError("disparity must be real; got a complex array")
    d = np.asarray(disparity, dtype=np.float32)
    if d.ndim != 2:
        raise ValueError(f"disparity must have shape (H, W); got {d.shape}")
    check_same_hw("disparity", d, "image", ref)
    if not np.isfinite(d[~holes]).all():
        raise ValueError("disparity must be finite outside the holes")
    return np.ascontiguousarray(np.where(holes, 0.0, d), dtype=np.float32)


def check_camera(name: str, cam: object) -> Camera:
    """``cam`` if it is a :class:`~vergence.camera.Camera`."""
    if not isinstance(cam, Camera):
        raise TypeError(f"{name} must be a Camera; got {type(cam).__name__}")
    return cam


def check_source_image(image: object, source: Camera) -> np.ndarray:
    """An image the size of the ``source`` camera."""
    img = check_image("image", image)
    if img.shape[:2] != (source.height, source.width):
        raise ValueError(f"image must have shape {(source.height, source.width)} matching the source camera; got {img.shape[:2]}")
    return img


def check_depth(depth: object, source: Camera) -> np.ndarray:
    """Metric depth (float64) the size of ``source``: > 0 where known, NaN unknown, no inf."""
    if np.iscomplexobj(depth):
        raise TypeError("depth must be real; got a complex array")
    z = np.asarray(depth, dtype=np.float64)
    if z.shape != (source.height, source.width):
        raise ValueError(f"depth must have shape {(source.height, source.width)} matching the source camera; got {z.shape}")
    if np.isinf(z).any():
        raise ValueError("depth must not contain inf (use NaN for unknown)")
    known = ~np.isnan(z)
    if not known.any():
        raise ValueError("depth must have at least one known value; got all unknown (NaN)")
    if (z[known] <= 0).any():
        raise ValueError(f"depth must be > 0 metres where known; got min {z[known].min():g}")
    return z


def check_depth_values(name: str, z: np.ndarray) -> None:
    """Raise unless ``z`` holds no inf and is > 0 where known (NaN = unknown)."""
    if np.isinf(z).any():
        raise ValueError(f"{name} must not contain inf (use NaN for no surface)")
    with np.errstate(invalid="ignore"):
        bad = z <= 0
    if bad.any():
        raise ValueError(f"{name} must be > 0 metres where known; got min {z[bad].min():g}")
