"""Temporal stability of disparity on video: a colour-gated filter, and the flicker it removes.

A disparity (or depth) map estimated frame by frame flickers where the picture does not move: the
matcher's noise, or the compression noise of an 8-bit depth video, changes a static wall's
disparity from one frame to the next, and the viewer sees the wall breathe. :func:`stabilize_disparity`
filters the disparity in time only where the colour did not change (Lang et al. 2010 smooth the
mapping in time; this smooths the map itself on static content):

    static(x) = |g_t(x) - g_{t-1}(x)| <= threshold      (g: mean of R, G, B in [0, 1])
    D~_t(x) = D~_{t-1}(x) + alpha (D_t(x) - D~_{t-1}(x))   where static(x) and D~_{t-1}(x) is known
    D~_t(x) = D_t(x)                                      elsewhere (moving content follows at once)

an exponential moving average with time constant ``1 / alpha`` frames on static pixels (a pixel whose
new disparity is unknown keeps the filtered one). :data:`STATIC_THRESHOLD` (0.03, about 8 of 255
levels) lies above the noise of H.264 at the default quality (CRF 18: 1-3 levels on flat regions) and
below the change of a moving edge; :data:`STABILIZE_ALPHA` (0.25) averages about 7 frames (the
equivalent window ``(2 - alpha) / alpha``), noise falls by ``sqrt(alpha / (2 - alpha))`` = 0.38.
The filter is reset at cuts by its caller (the first frame of a shot is taken as it is).

:func:`disparity_flicker` measures what it removes: the mean ``|D_t - D_{t-1}|`` over pixels static
in colour (same rule), both known, over all consecutive frame pairs of each shot (none across a cut).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["STABILIZE_ALPHA", "STATIC_THRESHOLD", "Flicker", "disparity_flicker", "stabilize_disparity"]

# A pixel is static when its grey level (mean of R, G, B in [0, 1]) changes by at most this between
# two frames: above H.264's noise at CRF 18, below a moving edge (module docstring).
STATIC_THRESHOLD = 0.03
# Weight of the new disparity on static pixels: an exponential average of about 7 frames.
STABILIZE_ALPHA = 0.25


def _grey(frame: object, name: str) -> np.ndarray:
    a = np.asarray(frame)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{name} must have shape (H, W, 3); got {a.shape}")
    return grey_levels(a)


def grey_levels(frame: np.ndarray) -> np.ndarray:
    """Mean of R, G and B as float32 ``(H, W)``: ``(R + G + B) * (1/3)`` summed in float32 (a Numba kernel in one
    pass for float32 frames; other types through NumPy, in the same order)."""
    if frame.dtype == np.float32 and frame.ndim == 3 and frame.shape[2] == 3:
        from vergence.video._kernels import grey_kernel

        return grey_kernel(frame)
    grey = np.add(frame[:, :, 0], frame[:, :, 1], dtype=np.float32)
    grey += frame[:, :, 2]
    grey *= np.float32(1.0 / 3.0)
    return grey


def _check_parameters(threshold: float, alpha: float | None = None) -> None:
    if isinstance(threshold, bool) or not isinstance(threshold, int | float) or not 0 <= threshold < 1:
        raise ValueError(f"threshold must be a number in [0, 1); got {threshold!r}")
    if alpha is not None and (isinstance(alpha, bool) or not isinstance(alpha, int | float) or not 0 < alpha <= 1):
        raise ValueError(f"alpha must be a number in (0, 1]; got {alpha!r}")


def stabilize_disparity(previous_frame: object, frame: object, previous: object, disparity: object, *,
                        threshold: float = STATIC_THRESHOLD, alpha: float = STABILIZE_ALPHA) -> np.ndarray:  # fmt: skip
    """One step of the colour-gated temporal filter of the module docstring.

    Parameters
    ----------
    previous_frame, frame : (H, W, 3) float arrays in [0, 1]
        The colour of frames ``t - 1`` and ``t``.
    previous : (H, W) float array
        The filtered disparity of frame ``t - 1`` (``D~_{t-1}``), NaN = unknown.
    disparity : (H, W) float array
        The disparity (or nearness, any unit) of frame ``t`` (``D_t``), NaN = unknown.
    threshold : float
        :data:`STATIC_THRESHOLD` by default, in [0, 1).
    alpha : float
        :data:`STABILIZE_ALPHA` by default, in (0, 1]; 1 turns the filter off.

    Returns
    -------
    (H, W) float32
        ``D~_t``.

    Raises
    ------
    ValueError
        Shapes that differ, or parameters out of range.

    Examples
    --------
    >>> import numpy as np
    >>> still = np.zeros((1, 2, 3)); moved = still.copy(); moved[0, 1] = 1.0
    >>> stabilize_disparity(still, moved, np.array([[4.0, 4.0]]), np.array([[8.0, 8.0]]), alpha=0.25).tolist()
    [[5.0, 8.0]]
    """
    from vergence.video._kernels import stabilize_kernel

    _check_parameters(threshold, alpha)
    g0, g1 = _grey(previous_frame, "previous_frame"), _grey(frame, "frame")
    p = np.asarray(previous, dtype=np.float32)
    d = np.asarray(disparity, dtype=np.float32)
    for name, a in (("frame", g1), ("previous", p), ("disparity", d)):
        if a.shape != g0.shape:
            raise ValueError(f"{name} must have shape {g0.shape} (H, W) of previous_frame; got {a.shape}")
    return stabilize_kernel(g0, g1, p, d, float(threshold), float(alpha))


@dataclass(frozen=True, slots=True)
class Flicker:
    """Frame-to-frame change of disparity on static content (:func:`disparity_flicker`).

    Attributes
    ----------
    mean_px : float
        Mean ``|D_t - D_{t-1}|`` over the static, known pixels of all consecutive pairs (NaN when none).
    pairs : int
        Frame pairs measured (consecutive frames of one shot).
    static_share : float
        Share of the pixels of those pairs that were static and known.
    """

    mean_px: float
    pairs: int
    static_share: float


class FlickerMeter:
    """Running sums of :func:`disparity_flicker` (one frame at a time; ``reset`` at a cut)."""

    def __init__(self, threshold: float = STATIC_THRESHOLD) -> None:
        _check_parameters(threshold)
        self.threshold = float(threshold)
        self.total = 0.0
        self.count = 0
        self.pixels = 0
        self.pairs = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        """Forget the last frame (a cut: no pair across it)."""
        self._last = None

    def restart(self) -> None:
        """Clear the sums, keep the last frame (a piece's warm-up: only the pair across its start counts)."""
        self.total, self.count, self.pixels, self.pairs = 0.0, 0, 0, 0

    def add(self, grey: np.ndarray, disparity: np.ndarray, gain: float = 1.0) -> None:
        """Add frame ``t`` (its float32 grey levels and disparity); ``gain`` scales its change (an output's psi slope)."""
        if self._last is not None:
            from vergence.video._kernels import flicker_kernel

            g0, d0 = self._last
            total, count = flicker_kernel(g0, grey, d0, disparity, np.float32(self.threshold))
            self.total += abs(gain) * float(total)
            self.count += int(count)
            self.pixels += disparity.size
            self.pairs += 1
        self._last = (grey, disparity)

    def result(self) -> Flicker:
        mean = self.total / self.count if self.count else float("nan")
        return Flicker(mean_px=mean, pairs=self.pairs, static_share=self.count / self.pixels if self.pixels else 0.0)


def disparity_flicker(frames: Iterable[np.ndarray], disparities: Iterable[np.ndarray], *,
                      cuts: Sequence[int] = (), threshold: float = STATIC_THRESHOLD) -> Flicker:  # fmt: skip
    """Mean frame-to-frame change of ``disparities`` on content static in ``frames`` (module docstring).

    Parameters
    ----------
    frames : iterable of (H, W, 3) float arrays in [0, 1]
        The colour of each frame (the left view of a stereo clip).
    disparities : iterable of (H, W) float arrays
        Their disparity (any unit: the result is in it), NaN = unknown; as many as ``frames``.
    cuts : sequence of int
        First frame of each shot after the first: no pair across a cut is measured.
    threshold : float
        :data:`STATIC_THRESHOLD` by default.

    Returns
    -------
    Flicker

    Raises
    ------
    ValueError
        Frames and disparities of different counts or shapes.

    Examples
    --------
    >>> import numpy as np
    >>> frames = [np.zeros((2, 2, 3))] * 3
    >>> disparities = [np.full((2, 2), v) for v in (1.0, 2.0, 2.5)]
    >>> disparity_flicker(frames, disparities).mean_px
    0.75
    """
    meter = FlickerMeter(threshold)
    cut_set = {int(c) for c in cuts}
    sentinel = object()
    k = 0
    for k, (frame, d) in enumerate(_zip_strict(frames, disparities, sentinel)):
        grey = _grey(frame, f"frames[{k}]")
        dk = np.asarray(d, dtype=np.float32)
        if dk.shape != grey.shape:
            raise ValueError(f"disparities[{k}] must have shape {grey.shape} of frames[{k}]; got {dk.shape}")
        if k in cut_set:
            meter.reset()
        meter.add(grey, dk)
    return meter.result()


def _zip_strict(a: Iterable, b: Iterable, sentinel: object):
    ia, ib = iter(a), iter(b)
    k = 0
    while True:
        x, y = next(ia, sentinel), next(ib, sentinel)
        if x is sentinel and y is sentinel:
            return
        if x is sentinel or y is sentinel:
            raise ValueError(f"frames and disparities must have one length; one of them ends after {k}")
        yield x, y
        k += 1
