"""The one parser of quantities with units (tactile_bt.units), as scene and tree files use it."""

import math

import pytest

from tactile_bt.errors import ParameterTypeError
from tactile_bt.units import TWIST, element_unit, format_value, parse_quantity, to_si


@pytest.mark.parametrize("text, unit, expected", [
    ("3 mm", "m", 0.003), ("1.5 kPa", "Pa", 1500.0), ("1500", "Pa", 1500.0), ("30 mm/s", "m/s", 0.03),
    ("90 deg", "rad", math.pi / 2), ("0.5 rad", "deg", math.degrees(0.5)), ("100 N/mm", "N/m", 1e5),
    ("2 px", "m", 0.01),
])
def test_parse_quantity(text, unit, expected):
    assert parse_quantity(text, unit, pitch_m=0.005) == pytest.approx(expected)


def test_tactels_need_the_pads_pitch():
    with pytest.raises(ParameterTypeError, match="unit 'px' does not fit a value in m"):
        parse_quantity("2 px", "m")


def test_a_twist_has_a_unit_per_element():
    assert [element_unit(TWIST, i) for i in range(6)] == ["m/s"] * 3 + ["rad/s"] * 3
    assert element_unit("m", 4) == "m"


@pytest.mark.parametrize("value, degrees, expected", [
    ("2.5 kPa", False, 2500.0), (1500, False, 1500), ("30 deg", False, math.radians(30)), ("30 deg", True, 30.0),
    ("0.5 rad", True, math.degrees(0.5)), ([0, "30 mm/s"], False, [0, 0.03]), ("soft", False, "soft"),
    ("0.5 px", False, "0.5 px"),
])
def test_to_si_for_tables(value, degrees, expected):
    if isinstance(expected, str):  # text, or tactels whose size is the pad's: kept as written
        assert to_si(value, degrees) == expected
    else:
        assert to_si(value, degrees) == pytest.approx(expected)


@pytest.mark.parametrize("value, expected", [
    (True, "true"), (None, "null"), (2000.0, "2000"), (0.1 + 0.2, "0.3"), (1.0e-4, "0.0001"), (3, "3"),
    ("2.5 kPa", "2.5 kPa"), ([0.0, 1.0, (0.5, False)], "[0, 1, [0.5, false]]"),
])
def test_values_are_shown_as_files_write_them(value, expected):
    """Parameters in ``tree --params`` and docs/trees.md, grid values in a sweep's summary: YAML
    spelling, floats without binary noise."""
    assert format_value(value) == expected

