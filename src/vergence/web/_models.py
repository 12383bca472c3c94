"""The base of the workbench's request bodies: what every JSON model of a page or job refuses."""

from __future__ import annotations

import types
import typing
from typing import Any

import pydantic

__all__ = ["RequestModel", "no_boolean"]


def no_boolean(value: object) -> object:
    """``value`` unless it is JSON ``true``/``false`` where a number is due (pydantic reads them as 1 and 0)."""
    if isinstance(value, bool):
        raise ValueError("expected a number")
    return value


def _numeric(annotation: Any) -> bool:
    """Whether a field's type takes a number and not a boolean (``int``, ``float | None``, ...)."""
    leaves, todo = set(), [annotation]
    while todo:
        a = todo.pop()
        origin = typing.get_origin(a)
        if origin is typing.Annotated:
            todo.append(typing.get_args(a)[0])
        elif origin in (typing.Union, types.UnionType):
            todo += typing.get_args(a)
        else:
            leaves.add(a)
    return bool(leaves & {int, float}) and bool not in leaves


class RequestModel(pydantic.BaseModel):
    """A request body: unknown fields refused, and JSON ``true``/``false`` never read as a number
    (pydantic would take them as 1 and 0: a render of ``"width": true`` is no request anyone meant).
    A refusal names the field: ``width: expected a number (got True)``."""

    model_config = pydantic.ConfigDict(extra="forbid")

    @pydantic.field_validator("*", mode="before")
    @classmethod
    def _no_boolean_numbers(cls, value: Any, info: pydantic.ValidationInfo) -> Any:
        field = cls.model_fields.get(info.field_name or "")
        return no_boolean(value) if field is not None and _numeric(field.annotation) else value
