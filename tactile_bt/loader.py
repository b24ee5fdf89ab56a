"""YAML → py_trees tree.

A tree file has a ``root`` node (and optionally ``name`` and ``description``). A node is a
mapping with exactly one key, its type, whose value holds the parameters::

    root:
      sequence:
        name: cable_follow
        children:
          - approach: {speed_mps: 0.01}
          - parallel:
              policy: success_on_one
              children:
                - force_hold: {target_pa: 2000}
                - guided_slide: {twist: [0, 0.02, 0, 0, 0, 0]}

Composites: ``sequence`` and ``selector`` (``memory``, default true), ``parallel``
(``policy``: ``success_on_all`` | ``success_on_one``, ``synchronise``). Decorators take their
child under ``child``. Leaves take the keyword arguments of their classes in
:mod:`tactile_bt.behaviours`, checked against the type hints before anything is built; every
error names the file, line and column and suggests the closest valid name.
"""

from __future__ import annotations

import inspect
import typing
from collections.abc import Sequence
from difflib import get_close_matches
from pathlib import Path
from typing import Any

import py_trees

from tactile_bt.behaviours import DECORATORS, LEAVES
from tactile_bt.yamlutil import Located, YamlError, load_located, plain

__all__ = ["load_tree", "build_node", "TreeError", "NODE_TYPES"]

TreeError = YamlError

COMPOSITES = ("sequence", "selector", "parallel")
POLICIES = {
    "success_on_all": lambda sync: py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=sync),
    "success_on_one": lambda sync: py_trees.common.ParallelPolicy.SuccessOnOne(),
}
NODE_TYPES = sorted((*COMPOSITES, *DECORATORS, *LEAVES))


def _hint(name: str, options) -> str:
    close = get_close_matches(name, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_type(value: Located, annotation: Any, field: str) -> Any:
    v = value.value
    origin = typing.get_origin(annotation)
    if annotation is bool:
        ok = isinstance(v, bool)
        expected = "true or false"
    elif annotation is int:
        ok = isinstance(v, int) and not isinstance(v, bool)
        expected = "an integer"
    elif annotation is float:
        ok = isinstance(v, (int, float)) and not isinstance(v, bool)
        expected = "a number"
    elif annotation is str:
        ok = isinstance(v, str)
        expected = "a string"
    elif origin in (Sequence, list, tuple) or annotation in (list, tuple):
        ok = isinstance(v, list) and all(
            isinstance(x.value, (int, float)) and not isinstance(x.value, bool) for x in v
        )
        expected = "a list of numbers"
    else:
        return plain(v)
    if not ok:
        raise value.error(f"{field}: expected {expected}, got {plain(v)!r}")
    return plain(v)


def _parameters(cls) -> dict[str, inspect.Parameter]:
    params = dict(inspect.signature(cls.__init__).parameters)
    params.pop("self", None)
    params.pop("child", None)
    return params


def _leaf_kwargs(cls, body: Located, type_name: str, reserved=()) -> dict[str, Any]:
    if body.value is None:
        return {}
    if not isinstance(body.value, dict):
        raise body.error(f"{type_name}: parameters must be a mapping, got {plain(body.value)!r}")
    params = _parameters(cls)
    hints = typing.get_type_hints(cls.__init__)
    kwargs = {}
    for key, value in body.value.items():
        if key in reserved:
            continue
        if key not in params:
            raise body.keys[key].error(
                f"{type_name}: unknown parameter {key!r}{_hint(key, params)}; "
                f"valid: {', '.join(params)}"
            )
        kwargs[key] = _check_type(value, hints.get(key, Any), f"{type_name}.{key}")
    missing = [n for n, p in params.items() if p.default is inspect.Parameter.empty and n not in kwargs]
    if missing:
        raise body.error(f"{type_name}: missing parameter(s) {', '.join(missing)}")
    return kwargs


def build_node(node: Located) -> py_trees.behaviour.Behaviour:
    """Build one node (and its children) from its located YAML mapping."""
    if not isinstance(node.value, dict) or len(node.value) != 1:
        raise node.error("a node is a mapping with exactly one key, its type "
                         f"(one of: {', '.join(NODE_TYPES)})")
    (type_name, body), = node.value.items()
    key_loc = node.keys[type_name]
    if type_name in COMPOSITES:
        return _build_composite(type_name, body, key_loc)
    if type_name in DECORATORS:
        cls = DECORATORS[type_name]
        if not isinstance(body.value, dict) or "child" not in body.value:
            raise body.error(f"{type_name}: a decorator needs a 'child' node")
        kwargs = _leaf_kwargs(cls, body, type_name, reserved=("child",))
        child = build_node(body.value["child"])
        try:
            return cls(child=child, **kwargs)
        except ValueError as exc:
            raise key_loc.error(str(exc)) from None
    if type_name in LEAVES:
        cls = LEAVES[type_name]
        kwargs = _leaf_kwargs(cls, body, type_name)
        try:
            return cls(**kwargs)
        except ValueError as exc:
            raise key_loc.error(str(exc)) from None
    raise key_loc.error(f"unknown node type {type_name!r}{_hint(type_name, NODE_TYPES)}")


def _build_composite(type_name: str, body: Located, key_loc: Located) -> py_trees.behaviour.Behaviour:
    if not isinstance(body.value, dict):
        raise body.error(f"{type_name}: expected a mapping with 'children'")
    allowed = {"name", "children", "memory"} if type_name != "parallel" else {"name", "children", "policy", "synchronise"}
    for key in body.value:
        if key not in allowed:
            raise body.keys[key].error(f"{type_name}: unknown parameter {key!r}{_hint(key, allowed)}; "
                                       f"valid: {', '.join(sorted(allowed))}")
    name = _check_type(body.value["name"], str, f"{type_name}.name") if "name" in body.value else type_name
    children_loc = body.value.get("children")
    if children_loc is None or not isinstance(children_loc.value, list) or not children_loc.value:
        raise (children_loc or body).error(f"{type_name}: 'children' must be a non-empty list of nodes")
    children = [build_node(c) for c in children_loc.value]
    if type_name == "parallel":
        policy_loc = body.value.get("policy")
        policy = _check_type(policy_loc, str, "parallel.policy") if policy_loc else "success_on_all"
        if policy not in POLICIES:
            raise policy_loc.error(f"parallel.policy: unknown policy {policy!r}{_hint(policy, POLICIES)}; "
                                   f"valid: {', '.join(POLICIES)}")
        sync = _check_type(body.value["synchronise"], bool, "parallel.synchronise") if "synchronise" in body.value else False
        composite = py_trees.composites.Parallel(name=name, policy=POLICIES[policy](sync))
    else:
        memory = _check_type(body.value["memory"], bool, f"{type_name}.memory") if "memory" in body.value else True
        cls = py_trees.composites.Sequence if type_name == "sequence" else py_trees.composites.Selector
        composite = cls(name=name, memory=memory)
    composite.add_children(children)
    return composite


def load_tree(path: str | Path, text: str | None = None) -> py_trees.trees.BehaviourTree:
    """Load and validate a YAML tree file into a :class:`py_trees.trees.BehaviourTree`.

    Raises
    ------
    TreeError
        With file, line and column, for syntax errors, unknown node types or parameters, wrong
        types or missing parameters.
    """
    doc = load_located(path, text)
    if not isinstance(doc.value, dict):
        raise doc.error("a tree file must be a mapping with a 'root' node")
    allowed = {"name", "description", "root"}
    for key in doc.value:
        if key not in allowed:
            raise doc.keys[key].error(f"unknown top-level key {key!r}{_hint(key, allowed)}; valid: name, description, root")
    if "root" not in doc.value:
        raise doc.error("a tree file needs a 'root' node")
    root = build_node(doc.value["root"])
    tree = py_trees.trees.BehaviourTree(root)
    tree.source = str(path)  # type: ignore[attr-defined]
    tree.tree_name = plain(doc.value["name"]) if "name" in doc.value else Path(str(path)).stem  # type: ignore[attr-defined]
    return tree
