"""Quantities with units, as scene and tree files write them: ``"3 mm"``, ``"1.5 kPa"``, ``"30 mm/s"``.

The one parser of numbers with units for the whole framework: the scene schema
(:mod:`tactile_bt.sim.scene`) and the tree's parameters (:mod:`tactile_bt.tree.parameters`) both
call :func:`parse_quantity`. A value's unit is its SI unit (``"m"``, ``"Pa"``, ``"m/s"`` ...); a
plain number is already in it, a number with a unit is converted to it with the factors of
:data:`ACCEPTED_UNITS`. Where the pad is known (a tree's parameters), lengths may also be given
in tactels of the pad (:data:`PAD_UNITS`), converted with its pitch. A vector whose elements have different units (a twist: three
m/s, then three rad/s) has a composite unit of :data:`VECTOR_UNITS`; :func:`element_unit` gives
the unit of each element.

Layer: base.
"""

from __future__ import annotations

import math
import re
from difflib import get_close_matches

from tactile_bt.errors import ParameterTypeError

__all__ = ["ACCEPTED_UNITS", "PAD_UNITS", "TWIST", "VECTOR_UNITS", "accepted_units", "element_unit",
           "split_quantity", "uses_pad_units", "parse_quantity", "to_si", "format_value"]

_DEG = math.pi / 180.0
#: SI unit → the units a value may carry instead, with their factor to the SI unit. Lengths
#: also take the :data:`PAD_UNITS`, whose factor is the pad's pitch (:func:`accepted_units`).
#: Angles written in degrees (scene fields ``*_deg``) have the unit ``"deg"``.
ACCEPTED_UNITS: dict[str, dict[str, float]] = {
    "Pa": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6},
    "m/s": {"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3},
    "rad/s": {"rad/s": 1.0, "deg/s": _DEG},
    "rad": {"rad": 1.0, "deg": _DEG, "°": _DEG},
    "deg": {"deg": 1.0, "°": 1.0, "rad": 1.0 / _DEG},
    "m": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6},
    "s": {"s": 1.0, "ms": 1e-3, "min": 60.0},
    "N": {"N": 1.0, "mN": 1e-3},
    "N/m": {"N/m": 1.0, "N/mm": 1e3, "kN/m": 1e3},
    "Hz": {"Hz": 1.0, "kHz": 1e3},
}
#: Length units counted in tactels of the pad: one is the pad's pitch in m.
PAD_UNITS: tuple[str, ...] = ("px", "tactel", "tactels")
#: The composite unit of a twist ``[vx, vy, vz, wx, wy, wz]``: m/s for the linear part, rad/s
#: for the angular part.
TWIST = "m/s, rad/s"
#: Composite units of vectors → the SI unit of each element.
VECTOR_UNITS: dict[str, tuple[str, ...]] = {TWIST: ("m/s",) * 3 + ("rad/s",) * 3}

#: A number with an optional unit: ``"1500"``, ``"1500Pa"``, ``"1.5 kPa"``, ``"2e3 Pa"``. The unit may not
#: start with a digit, so the digits of a plain number are never split into number and "unit".
_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)(?:\s*([^\s\d.+\-].*?))?\s*$")
_LEADING_NUMBER = re.compile(r"^\s*[-+]?(?:\d+\.?\d*|\.\d+)")


def element_unit(unit: str | None, index: int) -> str | None:
    """The unit of element ``index`` of a vector in ``unit`` (a composite unit of
    :data:`VECTOR_UNITS`, or one unit for every element)."""
    parts = VECTOR_UNITS.get(unit or "")
    if parts is None:
        return unit
    return parts[index] if 0 <= index < len(parts) else None


def accepted_units(unit: str | None, pitch_m: float | None = None) -> dict[str, float] | None:
    """The units a value in SI unit ``unit`` may carry, with their factors to it (None when it
    takes a plain number only): :data:`ACCEPTED_UNITS`, plus for lengths (``"m"``) the
    :data:`PAD_UNITS` when the pad's pitch ``pitch_m`` (m) is given."""
    table = ACCEPTED_UNITS.get(unit or "")
    if table is None or unit != "m" or pitch_m is None:
        return table
    return {**table, **dict.fromkeys(PAD_UNITS, pitch_m)}


def split_quantity(text: str) -> tuple[float, str | None] | None:
    """``"1.5 kPa"`` → ``(1.5, "kPa")``, ``"1500"`` → ``(1500.0, None)``; None when ``text`` is
    not a number with an optional unit."""
    match = _QUANTITY.match(text)
    if not match:
        return None
    return float(match.group(1)), match.group(2)


def uses_pad_units(value: object) -> bool:
    """Whether ``value`` (a quantity string such as ``"0.5 px"``, or a list of them) gives a
    length in tactels, whose value depends on the pad's pitch."""
    if isinstance(value, str):
        parts = split_quantity(value)
        return parts is not None and parts[1] in PAD_UNITS
    if isinstance(value, (list, tuple)):
        return any(uses_pad_units(v) for v in value)
    return False


def parse_quantity(text: str, unit: str | None, pitch_m: float | None = None) -> float:
    """The number ``text`` gives, in SI unit ``unit``.

    ``"2 kPa"`` → 2000.0 for a value in Pa; ``"1500"`` → 1500.0 (a plain number is in the SI
    unit); ``"3 mm"`` → 0.003 for a value in m; ``"2 px"`` → two pitches ``pitch_m`` (m), when
    the pitch is given (a tree's parameters; scene values, which set the pitch, take none).

    Raises
    ------
    ParameterTypeError
        On a malformed quantity, a unit of the wrong kind, or a unit on a value that takes a
        plain number (``unit`` None or not in :data:`ACCEPTED_UNITS`); the message lists the
        units that fit.
    """
    parts = split_quantity(text)
    if parts is not None and parts[1] is None:
        return parts[0]
    accepted = accepted_units(unit, pitch_m)
    if accepted is None:
        note = ""
        if _LEADING_NUMBER.match(text):
            note = f" (a plain number{f' in {unit}' if unit else ''}: this value takes no unit)"
        raise ParameterTypeError("a number", text, f"expected a number, got {text!r}{note}")
    if parts is None:
        raise ParameterTypeError(f"a number in {unit}", text,
                                 f"expected a number in {unit} (or a number with a unit: "
                                 f"{', '.join(accepted)}), got {text!r}")
    number, given = parts
    if given not in accepted:
        close = get_close_matches(given, list(accepted), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ParameterTypeError(f"a number in {unit}", text,
                                 f"unit {given!r} does not fit a value in {unit}{hint}; "
                                 f"valid units: {', '.join(accepted)}")
    return number * accepted[given]


def to_si(value: object, degrees: bool = False) -> object:
    """``value`` with every quantity written with a unit turned into its SI number, for tables:
    ``"2.5 kPa"`` → 2500.0, ``"30 mm/s"`` → 0.03, ``"30 deg"`` → 0.5236 (rad; 30.0 with
    ``degrees``, for the scene's ``*_deg`` fields), ``"1500"`` → 1500.0; lists element by
    element. Numbers, other text and lengths in tactels (whose size is the pad's) are returned
    as they are."""
    if isinstance(value, (list, tuple)):
        return [to_si(v, degrees) for v in value]
    if not isinstance(value, str):
        return value
    parts = split_quantity(value)
    if parts is None:
        return value
    number, unit = parts
    if unit is None:
        return number
    if degrees and unit in ACCEPTED_UNITS["deg"]:
        return number * ACCEPTED_UNITS["deg"][unit]
    table = next((t for si, t in ACCEPTED_UNITS.items() if si != "deg" and unit in t), None)
    return value if table is None else number * table[unit]


def format_value(value: object, digits: int = 6) -> str:
    """A parameter or grid value as a tree or scene file writes it (YAML spelling), for messages,
    tables and docs: ``true``/``false``, ``null``, floats with ``digits`` significant digits
    (``2000.0`` → ``2000``, ``0.1 + 0.2`` → ``0.3``), lists as ``[a, b]``; text (``"2.5 kPa"``)
    and other values as ``str`` gives them. The one formatter of values for people; tables that
    must round-trip (a sweep's CSV) keep ``repr``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(format_value(v, digits) for v in value) + "]"
    return str(value)
