"""The ``vergence stereospace`` group and what its commands share (the internal API of
``vergence.cli.stereospace`` and ``vergence.cli._stereospace_space``, which register on it)."""

from __future__ import annotations

from pathlib import Path

import typer

from vergence.cli._app import app

__all__ = ["camera_index", "stereospace_app"]

stereospace_app = typer.Typer(name="stereospace", help="Browse a calibrated photo collection in stereo (S2): view, "
                              "build, info, pair.",
                              no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False)  # fmt: skip
app.add_typer(stereospace_app, name="stereospace")

# Camera names listed in the message that refuses an unknown one: enough to show the pattern.
_LISTED_NAMES = 5


def camera_index(names: tuple[str, ...], name: str, option: str, roster: dict[str, str] | None = None) -> int:
    """Index of the camera ``name`` (its image's file name, or that name without its extension).

    With ``roster`` (:func:`vergence.stereospace.camera_roster` of the camera file, ``names`` then
    its kept cameras), a camera of the file that the collection left out is named as such (no image,
    unregistered) rather than as unknown.
    """
    if name in names:
        return names.index(name)
    stems = [i for i, n in enumerate(names) if Path(n).stem == name]
    if len(stems) == 1:
        return stems[0]
    if roster is not None:
        found = name if name in roster else next((n for n in roster if Path(n).stem == name), None)
        if found is not None and roster[found] == "no image":
            raise ValueError(f"{option}: camera {found!r} has no image in --images (left out of the collection)")
        if found is not None and roster[found] == "unregistered":
            raise ValueError(f"{option}: camera {found!r} is not registered in CAMERAS (f = 0: left out of the "
                             "collection)")  # fmt: skip
    shown = ", ".join(names[:_LISTED_NAMES]) + (f", ... ({len(names)} cameras)" if len(names) > _LISTED_NAMES else "")
    raise ValueError(f"{option}: no camera {name!r} in the collection; it has {shown}")
