"""Load a script of docs/ (``docs/unseen_scans.py``, ...) as a module, for the tests of its
functions: the docs folder is not a package, and its scripts import one another by name."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def load_docs_script(name: str):
    """The module of ``docs/<name>.py``, registered as ``name`` (dataclasses look their module
    up), with docs/ on the path so that its own imports resolve."""
    docs = str(REPO / "docs")
    if docs not in sys.path:
        sys.path.insert(0, docs)
    spec = importlib.util.spec_from_file_location(name, REPO / "docs" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
