"""The packages' layering, read from the source (imports inside functions included).

``robot`` (kinematics, hand-eye, plans, animation) imports neither ``sim``, ``locate`` nor
``cell``; ``sim`` may use ``robot``'s public names but not ``cell``; ``cell`` sits above all
three. No module reaches into ``robot``'s or ``cell``'s private modules from outside them.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import photomodel

SRC = Path(photomodel.__file__).parent
MODULES = sorted(SRC.rglob("*.py"))


def _module_name(path: Path) -> str:
    parts = ("photomodel", *path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, anywhere in it; ``from a import b`` counts as ``a.b``."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: resolve against the importing package
                anchor = package.rsplit(".", node.level - 1)[0]
                base = f"{anchor}.{base}" if base else anchor
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def _under(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


IMPORTS = {_module_name(p): _imports(p) for p in MODULES}


def test_the_source_tree_is_found() -> None:
    assert {"photomodel.robot", "photomodel.sim", "photomodel.cell"} <= set(IMPORTS)


@pytest.mark.parametrize("package, forbidden", [
    ("photomodel.robot", ("photomodel.sim", "photomodel.locate", "photomodel.cell")),
    ("photomodel.sim", ("photomodel.cell",)),
])
def test_lower_packages_do_not_import_higher_ones(package: str,
                                                   forbidden: tuple[str, ...]) -> None:
    bad = sorted(f"{module} imports {name}" for module, names in IMPORTS.items()
                 if _under(module, package) for name in names
                 if any(_under(name, f) for f in forbidden))
    assert bad == []


@pytest.mark.parametrize("package", ["photomodel.robot", "photomodel.cell"])
def test_no_private_imports_into_robot_or_cell_from_outside(package: str) -> None:
    bad = sorted(f"{module} imports {name}" for module, names in IMPORTS.items()
                 if not _under(module, package) for name in names
                 if _under(name, package) and name[len(package) + 1:].startswith("_"))
    assert bad == []


def _subpackage(name: str) -> str | None:
    """The subpackage ``name`` lies in (``photomodel.sim._table`` -> ``sim``), or None for
    the top level (``photomodel``, ``photomodel._files``, ``photomodel.errors``)."""
    parts = name.split(".")
    if len(parts) < 2 or parts[0] != "photomodel" or parts[1].startswith("_") or \
            parts[1] == "errors" or (SRC / parts[1]).is_dir() is False:
        return None
    return parts[1]


WARMUP = "photomodel._warmup"   # compiles every numba kernel, the private ones included


def test_no_module_imports_another_subpackages_private_modules() -> None:
    """Across subpackages only public names (a subpackage's ``__init__``); the top-level
    private modules (``_files``, ``_limits``, ``_jit``) are everyone's."""
    bad = sorted({f"{module} imports {'.'.join(name.split('.')[:3])}"
                  for module, names in IMPORTS.items() if module != WARMUP for name in names
                  if (theirs := _subpackage(name)) is not None
                  and theirs != _subpackage(module)
                  and len(name.split(".")) > 2 and name.split(".")[2].startswith("_")})
    assert bad == []


def test_no_import_cycle_between_subpackages() -> None:
    graph: dict[str, set[str]] = {}
    for module, names in IMPORTS.items():
        mine = _subpackage(module)
        if mine is None:
            continue
        graph.setdefault(mine, set()).update(
            theirs for name in names
            if (theirs := _subpackage(name)) is not None and theirs != mine)
    cycles = []

    def walk(node: str, path: list[str]) -> None:
        for nxt in sorted(graph.get(node, ())):
            if nxt in path:
                cycles.append(" -> ".join([*path[path.index(nxt):], nxt]))
            elif len(path) < len(graph):
                walk(nxt, [*path, nxt])

    for start in sorted(graph):
        walk(start, [start])
    assert sorted(set(cycles)) == []
