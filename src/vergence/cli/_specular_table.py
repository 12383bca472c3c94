"""``vergence specular --table`` and ``--reoptimise DIR``: the offset table written once, re-solved later.

:func:`scene_source` records in the table where its scene came from (a built-in name, or a file and
its SHA-256) and the options that made it; :func:`reoptimise_folder` reads ``DIR/specular_table.npz``
(:func:`vergence.specular.read_specular_table`), refuses options that contradict it, opens the same
scene at the table's size and re-solves (:func:`vergence.specular.specular_from_table`), then writes
the usual files into ``--out``: all or none.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from vergence.cli import raise_if_interrupted
from vergence.cli._app import check_output_path, console, err_console, open_scene_quietly, options_named, spoken

__all__ = ["reoptimise_folder", "scene_source"]


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def scene_source(spec: str, scene: object, display: str, *, baseline: float | None,
                 convergence: float | None) -> dict:  # fmt: skip
    """What the table records of its making: the scene (``spec`` as typed; for a file its absolute path
    and SHA-256), the size, the display preset and the rig options (None: the scene's)."""
    from vergence.render.builtin import BUILTIN_SCENES

    path = Path(spec)
    is_file = spec not in BUILTIN_SCENES and path.is_file()  # a bare built-in name is the built-in scene
    return {"scene": spec, "path": str(path.resolve()) if is_file else None,
            "sha256": _sha256(path) if is_file else None, "width": scene.camera.width, "height": scene.camera.height,
            "display": display, "baseline": baseline, "convergence": convergence}  # fmt: skip


def _table_values(table: object) -> dict:
    """The options a table fixes, as the command line spells them."""
    src, s = table.source, table.settings
    cam = table.physical_left.camera
    return {"SCENE": src.get("scene"), "--display": src.get("display") or s["display"]["name"],
            "--fit": s["display"]["fit"], "--k": s["k"], "--depth": s["max_depth"], "--samples": s["samples"],
            "--width": cam.width, "--height": cam.height, "--baseline": src.get("baseline"),
            "--convergence": src.get("convergence")}  # fmt: skip


def _read(folder: Path) -> object:
    from vergence.specular import TABLE_FILE, read_specular_table

    if not folder.is_dir():
        what = "is a file" if folder.exists() else "does not exist"
        raise ValueError(f"--reoptimise {folder}: {what}; give the folder of a run made with --table")
    path = folder / TABLE_FILE
    if not path.is_file():
        raise ValueError(f"--reoptimise {folder}: the folder holds no {TABLE_FILE}; write one with vergence specular "
                         f"SCENE --out {folder} --table")  # fmt: skip
    try:
        return read_specular_table(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"--reoptimise: {exc}") from None


def reoptimise_folder(folder: Path, out: Path, *, given: dict, weights: tuple | None, weight_map: list[str],
                      variant: str | None, factor: int | None, anaglyph_method: str) -> tuple:  # fmt: skip
    """Re-solve the table of ``folder`` and write the outputs into ``out``.

    ``given`` maps the options a table fixes (``"--k"``, ``"SCENE"``, ...) to what the user typed
    (None: not given); one that differs from the table is refused. Returns ``(result, file names,
    scene name, display name)``.
    """
    from vergence.cli._spinner import progress_bar

    from vergence.commands import ParameterError
    from vergence.commands._specular import weight_maps
    from vergence.io import atomic_folder
    from vergence.report.specular_outputs import SPECULAR_OUTPUT_FILES, write_specular_outputs
    from vergence.specular import TABLE_FILE, specular_from_table

    table = _read(folder)
    fixed = _table_values(table)
    for option, value in given.items():
        if value is not None and value != fixed[option]:
            unknown = "the scene's" if option in ("--baseline", "--convergence") else "a value it does not record"
            made = unknown if fixed[option] is None else repr(fixed[option])
            raise ValueError(f"--reoptimise {folder}: its table was made with {option} {made}; got {value!r} (the "
                             f"table fixes {option}: run without --reoptimise for a new table)")  # fmt: skip
    src = table.source
    if src.get("path") is not None:
        path = Path(src["path"])
        if not path.is_file():
            raise ValueError(f"--reoptimise {folder}: its scene file {path} is gone; the final render needs it")
        if _sha256(path) != src.get("sha256"):
            raise ValueError(f"--reoptimise {folder}: its scene file {path} changed since the table was written; "
                             "run without --reoptimise for a new table")  # fmt: skip
    from vergence.render.builtin import BUILTIN_SCENES

    name = table.settings.get("scene")  # a table written by the library alone records the scene's name only
    spec = src.get("path") or src.get("scene") or (name if name in BUILTIN_SCENES else None)
    if spec is None:
        raise ValueError(f"--reoptimise {folder}: its table does not say which scene it was made of")
    cam = table.physical_left.camera
    sc = open_scene_quietly(spec, cam.width, cam.height)
    n = table.analysis.importance.shape[1]
    try:
        maps = weight_maps(weight_map, n_layers=n, width=cam.width, height=cam.height)
    except ParameterError as exc:
        raise spoken(exc) from exc
    if out.resolve() == folder.resolve():
        raise ValueError(f"--out must not be the --reoptimise folder {folder}: its {TABLE_FILE} is an input")
    for name in SPECULAR_OUTPUT_FILES:
        check_output_path(out / name, folder / TABLE_FILE, *((Path(src["path"]),) if src.get("path") else ()))
    commit = atomic_folder(out)
    if sc.environment.note:
        err_console.print(f"[yellow]note:[/] {sc.environment.note}", highlight=False, soft_wrap=True)
    with progress_bar(f"specular {sc.name}: re-solving {folder / TABLE_FILE}") as report:
        with options_named(alpha="--weights", variant="--absolute", factor="--factor"):
            result = specular_from_table(table, sc, alpha=weights, variant=variant, maps=maps or None, factor=factor,
                                         progress=report)  # fmt: skip
    del table
    with commit as tmp:  # all files or none, even on Ctrl-C
        names = [p.name for p in write_specular_outputs(result, tmp, anaglyph_method=anaglyph_method)]
        raise_if_interrupted()
    console.print(f"re-solved the table of {folder} (not rendered again)", highlight=False)
    return result.release(), names, sc.name, fixed["--display"] or "(the table's)"
