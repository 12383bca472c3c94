"""A named camera of a planned rig (Quadri-Rig, Tri-Rig): which element it acquires, for which eye."""

from __future__ import annotations

import re
from dataclasses import dataclass

from vergence.camera import Camera

__all__ = ["ELEMENT_NAME_PATTERN", "RIG_EYES", "RigCamera"]

RIG_EYES = ("left", "right")
"""The eyes a rig camera serves: it is a source of that eye's view."""

ELEMENT_NAME_PATTERN = r"[A-Za-z0-9][A-Za-z0-9_-]*"
"""Element names: letters, digits, ``_`` and ``-``, starting with a letter or digit. Camera names
(``f"{element}_{eye}"``) become file names (``cameras/subject_left.png``): no separators, no spaces."""


def check_element_name(name: object, *, what: str = "element name") -> str:
    """``name`` if it is a str matching :data:`ELEMENT_NAME_PATTERN`, else TypeError/ValueError naming it."""
    if not isinstance(name, str):
        raise TypeError(f"{what} must be a str; got {type(name).__name__}")
    if re.fullmatch(ELEMENT_NAME_PATTERN, name) is None:
        raise ValueError(f"{what} must be letters, digits, '_' or '-' (starting with a letter or digit); got {name!r}")
    return name


@dataclass(frozen=True, slots=True)
class RigCamera:
    """One real camera of a rig.

    Attributes
    ----------
    name : str
        Unique in the rig; a file name (``f"{element}_{eye}"`` for a Quadri-Rig, the element for a Tri-Rig).
    element : str
        The scene element it acquires (a Quadri-Rig element, or ``"director"``, ``"subject"``, ``"background"``).
    eye : str
        ``"left"`` or ``"right"`` (:data:`RIG_EYES`): the virtual view it is a source of.
    camera : Camera
        Its pinhole model.
    """

    name: str
    element: str
    eye: str
    camera: Camera

    def __post_init__(self) -> None:
        check_element_name(self.name, what="name")
        check_element_name(self.element, what="element")
        if self.eye not in RIG_EYES:
            raise ValueError(f"eye must be one of {', '.join(RIG_EYES)}; got {self.eye!r}")
        if not isinstance(self.camera, Camera):
            raise TypeError(f"camera must be a vergence.camera.Camera; got {type(self.camera).__name__}")

    def to_dict(self) -> dict[str, object]:
        """``{"name", "element", "eye", "camera": Camera.to_dict()}`` (the ``rig plan --json`` entry)."""
        return {"name": self.name, "element": self.element, "eye": self.eye, "camera": self.camera.to_dict()}
