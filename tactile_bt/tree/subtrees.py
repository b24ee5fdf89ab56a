"""Named subtrees of a YAML tree file: their definitions, ``$param`` substitution and expansion.

A tree file, or a file it includes, defines subtrees under ``subtrees``::

    subtrees:
      touch:                                  # with parameters, their defaults and a body
        description: Approach until the pad presses.
        params: {pressure: 800, speed: null}  # null: required at every use
        root:
          approach: {speed_mps: $speed, pressure_pa: $pressure}
      settle:                                 # shorthand: name -> node, no parameters
        force_hold: {target_pa: 900}

This module parses and checks the definitions (:func:`parse_subtrees`: identifiers, no clash
with a built-in node type, every declared parameter used and every ``$name`` declared) and
substitutes the arguments of a use into a body (:func:`_substitute`); :class:`SubtreeExpansion`
turns a use into nodes, with the recursion check and the use's position in its errors, as part
of the tree builder of :mod:`tactile_bt.tree.loader`.

Layer: tree.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from tactile_bt.tree.registry import IDENTIFIER, node_types
from tactile_bt.tree.diagnostics import located_error, did_you_mean, origin_of, with_context
from tactile_bt.yamlutil import Located, plain
from tactile_bt.errors import YamlError

_SUBTREE_KEYS = ("name", "params")  # keys of a use written as {subtree: {...}}
_DEFINITION_KEYS = ("description", "params", "root")  # keys of a definition
PARAM_REF = re.compile(r"^\$([A-Za-z_]\w*)$")  # a "$name" value: a subtree parameter


@dataclass
class Subtree:
    """A parsed subtree definition, and whether (and with which defaults) it has been used."""

    name: str
    where: Located  # the name key of the definition
    params: dict[str, Located | None]  # default value, or None when required
    param_keys: dict[str, Located]
    root: Located
    description: str = ""
    used: bool = False
    defaults_used: set = field(default_factory=set)  # parameters whose default some use took


def parse_subtrees(doc: Located, table: dict[str, Subtree]) -> None:
    """Parse the ``subtrees`` section of a file into ``table`` (name -> definition)."""
    section = doc.value["subtrees"]
    if not isinstance(section.value, dict):
        raise located_error(section, "subtrees: expected a mapping of subtree name → definition", "subtrees")
    for name, body in section.value.items():
        where = section.keys[name]
        if not IDENTIFIER.match(name):
            raise located_error(where, f"subtree name {name!r} must be an identifier (letters, digits, _)", "subtrees")
        if name in node_types():
            raise located_error(where, f"subtree name {name!r} is a built-in node type; choose another name", "subtrees")
        if name in table:
            other = table[name].where
            raise located_error(where, f"subtree {name!r} is defined twice (also at {origin_of(other)})", "subtrees")
        table[name] = _parse_definition(name, where, body)


def _parse_definition(name: str, where: Located, body: Located) -> Subtree:
    """Parse and check one definition (full form or shorthand) of subtree ``name``."""
    field = f"subtrees.{name}"
    v = body.value
    if isinstance(v, dict) and "root" in v:
        for key in v:
            if key not in _DEFINITION_KEYS:
                raise located_error(body.keys[key], f"{field}: unknown key {key!r}{did_you_mean(key, _DEFINITION_KEYS)}; "
                                             f"valid: {', '.join(_DEFINITION_KEYS)}", field)
        params_loc = v.get("params")
        params: dict[str, Located | None] = {}
        param_keys: dict[str, Located] = {}
        if params_loc is not None and params_loc.value is not None:
            if not isinstance(params_loc.value, dict):
                raise located_error(params_loc, f"{field}.params: expected a mapping of parameter → default "
                                         "(null for a required parameter)", f"{field}.params")
            for p, default in params_loc.value.items():
                if not IDENTIFIER.match(p):
                    raise located_error(params_loc.keys[p], f"{field}.params: parameter name {p!r} must be an identifier",
                                 f"{field}.params")
                params[p] = None if default.value is None else default
                param_keys[p] = params_loc.keys[p]
        description = plain(v["description"]) if "description" in v else ""
        sub = Subtree(name, where, params, param_keys, v["root"], str(description or ""))
    elif isinstance(v, dict) and ("params" in v or "description" in v):
        raise located_error(body, f"{field}: a subtree with params or a description needs its node under 'root'", field)
    elif isinstance(v, dict) and len(v) == 1:
        sub = Subtree(name, where, {}, {}, body)  # shorthand: name → node, no parameters
    else:
        raise located_error(body, f"{field}: a subtree is a node, or a mapping with 'root' (and optional 'params', "
                           "'description')", field)
    used = set(_parameter_uses(sub.root))
    for ref, loc in _parameter_uses(sub.root).items():
        if ref not in sub.params:
            raise located_error(loc, f"{field}: unknown parameter ${ref}{did_you_mean(ref, sub.params)}; "
                              f"declared: {', '.join(sub.params) or 'none (declare them under params)'}", field)
    for p in sub.params:
        if p not in used:
            raise located_error(sub.param_keys[p], f"{field}.params: parameter {p!r} is never used in the body "
                                            f"(write ${p} where its value goes)", f"{field}.params")
    return sub


def _parameter_uses(loc: Located, found: dict[str, Located] | None = None) -> dict[str, Located]:
    """Every ``$name`` in a body, with the location of its first use."""
    found = {} if found is None else found
    v = loc.value
    if isinstance(v, str):
        m = PARAM_REF.match(v.strip())
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
    """A copy of a body with every ``$name`` value replaced by ``env[name]``."""
    v = loc.value
    if isinstance(v, str):
        m = PARAM_REF.match(v.strip())
        return env[m.group(1)] if m else loc
    if isinstance(v, dict):
        new = Located({k: _substitute(item, env) for k, item in v.items()}, loc.file, loc.line, loc.column)
        new.keys = loc.keys  # type: ignore[attr-defined]
        return new
    if isinstance(v, list):
        return Located([_substitute(item, env) for item in v], loc.file, loc.line, loc.column)
    return loc


class SubtreeExpansion:
    """The uses of named subtrees, for the tree builder of :mod:`tactile_bt.tree.loader`.

    Mixed into its ``_Builder``, which provides ``subtrees`` (name -> :class:`Subtree`),
    ``stack`` (names of the subtrees being expanded, for the recursion check) and ``node``
    (build a located node).  A use binds the arguments (defaults for the others), substitutes
    them into a copy of the body and builds it; its errors say which use they came from.
    """

    subtrees: dict[str, Subtree]
    stack: list[str]

    def subtree_node(self, body: Located, key_loc: Located):
        """Build a ``subtree: {name: ..., params: {...}}`` node."""
        if not isinstance(body.value, dict) or "name" not in body.value:
            raise located_error(body if body.value is not None else key_loc,
                         "subtree: expected {name: SUBTREE, params: {...}}", "subtree.name")
        for key in body.value:
            if key not in _SUBTREE_KEYS:
                raise located_error(body.keys[key], f"subtree: unknown key {key!r}{did_you_mean(key, _SUBTREE_KEYS)}; "
                                             f"valid: {', '.join(_SUBTREE_KEYS)}", f"subtree.{key}")
        name_loc = body.value["name"]
        name = name_loc.value
        if name not in self.subtrees:
            known = ", ".join(sorted(self.subtrees)) or "none defined (add them under the top-level 'subtrees')"
            raise located_error(name_loc, f"subtree.name: unknown subtree {name!r}{did_you_mean(name, self.subtrees)}; "
                                   f"known: {known}", "subtree.name")
        return self.expand(self.subtrees[name], body.value.get("params"), name_loc)

    def expand(self, sub: Subtree, args: Located | None, call: Located):
        """Build subtree ``sub`` with the arguments ``args`` of the use at ``call``."""
        if sub.name in self.stack:
            chain = " → ".join([*self.stack[self.stack.index(sub.name):], sub.name])
            raise located_error(call, f"subtree recursion: {chain}", sub.name)
        items: dict[str, Located] = {}
        if args is not None and args.value is not None:
            if not isinstance(args.value, dict):
                raise located_error(args, f"{sub.name}: parameters must be a mapping, got {plain(args.value)!r}", sub.name)
            items = args.value
        env: dict[str, Located] = {}
        for key, value in items.items():
            if key not in sub.params:
                declared = ", ".join(sub.params) or "none"
                raise located_error(args.keys[key], f"{sub.name}: unknown parameter {key!r}{did_you_mean(key, sub.params)}; "
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
            raise located_error(call, f"{sub.name}: missing parameter(s) {', '.join(missing)} "
                               f"(the subtree defined at {origin_of(sub.where)} has no default for them)", sub.name)
        sub.used = True
        self.stack.append(sub.name)
        try:
            return self.node(_substitute(sub.root, env), default_name=sub.name)
        except YamlError as exc:
            if getattr(exc, "_in_subtree", False):
                raise
            new = with_context(exc, f" (in subtree {sub.name!r}, used at {origin_of(call)})")
            new._in_subtree = True  # type: ignore[attr-defined]
            raise new from None
        finally:
            self.stack.pop()
