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

    ``range_in`` is the shot's nearness (2D + depth) or disparity (stereo, px) range (1st-99th
    percentiles); ``range_px`` the output parallax ``P = x_r - x_l`` it maps to (positive behind the
    screen; :attr:`disparity_out_px` is the same range in the disparity's sign); ``reused`` is True when
    ``--resume`` found its segments finished; ``search`` (stereo) the matching's search range and its
    checks (:mod:`vergence.video.search`), its ``on_bound`` naming an end of ``range_in`` on a search
    bound; ``output`` the output measured (:mod:`vergence.video.measured`); ``window`` the stereo window at
    the frame's edges: ``edge_disparity_px`` (the output's disparity at the left and right edges, positive
    in front of the screen), ``applied`` (the floating window asked for) and ``left_px`` / ``right_px``, the
    columns masked at the left edge of the left view and the right edge of the right one.
    """

    start: int
    end: int
    mapping: LinearMapping
    range_in: tuple[float, float]
    range_px: tuple[float, float]
    reused: bool
    search: dict | None = None
    output: OutputCheck | None = None
    window: dict | None = None

    @property
    def saturated(self) -> bool:
        """Stereo: the matching's content reached past its search range (:mod:`vergence.video.search`)."""
        s = self.search
        return bool(s and (s["saturated_frames"] or s["features_outside"] > SATURATION_SHARE))

    @property
    def disparity_out_px(self) -> tuple[float, float]:
        """The planned output disparity ``D' = -P`` (positive in front of the screen), low to high."""
        return (-self.range_px[1], -self.range_px[0])

    @property
    def budget_used(self) -> float | None:
        """The share of the planned range (the budget) that the output's re-matched 1st-99th percentiles span;
        None when the output was not measured."""
        if self.output is None:
            return None
        lo, hi = self.disparity_out_px
        return (self.output.disparity_px["p99"] - self.output.disparity_px["p1"]) / (hi - lo) if hi > lo else None

    @property
    def window_edges(self) -> tuple[tuple[str, float], ...]:
        """The edges (``"left"``, ``"right"``) whose content the output puts in front of the screen, with its
        disparity there (px): a stereo-window violation unless masked."""
        from vergence.video.analysis import WINDOW_MIN_PX

        if self.window is None:
            return ()
        return tuple((edge, d) for edge, d in zip(("left", "right"), self.window["edge_disparity_px"])
                     if math.isfinite(d) and d > WINDOW_MIN_PX)  # fmt: skip

    def to_dict(self) -> dict:
        """JSON-ready; every disparity in px positive in front of the screen (``docs/conventions.md``)."""
        window = None
        if self.window is not None:
            window = {"edge_disparity_px": [None if not math.isfinite(v) else v for v in self.window["edge_disparity_px"]],
                      "floating_window": [{"edge": e, "width_px": self.window[f"{e}_px"]} for e in ("left", "right")
                                          if self.window[f"{e}_px"] > 0],
                      "violations": [e for e, _ in self.window_edges if not self.window[f"{e}_px"]]}  # fmt: skip
        return {"start": self.start, "end": self.end, "range_in": list(self.range_in),
                "disparity_out_px": list(self.disparity_out_px), "budget_used": self.budget_used,
                "gain": None if self.mapping is None else self.mapping.gain, "reused": self.reused,
                **({} if self.search is None else {"search": self.search, "saturated": self.saturated}),
                "window": window, "output": None if self.output is None else self.output.to_dict()}  # fmt: skip


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
        Frames in the output (fewer than the clip's when it stopped early).
    fps : float
    layout, pixel_format : str
        Output layout (:data:`vergence.display.LAYOUTS`) and chroma format (None for images).
    shots : tuple of ShotConversion
    flicker_before, flicker_after : Flicker
        Frame-to-frame change of the output parallax on static content (px of the views), without and
        with the stabilisation, over the shots converted in this run: the filtered map's, before synthesis.
        :attr:`flicker_output` is the output's, re-matched.
    stopped : str or None
        Why the input ended before its announced length (the frames before were converted), else None.
    seconds : float
        Wall time of the whole conversion.
    rendered : int
        Frames rendered in this run (``frames`` less those of the segments ``resume`` reused).
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
    rendered: int = 0

    @property
    def flicker_output(self) -> Flicker:
        """The flicker measured on the output (re-matched, :mod:`vergence.video.measured`), over the shots measured."""
        checks = [s.output for s in self.shots if s.output is not None and s.output.flicker_pairs]
        count = sum(c.static_share for c in checks)  # shots weigh by their static share
        total = sum(c.flicker_px * c.static_share for c in checks if math.isfinite(c.flicker_px))
        return Flicker(mean_px=total / count if count else math.nan, pairs=sum(c.flicker_pairs for c in checks),
                       static_share=count / len(checks) if checks else 0.0)  # fmt: skip

    def to_dict(self) -> dict:
        """Plain JSON-ready summary (NaN as null)."""
        def number(v: float) -> float | None:
            return None if not math.isfinite(v) else v

        return {
            "out": str(self.out), "kind": self.kind, "frames": self.frames, "rendered": self.rendered, "fps": self.fps,
            "layout": self.layout, "pixel_format": self.pixel_format, "stopped": self.stopped, "seconds": self.seconds,
            "flicker_before_px": number(self.flicker_before.mean_px),
            "flicker_after_px": number(self.flicker_after.mean_px),
            "flicker_output_px": number(self.flicker_output.mean_px),
            "shots": [s.to_dict() for s in self.shots],
            "warnings": list(self.warnings),
        }  # fmt: skip

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per shot whose output does not keep the depth order or passes its plan, whose matching reached
        past its search range or whose range sits on it, or whose content breaks the stereo window unmasked."""
        lines = []
        for k, shot in enumerate(self.shots):
            where = f"shot {k} (frames {shot.start}-{shot.end - 1})"
            out = shot.output
            if out is not None and not out.order_kept:
                lines.append(f"{where}: the output does not keep the source's depth order (rank correlation "
                             f"{out.rank_correlation:.2f} < {DEPTH_ORDER_MIN}, re-matched on frames "
                             f"{', '.join(map(str, out.frames))})")  # fmt: skip
            planned = shot.disparity_out_px
            if out is not None and (out.disparity_px["p1"] < planned[0] - OUTPUT_TOL_PX
                                    or out.disparity_px["p99"] > planned[1] + OUTPUT_TOL_PX):
                lines.append(f"{where}: the output's disparity, re-matched, runs {out.disparity_px['p1']:+.2f} .. "
                             f"{out.disparity_px['p99']:+.2f} px (1-99 %), past the planned {planned[0]:+.2f} .. "
                             f"{planned[1]:+.2f} px")  # fmt: skip
            if out is not None and out.on_bound:
                lines.append(f"{where}: the output's measured {', '.join(out.on_bound)} sit on the re-match's search "
                             f"bound ({out.search_px[0]} .. {out.search_px[1]} px): a bound, not a measure")
            unmasked = [(e, d) for e, d in shot.window_edges if not (shot.window or {}).get(f"{e}_px")]
            if unmasked:
                edges = " and ".join(f"the {e} edge ({d:+.1f} px)" for e, d in unmasked)
                lines.append(f"{where}: content in front of the screen at {edges} breaks the stereo window: "
                             "a floating window (--floating-window) masks it")  # fmt: skip
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
