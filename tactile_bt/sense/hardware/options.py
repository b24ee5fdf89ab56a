"""Command-line checks of the sensor commands: device frame rates and fault specifications.

The generic checks (numbers, output files, warnings) are in :mod:`tactile_bt.arguments`.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import argparse
import math

from tactile_bt.arguments import validator
from tactile_bt.sense.hardware.framing import PERIOD_UNIT_S

__all__ = ["device_rate", "fault_spec"]

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
