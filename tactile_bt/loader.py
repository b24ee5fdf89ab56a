"""YAML → py_trees tree, with validation before anything runs.

A tree file has a ``root`` node, optionally a ``name``, a ``description``, named ``subtrees``
and an ``include`` list of files whose subtrees it uses. A node is a mapping with exactly one
key, its type, whose value holds the parameters::

    subtrees:
      touch:                                  # a named subtree with parameters and defaults
        params: {pressure: 800}
        root:
          approach: {speed_mps: 0.01, pressure_pa: $pressure}
    root:
      sequence:
        name: cable_follow
        children:
          - touch: {pressure: 900}            # or {subtree: {name: touch, params: {...}}}
          - parallel:
              policy: success_on_one
              children:
                - force_hold: {target_pa: "@/goal/pressure"}   # read from the blackboard
                - guided_slide: {twist: [0, 0.02, 0, 0, 0, 0]}

Composites: ``sequence`` and ``selector`` (``memory``, default true), ``parallel``
(``policy``: ``success_on_all`` | ``success_on_one``, ``synchronise``). Decorators take their
child under ``child``: ``mission_timeout`` (mission clock), ``retry``, ``repeat``, ``inverter``,
``oneshot``. Leaves take the keyword arguments of their classes in :mod:`tactile_bt.behaviours`,
checked against the type hints before anything is built. Numbers for parameters with a unit in
their name also take a unit (``target_pa: 2 kPa``, ``target_rad: 90 deg``). A parameter value
``{blackboard: /key}`` or ``"@/key"`` is read from the blackboard each time the node starts.

Every error names the file, line and column and the field, and suggests the closest valid name.

This module builds and checks trees; the pieces around it live next to it and are re-exported
here: the node registry (:mod:`tactile_bt.node_registry`: :data:`COMPOSITES`,
:func:`node_types`, :func:`register_node`), the located errors (:mod:`tactile_bt.tree_errors`:
:data:`TreeError`), the named subtrees and their ``$param`` substitution
(:mod:`tactile_bt.subtrees`) and the node reference (:mod:`tactile_bt.tree_reference`:
:func:`describe_nodes` lists every node type with its parameters, docs/trees.md is made from it;
``python -m tactile_bt.loader docs/trees.md`` regenerates it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees

from tactile_bt.behaviours import DECORATORS, LEAVES
from tactile_bt.behaviours.parameters import (
    ParameterTypeError,
    bind_blackboard,
    convert_parameter,
    describe_type,
    normalise_key,
    parameters_of,
)
from tactile_bt.node_registry import COMPOSITES, POLICIES, node_types
from tactile_bt.subtrees import _PARAM_REF, _parse_subtrees, _Subtree, _SubtreeExpansion
from tactile_bt.tree_errors import _error, _hint, _origin
from tactile_bt.yamlutil import Located, load_located, plain

# Re-exported: these names lived in this module before it was split; code imports them from here.
from tactile_bt.node_registry import _IDENTIFIER, _MISSING, _NODES, NODE_TYPES, register_node  # noqa: F401, E402
from tactile_bt.subtrees import (  # noqa: F401, E402
    _DEFINITION_KEYS,
    _SUBTREE_KEYS,
    _parameter_uses,
    _parse_definition,
    _substitute,
)
from tactile_bt.tree_errors import TreeError, _message_of, _with_context  # noqa: F401, E402
from tactile_bt.yamlutil import YamlError  # noqa: F401, E402
from tactile_bt.tree_reference import (  # noqa: F401, E402
    _BEGIN,
    _COMPOSITE_SUMMARY,
    _END,
    _NODE,
    NodeDoc,
    _format_default,
    _summary,
    describe_nodes,
    reference_markdown,
    update_reference,
)

__all__ = [
    "load_tree",
    "build_node",
    "TreeError",
    "NODE_TYPES",
    "node_types",
    "register_node",
    "COMPOSITES",
    "describe_nodes",
    "reference_markdown",
    "update_reference",
    "NodeDoc",
]

_TOP_KEYS = ("name", "description", "include", "subtrees", "root")


# ------------------------------------------------------------------------------ values


def _check_type(value: Located, annotation: Any, field: str, unit: str | None = None) -> Any:
    """Check a located value against a parameter's type hint; return it in its Python form
    (strings with a unit converted to ``unit``). Errors name the value's position and the field."""
    v = value.value
    if isinstance(v, list) and describe_type(annotation) == "list[float]":
        for element in v:  # element by element, so that the error points at the bad one
            try:
                convert_parameter([element.value], annotation, unit)
            except ParameterTypeError as exc:
                problem = exc.detail or f"expected a list of numbers, got {plain(v)!r}"
                raise _error(element, f"{field}: {_hinted(problem, element.value)}", field) from None
    try:
        return convert_parameter(plain(v), annotation, unit)
    except ParameterTypeError as exc:
        raise _error(value, f"{field}: {_hinted(str(exc), plain(v))}", field) from None


def _hinted(problem: str, value: Any) -> str:
    if isinstance(value, str) and _PARAM_REF.match(value.strip()):
        problem += f" ({value!r} names a subtree parameter: it works only inside a subtree's body)"
    return problem


def _reference(value: Located, field: str) -> str | None:
    """The blackboard key of a ``{blackboard: key}`` or ``"@key"`` value, else None."""
    v = value.value
    key_loc = None
    if isinstance(v, dict) and set(v) == {"blackboard"}:
        key_loc = v["blackboard"]
        key = key_loc.value
    elif isinstance(v, str) and v.startswith("@"):
        key = v[1:]
    else:
        return None
    try:
        return normalise_key(key)
    except ValueError as exc:
        raise _error(key_loc or value, f"{field}: {exc}", field) from None


# ------------------------------------------------------------------------------ building


@dataclass
class _Builder(_SubtreeExpansion):
    """Builds nodes from located YAML, expanding the uses of the named ``subtrees``."""

    subtrees: dict[str, _Subtree] = field(default_factory=dict)
    stack: list[str] = field(default_factory=list)

    def node(self, node: Located, default_name: str | None = None) -> py_trees.behaviour.Behaviour:
        if not isinstance(node.value, dict) or len(node.value) != 1:
            raise _error(node, "a node is a mapping with exactly one key, its type "
                               f"(one of: {', '.join(self.types())})")
        (type_name, body), = node.value.items()
        key_loc = node.keys[type_name]
        if type_name in COMPOSITES:
            return self.composite(type_name, body, default_name)
        if type_name in DECORATORS:
            return self.decorator(type_name, body, key_loc, default_name)
        if type_name in LEAVES:
            return self.leaf(LEAVES[type_name], type_name, body, key_loc, default_name)
        if type_name == "subtree":
            return self.subtree_node(body, key_loc)
        if type_name in self.subtrees:
            return self.expand(self.subtrees[type_name], body, key_loc)
        raise _error(key_loc, f"unknown node type {type_name!r}{_hint(type_name, self.types())}", type_name)

    def types(self) -> list[str]:
        return [*node_types(), *sorted(self.subtrees)]

    # -- leaves and decorators --------------------------------------------------------------
    def _kwargs(self, cls, body: Located, type_name: str, reserved=()) -> tuple[dict, dict, dict]:
        """(kwargs, value locations, blackboard references) of a leaf or decorator body."""
        if body.value is None:
            body_items: dict[str, Located] = {}
        elif not isinstance(body.value, dict):
            raise _error(body, f"{type_name}: parameters must be a mapping, got {plain(body.value)!r}", type_name)
        else:
            body_items = body.value
        params = {p.name: p for p in parameters_of(cls)}
        fixed = getattr(cls, "fixed_parameters", frozenset({"name"}))
        kwargs, locs, refs = {}, {}, {}
        for key, value in body_items.items():
            if key in reserved:
                continue
            field = f"{type_name}.{key}"
            if key not in params:
                raise _error(body.keys[key], f"{type_name}: unknown parameter {key!r}{_hint(key, params)}; "
                                             f"valid: {', '.join(params) or 'none'}", field)
            locs[key] = value
            ref = _reference(value, field)
            if ref is not None:
                if key in fixed:
                    raise _error(value, f"{field}: this parameter is fixed when the tree is built; "
                                        "it cannot come from the blackboard", field)
                if params[key].required:
                    raise _error(value, f"{field}: a required parameter cannot come from the blackboard", field)
                refs[key] = (ref, _origin(value))
                continue
            kwargs[key] = _check_type(value, params[key].annotation, field, params[key].unit)
        missing = [n for n, p in params.items() if p.required and n not in kwargs and n not in refs]
        if missing:
            raise _error(body, f"{type_name}: missing parameter(s) {', '.join(missing)}", type_name)
        return kwargs, locs, refs

    def _construct(self, cls, type_name: str, kwargs: dict, locs: dict, refs: dict, key_loc: Located, **extra):
        try:
            node = cls(**extra, **kwargs)
        except ValueError as exc:
            message = str(exc)
            loc, field = key_loc, type_name
            for name in locs:
                if re.search(rf"\b{re.escape(name)}\b", message):
                    loc, field = locs[name], f"{type_name}.{name}"
                    break
            raise _error(loc, message, field) from None
        for param, (key, origin) in refs.items():
            bind_blackboard(node, param, key, origin)
        return node

    def leaf(self, cls, type_name: str, body: Located, key_loc: Located, default_name: str | None):
        kwargs, locs, refs = self._kwargs(cls, body, type_name)
        if default_name is not None and "name" not in kwargs:
            kwargs["name"] = default_name
        return self._construct(cls, type_name, kwargs, locs, refs, key_loc)

    def decorator(self, type_name: str, body: Located, key_loc: Located, default_name: str | None):
        cls = DECORATORS[type_name]
        if not isinstance(body.value, dict) or "child" not in body.value:
            where = body if body.value is not None else key_loc
            extra = ""
            if isinstance(body.value, dict) and "children" in body.value:
                where, extra = body.keys["children"], " (not 'children': a decorator has exactly one child)"
            raise _error(where, f"{type_name}: a decorator needs its node under 'child'{extra}", f"{type_name}.child")
        kwargs, locs, refs = self._kwargs(cls, body, type_name, reserved=("child",))
        if default_name is not None and "name" not in kwargs:
            kwargs["name"] = default_name
        child = self.node(body.value["child"])
        return self._construct(cls, type_name, kwargs, locs, refs, key_loc, child=child)

    # -- composites ---------------------------------------------------------------------------
    def composite(self, type_name: str, body: Located, default_name: str | None):
        if not isinstance(body.value, dict):
            raise _error(body, f"{type_name}: expected a mapping with 'children'", type_name)
        spec = {p.name: p for p in COMPOSITES[type_name]}
        values = {}
        for key, value in body.value.items():
            field = f"{type_name}.{key}"
            if key not in spec:
                raise _error(body.keys[key], f"{type_name}: unknown parameter {key!r}{_hint(key, spec)}; "
                                             f"valid: {', '.join(spec)}", field)
            if key == "children":
                continue
            if _reference(value, field) is not None:
                raise _error(value, f"{field}: composite parameters cannot come from the blackboard", field)
            values[key] = _check_type(value, spec[key].annotation, field)
        name = values.get("name", default_name or type_name)
        children_loc = body.value.get("children")
        if children_loc is None or not isinstance(children_loc.value, list) or not children_loc.value:
            raise _error(children_loc or body, f"{type_name}: 'children' must be a non-empty list of nodes",
                         f"{type_name}.children")
        children = [self.node(c) for c in children_loc.value]
        if type_name == "parallel":
            policy = values.get("policy", "success_on_all")
            sync = values.get("synchronise", False)
            if sync and policy != "success_on_all":
                raise _error(body.value["synchronise"], "parallel.synchronise: only meaningful with policy "
                                                        "success_on_all", "parallel.synchronise")
            composite = py_trees.composites.Parallel(name=name, policy=POLICIES[policy](sync))
        else:
            cls = py_trees.composites.Sequence if type_name == "sequence" else py_trees.composites.Selector
            composite = cls(name=name, memory=values.get("memory", True))
        composite.add_children(children)
        return composite


def build_node(node: Located) -> py_trees.behaviour.Behaviour:
    """Build one node (and its children) from its located YAML mapping (no subtrees)."""
    return _Builder().node(node)


# ------------------------------------------------------------------------------ files


def _discard(node: py_trees.behaviour.Behaviour) -> None:
    """Unregister the blackboard clients of nodes built only to be checked."""
    for n in node.iterate():
        for client in n.blackboards:
            client.unregister(clear=False)


def _collect_subtrees(doc: Located, path: Path, table: dict[str, _Subtree], seen: set[Path]) -> None:
    if "include" in doc.value:
        inc = doc.value["include"]
        entries = inc.value if isinstance(inc.value, list) else [inc]
        for entry in entries:
            if not isinstance(entry.value, str):
                raise _error(entry, f"include: expected a file name, got {plain(entry.value)!r}", "include")
            target = (path.parent / entry.value).resolve()
            if target in seen:
                continue
            seen.add(target)
            if not target.is_file():
                raise _error(entry, f"include: no such file {entry.value!r} (looked for {target})", "include")
            included = load_located(target)
            if not isinstance(included.value, dict):
                raise _error(included, "an included file must be a mapping with 'subtrees'")
            _check_top_keys(included)
            _collect_subtrees(included, target, table, seen)
    if "subtrees" in doc.value:
        _parse_subtrees(doc, table)


def _check_top_keys(doc: Located) -> None:
    for key in doc.value:
        if key not in _TOP_KEYS:
            raise _error(doc.keys[key], f"unknown top-level key {key!r}{_hint(key, _TOP_KEYS)}; "
                                        f"valid: {', '.join(_TOP_KEYS)}", key)


def load_tree(path: str | Path, text: str | None = None) -> py_trees.trees.BehaviourTree:
    """Load and validate a YAML tree file into a :class:`py_trees.trees.BehaviourTree`.

    ``text`` gives the file's content directly (``path`` then only names it in errors and
    anchors relative ``include`` paths).

    Every subtree defined in the file is checked too, also when the tree does not use it
    (with its defaults, when it has defaults for all its parameters).

    Raises
    ------
    TreeError
        With file, line and column, for syntax errors, unknown node types, subtrees or
        parameters, wrong types or units, missing parameters, bad policies and recursion.
    """
    doc = load_located(path, text)
    if not isinstance(doc.value, dict):
        raise _error(doc, "a tree file must be a mapping with a 'root' node")
    _check_top_keys(doc)
    if "root" not in doc.value:
        raise _error(doc, "a tree file needs a 'root' node", "root")
    here = Path(str(path)).resolve()
    subtrees: dict[str, _Subtree] = {}
    _collect_subtrees(doc, here, subtrees, {here})
    builder = _Builder(subtrees)
    root = builder.node(doc.value["root"])
    for sub in subtrees.values():
        # Check the defaults no use has taken (and unused subtrees) by building once with them.
        if not sub.used or sub.defaults_used != set(sub.params):
            if all(d is not None for d in sub.params.values()):
                _discard(builder.expand(sub, None, sub.where))
    tree = py_trees.trees.BehaviourTree(root)
    tree.source = str(path)  # type: ignore[attr-defined]
    tree.tree_name = plain(doc.value["name"]) if "name" in doc.value else Path(str(path)).stem  # type: ignore[attr-defined]
    tree.description = str(plain(doc.value["description"])) if "description" in doc.value else ""  # type: ignore[attr-defined]
    return tree


if __name__ == "__main__":  # python -m tactile_bt.loader docs/trees.md
    import sys

    for target in sys.argv[1:] or ["docs/trees.md"]:
        print(f"{target}: {'updated' if update_reference(target) else 'up to date'}")
