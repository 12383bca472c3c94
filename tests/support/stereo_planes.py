"""Synthetic stereo clips of textured planes at known disparities (tests of the disparity search range).

Each shot is a background plane whose disparity runs linearly down the rows, from ``top_px`` to
``bottom_px`` (each row a constant shift: a plane slanted in depth), and a foreground rectangle at
``front_px`` covering the middle of the frame. The right view is the left one's world sampled at
``x + D`` (``D = x_left - x_right``), so the truth is exact up to the bilinear resampling of a
smooth texture; the texture pans one pixel a frame so that the frames differ. Each shot has its own
colours, so the cut between shots is plain. Written as full side-by-side H.264 with the library's
writer (lossy at ``crf``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class PlaneShot:
    """One shot: background rows from ``top_px`` to ``bottom_px``, a rectangle at ``front_px``; ``scale`` is
    the texture's grain (px) and ``tint`` its colour."""

    top_px: float
    bottom_px: float
    front_px: float
    scale: float = 4.0
    tint: tuple[float, float, float] = (1.0, 0.8, 0.6)


def _texture(rng: np.random.Generator, height: int, width: int, scale: float, tint) -> np.ndarray:
    """Smooth colour noise, (H, W, 3) float32 in [0, 1]: octaves of upsampled noise."""
    import cv2

    grey = np.zeros((height, width), np.float32)
    for octave, weight in ((scale, 1.0), (scale * 3, 0.7), (scale * 9, 0.5)):
        h, w = max(2, int(height / octave)), max(2, int(width / octave))
        grey += weight * cv2.resize(rng.random((h, w)).astype(np.float32), (width, height),
                                    interpolation=cv2.INTER_CUBIC)  # fmt: skip
    grey = (grey - grey.min()) / (grey.max() - grey.min())
    colour = np.stack([grey * t + (1 - t) * 0.5 * (1 - grey) for t in tint], axis=2)
    return np.clip(colour, 0.0, 1.0).astype(np.float32)


def _shift_rows(texture: np.ndarray, x0: float, shift: np.ndarray, width: int) -> np.ndarray:
    """``texture`` sampled at columns ``x0 + x + shift[y]`` for x in [0, width), bilinear."""
    import cv2

    h = shift.shape[0]
    map_x = (x0 + np.arange(width, dtype=np.float32)[None, :] + shift[:, None].astype(np.float32)).astype(np.float32)
    map_y = np.repeat(np.arange(h, dtype=np.float32)[:, None], width, axis=1)
    return cv2.remap(texture, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def render_pair(shot: PlaneShot, *, width: int, height: int, frame: int, background: np.ndarray,
                front: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(left, right, disparity of the left view) of one frame."""
    rows = np.linspace(shot.top_px, shot.bottom_px, height)
    margin = background.shape[1] - width  # texture columns to the left of the view: pan and shifts
    x0 = margin / 2 + frame
    left = _shift_rows(background, x0, np.zeros(height), width)
    right = _shift_rows(background, x0, rows, width)
    disparity = np.repeat(rows[:, None], width, axis=1)
    y0, y1, c0, c1 = height // 4, 3 * height // 4, width // 3, 2 * width // 3
    fl = _shift_rows(front, x0, np.zeros(height), width)
    fr = _shift_rows(front, x0, np.full(height, shot.front_px), width)
    left[y0:y1, c0:c1] = fl[y0:y1, c0:c1]
    disparity[y0:y1, c0:c1] = shot.front_px
    # the rectangle in the right view: left-view columns [c0, c1) seen at x - front_px
    r0, r1 = int(round(c0 - shot.front_px)), int(round(c1 - shot.front_px))
    a, b = max(0, r0), min(width, r1)
    if b > a:
        right[y0:y1, a:b] = fr[y0:y1, a:b]
    return left, right, disparity


def write_planes_clip(path: Path, shots: tuple[PlaneShot, ...], *, width: int = 480, height: int = 272,
                      frames_per_shot: int = 8, seed: int = 0, crf: int = 16) -> np.ndarray:  # fmt: skip
    """Write the clip (full SBS) and return the truth: the left view's disparity of every frame, (N, H, W)
    float64, NaN where the match falls outside the right view."""
    from vergence.video.writer import VideoWriter

    rng = np.random.default_rng(seed)
    truth = []
    span = int(max(abs(v) for s in shots for v in (s.top_px, s.bottom_px, s.front_px))) + frames_per_shot + 8
    with VideoWriter(path, fps=24, width=2 * width, height=height, crf=crf) as writer:
        for shot in shots:
            background = _texture(rng, height, width + 2 * span, shot.scale, shot.tint)
            front = _texture(rng, height, width + 2 * span, shot.scale * 0.7, shot.tint[::-1])
            for k in range(frames_per_shot):
                left, right, d = render_pair(shot, width=width, height=height, frame=k, background=background,
                                             front=front)  # fmt: skip
                writer.write(np.concatenate([left, right], axis=1))
                x = np.arange(width)[None, :]
                truth.append(np.where((x - d >= 0) & (x - d <= width - 1), d, np.nan))
    return np.stack(truth)


def shot_truth(truth: np.ndarray, start: int, end: int, percentiles=(1, 5, 50, 95, 99)) -> dict[str, float]:
    """The pooled percentiles of a shot's true disparity (its known pixels)."""
    values = truth[start:end][np.isfinite(truth[start:end])]
    return {f"p{p}": float(v) for p, v in zip(percentiles, np.percentile(values, percentiles))}


# The clip of issue 28 (true disparities 36-95 px at 480 px per view) and a second, different one for the check.
HARD_SHOTS = (PlaneShot(36.0, 70.0, 95.0, scale=4.0, tint=(1.0, 0.8, 0.5)),
              PlaneShot(40.0, 80.0, 92.0, scale=6.0, tint=(0.3, 0.6, 1.0)))  # fmt: skip
OTHER_SHOTS = (PlaneShot(-110.0, -70.0, -40.0, scale=3.0, tint=(0.9, 0.3, 0.9)),
               PlaneShot(-20.0, 30.0, 120.0, scale=8.0, tint=(0.4, 1.0, 0.4)))  # fmt: skip
