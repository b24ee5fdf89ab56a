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
``oneshot``. Leaves take the parameters their classes in :mod:`tactile_bt.tree.behaviours`
declare (:class:`~tactile_bt.tree.declaration.Parameter`), checked against the declared types and
ranges (finite numbers, with the sign physics demands) before anything is built. Numbers for
parameters with a unit also take a unit (``target_pa: 2 kPa``, ``target_rad: 90 deg``); a
quoted number is a number. A
parameter value ``{blackboard: /key}`` or ``"@/key"`` is read from the blackboard each time the
node starts.

``load_tree(path, params=[...], blackboard=[...])`` sets parameters (``"NODE.PARAM=VALUE"``, as
``tactile-bt run --param``) before the tree is built, with the same checks, and blackboard keys
the tree reads (``"KEY=VALUE"``, as ``--blackboard``), written when the tree is set up.

Lengths in tactels (``band: 0.5 px``) are converted to metres when the tree is loaded, with the
pitch of ``load_tree(..., pad=...)`` (a :class:`~tactile_bt.sense.geometry.PadGeometry`; default
``PadGeometry()``, 5 mm). :func:`~tactile_bt.mission.run.run_mission` loads a tree file with the
scene's pad; a tree loaded (or built) in Python keeps the conversions of the pad it was given,
so load it with the pad of the scene or sensor it will run on. Blackboard references in tactels
are converted when the node starts, with the pad on the blackboard (``/tactile/pad``).

Every error names the file, line and column and the field, and suggests the closest valid name.

This module builds and checks trees; the pieces around it live next to it: the node registry
(:mod:`tactile_bt.tree.registry`: :data:`COMPOSITES`, :func:`node_types`, :func:`register_node`),
the located messages (:mod:`tactile_bt.tree.diagnostics`), the named subtrees and their
``$param`` substitution (:mod:`tactile_bt.tree.subtrees`) and the node reference
(:mod:`tactile_bt.tree.reference`: :func:`describe_nodes` lists every node type with its
parameters; ``python -m tactile_bt.tree.reference docs/trees.md`` regenerates docs/trees.md).

Layer: tree.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees
from py_trees.common import Access

from tactile_bt import shipped
from tactile_bt.arguments import option_error, parse_assignments
from tactile_bt.errors import ParameterTypeError, ParameterValueError, TreeError
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.tree.behaviours import DECORATORS, LEAVES
from tactile_bt.tree.blackboard import NAMESPACE
from tactile_bt.tree.composites import Parallel, Selector, Sequence
from tactile_bt.tree.diagnostics import did_you_mean, located_error, origin_of
from tactile_bt.tree.parameters import (Bound, bind_blackboard, convert_parameter, describe_type, node_label,
                                        normalise_key, parameters_of, uses_pad_units)
from tactile_bt.tree.registry import COMPOSITES, POLICIES, format_parameter, load_entry_points, node_types
from tactile_bt.tree.subtrees import PARAM_REF, Subtree, SubtreeExpansion, parse_subtrees
from tactile_bt.units import element_unit
from tactile_bt.yamlutil import Located, load_located, plain

__all__ = ["load_tree", "LoadedTree", "NodeParameters", "format_parameters", "build_node"]

_TOP_KEYS = ("name", "description", "include", "subtrees", "root")


# ------------------------------------------------------------------------------ values


def _check_type(value: Located, annotation: Any, field: str, unit: str | None = None, bound: Bound | None = None,
                label: str | None = None, pad: PadGeometry | None = None) -> Any:
    """Check a located value against a parameter's type hint and bound; return it in its Python
    form (strings with a unit converted to ``unit``, tactels with the pitch of ``pad``). Errors
    name the value's position (the bad element of a list) and the field; a value out of bounds
    also names the node (``label``, e.g. ``force_hold 'hold'``)."""
    v = value.value
    name = field.rsplit(".", 1)[-1]
    node = label or field.rsplit(".", 1)[0]
    if isinstance(v, list) and describe_type(annotation) == "list[float]":
        for i, element in enumerate(v):  # element by element, so that the error points at the bad one
            try:
                convert_parameter(element.value, float, element_unit(unit, i), bound, name, pad)
            except ParameterTypeError as exc:
                problem = exc.detail or f"expected a list of numbers, got {plain(v)!r}"
                raise located_error(element, f"{field}: {_hinted(problem, element.value)}", field) from None
            except ParameterValueError as exc:
                message = ParameterValueError(name, exc.detail, i).message
                raise located_error(element, f"{node}: {message}", field) from None
    try:
        return convert_parameter(plain(v), annotation, unit, bound, name, pad)
    except ParameterTypeError as exc:
        raise located_error(value, f"{field}: {_hinted(str(exc), plain(v))}", field) from None
    except ParameterValueError as exc:
        raise located_error(value, f"{node}: {exc.message}", field) from None


def _hinted(problem: str, value: Any) -> str:
    if isinstance(value, str) and PARAM_REF.match(value.strip()):
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
        raise located_error(key_loc or value, f"{field}: {exc}", field) from None


# ------------------------------------------------------------------------------ building


@dataclass
class NodeParameters:
    """The resolved parameters of one node of a loaded tree (``tree.node_parameters``), after
    subtree substitution, unit conversion and ``--param`` overrides.

    ``values`` maps every parameter (but ``name`` and the children) to its value in SI units,
    or to ``"@/key"`` for a blackboard reference; ``sources`` says where each came from:
    ``default``, the ``file:line:column`` of the value, ``--param NODE.PARAM`` or the reference.
    """

    type: str
    kind: str  # "composite", "decorator" or "leaf"
    name: str
    node: py_trees.behaviour.Behaviour
    values: dict[str, Any]
    units: dict[str, str | None]
    sources: dict[str, str]
    where: Located  # the node's type key


@dataclass
class _Surveyed:
    """A node met by the survey that resolves ``--param`` targets (nothing is checked or built)."""

    index: int
    kind: str
    type: str
    name: str
    cls: type | None
    where: Located


def _node_name(body: Located, default: str, override: dict[str, Located] | None = None) -> str:
    """The name a node will have: ``name`` given in its body (or by an override), else ``default``."""
    for items in (override or {}, body.value if isinstance(body.value, dict) else {}):
        given = items.get("name")
        if given is not None and isinstance(given.value, str):
            return given.value
    return default


def _class_default_name(cls, type_name: str) -> str:
    p = {p.name: p for p in parameters_of(cls)}.get("name")
    return p.default if p is not None and isinstance(p.default, str) else type_name


@dataclass
class _Builder(SubtreeExpansion):
    """Builds nodes from located YAML, expanding the uses of the named ``subtrees``.

    Every composite, decorator and leaf gets an index in build order (the same in every pass
    over the same file). With ``survey`` the builder only notes each node's index, type and
    name (``surveyed``) and builds placeholders, so that ``--param`` targets can be resolved
    even when a value in the file is bad; ``overrides`` (index → parameter → located value)
    replaces or adds parameters of the nodes with those indices. ``records`` collects the
    resolved parameters of every node built. ``pad`` converts lengths in tactels.
    """

    subtrees: dict[str, Subtree] = field(default_factory=dict)
    stack: list[str] = field(default_factory=list)
    survey: bool = False
    overrides: dict[int, dict[str, Located]] = field(default_factory=dict)
    surveyed: list[_Surveyed] = field(default_factory=list)
    records: list[NodeParameters] = field(default_factory=list)
    count: int = 0
    pad: PadGeometry = field(default_factory=PadGeometry)
    pad_fields: list[str] = field(default_factory=list)

    def node(self, node: Located, default_name: str | None = None) -> py_trees.behaviour.Behaviour:
        if not isinstance(node.value, dict) or len(node.value) != 1:
            raise located_error(node, "a node is a mapping with exactly one key, its type "
                               f"(one of: {', '.join(self.types())})")
        (type_name, body), = node.value.items()
        key_loc = node.keys[type_name]
        if type_name in COMPOSITES or type_name in DECORATORS or type_name in LEAVES:
            index = self.count
            self.count += 1
        if type_name in COMPOSITES:
            return self.composite(type_name, body, key_loc, default_name, index)
        if type_name in DECORATORS:
            return self.decorator(type_name, body, key_loc, default_name, index)
        if type_name in LEAVES:
            return self.leaf(LEAVES[type_name], type_name, body, key_loc, default_name, index)
        if type_name == "subtree":
            return self.subtree_node(body, key_loc)
        if type_name in self.subtrees:
            return self.expand(self.subtrees[type_name], body, key_loc)
        hint = did_you_mean(type_name, self.types()) or (
            " (a node type of your own? install its package, or import the module that registers it with "
            "--plugin MODULE)")
        raise located_error(key_loc, f"unknown node type {type_name!r}{hint}", type_name)

    def types(self) -> list[str]:
        return [*node_types(), *sorted(self.subtrees)]

    # -- leaves and decorators --------------------------------------------------------------
    def _kwargs(self, cls, body: Located, type_name: str, label: str, override: dict[str, Located],
                reserved=()) -> tuple[dict, dict, dict]:
        """(kwargs, value locations, blackboard references) of a leaf or decorator body, with
        the ``--param`` values of ``override`` in place of the file's."""
        if body.value is None:
            body_items: dict[str, Located] = {}
        elif not isinstance(body.value, dict):
            raise located_error(body, f"{type_name}: parameters must be a mapping, got {plain(body.value)!r}", type_name)
        else:
            body_items = body.value
        params = {p.name: p for p in parameters_of(cls)}
        fixed = getattr(cls, "fixed_parameters", frozenset({"name"}))
        kwargs, locs, refs = {}, {}, {}
        for key, value in {**body_items, **override}.items():
            if key in reserved:
                continue
            field = f"{type_name}.{key}"
            if key not in params:
                raise located_error(body.keys[key], f"{type_name}: unknown parameter {key!r}{did_you_mean(key, params)}; "
                                             f"valid: {', '.join(params) or 'none'}", field)
            locs[key] = value
            ref = _reference(value, field)
            if ref is not None:
                if key in fixed:
                    raise located_error(value, f"{field}: this parameter is fixed when the tree is built; "
                                        "it cannot come from the blackboard", field)
                if params[key].required:
                    raise located_error(value, f"{field}: a required parameter cannot come from the blackboard", field)
                refs[key] = (ref, origin_of(value))
                continue
            p = params[key]
            kwargs[key] = _check_type(value, p.annotation, field, p.unit, p.bound, label, self.pad)
            if uses_pad_units(plain(value.value)):
                self.pad_fields.append(f"{origin_of(value)} {field}")
        missing = [n for n, p in params.items() if p.required and n not in kwargs and n not in refs]
        if missing:
            raise located_error(body, f"{type_name}: missing parameter(s) {', '.join(missing)}", type_name)
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
            raise located_error(loc, message, field) from None
        for param, (key, origin) in refs.items():
            bind_blackboard(node, param, key, origin)
        return node

    def _record(self, kind: str, type_name: str, node, params, kwargs: dict, locs: dict, refs: dict,
                override: dict, key_loc: Located) -> None:
        values, units, sources = {}, {}, {}
        for p in params:
            if p.name in ("name", "child", "children"):
                continue
            units[p.name] = p.unit
            if p.name in refs:
                values[p.name], sources[p.name] = f"@{refs[p.name][0]}", "blackboard"
            elif p.name in kwargs:
                values[p.name] = kwargs[p.name]
                sources[p.name] = origin_of(locs[p.name]) if p.name not in override else str(locs[p.name].file)
            else:
                values[p.name], sources[p.name] = p.default, "default"
        self.records.append(NodeParameters(type_name, kind, node.name, node, values, units, sources, key_loc))

    def _survey(self, kind: str, type_name: str, cls, name: str, index: int, key_loc: Located) -> None:
        self.surveyed.append(_Surveyed(index, kind, type_name, name, cls, key_loc))

    def leaf(self, cls, type_name: str, body: Located, key_loc: Located, default_name: str | None, index: int = -1):
        override = self.overrides.get(index, {})
        name = _node_name(body, default_name or _class_default_name(cls, type_name), override)
        if self.survey:
            self._survey("leaf", type_name, cls, name, index, key_loc)
            return py_trees.behaviours.Dummy(name)
        kwargs, locs, refs = self._kwargs(cls, body, type_name, node_label(cls, name), override)
        if default_name is not None and "name" not in kwargs:
            kwargs["name"] = default_name
        node = self._construct(cls, type_name, kwargs, locs, refs, key_loc)
        self._record("leaf", type_name, node, parameters_of(cls), kwargs, locs, refs, override, key_loc)
        return node

    def decorator(self, type_name: str, body: Located, key_loc: Located, default_name: str | None, index: int = -1):
        cls = DECORATORS[type_name]
        if not isinstance(body.value, dict) or "child" not in body.value:
            where = body if body.value is not None else key_loc
            extra = ""
            if isinstance(body.value, dict) and "children" in body.value:
                where, extra = body.keys["children"], " (not 'children': a decorator has exactly one child)"
            raise located_error(where, f"{type_name}: a decorator needs its node under 'child'{extra}", f"{type_name}.child")
        override = self.overrides.get(index, {})
        name = _node_name(body, default_name or _class_default_name(cls, type_name), override)
        if self.survey:
            self._survey("decorator", type_name, cls, name, index, key_loc)
            self.node(body.value["child"])
            return py_trees.behaviours.Dummy(name)
        kwargs, locs, refs = self._kwargs(cls, body, type_name, node_label(cls, name), override, reserved=("child",))
        if default_name is not None and "name" not in kwargs:
            kwargs["name"] = default_name
        record = len(self.records)  # the decorator's record goes before its child's
        child = self.node(body.value["child"])
        node = self._construct(cls, type_name, kwargs, locs, refs, key_loc, child=child)
        self._record("decorator", type_name, node, parameters_of(cls), kwargs, locs, refs, override, key_loc)
        self.records.insert(record, self.records.pop())
        return node

    # -- composites ---------------------------------------------------------------------------
    def composite(self, type_name: str, body: Located, key_loc: Located, default_name: str | None, index: int = -1):
        if not isinstance(body.value, dict):
            raise located_error(body, f"{type_name}: expected a mapping with 'children'", type_name)
        spec = {p.name: p for p in COMPOSITES[type_name]}
        values, locs = {}, {}
        for key, value in body.value.items():
            field = f"{type_name}.{key}"
            if key not in spec:
                raise located_error(body.keys[key], f"{type_name}: unknown parameter {key!r}{did_you_mean(key, spec)}; "
                                             f"valid: {', '.join(spec)}", field)
            if key == "children":
                continue
            if _reference(value, field) is not None:
                raise located_error(value, f"{field}: composite parameters cannot come from the blackboard", field)
            values[key] = _check_type(value, spec[key].annotation, field)
            locs[key] = value
        name = values.get("name", default_name or type_name)
        if self.survey:
            self._survey("composite", type_name, None, name, index, key_loc)
        record = len(self.records)  # the composite's record goes before its children's
        children_loc = body.value.get("children")
        if children_loc is None or not isinstance(children_loc.value, list) or not children_loc.value:
            raise located_error(children_loc or body, f"{type_name}: 'children' must be a non-empty list of nodes",
                         f"{type_name}.children")
        children = [self.node(c) for c in children_loc.value]
        if type_name == "parallel":
            policy = values.get("policy", "success_on_all")
            sync = values.get("synchronise", False)
            if sync and policy != "success_on_all":
                raise located_error(body.value["synchronise"], "parallel.synchronise: only meaningful with policy "
                                                        "success_on_all", "parallel.synchronise")
            composite = Parallel(name=name, policy=POLICIES[policy](sync))
        else:
            cls = Sequence if type_name == "sequence" else Selector
            composite = cls(name=name, memory=values.get("memory", True))
        composite.add_children(children)
        if not self.survey:
            self._record("composite", type_name, composite, COMPOSITES[type_name], values, locs, {}, {}, key_loc)
            self.records.insert(record, self.records.pop())
        return composite


def build_node(node: Located) -> py_trees.behaviour.Behaviour:
    """Build one node (and its children) from its located YAML mapping (no subtrees)."""
    return _Builder().node(node)


# ------------------------------------------------------------------------------ --param and --blackboard


def _located(value: Any, source: str) -> Located:
    """A plain value as a :class:`Located` from ``source`` (no line: the value is not in a file)."""
    if isinstance(value, dict):
        loc = Located({str(k): _located(v, source) for k, v in value.items()}, source, None, None)  # type: ignore[arg-type]
        loc.keys = {str(k): Located(str(k), source, None, None) for k in value}  # type: ignore[attr-defined, arg-type]
        return loc
    if isinstance(value, (list, tuple)):
        return Located([_located(v, source) for v in value], source, None, None)  # type: ignore[arg-type]
    return Located(value, source, None, None)  # type: ignore[arg-type]


def _parse_assignments(items, option: str, what: str) -> list[tuple[str, str, Located]]:
    """A mapping key → value, or ``KEY=VALUE`` strings (:func:`~tactile_bt.arguments.parse_assignments`),
    as (key, source, located value)."""
    if isinstance(items, dict):
        pairs = [(str(k), f"{option} {k}", v) for k, v in items.items()]
    else:
        pairs = parse_assignments(items, option, what)
    return [(key, source, _located(value, source)) for key, source, value in pairs]


def _resolve_overrides(params, surveyed: list[_Surveyed]) -> dict[int, dict[str, Located]]:
    """Node index → parameter → value of the ``--param NODE.PARAM=VALUE`` overrides.

    NODE is a node's name (every leaf or decorator of that name), or else its type when exactly
    one node has it. Unknown nodes and parameters are errors that list the valid ones.
    """
    targets = [s for s in surveyed if s.kind != "composite"]
    names = list(dict.fromkeys(s.name for s in targets))
    overrides: dict[int, dict[str, Located]] = {}
    for key, source, value in _parse_assignments(params, "--param", "NODE.PARAM"):
        if "." not in key:
            raise option_error(source, f"expected NODE.PARAM=VALUE (a node's name or type, a dot and one of "
                                        f"its parameters); nodes: {', '.join(names) or 'none'}")
        node, param = key.rsplit(".", 1)
        chosen = [s for s in targets if s.name == node]
        if not chosen:
            by_type = [s for s in targets if s.type == node]
            if len(by_type) > 1:
                raise option_error(source, f"{len(by_type)} nodes are of type {node!r} (named "
                                            f"{', '.join(repr(s.name) for s in by_type)}): give one's name")
            chosen = by_type
        if not chosen:
            composite = next((s for s in surveyed if node in (s.name, s.type)), None)
            if composite is not None:
                raise option_error(source, f"{node!r} is a {composite.type} (a composite): --param sets the "
                                            f"parameters of leaves and decorators; nodes: {', '.join(names)}")
            candidates = [*names, *dict.fromkeys(s.type for s in targets)]
            raise option_error(source, f"no node named {node!r}{did_you_mean(node, candidates)}; "
                                        f"nodes: {', '.join(names) or 'none'}")
        for s in chosen:
            params = [p.name for p in parameters_of(s.cls)]
            if param not in params:
                raise option_error(source, f"{node_label(s.cls, s.name)} has no parameter {param!r}"
                                            f"{did_you_mean(param, params)}; parameters: {', '.join(params)}", key)
            overrides.setdefault(s.index, {})[param] = value
    return overrides


def _keys_read(root: py_trees.behaviour.Behaviour) -> list[str]:
    """The blackboard keys the nodes of a tree read, apart from the mission's ``/tactile`` keys."""
    keys: dict[str, None] = {}
    for node in root.iterate():
        for client in node.blackboards:
            for key in sorted(client.read):
                if not key.startswith(NAMESPACE + "/"):
                    keys[key] = None
    return list(keys)


def _key_uses(key: str, records: list[NodeParameters]) -> list[tuple[NodeParameters, str]]:
    """(node, parameter) of every value that the blackboard ``key`` gives: the parameters that
    reference it, and for keys a node reads on every tick (``key_parameters`` of its class, e.g.
    ``guided_slide``'s ``twist_key`` → ``twist``) the parameter the key stands in for."""
    uses = []
    for record in records:
        if record.kind == "composite":
            continue
        for name, value in record.values.items():
            if record.sources[name] == "blackboard" and value == f"@{key}":
                uses.append((record, name))
        for key_param, like in getattr(type(record.node), "key_parameters", {}).items():
            given = record.values.get(key_param)
            if isinstance(given, str) and given and normalise_key(given) == key:
                uses.append((record, like))
    return uses


def _probe(record: NodeParameters, parameter: str, value: Any, source: str) -> None:
    """Build a throwaway copy of ``record``'s node with ``parameter`` = ``value``, so that the
    class's own checks (e.g. a twist of six numbers) judge a blackboard value before the run."""
    kwargs = {n: v for n, v in record.values.items() if record.sources[n] != "blackboard"}
    kwargs[parameter] = value
    extra = {"child": py_trees.behaviours.Dummy()} if record.kind == "decorator" else {}
    try:
        probe = type(record.node)(name=record.name, **extra, **kwargs)
    except ValueError as exc:
        raise option_error(source, str(exc)) from None
    _discard(probe)


def _blackboard_values(items, root, records: list[NodeParameters], pad: PadGeometry,
                       pad_fields: list[str]) -> dict[str, Any]:
    """Key → value of the ``--blackboard KEY=VALUE`` settings, each checked like the parameters
    it gives (type, unit, range and the class's own checks; tactels with the pitch of ``pad``,
    noted in ``pad_fields``)."""
    read = _keys_read(root)
    values: dict[str, Any] = {}
    for key, source, value in _parse_assignments(items, "--blackboard", "KEY"):
        try:
            key = normalise_key(key)
        except ValueError as exc:
            raise option_error(source, str(exc)) from None
        if key not in read:
            raise option_error(source, f"the tree reads no blackboard key {key!r}{did_you_mean(key, read)}; "
                                        f"it reads: {', '.join(read) or 'none'}")
        converted = plain(value)
        if uses_pad_units(converted):
            pad_fields.append(source)
        for record, name in _key_uses(key, records):
            info = {p.name: p for p in parameters_of(type(record.node))}[name]
            label = node_label(type(record.node), record.name)
            converted = _check_type(value, info.annotation, f"{record.type}.{name}", info.unit, info.bound, label,
                                    pad)
            _probe(record, name, converted, source)
        values[key] = converted
    return values


class LoadedTree(py_trees.trees.BehaviourTree):
    """The tree :func:`load_tree` returns: a py_trees BehaviourTree that also knows its source
    (``source``, ``tree_name``, ``description``), the resolved parameters of its nodes
    (``node_parameters``, a list of :class:`NodeParameters` in build order) and the blackboard
    values to write before it runs (``blackboard_values``, from ``--blackboard``): ``setup()``
    writes them, so they are in place when the mission (or a test harness) starts ticking.
    ``pad`` is the pad whose pitch converted the lengths given in tactels, ``pad_fields`` the
    places (``file:line:column field``, or the option) that gave one."""

    source: str = ""
    tree_name: str = ""
    description: str = ""
    node_parameters: list[NodeParameters]
    blackboard_values: dict[str, Any]
    pad: PadGeometry
    pad_fields: list[str]

    def __init__(self, root: py_trees.behaviour.Behaviour) -> None:
        super().__init__(root)
        self.node_parameters = []
        self.blackboard_values = {}
        self.pad = PadGeometry()
        self.pad_fields = []
        self._writer: py_trees.blackboard.Client | None = None

    def check_pad(self, pad: PadGeometry, where: str) -> None:
        """Raise :class:`TreeError` when lengths in tactels of this tree were converted with
        another pitch than that of ``pad``, the pad it is about to run on (``where`` names it,
        e.g. the scene file)."""
        if self.pad_fields and self.pad.pitch != pad.pitch:
            raise TreeError(f"{', '.join(self.pad_fields)}: lengths in tactels were converted with a "
                            f"{self.pad.pitch * 1e3:g} mm pitch, {where} has {pad.pitch * 1e3:g} mm; "
                            f"load the tree with load_tree(..., pad=) of that pad")

    def write_blackboard(self) -> None:
        """Write ``blackboard_values`` (an absolute key → value) to the blackboard."""
        if not self.blackboard_values:
            return
        if self._writer is None:
            self._writer = py_trees.blackboard.Client(name=f"{self.tree_name or 'tree'}/--blackboard")
        for key, value in self.blackboard_values.items():
            if not self._writer.is_registered(key, access=Access.WRITE):
                self._writer.register_key(key=key, access=Access.WRITE)
            self._writer.set(key, value, overwrite=True)

    def setup(self, *args, **kwargs) -> None:
        self.write_blackboard()
        super().setup(*args, **kwargs)


def format_parameters(tree: LoadedTree) -> str:
    """Every node of a loaded tree with its resolved parameters, one row per parameter:
    ``node  type  parameter  value  unit  source`` (``tactile-bt tree FILE --params``)."""
    rows = [("node", "type", "parameter", "value", "unit", "source")]
    for record in tree.node_parameters:
        for name, value in record.values.items():
            rows.append((record.name, record.type, name, format_parameter(value), record.units.get(name) or "",
                         record.sources[name]))
        if not record.values:
            rows.append((record.name, record.type, "", "", "", ""))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows)


# ------------------------------------------------------------------------------ files


def _discard(node: py_trees.behaviour.Behaviour) -> None:
    """Unregister the blackboard clients of nodes built only to be checked."""
    for n in node.iterate():
        for client in n.blackboards:
            client.unregister(clear=False)


def _collect_subtrees(doc: Located, path: Path, table: dict[str, Subtree], seen: set[Path]) -> None:
    if "include" in doc.value:
        inc = doc.value["include"]
        entries = inc.value if isinstance(inc.value, list) else [inc]
        for entry in entries:
            if not isinstance(entry.value, str):
                raise located_error(entry, f"include: expected a file name, got {plain(entry.value)!r}", "include")
            target = (path.parent / entry.value).resolve()
            if target in seen:
                continue
            seen.add(target)
            if not target.is_file():
                raise located_error(entry, f"include: no such file {entry.value!r} (looked for {target})", "include")
            included = load_located(target)
            if not isinstance(included.value, dict):
                raise located_error(included, "an included file must be a mapping with 'subtrees'")
            _check_top_keys(included)
            _collect_subtrees(included, target, table, seen)
    if "subtrees" in doc.value:
        parse_subtrees(doc, table)


def _check_top_keys(doc: Located) -> None:
    for key in doc.value:
        if key not in _TOP_KEYS:
            raise located_error(doc.keys[key], f"unknown top-level key {key!r}{did_you_mean(key, _TOP_KEYS)}; "
                                        f"valid: {', '.join(_TOP_KEYS)}", key)


def load_tree(path: str | Path, text: str | None = None, params=None, blackboard=None,
              pad: PadGeometry | None = None) -> LoadedTree:
    """Load and validate a YAML tree file into a :class:`py_trees.trees.BehaviourTree`
    (a :class:`LoadedTree`).

    ``text`` gives the file's content directly (``path`` then only names it in errors and
    anchors relative ``include`` paths).

    ``pad`` (a :class:`~tactile_bt.sense.geometry.PadGeometry`, default ``PadGeometry()``: the
    paper's 5 mm pitch) converts lengths given in tactels (``band: 0.5 px``) to metres, here at
    load time, before any scene is known. :func:`~tactile_bt.mission.run.run_mission` passes the
    scene's pad when it loads a tree file; a tree loaded or built in Python converts its tactels
    with the pad given here, whatever pad it later runs on, so pass the pad of that scene
    (``scene.sensor.geometry``) or sensor. Blackboard references in tactels are converted when
    their node starts, with the pad on the blackboard.

    ``params`` sets node parameters as ``--param`` does: strings ``"NODE.PARAM=VALUE"`` (or a
    mapping ``{"NODE.PARAM": value}``), where NODE is a node's name as ``tactile-bt tree``
    shows it (every leaf or decorator of that name) or its type when only one node has it, and
    VALUE is read like a YAML value, units included (``"hold.target_pa=1.5 kPa"``). The value
    replaces the file's before the tree is built, with the same checks; errors name the option
    (``--param hold.target_pa: ...``).

    ``blackboard`` sets blackboard keys the tree reads (blackboard references, ``twist_key``)
    as ``--blackboard`` does: ``"KEY=VALUE"`` strings or a mapping, checked against every
    parameter that references the key, and written when the tree is set up
    (:attr:`LoadedTree.blackboard_values`).

    Every subtree defined in the file is checked too, also when the tree does not use it
    (with its defaults, when it has defaults for all its parameters).

    Raises
    ------
    TreeError
        With file, line and column, for syntax errors, unknown node types, subtrees or
        parameters, wrong types, units or values out of range, missing parameters, bad policies
        and recursion; with the option for bad ``params`` and ``blackboard``.
    """
    load_entry_points()  # node types of installed plugins, once per process
    if text is None:
        path = shipped.resolve(path)  # trees/NAME.yaml names a shipped tree where no such file is here
    doc = load_located(path, text)
    if not isinstance(doc.value, dict):
        raise located_error(doc, "a tree file must be a mapping with a 'root' node")
    _check_top_keys(doc)
    if "root" not in doc.value:
        raise located_error(doc, "a tree file needs a 'root' node", "root")
    pad = PadGeometry() if pad is None else pad
    here = Path(str(path)).resolve()
    subtrees: dict[str, Subtree] = {}
    _collect_subtrees(doc, here, subtrees, {here})
    overrides: dict[int, dict[str, Located]] = {}
    if params:
        survey = _Builder(subtrees, survey=True, pad=pad)
        survey.node(doc.value["root"])
        for sub in subtrees.values():
            sub.used, sub.defaults_used = False, set()
        overrides = _resolve_overrides(params, survey.surveyed)
    builder = _Builder(subtrees, overrides=overrides, pad=pad)
    root = builder.node(doc.value["root"])
    records = list(builder.records)
    pad_fields = list(builder.pad_fields)  # of the tree, not of the unused subtrees checked below
    for sub in subtrees.values():
        # Check the defaults no use has taken (and unused subtrees) by building once with them.
        if not sub.used or sub.defaults_used != set(sub.params):
            if all(d is not None for d in sub.params.values()):
                _discard(builder.expand(sub, None, sub.where))
    tree = LoadedTree(root)
    tree.source = str(path)
    tree.tree_name = plain(doc.value["name"]) if "name" in doc.value else Path(str(path)).stem
    tree.description = str(plain(doc.value["description"])) if "description" in doc.value else ""
    tree.node_parameters = records
    tree.pad = pad
    tree.pad_fields = pad_fields
    if blackboard:
        tree.blackboard_values = _blackboard_values(blackboard, root, records, pad, tree.pad_fields)
    return tree
