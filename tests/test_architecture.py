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


# ------------------------------------------------------------------ private names across modules
# A helper that several modules use is part of its package's internal API: it has a public name in a
# module that says so (a private module of public names, as vergence.io._camera_files or
# vergence.viewing._shared), never a ``_name`` imported from another module. Importing a private
# *module* (``from vergence.render import _kernels``) is fine: its names are its package's internals.


def _is_module(name: str) -> bool:
    path = PACKAGE.parent.joinpath(*name.split("."))
    return path.is_dir() or path.with_suffix(".py").is_file()


def _private_imports(path: Path, module: str) -> list[tuple[str, str]]:
    """(imported module, name) for every ``from M import _name`` of ``path`` (lazy ones too) where M is
    another module of the package and ``_name`` is not a module."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:  # relative: resolved against the importing module's package
            base = package.split(".")[: len(package.split(".")) - node.level + 1]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        if source.split(".")[0] != "vergence" or source == module:
            continue
        for alias in node.names:
            name = alias.name
            if name.startswith("_") and not name.startswith("__") and not _is_module(f"{source}.{name}"):
                found.append((source, name))
    return found


def _private_imports_across_modules() -> list[str]:
    return [f"{module} imports {name} from {source}"
            for path in sorted(PACKAGE.rglob("*.py"))
            for module in [_module(path)]
            for source, name in _private_imports(path, module)]


def test_no_module_imports_a_private_name_of_another():
    assert _private_imports_across_modules() == []


def test_the_check_sees_a_private_name_and_lets_a_private_module_through(tmp_path):
    source = tmp_path / "m.py"
    source.write_text("from vergence.render import _kernels\nfrom vergence.io._files import read_bytes\n\n\n"
                      "def f():\n    from vergence.metrics import _patch_contrast\n")
    assert _private_imports(source, "vergence.m") == [("vergence.metrics", "_patch_contrast")]


# ------------------------------------------------------------------ import cycles
# No two modules import each other (issue 31 found six pairs). Imports under ``if TYPE_CHECKING:``
# are annotations only and do not count; nor does a package's ``__init__`` with its own submodules
# (``vergence.cli.main`` runs ``vergence.cli._run``, which reads the package's Ctrl-C state).


def _runtime_imports(path: Path, module: str) -> set[str]:
    """Modules of the package that ``path`` imports at run time (lazy imports included), resolved to
    module names (``from vergence.x import name`` names ``vergence.x.name`` when that is a module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for n in ast.walk(node)}
    out = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("vergence")}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            if not base.startswith("vergence"):
                continue
            for a in node.names:
                out.add(f"{base}.{a.name}" if _is_module(f"{base}.{a.name}") else base)
    return out


def test_no_two_modules_import_each_other():
    graph = {_module(p): _runtime_imports(p, _module(p)) for p in sorted(PACKAGE.rglob("*.py"))}
    pairs = []
    for a, imported in graph.items():
        for b in imported:
            if a < b and a in graph.get(b, ()) and not (b.startswith(a + ".") or a.startswith(b + ".")):
                pairs.append(f"{a} <-> {b}")
    assert pairs == []


def test_the_cycle_check_sees_a_cycle_and_skips_annotations(tmp_path):
    source = tmp_path / "m.py"
    source.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from vergence.camera import Camera\n"
                      "def f():\n    from vergence.render import raytree\n")
    assert _runtime_imports(source, "vergence.m") == {"vergence.render.raytree"}
