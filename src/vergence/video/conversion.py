"""What :func:`vergence.video.convert_clip` returns: the conversion of a clip and of each of its shots.

The figures follow ``docs/conventions.md``: a disparity ``D = x_left - x_right`` (px of the views, or
arcmin of vergence on the display) is positive in front of the screen, in the source and in the output
alike, and each percentile key ``pN`` holds the N-th percentile of that signed value. ``range_px`` keeps
the screen parallax ``P = -D`` (positive behind the screen) that :func:`vergence.synthesis.plan_parallax`
plans with, for the library's callers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from vergence.video.measured import DEPTH_ORDER_MIN, OutputCheck
from vergence.video.search import SATURATION_SHARE
from vergence.video.stability import Flicker

if TYPE_CHECKING:
    from vergence.viewing.mapping_operators import LinearMapping

__all__ = ["OUTPUT_TOL_PX", "Conversion", "ShotConversion"]

# The output's re-matched parallax range may pass the planned one by this much (px of the views) before a warning:
# matching noise of the re-match through H.264 (on the plane clips of tests/video/test_convert_budget.py, 0.1-0.2 px).
OUTPUT_TOL_PX = 1.0


@dataclass(frozen=True, slots=True, eq=False)
class ShotConversion:
    """One shot, ``[start, end)``, and the linear psi that maps its range into the budget.

    ``range_in`` is the shot's nearness (2D + depth) or disparity (stereo, px) range; ``range_px``
    the output parallax ``P = x_r - x_l`` it maps to (positive behind the screen); ``reused`` is True
    when ``--resume`` found its segment finished; ``search`` (stereo) the matching's search range and its
    checks (:mod:`vergence.video.search`), its ``on_bound`` naming an end of ``range_in`` on a search bound.
    """

    start: int
    end: int
    mapping: LinearMapping
    range_in: tuple[float, float]
    range_px: tuple[float, float]
    reused: bool
    search: dict | None = None
    output: OutputCheck | None = None

    @property
    def saturated(self) -> bool:
        """Stereo: the matching's content reached past its search range (:mod:`vergence.video.search`)."""
        s = self.search
        return bool(s and (s["saturated_frames"] or s["features_outside"] > SATURATION_SHARE))


@dataclass(frozen=True, slots=True, eq=False)
class Conversion:
    """What :func:`convert_clip` wrote.

    Attributes
    ----------
    out : pathlib.Path
        The video file or the image folder.
    kind : str
        ``"stereo"`` or ``"2d+depth"``.
    frames : int
        Frames converted (fewer than the clip's when it stopped early).
    fps : float
    layout, pixel_format : str
        Output layout (:data:`vergence.display.LAYOUTS`) and chroma format (None for images).
    shots : tuple of ShotConversion
    flicker_before, flicker_after : Flicker
        Frame-to-frame change of the output parallax on static content (px of the views), without and
        with the stabilisation, over the shots converted in this run.
    stopped : str or None
        Why the input ended before its announced length (the frames before were converted), else None.
    seconds : float
        Wall time of the whole conversion.
    """

    out: Path
    kind: str
    frames: int
    fps: float
    layout: str
    pixel_format: str | None
    shots: tuple[ShotConversion, ...]
    flicker_before: Flicker
    flicker_after: Flicker
    stopped: str | None
    seconds: float

    def to_dict(self) -> dict:
        """Plain JSON-ready summary."""
        return {
            "out": str(self.out), "kind": self.kind, "frames": self.frames, "fps": self.fps, "layout": self.layout,
            "pixel_format": self.pixel_format, "stopped": self.stopped, "seconds": self.seconds,
            "flicker_before_px": self.flicker_before.mean_px, "flicker_after_px": self.flicker_after.mean_px,
            "shots": [{"start": s.start, "end": s.end, "range_in": list(s.range_in), "range_px": list(s.range_px),
                       "gain": None if s.mapping is None else s.mapping.gain, "reused": s.reused,
                        **({} if s.search is None else {"search": s.search, "saturated": s.saturated}),
                        "output": None if s.output is None else s.output.to_dict()}
                       for s in self.shots],
            "warnings": list(self.warnings),
        }  # fmt: skip

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per stereo shot whose matching reached past its search range or whose range sits on it."""
        lines = []
        for k, shot in enumerate(self.shots):
            where = f"shot {k} (frames {shot.start}-{shot.end - 1})"
            out = shot.output
            if out is not None and not out.order_kept:
                lines.append(f"{where}: the output does not keep the source's depth order (rank correlation "
                             f"{out.rank_correlation:.2f} < {DEPTH_ORDER_MIN}, re-matched on frames "
                             f"{', '.join(map(str, out.frames))})")  # fmt: skip
            if out is not None and (out.range_px[0] < shot.range_px[0] - OUTPUT_TOL_PX
                                    or out.range_px[1] > shot.range_px[1] + OUTPUT_TOL_PX):
                lines.append(f"{where}: the output's parallax, re-matched, runs {out.range_px[0]:+.2f} .. "
                             f"{out.range_px[1]:+.2f} px (1-99 %), past the planned {shot.range_px[0]:+.2f} .. "
                             f"{shot.range_px[1]:+.2f} px")  # fmt: skip
            if out is not None and out.on_bound:
                lines.append(f"{where}: the output's measured {', '.join(out.on_bound)} sit on the re-match's search "
                             f"bound ({out.search_px[0]} .. {out.search_px[1]} px): a bound, not a measure")
            if shot.search is None:
                continue
            lo, hi = shot.search["search_px"]
            if shot.saturated:
                lines.append(f"{where}: its content reaches past the disparity search range ({lo} .. {hi} px): "
                             f"{shot.search['saturated_frames']} frames with matches piled up at a bound, "
                             f"{100 * shot.search['features_outside']:.0f} % of its features outside; its depth "
                             "beyond is lost: give a wider search range")  # fmt: skip
            if shot.search["on_bound"]:
                lines.append(f"{where}: its disparity range {shot.range_in[0]:+.1f} .. {shot.range_in[1]:+.1f} px "
                             f"({', '.join(shot.search['on_bound'])}) sits on the search bound ({lo} .. {hi} px)")
        return tuple(lines)
