"""The package's layers (docs/architecture.md): the library imports neither face, and the two faces,
``vergence.cli`` and ``vergence.web``, import each other nowhere but at the one launcher named here."""

from __future__ import annotations

import ast
from pathlib import Path

import vergence

PACKAGE = Path(vergence.__file__).parent

# (importing module, imported face): the only arrows allowed between a face and the rest.
# `vergence serve` starts the workbench: the command line's launcher of the web face.
LAUNCHERS = {("vergence.cli.serve", "vergence.web")}


def _imports(path: Path) -> set[str]:
    """Every module an import statement of ``path`` names, at any depth (lazy imports included)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def _module(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _face(name: str) -> str | None:
    for face in ("vergence.cli", "vergence.web"):
        if name == face or name.startswith(face + "."):
            return face
    return None


def test_no_arrow_between_the_faces_and_none_from_the_library_to_a_face():
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = _module(path)
        home = _face(module) if module != "vergence.__main__" else "vergence.cli"
        for imported in _imports(path):
            face = _face(imported)
            if face is None or face == home or (module, face) in LAUNCHERS:
                continue
            wrong.append(f"{module} imports {imported}")
    assert wrong == []


def test_the_check_sees_an_arrow(tmp_path):
    # the scan reads lazy imports inside functions too
    source = tmp_path / "m.py"
    source.write_text("def f():\n    from vergence.cli._app import scene_rig\n    import vergence.web.app\n")
    assert _imports(source) == {"vergence.cli._app", "vergence.web.app"}
