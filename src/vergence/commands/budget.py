"""``vergence budget``'s work: the depth budget of a rig on a display (S0 §2, Eq. 1-6)."""

from __future__ import annotations

from dataclasses import dataclass

from vergence.commands._display import DISPLAY_PARAMETERS, SCREEN_PIXELS, display_from, display_parameter
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.viewing.budget import DepthBudget, depth_budget
from vergence.viewing.geometry import Display, Shooting

__all__ = ["BUDGET", "BudgetReport", "budget", "shooting_from"]


@dataclass(frozen=True, slots=True)
class BudgetReport:
    """The budget and the rig and display it was made for."""

    budget: DepthBudget
    shooting: Shooting
    display: Display

    @property
    def warnings(self) -> tuple[str, ...]:
        return self.budget.warnings

    def to_dict(self) -> dict[str, object]:
        return self.budget.to_dict()


def shooting_from(baseline: float, convergence: float, window: float | None, focal_mm: float | None,
                  sensor_mm: float | None) -> Shooting:
    """The rig from ``window``, or from ``focal_mm`` with ``sensor_mm`` (exactly one of the two).

    Raises
    ------
    ParameterError
        Naming the parameters at fault.
    """
    if window is not None and (focal_mm is not None or sensor_mm is not None):
        raise ParameterError("give either {window} or {focal_mm} with {sensor_mm}, not both")
    with naming(baseline="baseline", convergence="convergence", window="window"):
        if window is not None:
            return Shooting(baseline=baseline, convergence=convergence, window=window)
    if focal_mm is None and sensor_mm is None:
        raise ParameterError("the convergence window is missing: give {window}, or {focal_mm} with {sensor_mm}")
    if sensor_mm is None:
        raise ParameterError("{sensor_mm} (sensor width in mm) is required with {focal_mm}")
    if focal_mm is None:
        raise ParameterError("{focal_mm} (focal length in mm) is required with {sensor_mm}")
    try:
        with naming(baseline="baseline", convergence="convergence", focal_mm="focal_mm", sensor_mm="sensor_mm",
                    window="window"):
            return Shooting.from_focal(baseline=baseline, convergence=convergence, focal_mm=focal_mm,
                                       sensor_mm=sensor_mm)
    except ParameterError as exc:
        if not exc.template.startswith("{window} "):
            raise
        # The window was not given: it is H S / F (S0 §2); say which parameters made it.
        raise ParameterError("the convergence window H S/F from {convergence}, {sensor_mm} and {focal_mm} "
                             + exc.template.removeprefix("{window} ")) from None


def budget(*, baseline: float, convergence: float, window: float | None = None, focal_mm: float | None = None,
           sensor_mm: float | None = None, eye_separation: float | None = None,
           viewing_distance: float | None = None, screen_width: float | None = None,
           screen_pixels: int | None = None, display: str | None = None,
           depth: list[float] | None = None) -> BudgetReport:
    """The depth budget of the rig on the display at ``depth`` (default: :data:`DEFAULT_DEPTH_FACTORS`
    times the convergence distance); see :func:`vergence.viewing.depth_budget`.

    Raises
    ------
    ParameterError
        A value the rig, the display or the depths refuse, naming its parameter.
    """
    shooting = shooting_from(baseline, convergence, window, focal_mm, sensor_mm)
    chosen = display_from(display, eye_separation, viewing_distance, screen_width, screen_pixels)
    with naming(depths="depth"):
        return BudgetReport(depth_budget(shooting, chosen, depth if depth else None), shooting, chosen)


BUDGET = Command(
    name="budget",
    summary="Depth budget of a rig on a display: divergence and roundness baselines, z' and roundness per depth (S0 §2).",
    parameters=(
        Parameter("baseline", "number", "Camera baseline b (m)."),
        Parameter("convergence", "number", "Convergence distance H (m)."),
        Parameter("window", "number", "Convergence-window width W (m).", None),
        Parameter("focal_mm", "number", "Focal length F (mm), with --sensor-mm instead of --window.", None),
        Parameter("sensor_mm", "number", "Sensor width S (mm), with --focal-mm.", None),
        *DISPLAY_PARAMETERS,
        SCREEN_PIXELS,
        display_parameter(),
        Parameter("depth", "numbers", "Scene depth z (m), inf allowed; repeat. Default: 0.5, 0.75, 1, 1.5, 2, 3, 5 "
                  "and 10 times H.", None),
    ),
    work=budget,
)
