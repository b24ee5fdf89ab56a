"""Typed node parameters: units, value checks, conversions and blackboard references.

A node class declares each parameter once (:class:`~tactile_bt.tree.declaration.Parameter`);
this module holds what judges a value against such a declaration: the admissible ranges
(:class:`Bound`: ``POSITIVE``, ``NON_NEGATIVE``, ``between(0, 1)``, ...; a number without a
declared bound must still be finite), the units (:data:`UNITS`, the name suffixes that give a
parameter its unit unless it declares one) and the conversion of values written with a unit
(:func:`convert_parameter`). The YAML loader, blackboard references, ``--param`` and the
construction of a node in Python use the same checks, so a value is judged the same way
wherever it comes from.

A blackboard reference makes a parameter follow a blackboard key: the key is read when the node
starts (each time, just before its ``initialise``), never on every tick, so references cost
nothing on the control cycle's hot path. See :func:`bind_blackboard`.

Lengths may be given in tactels of the pad (``px``, ``tactel``, :data:`PAD_UNITS`): they are
converted with the pitch of a :class:`~tactile_bt.sense.geometry.PadGeometry` (``pad=`` of
:func:`parse_quantity` and :func:`convert_parameter`, the scene's pad for a tree file a mission
loads, the blackboard's ``/tactile/pad`` for a blackboard reference).

Layer: tree.
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

from tactile_bt import units
from tactile_bt.errors import BlackboardReferenceError, ParameterTypeError, ParameterValueError
from tactile_bt.sense.geometry import PadGeometry
from tactile_bt.tree.blackboard import current_pad
from tactile_bt.units import ACCEPTED_UNITS, PAD_UNITS, element_unit, uses_pad_units

__all__ = [
    "UNITS",
    "ACCEPTED_UNITS",
    "PAD_UNITS",
    "accepted_units",
    "uses_pad_units",
    "ParameterTypeError",
    "ParameterValueError",
    "BlackboardReferenceError",
    "Bound",
    "FINITE",
    "POSITIVE",
    "NON_NEGATIVE",
    "POSITIVE_OR_INF",
    "between",
    "check_bound",
    "ParameterInfo",
    "node_label",
    "parse_quantity",
    "convert_parameter",
    "describe_type",
    "parameters_of",
    "normalise_key",
    "bind_blackboard",
    "resolve_references",
    "blackboard_references",
]

#: Name suffix → SI unit: a parameter named ``*_pa`` is in Pa, ``*_mps`` in m/s, and so on.
#: A declaration names the unit of other parameters (``Parameter(..., unit="1/s")``).
UNITS: dict[str, str] = {"_pa": "Pa", "_mps": "m/s", "_rps": "rad/s", "_rad": "rad", "_m": "m", "_s": "s", "_n": "N"}


# ------------------------------------------------------------------------------ bounds


def _number_text(x: float) -> str:
    if x == math.pi:
        return "π"
    if x == math.pi / 2:
        return "π/2"
    return f"{x:g}"


@dataclass(frozen=True)
class Bound:
    """The admissible values of a numeric parameter: finite numbers in ``[low, high]`` (each end
    open or closed), plus ``+inf`` when ``allow_inf`` (e.g. an output limit where inf means "no
    limit") and the values in ``also`` (e.g. ``-1`` = "forever" for a repeat count). NaN is never
    admissible. Lists of numbers are checked element by element."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    allow_inf: bool = False
    also: tuple = ()
    #: Appended to the message of a value out of bounds: why the bound is there, what to write.
    note: str = ""

    def __str__(self) -> str:
        """The range as the reference tables show it: ``> 0``, ``>= 0``, ``[0, 1)``, ``finite``."""
        lo, hi = math.isfinite(self.low), math.isfinite(self.high)
        if lo and hi:
            text = (f"{'(' if self.low_open else '['}{_number_text(self.low)}, "
                    f"{_number_text(self.high)}{')' if self.high_open else ']'}")
        elif lo:
            text = f"{'>' if self.low_open else '>='} {_number_text(self.low)}"
        elif hi:
            text = f"{'<' if self.high_open else '<='} {_number_text(self.high)}"
        else:
            text = "finite" if not self.allow_inf else ""
        extras = [_number_text(a) for a in self.also] + (["inf"] if self.allow_inf else [])
        return " or ".join(t for t in (text, *extras) if t)

    def _inside(self, x: float) -> bool:
        if self.low_open and not x > self.low or not x >= self.low:
            return False
        if self.high_open and not x < self.high or not x <= self.high:
            return False
        return True

    def problem(self, x: float) -> str | None:
        """Why ``x`` is not admissible (``"must be > 0"``), or None when it is."""
        if x in self.also:
            return None
        if math.isinf(x) and x > 0 and self.allow_inf:
            return None
        text = str(self)
        if not math.isfinite(x):
            if self.allow_inf or text == "finite":
                return f"must be {text}"
            return f"must be finite and {text}"
        if self._inside(x):
            return None
        if (self.low, self.low_open, self.high, self.also) == (0.0, False, math.inf, ()):
            return "must not be negative"
        return f"must be {text}"


#: Any finite number (the bound of every float parameter that declares none).
FINITE = Bound()
#: > 0: pressures, targets, thresholds, bands, lengths that must be something.
POSITIVE = Bound(0.0, low_open=True)
#: >= 0: gains, times, distances where 0 means "none" or "off".
NON_NEGATIVE = Bound(0.0)
#: > 0 or inf: a limit where inf means "no limit".
POSITIVE_OR_INF = Bound(0.0, low_open=True, allow_inf=True)


def between(low: float, high: float, low_open: bool = False, high_open: bool = False, note: str = "") -> Bound:
    """The finite numbers from ``low`` to ``high`` (``between(0, 1, high_open=True)`` is [0, 1));
    ``note`` is added to the message of a value outside."""
    return Bound(float(low), float(high), low_open, high_open, note=note)


def _with_unit(x: Any, unit: str | None) -> str:
    text = repr(float(x)) if isinstance(x, float) or not isinstance(x, numbers.Integral) else repr(int(x))
    return f"{text} {unit}" if unit else text


def _noted(bound: Bound) -> str:
    return f"; {bound.note}" if bound.note else ""


def check_bound(name: str | None, value: Any, bound: Bound | None, unit: str | None = None) -> None:
    """Raise :class:`ParameterValueError` when ``value`` (a number, or a list of numbers checked
    element by element) is outside ``bound``; values that are not numbers are left to the type
    checks."""
    if bound is None or isinstance(value, (bool, str, bytes)):
        return
    if _is_number(value):
        problem = bound.problem(float(value))
        if problem:
            raise ParameterValueError(name, f"{problem} (got {_with_unit(value, unit)}){_noted(bound)}")
        return
    if isinstance(value, typing.Iterable) and not isinstance(value, dict):
        try:
            items = list(value)
        except TypeError:  # e.g. a 0-d numpy array
            return
        for i, v in enumerate(items):
            if _is_number(v) and not isinstance(v, bool):
                problem = bound.problem(float(v))
                if problem:
                    raise ParameterValueError(name, f"{problem} (got {_with_unit(v, element_unit(unit, i))}){_noted(bound)}",
                                              index=i)


def _is_float_like(annotation: Any) -> bool:
    return annotation is float or describe_type(annotation) == "list[float]"


def node_label(cls, name: Any) -> str:
    """``force_hold 'hold'``: the YAML type of a node class (its class name when it is not
    registered) and the node's name, for messages."""
    type_name = vars(cls).get("node_type", cls.__name__)  # set when the class is registered
    return f"{type_name} {str(name)!r}" if name is not None else type_name


def accepted_units(unit: str | None, pad: PadGeometry | None = None) -> dict[str, float] | None:
    """The units a value in SI unit ``unit`` may carry, with their factors to it (None when it
    takes a plain number only): :data:`~tactile_bt.units.ACCEPTED_UNITS`, plus for lengths the
    :data:`~tactile_bt.units.PAD_UNITS` with the pitch of ``pad`` (default ``PadGeometry()``, 5 mm)."""
    return units.accepted_units(unit, (PadGeometry() if pad is None else pad).pitch)


def parse_quantity(text: str, unit: str | None, pad: PadGeometry | None = None) -> float:
    """``"2 kPa"`` → 2000.0 for a parameter in Pa, ``"1500"`` → 1500.0 (a plain number is in the
    parameter's SI unit); ``"2 px"`` is two pitches of ``pad`` (default ``PadGeometry()``).
    :func:`tactile_bt.units.parse_quantity` with the pad's pitch; raises
    :class:`ParameterTypeError` on a unit of the wrong kind, a malformed quantity, or a unit on
    a parameter that takes a plain number."""
    return units.parse_quantity(text, unit, (PadGeometry() if pad is None else pad).pitch)


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


def convert_parameter(value: Any, annotation: Any, unit: str | None = None, bound: Bound | None = None,
                      name: str | None = None, pad: PadGeometry | None = None) -> Any:
    """Check ``value`` against ``annotation`` (bool, int, float, str, Literal[...] or a sequence
    of floats) and ``bound``, and return it in its Python form (floats as float, sequences as
    tuples).

    Strings holding a number are accepted for numbers: a plain number (``"1500"``) is in the
    parameter's SI unit ``unit``; a number with a unit (``"2 kPa"``, ``"90 deg"``) is converted
    when ``unit`` is one of :data:`ACCEPTED_UNITS` (``"1 px"``: the pitch of ``pad``, default
    ``PadGeometry()``). Floats must be finite and inside ``bound``
    (:data:`FINITE` when None); ints inside ``bound`` when given. Raises
    :class:`ParameterTypeError` for a value of the wrong type and :class:`ParameterValueError`
    (naming ``name``) for one out of bounds.
    """
    out = _convert(value, annotation, unit, pad)
    if bound is None and _is_float_like(annotation):
        bound = FINITE
    check_bound(name, out, bound, unit)
    return out


def _convert(value: Any, annotation: Any, unit: str | None, pad: PadGeometry | None) -> Any:
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
            return parse_quantity(value, unit, pad)
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
        for i, v in enumerate(value):
            if isinstance(v, str):
                out.append(parse_quantity(v, element_unit(unit, i), pad))
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
    bound: Bound | None = None  # admissible numbers (None: not a number, or no check)
    fixed: bool = False  # set when the node is built (no blackboard reference)

    @property
    def required(self) -> bool:
        return self.default is inspect.Parameter.empty

    @property
    def type_name(self) -> str:
        return describe_type(self.annotation)


def parameters_of(cls) -> list:
    """The declared parameters of a node class (:class:`~tactile_bt.tree.declaration.Parameter`
    s, ``name`` first); TypeError for a class that declares none (not a
    :class:`~tactile_bt.tree.declaration.Parameterised`)."""
    params = getattr(cls, "parameters", None)
    if not isinstance(params, dict):
        raise TypeError(f"{getattr(cls, '__name__', cls)!r} declares no parameters: derive it from TactileBehaviour "
                        "(or Parameterised) and declare each parameter as a class attribute Parameter(...)")
    return list(params.values())


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

    The key is read each time the behaviour starts (:func:`resolve_references`, which the
    node's tick calls just before ``initialise``), checked against the parameter's declaration
    and applied with ``behaviour.set_parameter``; a length in tactels (``"0.5 px"``) is
    converted with the pad on the blackboard (``/tactile/pad``). A missing key or a bad value
    raises :class:`BlackboardReferenceError` naming ``origin`` (the tree file, line and column
    of the reference), the parameter and the key. Nothing is added to the tick of a running node.

    Works for any node class that declares the parameter; the loader calls it for
    ``{blackboard: /key}`` and ``"@/key"`` values.
    """
    key = normalise_key(key)
    params = {p.name: p for p in parameters_of(type(behaviour))}
    if parameter not in params:
        raise ValueError(f"{behaviour.name}: no parameter {parameter!r} to bind to {key!r}")
    if params[parameter].fixed:
        raise ValueError(f"{behaviour.name}: parameter {parameter!r} is fixed at construction; "
                         "it cannot come from the blackboard")
    refs = behaviour.__dict__.get("_blackboard_parameters")
    if refs is None:
        refs = {}
        behaviour._blackboard_parameters = refs  # type: ignore[attr-defined]
        client = behaviour.attach_blackboard_client(name=f"{behaviour.name}/parameters")
        behaviour._parameter_client = client  # type: ignore[attr-defined]
    behaviour._parameter_client.register_key(key=key, access=Access.READ)  # type: ignore[attr-defined]
    refs[parameter] = (key, origin)


def resolve_references(behaviour: py_trees.behaviour.Behaviour) -> None:
    """Read the blackboard keys ``behaviour``'s parameters follow (:func:`bind_blackboard`) and
    set them; nothing for a node without references. The ticks of the nodes
    (:class:`~tactile_bt.tree.ticking.DirectDecorator`,
    :class:`~tactile_bt.tree.behaviours.base.TactileBehaviour`) call it when the node starts,
    before its ``initialise``."""
    refs = behaviour.__dict__.get("_blackboard_parameters")
    if not refs:
        return
    client = behaviour._parameter_client  # type: ignore[attr-defined]
    params = {p.name: p for p in parameters_of(type(behaviour))}
    pad = current_pad()
    for parameter, (key, origin) in refs.items():
        prefix = f"{origin}: " if origin else ""
        field = f"{behaviour.name}.{parameter}"
        if not client.exists(key):
            raise BlackboardReferenceError(
                f"{prefix}{field}: blackboard key {key!r} is not set; write it before the node starts "
                f"(e.g. a py_trees.blackboard.Client with WRITE access to {key!r})")
        value = client.get(key)
        try:
            info = params[parameter]
            value = convert_parameter(value, info.annotation, info.unit, info.bound, parameter, pad)
            behaviour.set_parameter(parameter, value)  # type: ignore[attr-defined]
        except (ParameterTypeError, ValueError) as exc:
            raise BlackboardReferenceError(f"{prefix}{field}: bad value from blackboard key {key!r}: {exc}") from None
