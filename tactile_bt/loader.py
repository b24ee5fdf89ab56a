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
:func:`describe_nodes` lists every node type with its parameters (docs/trees.md is made from it).
"""

from __future__ import annotations

import inspect
import re
from dataclasses import dataclass, field
from difflib import get_close_matches
from pathlib import Path
from typing import Any, Literal

import py_trees

from tactile_bt.behaviours import DECORATORS, LEAVES
from tactile_bt.behaviours.parameters import (
    ParameterInfo,
    ParameterTypeError,
    bind_blackboard,
    convert_parameter,
    describe_type,
    normalise_key,
    parameters_of,
)
from tactile_bt.yamlutil import Located, YamlError, load_located, plain

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

TreeError = YamlError

POLICIES = {
    "success_on_all": lambda sync: py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=sync),
    "success_on_one": lambda sync: py_trees.common.ParallelPolicy.SuccessOnOne(),
}
_MISSING = inspect.Parameter.empty
_NODES = "list of nodes"
_NODE = "node"

#: Parameters of the composites (py_trees' Sequence, Selector and Parallel).
COMPOSITES: dict[str, list[ParameterInfo]] = {
    "sequence": [
        ParameterInfo("name", str, "sequence", None, "Name of the node."),
        ParameterInfo("memory", bool, True, None,
                      "Resume at the running child on the next tick (true) or start again from the first "
                      "child every tick (false)."),
        ParameterInfo("children", _NODES, _MISSING, None, "The children, ticked in order until one does not succeed."),
    ],
    "selector": [
        ParameterInfo("name", str, "selector", None, "Name of the node."),
        ParameterInfo("memory", bool, True, None,
                      "Resume at the running child (true) or re-check higher-priority children every tick (false)."),
        ParameterInfo("children", _NODES, _MISSING, None, "The children, tried in order until one does not fail."),
    ],
    "parallel": [
        ParameterInfo("name", str, "parallel", None, "Name of the node."),
        ParameterInfo("policy", Literal["success_on_all", "success_on_one"], "success_on_all", None,
                      "SUCCESS when all children have succeeded, or as soon as one has; FAILURE as soon as "
                      "one fails."),
        ParameterInfo("synchronise", bool, False, None,
                      "With success_on_all: do not tick children that already succeeded."),
        ParameterInfo("children", _NODES, _MISSING, None,
                      "The children, all ticked every tick: running servo leaves superimpose their "
                      "projections (paper Eq. 3)."),
    ],
}
_COMPOSITE_SUMMARY = {
    "sequence": "Tick the children in order; FAILURE at the first failure, SUCCESS when all succeeded.",
    "selector": "Tick the children in order; SUCCESS at the first success, FAILURE when all failed.",
    "parallel": "Tick every child each tick; the policy decides SUCCESS, any failure is FAILURE.",
}
_SUBTREE_KEYS = ("name", "params")
_DEFINITION_KEYS = ("description", "params", "root")
_TOP_KEYS = ("name", "description", "include", "subtrees", "root")
_PARAM_REF = re.compile(r"^\$([A-Za-z_]\w*)$")
_IDENTIFIER = re.compile(r"^[A-Za-z_]\w*$")

NODE_TYPES = sorted((*COMPOSITES, *DECORATORS, *LEAVES, "subtree"))


def node_types() -> list[str]:
    """Every built-in node type, including those added with :func:`register_node`."""
    return sorted((*COMPOSITES, *DECORATORS, *LEAVES, "subtree"))


def register_node(type_name: str, cls: type, decorator: bool = False) -> None:
    """Make a behaviour class of your own a YAML node type.

    Its parameters are the keyword arguments of ``cls.__init__`` with type hints (``float``,
    ``int``, ``bool``, ``str``, ``Literal[...]``, ``Sequence[float]``) and defaults, exactly as
    for the built-in leaves; a decorator class takes its child as the first argument ``child``.
    """
    if not _IDENTIFIER.match(type_name):
        raise ValueError(f"node type {type_name!r} must be an identifier")
    if type_name in node_types():
        raise ValueError(f"node type {type_name!r} exists already")
    if not (isinstance(cls, type) and issubclass(cls, py_trees.behaviour.Behaviour)):
        raise TypeError(f"{cls!r} is not a py_trees behaviour class")
    (DECORATORS if decorator else LEAVES)[type_name] = cls


# ------------------------------------------------------------------------------ errors


def _error(loc: Located, message: str, field: str | None = None) -> YamlError:
    err = loc.error(message)
    err.message = message  # type: ignore[attr-defined]
    err.field = field  # type: ignore[attr-defined]
    return err


def _message_of(exc: YamlError) -> str:
    message = getattr(exc, "message", None)
    if message is not None:
        return message
    prefix = str(YamlError("", exc.file, exc.line, exc.column))
    return str(exc)[len(prefix):]


def _with_context(exc: YamlError, context: str) -> YamlError:
    message = _message_of(exc) + context
    new = YamlError(message, exc.file, exc.line, exc.column)
    new.message = message  # type: ignore[attr-defined]
    new.field = getattr(exc, "field", None)  # type: ignore[attr-defined]
    return new


def _hint(name: str, options) -> str:
    close = get_close_matches(str(name), [str(o) for o in options], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _origin(loc: Located) -> str:
    return f"{loc.file}:{loc.line}:{loc.column}"


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


# ------------------------------------------------------------------------------ subtrees


@dataclass
class _Subtree:
    name: str
    where: Located  # the name key of the definition
    params: dict[str, Located | None]  # default value, or None when required
    param_keys: dict[str, Located]
    root: Located
    description: str = ""
    used: bool = False
    defaults_used: set = field(default_factory=set)  # parameters whose default some use took


def _parse_subtrees(doc: Located, table: dict[str, _Subtree]) -> None:
    section = doc.value["subtrees"]
    if not isinstance(section.value, dict):
        raise _error(section, "subtrees: expected a mapping of subtree name → definition", "subtrees")
    for name, body in section.value.items():
        where = section.keys[name]
        if not _IDENTIFIER.match(name):
            raise _error(where, f"subtree name {name!r} must be an identifier (letters, digits, _)", "subtrees")
        if name in node_types():
            raise _error(where, f"subtree name {name!r} is a built-in node type; choose another name", "subtrees")
        if name in table:
            other = table[name].where
            raise _error(where, f"subtree {name!r} is defined twice (also at {_origin(other)})", "subtrees")
        table[name] = _parse_definition(name, where, body)


def _parse_definition(name: str, where: Located, body: Located) -> _Subtree:
    field = f"subtrees.{name}"
    v = body.value
    if isinstance(v, dict) and "root" in v:
        for key in v:
            if key not in _DEFINITION_KEYS:
                raise _error(body.keys[key], f"{field}: unknown key {key!r}{_hint(key, _DEFINITION_KEYS)}; "
                                             f"valid: {', '.join(_DEFINITION_KEYS)}", field)
        params_loc = v.get("params")
        params: dict[str, Located | None] = {}
        param_keys: dict[str, Located] = {}
        if params_loc is not None and params_loc.value is not None:
            if not isinstance(params_loc.value, dict):
                raise _error(params_loc, f"{field}.params: expected a mapping of parameter → default "
                                         "(null for a required parameter)", f"{field}.params")
            for p, default in params_loc.value.items():
                if not _IDENTIFIER.match(p):
                    raise _error(params_loc.keys[p], f"{field}.params: parameter name {p!r} must be an identifier",
                                 f"{field}.params")
                params[p] = None if default.value is None else default
                param_keys[p] = params_loc.keys[p]
        description = plain(v["description"]) if "description" in v else ""
        sub = _Subtree(name, where, params, param_keys, v["root"], str(description or ""))
    elif isinstance(v, dict) and ("params" in v or "description" in v):
        raise _error(body, f"{field}: a subtree with params or a description needs its node under 'root'", field)
    elif isinstance(v, dict) and len(v) == 1:
        sub = _Subtree(name, where, {}, {}, body)  # shorthand: name → node, no parameters
    else:
        raise _error(body, f"{field}: a subtree is a node, or a mapping with 'root' (and optional 'params', "
                           "'description')", field)
    used = set(_parameter_uses(sub.root))
    for ref, loc in _parameter_uses(sub.root).items():
        if ref not in sub.params:
            raise _error(loc, f"{field}: unknown parameter ${ref}{_hint(ref, sub.params)}; "
                              f"declared: {', '.join(sub.params) or 'none (declare them under params)'}", field)
    for p in sub.params:
        if p not in used:
            raise _error(sub.param_keys[p], f"{field}.params: parameter {p!r} is never used in the body "
                                            f"(write ${p} where its value goes)", f"{field}.params")
    return sub


def _parameter_uses(loc: Located, found: dict[str, Located] | None = None) -> dict[str, Located]:
    found = {} if found is None else found
    v = loc.value
    if isinstance(v, str):
        m = _PARAM_REF.match(v.strip())
        if m:
            found.setdefault(m.group(1), loc)
    elif isinstance(v, dict):
        for item in v.values():
            _parameter_uses(item, found)
    elif isinstance(v, list):
        for item in v:
            _parameter_uses(item, found)
    return found


def _substitute(loc: Located, env: dict[str, Located]) -> Located:
    v = loc.value
    if isinstance(v, str):
        m = _PARAM_REF.match(v.strip())
        return env[m.group(1)] if m else loc
    if isinstance(v, dict):
        new = Located({k: _substitute(item, env) for k, item in v.items()}, loc.file, loc.line, loc.column)
        new.keys = loc.keys  # type: ignore[attr-defined]
        return new
    if isinstance(v, list):
        return Located([_substitute(item, env) for item in v], loc.file, loc.line, loc.column)
    return loc


# ------------------------------------------------------------------------------ building


@dataclass
class _Builder:
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

    # -- subtrees -----------------------------------------------------------------------------
    def subtree_node(self, body: Located, key_loc: Located):
        if not isinstance(body.value, dict) or "name" not in body.value:
            raise _error(body if body.value is not None else key_loc,
                         "subtree: expected {name: SUBTREE, params: {...}}", "subtree.name")
        for key in body.value:
            if key not in _SUBTREE_KEYS:
                raise _error(body.keys[key], f"subtree: unknown key {key!r}{_hint(key, _SUBTREE_KEYS)}; "
                                             f"valid: {', '.join(_SUBTREE_KEYS)}", f"subtree.{key}")
        name_loc = body.value["name"]
        name = name_loc.value
        if name not in self.subtrees:
            known = ", ".join(sorted(self.subtrees)) or "none defined (add them under the top-level 'subtrees')"
            raise _error(name_loc, f"subtree.name: unknown subtree {name!r}{_hint(name, self.subtrees)}; "
                                   f"known: {known}", "subtree.name")
        return self.expand(self.subtrees[name], body.value.get("params"), name_loc)

    def expand(self, sub: _Subtree, args: Located | None, call: Located):
        if sub.name in self.stack:
            chain = " → ".join([*self.stack[self.stack.index(sub.name):], sub.name])
            raise _error(call, f"subtree recursion: {chain}", sub.name)
        items: dict[str, Located] = {}
        if args is not None and args.value is not None:
            if not isinstance(args.value, dict):
                raise _error(args, f"{sub.name}: parameters must be a mapping, got {plain(args.value)!r}", sub.name)
            items = args.value
        env: dict[str, Located] = {}
        for key, value in items.items():
            if key not in sub.params:
                declared = ", ".join(sub.params) or "none"
                raise _error(args.keys[key], f"{sub.name}: unknown parameter {key!r}{_hint(key, sub.params)}; "
                                             f"the subtree declares: {declared}", f"{sub.name}.{key}")
            env[key] = value
        missing = []
        for p, default in sub.params.items():
            if p not in env:
                if default is None:
                    missing.append(p)
                else:
                    env[p] = default
                    sub.defaults_used.add(p)
        if missing:
            raise _error(call, f"{sub.name}: missing parameter(s) {', '.join(missing)} "
                               f"(the subtree defined at {_origin(sub.where)} has no default for them)", sub.name)
        sub.used = True
        self.stack.append(sub.name)
        try:
            return self.node(_substitute(sub.root, env), default_name=sub.name)
        except YamlError as exc:
            if getattr(exc, "_in_subtree", False):
                raise
            new = _with_context(exc, f" (in subtree {sub.name!r}, used at {_origin(call)})")
            new._in_subtree = True  # type: ignore[attr-defined]
            raise new from None
        finally:
            self.stack.pop()


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


# ------------------------------------------------------------------------------ reference


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
    text = inspect.cleandoc(cls.__doc__ or "")
    return " ".join(text.split("\n\n")[0].split())


def describe_nodes() -> dict[str, NodeDoc]:
    """Every YAML node type with its parameters, types, units and defaults, from the registry
    and the classes' signatures and docstrings (docs/trees.md is generated from this)."""
    out: dict[str, NodeDoc] = {}
    for name, params in COMPOSITES.items():
        cls = {"sequence": py_trees.composites.Sequence, "selector": py_trees.composites.Selector,
               "parallel": py_trees.composites.Parallel}[name]
        out[name] = NodeDoc(name, "composite", cls, _COMPOSITE_SUMMARY[name], list(params))
    for name, cls in DECORATORS.items():
        child = ParameterInfo("child", _NODE, _MISSING, None, "The decorated node.")
        out[name] = NodeDoc(name, "decorator", cls, _summary(cls), [*parameters_of(cls), child])
    for name, cls in LEAVES.items():
        out[name] = NodeDoc(name, "leaf", cls, _summary(cls), parameters_of(cls))
    return out


def _format_default(value: Any) -> str:
    if value is _MISSING:
        return "required"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_format_default(float(v) if isinstance(v, int) and not isinstance(v, bool) else v)
                               for v in value) + "]"
    return str(value)


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
            lines += ["| parameter | type | unit | default | meaning |", "|---|---|---|---|---|"]
            for p in doc.parameters:
                kind_name = p.annotation if isinstance(p.annotation, str) else describe_type(p.annotation)
                kind_name = kind_name.replace(" | ", " \\| ")
                meaning = p.doc.replace("|", "\\|")
                lines.append(f"| `{p.name}` | {kind_name} | {p.unit or ''} | {_format_default(p.default)} | {meaning} |")
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


if __name__ == "__main__":  # python -m tactile_bt.loader docs/trees.md
    import sys

    for target in sys.argv[1:] or ["docs/trees.md"]:
        print(f"{target}: {'updated' if update_reference(target) else 'up to date'}")
