"""``vergence rig plan``'s work: the real cameras of a shot file's Quadri-Rig or Tri-Rig (S0 §5–6)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from vergence.commands._spec import Command, Parameter

if TYPE_CHECKING:
    from vergence.rigs import QuadriRig, Shot, TriRig

__all__ = ["RIG_PLAN", "RigPlan", "rig_plan"]


@dataclass(frozen=True, slots=True)
class RigPlan:
    """The shot and its planned rig."""

    shot: Shot
    rig: QuadriRig | TriRig

    def to_dict(self) -> dict[str, object]:
        """:func:`vergence.rigs.plan_document`: what ``vergence rig plan --json`` prints (``docs/shots.md``)."""
        from vergence.rigs import plan_document

        return plan_document(self.shot, self.rig)


def rig_plan(*, shot: Path) -> RigPlan:
    """The rig of the shot file ``shot`` (:func:`vergence.rigs.load_shot`, :meth:`vergence.rigs.Shot.plan`).

    Raises
    ------
    ValueError, TypeError, OSError
        The shot file's and the planner's one-line refusals (a file's begin with its path).
    """
    from vergence.rigs import load_shot  # SciPy loads with vergence.rigs: not for --help

    loaded = load_shot(shot)
    return RigPlan(loaded, loaded.plan())


RIG_PLAN = Command(
    name="rig plan",
    summary="Plan the real cameras of SHOT: positions, focal lengths (fx and the ratio), baselines.",
    parameters=(
        Parameter("shot", "file", "Shot file (JSON, docs/shots.md).", option=""),
    ),
    work=rig_plan,
)
