"""Kinds of value in the scene schema (:mod:`tactile_bt.sim.scene` checks them).

A kind is a string for non-numeric values (``"string"``, ``"mapping"``, ``"list"``), a
:class:`Range` for numbers and integers (finite, within bounds, in the range's SI unit; a number
may be written with a unit: ``3 mm``), or a :class:`ListOf` for fixed-length lists. ``str(kind)`` is the phrase used in error messages
(``expected an integer from 1 to 128``) and in ``sim/README.md``.

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

__all__ = ["Range", "ListOf", "STR", "MAPPING", "LIST", "NUMBER", "POSITIVE", "NONNEGATIVE", "INT",
           "COORD", "LENGTH", "ANGLE_DEG", "MAX_COORD_M"]

STR = "string"
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
