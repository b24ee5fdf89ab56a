"""The package keeps its layers: folders in the order of one control cycle, a lower layer never
imports a higher one and no package has an import cycle (import-linter's contracts in
pyproject.toml), and no module reaches into another module's private names."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import tactile_bt

PACKAGE = Path(tactile_bt.__file__).resolve().parent
MODULES = sorted(PACKAGE.rglob("*.py"))


def test_the_layer_contract_is_kept():
    lint = pytest.importorskip("importlinter.cli", reason="import-linter is part of the test extra")
    config = PACKAGE.parent / "pyproject.toml"
    assert lint.lint_imports(config_filename=str(config)) == 0


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_no_module_imports_a_private_name_of_another(path):
    own = _module_name(path)
    offending = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("tactile_bt"):
            if node.module == own:
                continue
            offending += [f"line {node.lineno}: {node.module}.{a.name}" for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")]
    assert not offending, offending


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_every_module_says_its_layer(path):
    """Module docstrings name their layer (the package's own ``__init__`` files describe it)."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    if path.name == "__init__.py" and path.parent != PACKAGE:
        assert "layer" in doc.lower(), f"{path}: the package docstring names no layer"
    elif path.parent != PACKAGE or path.name in LAYERED_TOP_LEVEL:
        assert "Layer:" in doc or "layer" in doc.lower(), f"{path}: the docstring names no layer"


#: Top-level modules that belong to a layer (the others are the entry points: cli, testing, the
#: public ``features`` name, and the package itself).
LAYERED_TOP_LEVEL = {"defaults.py", "errors.py", "yamlutil.py", "progress.py", "arguments.py"}
