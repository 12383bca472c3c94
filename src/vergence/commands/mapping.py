"""``vergence mapping``'s work: the disparity mapping psi built from director constraints (S0 §6, Eq. 7-9)."""

from __future__ import annotations

from dataclasses import dataclass

from vergence.commands._display import DISPLAY_PARAMETERS, display_from, display_parameter
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.viewing.geometry import Shooting
from vergence.viewing.mapping_constraints import ConstrainedMapping, DirectorConstraint, psi_from_constraints

__all__ = ["MAPPING", "MappingReport", "mapping"]


@dataclass(frozen=True, slots=True)
class MappingReport:
    """The mapping and the depths it is reported at (None: 201 samples evenly spaced in d)."""

    mapping: ConstrainedMapping
    depths: tuple[float, ...] | None

    @property
    def warnings(self) -> tuple[str, ...]:
        return tuple(self.mapping.warnings)

    def to_dict(self) -> dict[str, object]:
        return self.mapping.to_dict(depths=None if self.depths is None else list(self.depths))


def mapping(*, reference_baseline: float, convergence: float, window: float, constraint: list[str], near: float,
            far: float, eye_separation: float | None = None, viewing_distance: float | None = None,
            screen_width: float | None = None, display: str | None = None,
            depth: list[float] | None = None) -> MappingReport:
    """psi from the director's ``constraint`` strings (:meth:`DirectorConstraint.from_string`) for the
    reference rig on the display, over the scene ``near``..``far``; see
    :func:`vergence.viewing.psi_from_constraints`.

    Raises
    ------
    ParameterError
        A value the rig, the display, a constraint or the depth range refuse, naming its parameter.
    """
    if near >= far:  # the library would say "far must be > near": name both
        raise ParameterError("{far} must be > {near} " + f"{near:g}; got {far:g}")
    with naming(baseline="reference_baseline", convergence="convergence", window="window", near="near", far="far",
                constraint="constraint", constraints="constraint", depths="depth"):
        reference = Shooting(baseline=reference_baseline, convergence=convergence, window=window)
        chosen = display_from(display, eye_separation, viewing_distance, screen_width)
        constraints = [DirectorConstraint.from_string(text) for text in constraint]
        result = psi_from_constraints(reference, chosen, constraints, near=near, far=far)
        report = MappingReport(result, tuple(depth) if depth else None)
        report.to_dict()  # the depths are checked here, where their errors are named
    return report


MAPPING = Command(
    name="mapping",
    summary="Build the disparity mapping psi from director constraints and report it (S0 §6, Eq. 7–9).",
    parameters=(
        Parameter("reference_baseline", "number", "Reference rig baseline b_r (m)."),
        Parameter("convergence", "number", "Convergence distance H (m)."),
        Parameter("window", "number", "Convergence-window width W (m)."),
        *DISPLAY_PARAMETERS,
        display_parameter(),
        Parameter("constraint", "texts", "Director constraint 'z=Z,perceived=Z[,roundness=R]' (inf allowed); repeat."),
        Parameter("near", "number", "Nearest scene depth (m)."),
        Parameter("depth", "numbers", "Report these scene depths (m, inf allowed; repeat) instead of samples over "
                  "the scene.", None),
        Parameter("far", "number", "Farthest scene depth (m); inf allowed."),
    ),
    work=mapping,
)
