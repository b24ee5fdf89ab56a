"""Kinds of value in the scene schema (:mod:`tactile_bt.sim.scene` checks them).

A kind is a string for non-numeric values (``"string"``, ``"mapping"``, ``"list"``), a
:class:`Range` for numbers and integers (finite, within bounds, in the range's SI unit; a number
may be written with a unit: ``3 mm``), or a :class:`ListOf` for fixed-length lists. ``str(kind)`` is the phrase used in error messages
(``expected an integer from 1 to 128``) and in ``sim/README.md``. :func:`check_value` and
:func:`check_fields` check located YAML values against kinds (the scene, the robot file).

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from tactile_bt.errors import ParameterTypeError
from tactile_bt.units import parse_quantity
from tactile_bt.yamlutil import Located, plain

__all__ = ["Range", "ListOf", "STR", "MAPPING", "LIST", "NUMBER", "POSITIVE", "NONNEGATIVE", "INT",
           "COORD", "LENGTH", "ANGLE_DEG", "MAX_COORD_M", "check_value", "check_fields", "check_keys", "BOOL"]

STR = "string"
BOOL = "boolean"
MAPPING = "mapping"
LIST = "list"


def _g(x: float) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


@dataclass(frozen=True)
class Range:
    """A finite number (or an integer) with optional bounds: ``lo <= x <= hi``, ``lo < x`` when
    ``lo_open``. ``unit`` is only for messages."""

    lo: float | None = None
    hi: float | None = None
    integer: bool = False
    lo_open: bool = False
    #: The SI unit of the value (``"m"``, ``"s"``, ...): a plain number is in it, and a string
    #: with a unit of the same kind (``"3 mm"``) is converted to it (:mod:`tactile_bt.units`).
    unit: str = ""

    def accepts(self, x: Any) -> bool:
        """Whether ``x`` (an int or float, not a bool) is of this kind."""
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            return False
        if self.integer and not isinstance(x, int):
            return False
        if not math.isfinite(x):
            return False
        if self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo)):
            return False
        return self.hi is None or x <= self.hi

    def describe(self, plural: bool = False) -> str:
        noun = ("integers" if plural else "an integer") if self.integer else ("numbers" if plural else "a number")
        unit = f" {self.unit}" if self.unit else ""
        lo, hi = self.lo, self.hi
        if lo == 0 and not self.integer:  # "a positive number", "a non-negative number up to 1"
            sign = "positive" if self.lo_open else "non-negative"
            noun = f"{sign} numbers" if plural else f"a {sign} number"
            return noun + (f" up to {_g(hi)}{unit}" if hi is not None else (f" ({self.unit})" if unit else ""))
        if lo is not None and hi is not None and not self.lo_open:
            return f"{noun} from {_g(lo)} to {_g(hi)}{unit}"
        parts = []
        if lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {_g(lo)}")
        if hi is not None:
            parts.append(f"<= {_g(hi)}")
        if not parts:
            return noun + (f" ({self.unit})" if unit else "")
        return f"{noun} {' and '.join(parts)}{unit}"

    def __str__(self) -> str:
        return self.describe()


@dataclass(frozen=True)
class ListOf:
    """A list of exactly ``n`` items of kind ``item``."""

    n: int
    item: Any

    def __str__(self) -> str:
        item = self.item.describe(plural=True) if isinstance(self.item, Range) else f"{self.item}s"
        return f"a list of {self.n} {item}"


NUMBER = Range()
POSITIVE = Range(0.0, lo_open=True)
NONNEGATIVE = Range(0.0)
INT = Range(integer=True)
#: Positions (of the pad, objects, tables, cable points, event shifts) lie within this many
#: metres of the origin: far beyond any reach, and far from overflows.
MAX_COORD_M = 100.0
COORD = Range(-MAX_COORD_M, MAX_COORD_M, unit="m")
#: Angles in degrees (fields named ``*_deg``); ``"0.5 rad"`` is converted.
ANGLE_DEG = Range(unit="deg")
#: Sizes of objects (radius, length, edges): positive, at most ``MAX_COORD_M``.
LENGTH = Range(0.0, MAX_COORD_M, lo_open=True, unit="m")


def check_value(value: Located, kind: Any, field_name: str) -> Any:
    """The value of ``value`` if it is of ``kind`` (see :mod:`tactile_bt.sim.schema`), else a
    :class:`~tactile_bt.errors.YamlError` naming the field, the file and the line."""
    v = value.value
    if isinstance(kind, Range):
        if isinstance(v, str) and not kind.integer:
            v = _quantity(value, kind, field_name)
        if isinstance(v, float) and not np.isfinite(v):
            raise value.error(f"{field_name}: expected a finite number, got {v!r}")
        if not kind.accepts(v):
            raise value.error(f"{field_name}: expected {kind}, got {plain(value.value)!r}")
        return int(v) if kind.integer else float(v)
    if isinstance(kind, ListOf):
        if not isinstance(v, list) or len(v) != kind.n:
            raise value.error(f"{field_name}: expected {kind}, got {plain(v)!r}")
        return [check_value(x, kind.item, f"{field_name}[{i}]") for i, x in enumerate(v)]
    if kind == STR:
        if not isinstance(v, str):
            raise value.error(f"{field_name}: expected a string, got {plain(v)!r}")
        return v
    if kind == BOOL:
        if not isinstance(v, bool):
            raise value.error(f"{field_name}: expected true or false, got {plain(v)!r}")
        return v
    if kind == MAPPING:
        if not isinstance(v, dict):
            raise value.error(f"{field_name}: expected a mapping")
        return v
    if kind == LIST:
        if not isinstance(v, list):
            raise value.error(f"{field_name}: expected a list")
        return v
    raise AssertionError(kind)


def _quantity(value: Located, kind: Range, field_name: str) -> float:
    """A number written with a unit (``radius: 3 mm``), in the field's SI unit; the same parser
    as the tree's parameters (:func:`tactile_bt.units.parse_quantity`)."""
    try:
        return parse_quantity(value.value, kind.unit or None)
    except ParameterTypeError as exc:
        raise value.error(f"{field_name}: {exc}") from None


def check_keys(section: Located, names, where_: str) -> None:
    """An error for the first key of the mapping ``section`` that is not in ``names``, naming the
    closest valid one (``where_``: the section's path, prefixed to the field names)."""
    from difflib import get_close_matches

    for key in section.value:
        if key not in names:
            hint = get_close_matches(key, list(names), n=1)
            raise section.keys[key].error(f"unknown field {where_ + key!r}" + (f" (did you mean {hint[0]!r}?)" if hint else "")
                                          + f"; valid fields: {', '.join(sorted(names))}")


def check_fields(section: Located, schema: dict, where_: str) -> dict:
    """The checked values of the mapping ``section`` (field -> value), every key in ``schema``
    (field -> kind); an unknown key is an error that names the closest valid one. ``where_`` is
    the section's path, prefixed to the field names in messages (``"supervisor."``)."""
    check_keys(section, schema, where_)
    return {key: check_value(value, schema[key], where_ + key) for key, value in section.value.items()}
