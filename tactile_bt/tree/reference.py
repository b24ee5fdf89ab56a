"""The node reference of docs/trees.md, generated from the node registry.

:func:`describe_nodes` lists every YAML node type with its parameters, types, units, ranges,
defaults and meanings, taken from :data:`tactile_bt.tree.registry.COMPOSITES` and from the parameter
declarations of the behaviour classes (:class:`~tactile_bt.tree.declaration.Parameter`); :func:`reference_markdown` renders that as Markdown tables
and :func:`update_reference` rewrites the generated part of a Markdown file.  All of them are
re-exported by :mod:`tactile_bt.tree.loader`; regenerate the reference with
``python -m tactile_bt.tree.reference docs/trees.md``.

Layer: tree.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from pathlib import Path

import py_trees

from tactile_bt.tree.behaviours import DECORATORS, LEAVES
from tactile_bt.tree.composites import Parallel
from tactile_bt.tree.parameters import ParameterInfo, describe_type, parameters_of
from tactile_bt.tree.registry import MISSING, COMPOSITES, format_parameter

__all__ = ["NodeDoc", "describe_nodes", "reference_markdown", "update_reference"]

_NODE = "node"  # the "type" of a decorator's child
#: One-line summary of each composite (the behaviour classes have theirs in their docstrings).
_COMPOSITE_SUMMARY = {
    "sequence": "Tick the children in order; FAILURE at the first failure, SUCCESS when all succeeded.",
    "selector": "Tick the children in order; SUCCESS at the first success, FAILURE when all failed.",
    "parallel": "Tick every child each tick; the policy decides SUCCESS, any failure is FAILURE.",
}


@dataclass(frozen=True)
class NodeDoc:
    """One YAML node type: its kind (composite, decorator, leaf), the class it builds, a
    one-line summary and its parameters."""

    type: str
    kind: str
    cls: type
    summary: str
    parameters: list[ParameterInfo]


def _summary(cls) -> str:
    """First paragraph of a class docstring, on one line."""
    text = inspect.cleandoc(cls.__doc__ or "")
    return " ".join(text.split("\n\n")[0].split())


def describe_nodes() -> dict[str, NodeDoc]:
    """Every YAML node type with its parameters, types, units and defaults, from the registry
    and the classes' parameter declarations (docs/trees.md is generated from this)."""
    out: dict[str, NodeDoc] = {}
    for name, params in COMPOSITES.items():
        cls = {"sequence": py_trees.composites.Sequence, "selector": py_trees.composites.Selector,
               "parallel": Parallel}[name]
        out[name] = NodeDoc(name, "composite", cls, _COMPOSITE_SUMMARY[name], list(params))
    for name, cls in DECORATORS.items():
        child = ParameterInfo("child", _NODE, MISSING, None, "The decorated node.")
        out[name] = NodeDoc(name, "decorator", cls, _summary(cls), [*parameters_of(cls), child])
    for name, cls in LEAVES.items():
        out[name] = NodeDoc(name, "leaf", cls, _summary(cls), parameters_of(cls))
    return out


def reference_markdown() -> str:
    """The node reference of docs/trees.md: one table per node type."""
    lines: list[str] = []
    kinds = (("composite", "Composites"), ("decorator", "Decorators"), ("leaf", "Leaves"))
    docs = describe_nodes()
    for kind, title in kinds:
        lines += [f"### {title}", ""]
        for doc in docs.values():
            if doc.kind != kind:
                continue
            module = doc.cls.__module__
            lines += [f"#### `{doc.type}`", "", f"{doc.summary} (`{module}.{doc.cls.__name__}`)", ""]
            lines += ["| parameter | type | unit | range | default | meaning |", "|---|---|---|---|---|---|"]
            for p in doc.parameters:
                kind_name = p.annotation if isinstance(p.annotation, str) else describe_type(p.annotation)
                kind_name = kind_name.replace(" | ", " \\| ")
                meaning = p.doc.replace("|", "\\|")
                bound = str(p.bound) if p.bound is not None else ""
                lines.append(f"| `{p.name}` | {kind_name} | {p.unit or ''} | {bound} | {format_parameter(p.default)} "
                             f"| {meaning} |")
            lines.append("")
    return "\n".join(lines).rstrip() + "\n"


_BEGIN, _END = "<!-- BEGIN describe_nodes -->\n", "<!-- END describe_nodes -->"


def update_reference(path: str | Path) -> bool:
    """Rewrite the generated node reference between the ``describe_nodes`` markers of a
    Markdown file (docs/trees.md); return whether the file changed."""
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    head, rest = text.split(_BEGIN, 1)
    _, tail = rest.split(_END, 1)
    new = head + _BEGIN + "\n" + reference_markdown() + "\n" + _END + tail
    if new != text:
        path.write_text(new, encoding="utf-8")
    return new != text


if __name__ == "__main__":  # python -m tactile_bt.tree.reference docs/trees.md
    import argparse

    parser = argparse.ArgumentParser(prog="python -m tactile_bt.tree.reference",
                                     description="Regenerate the node reference of Markdown files.")
    parser.add_argument("files", nargs="*", default=["docs/trees.md"], help="default: docs/trees.md")
    for target in parser.parse_args().files:
        print(f"{target}: {'updated' if update_reference(target) else 'up to date'}")
