"""Command-line checks of the sensor commands: device frame rates and fault specifications.

The generic checks (numbers, output files, warnings) are in :mod:`tactile_bt.arguments`.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import argparse
import math

from tactile_bt.arguments import validator
from tactile_bt.sense.hardware.framing import PERIOD_UNIT_S

__all__ = ["device_rate", "fault_spec", "module_name", "sensor_type"]

#: Frame rates a device period can express: 1..65535 steps of 100 us.
MIN_RATE_HZ = 1.0 / (65535 * PERIOD_UNIT_S)
MAX_RATE_HZ = 1.0 / PERIOD_UNIT_S


#: A frame rate a device period can be set to (100 us steps, at most 65535 of them).
device_rate = validator(float, lambda v: math.isfinite(v) and MIN_RATE_HZ <= v <= MAX_RATE_HZ,
                         f"a frame rate from {MIN_RATE_HZ:.3g} to {MAX_RATE_HZ:g} Hz")


def fault_spec(text: str):
    """``--faults`` value -> :class:`~tactile_bt.sense.hardware.faults.FaultConfig` (checked)."""
    from tactile_bt.sense.hardware.faults import FaultConfig

    try:
        return FaultConfig.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def module_name(text: str) -> str:
    """``--module`` value: the name of a tactile module the driver knows
    (:data:`~tactile_bt.sense.hardware.modules.MODULES`)."""
    from tactile_bt.errors import SensorModuleError
    from tactile_bt.sense.hardware.modules import get_module

    try:
        return get_module(text, "module").name
    except SensorModuleError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("module: ")) from None


def sensor_type(text: str) -> int:
    """``--sensor-type`` value: a 16-bit sensor type number, decimal or ``0x`` hexadecimal."""
    try:
        value = int(text, 0)
    except ValueError:
        value = -1
    if not 0 <= value <= 0xFFFF:
        raise argparse.ArgumentTypeError(f"{text!r} is not a sensor type number 0..0xFFFF")
    return value
