"""Typed leaf parameters: units from their names, value checks, documentation and blackboard
references.

The parameters of a node are the keyword arguments of its class's ``__init__``; their types
come from the type hints and their units from the name's suffix (``target_pa``, ``speed_mps``,
``grace_s``). The YAML loader and blackboard references use the same checks, so a value is
judged the same way whether it comes from a file or from the blackboard.

A blackboard reference makes a parameter follow a blackboard key: the key is read when the node
is *initialised* (each time it starts), never on every tick, so references cost nothing on the
control cycle's hot path. See :func:`bind_blackboard`.
"""

from __future__ import annotations

import inspect
import math
import numbers
import re
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import py_trees
from py_trees.common import Access

from tactile_bt import defaults

__all__ = [
    "UNITS",
    "ACCEPTED_UNITS",
    "ParameterTypeError",
    "BlackboardReferenceError",
    "ParameterInfo",
    "unit_of",
    "parse_quantity",
    "convert_parameter",
    "describe_type",
    "parameters_of",
    "normalise_key",
    "bind_blackboard",
    "blackboard_references",
]

#: SI unit → the units a YAML value may carry instead, with their factor to the SI unit.
ACCEPTED_UNITS: dict[str, dict[str, float]] = {
    "Pa": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6},
    "m/s": {"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3},
    "rad/s": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "rad": {"rad": 1.0, "deg": math.pi / 180.0, "°": math.pi / 180.0},
    "m": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "px": defaults.PITCH_M,
          "tactel": defaults.PITCH_M, "tactels": defaults.PITCH_M},
    "s": {"s": 1.0, "ms": 1e-3, "min": 60.0},
    "N": {"N": 1.0, "mN": 1e-3},
}
#: Name suffix → SI unit: a parameter named ``*_pa`` is in Pa, ``*_mps`` in m/s, and so on.
#: Classes name the units of other parameters in ``parameter_units`` (e.g. ``band``).
UNITS: dict[str, str] = {"_pa": "Pa", "_mps": "m/s", "_rps": "rad/s", "_rad": "rad", "_m": "m", "_s": "s", "_n": "N"}
_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S.*?)\s*$")


class ParameterTypeError(TypeError):
    """A value does not fit a parameter's type; ``expected`` says what would."""

    def __init__(self, expected: str, value: Any, detail: str = "") -> None:
        self.expected, self.value, self.detail = expected, value, detail
        super().__init__(detail or f"expected {expected}, got {value!r}")


class BlackboardReferenceError(RuntimeError):
    """A blackboard reference could not be resolved when its node started (missing key or a
    value of the wrong type). The message names the tree file, line and column of the
    reference, the node and parameter, and the key."""


def unit_of(name: str, cls: type | None = None) -> str | None:
    """Unit of a parameter: from ``cls.parameter_units`` when it names one, else from the
    name's suffix (``target_pa`` → ``"Pa"``); None for plain numbers."""
    declared = getattr(cls, "parameter_units", {}) if cls is not None else {}
    if name in declared:
        return declared[name]
    for suffix, unit in UNITS.items():
        if name.endswith(suffix):
            return unit
    return None


def parse_quantity(text: str, unit: str | None) -> float:
    """``"2 kPa"`` → 2000.0 for a parameter in Pa; raises :class:`ParameterTypeError` on a unit
    of the wrong kind, a malformed quantity, or a parameter that takes a plain number."""
    match = _QUANTITY.match(text)
    accepted = ACCEPTED_UNITS.get(unit or "")
    if accepted is None:
        note = ""
        if match:
            note = f" (a plain number{f' in {unit}' if unit else ''}: this parameter takes no unit)"
        raise ParameterTypeError("a number", text, f"expected a number, got {text!r}{note}")
    if not match:
        raise ParameterTypeError(f"a number in {unit}", text,
                                 f"expected a number in {unit} (or a number with a unit: "
                                 f"{', '.join(accepted)}), got {text!r}")
    number, given = float(match.group(1)), match.group(2)
    if given not in accepted:
        from difflib import get_close_matches

        close = get_close_matches(given, list(accepted), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ParameterTypeError(f"a number in {unit}", text,
                                 f"unit {given!r} does not fit a value in {unit}{hint}; "
                                 f"valid units: {', '.join(accepted)}")
    return number * accepted[given]


def _is_number(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def describe_type(annotation: Any) -> str:
    """Short human name of a parameter type, for errors and the reference tables."""
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        return " | ".join(str(a) for a in typing.get_args(annotation))
    if annotation is bool:
        return "bool"
    if annotation is int:
        return "int"
    if annotation is float:
        return "float"
    if annotation is str:
        return "str"
    if origin in (Sequence, list, tuple) or annotation in (list, tuple):
        return "list[float]"
    return "any"


def convert_parameter(value: Any, annotation: Any, unit: str | None = None) -> Any:
    """Check ``value`` against ``annotation`` (bool, int, float, str, Literal[...] or a sequence
    of floats) and return it in its Python form (floats as float, sequences as tuples).

    Strings with a unit (``"2 kPa"``, ``"90 deg"``) are accepted for numbers when the
    parameter's ``unit`` (its SI unit) is one of :data:`ACCEPTED_UNITS`. Raises
    :class:`ParameterTypeError`.
    """
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        choices = typing.get_args(annotation)
        if value not in choices or isinstance(value, bool):
            from difflib import get_close_matches

            close = get_close_matches(str(value), [str(c) for c in choices], n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ParameterTypeError("one of " + ", ".join(map(str, choices)), value,
                                     f"unknown value {value!r}{hint}; valid: {', '.join(map(str, choices))}")
        return value
    if annotation is bool:
        if not isinstance(value, (bool,)) and type(value).__name__ != "bool_":
            raise ParameterTypeError("true or false", value)
        return bool(value)
    if annotation is int:
        if not isinstance(value, numbers.Integral) or isinstance(value, bool):
            raise ParameterTypeError("an integer", value)
        return int(value)
    if annotation is float:
        if isinstance(value, str):
            return parse_quantity(value, unit)
        if not _is_number(value):
            raise ParameterTypeError("a number", value)
        return float(value)
    if annotation is str:
        if not isinstance(value, str):
            raise ParameterTypeError("a string", value)
        return value
    if origin in (Sequence, list, tuple) or annotation in (list, tuple):
        if isinstance(value, (str, bytes)) or not isinstance(value, typing.Iterable):
            raise ParameterTypeError("a list of numbers", value)
        out = []
        for v in value:
            if isinstance(v, str) and unit in ACCEPTED_UNITS:
                out.append(parse_quantity(v, unit))
            elif _is_number(v):
                out.append(float(v))
            else:
                raise ParameterTypeError("a list of numbers", value)
        return tuple(out)
    return value


# ------------------------------------------------------------------------------ documentation


@dataclass(frozen=True)
class ParameterInfo:
    """One documented parameter of a node class."""

    name: str
    annotation: Any
    default: Any  # inspect.Parameter.empty when required
    unit: str | None
    doc: str

    @property
    def required(self) -> bool:
        return self.default is inspect.Parameter.empty

    @property
    def type_name(self) -> str:
        return describe_type(self.annotation)


_ENTRY = re.compile(r"^([A-Za-z_]\w*(?:\s*,\s*[A-Za-z_]\w*)*)\s*(?::.*)?$")


def _docstring_parameters(cls) -> dict[str, str]:
    """Descriptions from the numpydoc ``Parameters`` sections of ``cls`` and its bases (the
    most derived class's text wins)."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        lines = inspect.cleandoc(klass.__dict__.get("__doc__") or "").splitlines()
        start = next((i + 2 for i in range(len(lines) - 1)
                      if lines[i].strip() == "Parameters" and set(lines[i + 1].strip()) == {"-"}), None)
        if start is None:
            continue
        names: list[str] = []
        text: list[str] = []

        def flush() -> None:
            for n in names:
                docs[n] = " ".join(text)

        for i in range(start, len(lines)):
            line = lines[i]
            following = lines[i + 1].strip() if i + 1 < len(lines) else ""
            if line.strip() and following and set(following) == {"-"}:
                break  # the next section
            entry = _ENTRY.match(line) if line and not line[0].isspace() else None
            if entry:
                flush()
                names = [n.strip() for n in entry.group(1).split(",")]
                text = []
            elif line and not line[0].isspace():
                break  # prose after the section
            elif line.strip() and names:
                text.append(line.strip())
        flush()
    return docs


def parameters_of(cls) -> list[ParameterInfo]:
    """The YAML parameters of a node class: its ``__init__`` keywords except ``self`` and
    ``child``, with type hints, defaults, units and the docstring's description."""
    hints = typing.get_type_hints(cls.__init__)
    docs = _docstring_parameters(cls)
    out = []
    for name, p in inspect.signature(cls.__init__).parameters.items():
        if name in ("self", "child") or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        out.append(ParameterInfo(name, hints.get(name, Any), p.default, unit_of(name, cls), docs.get(name, "")))
    return out


# ------------------------------------------------------------------------------ blackboard references


def normalise_key(key: str) -> str:
    """An absolute blackboard key (``"goal/pressure"`` → ``"/goal/pressure"``); ValueError when
    the key is empty or malformed."""
    if not isinstance(key, str):
        raise ValueError(f"a blackboard key is a string like '/goal/pressure', got {key!r}")
    k = key.strip()
    if not k.startswith("/"):
        k = "/" + k
    if not re.fullmatch(r"(/[A-Za-z_][\w.\-]*)+", k):
        raise ValueError(f"malformed blackboard key {key!r}: use names separated by '/', e.g. '/goal/pressure'")
    return k


def blackboard_references(behaviour: py_trees.behaviour.Behaviour) -> dict[str, tuple[str, str]]:
    """The references bound to ``behaviour``: parameter → (absolute key, origin)."""
    return dict(behaviour.__dict__.get("_blackboard_parameters", {}))


def bind_blackboard(behaviour: py_trees.behaviour.Behaviour, parameter: str, key: str, origin: str = "") -> None:
    """Make ``parameter`` of ``behaviour`` follow the blackboard ``key``.

    The key is read each time the behaviour starts (``initialise``), checked against the
    parameter's type and applied with ``behaviour.set_parameter`` (or ``setattr``). A missing key
    or a bad value raises :class:`BlackboardReferenceError` naming ``origin`` (the tree file,
    line and column of the reference), the parameter and the key. Nothing is added to the tick.

    Works for any behaviour class whose ``__init__`` has the parameter; the loader calls it for
    ``{blackboard: /key}`` and ``"@/key"`` values.
    """
    key = normalise_key(key)
    params = {p.name: p for p in parameters_of(type(behaviour))}
    if parameter not in params:
        raise ValueError(f"{behaviour.name}: no parameter {parameter!r} to bind to {key!r}")
    fixed = getattr(behaviour, "fixed_parameters", frozenset({"name"}))
    if parameter in fixed:
        raise ValueError(f"{behaviour.name}: parameter {parameter!r} is fixed at construction; "
                         "it cannot come from the blackboard")
    refs = behaviour.__dict__.get("_blackboard_parameters")
    if refs is None:
        refs = {}
        behaviour._blackboard_parameters = refs  # type: ignore[attr-defined]
        client = behaviour.attach_blackboard_client(name=f"{behaviour.name}/parameters")
        behaviour._parameter_client = client  # type: ignore[attr-defined]
        original = behaviour.initialise

        def initialise() -> None:
            _resolve(behaviour, params)
            original()

        initialise.__doc__ = original.__doc__
        behaviour.initialise = initialise  # type: ignore[method-assign]
    behaviour._parameter_client.register_key(key=key, access=Access.READ)  # type: ignore[attr-defined]
    refs[parameter] = (key, origin)


def _resolve(behaviour, params: dict[str, ParameterInfo]) -> None:
    client = behaviour._parameter_client
    for parameter, (key, origin) in behaviour._blackboard_parameters.items():
        prefix = f"{origin}: " if origin else ""
        field = f"{behaviour.name}.{parameter}"
        if not client.exists(key):
            raise BlackboardReferenceError(
                f"{prefix}{field}: blackboard key {key!r} is not set; write it before the node starts "
                f"(e.g. a py_trees.blackboard.Client with WRITE access to {key!r})")
        value = client.get(key)
        try:
            value = convert_parameter(value, params[parameter].annotation, params[parameter].unit)
            setter = getattr(behaviour, "set_parameter", None)
            if setter is not None:
                setter(parameter, value)
            else:
                setattr(behaviour, parameter, value)
        except (ParameterTypeError, ValueError) as exc:
            raise BlackboardReferenceError(f"{prefix}{field}: bad value from blackboard key {key!r}: {exc}") from None
